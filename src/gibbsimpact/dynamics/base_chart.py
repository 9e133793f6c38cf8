"""The spatial free base's orientation chart and its change (formulation §18, docs/theory.md §2.1).

The base frame is T_1 = Trans(X) R_ref Rx(theta_-1) Ry(theta_0) A Rz(theta_1): three angles measured
from a reference orientation R_ref (Model.base_chart) that a run may change; A (3, 3) is the constant
axis_rotation of the root's revolute (I by default). With u = A e_z:

    omega  = R_ref B(theta) thetadot            (world angular velocity of the base, [rad/s])
    B(theta) = [e_x, Rx(theta_-1) e_y, Rx(theta_-1) Ry(theta_0) u]      (3, 3)
    det B = e_z . Ry(theta_0) u  = cos theta_0 for A = I

The chart is singular where det B = 0. A re-chart keeps the orientation and moves the angles to
(0, b*, 0), b* = atan2(-u_x, u_z) (0 for A = I), where |det B| = |(u_x, u_z)| is largest:

    R_ref' = R_ref C(theta) (Ry(b*) A)^T,   C(theta) = Rx(theta_-1) Ry(theta_0) A Rz(theta_1)
    thetadot' = B(theta')^-1 R_ref'^T R_ref B(theta) thetadot

so T_1, its velocity (hence every point's position and velocity, the energy and the momenta) are the
same before and after; X, the joint angles theta_2 .. theta_n and the deltas do not change.
"""

from __future__ import annotations

import numpy as np

#: The chart is re-charted when |det B| falls to cos(RECHART_ANGLE): |theta_0| = 1.2 rad for A = I, where
#: cos theta_0 = 0.36 and B has a condition number of at most ~5.6 in every chart a run uses.
RECHART_ANGLE = 1.2
_DET_MIN = float(np.cos(RECHART_ANGLE))


def axis_rotation(axis: int, angle) -> np.ndarray:
    """R_axis(angle) (..., 3, 3) for axis 0 (x), 1 (y) or 2 (z) and angles (...) [rad]."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i, j = (axis + 1) % 3, (axis + 2) % 3
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def root_rotation(model) -> np.ndarray:
    """A (3, 3): the constant axis rotation of the free base's root revolute (I when it has none)."""
    A = getattr(model.chain.joints[0], "axis_rotation", None)
    return np.eye(3) if A is None else np.asarray(A, dtype=float)


def base_angles(model, q) -> np.ndarray:
    """(theta_-1, theta_0, theta_1) (..., 3) [rad] of q (..., N) of a spatial free base."""
    q = np.asarray(q, dtype=float)
    return q[..., [3, 4, model.theta_index[0]]]


def chart_rotation(angles, A=None) -> np.ndarray:
    """C = Rx(theta_-1) Ry(theta_0) A Rz(theta_1) (..., 3, 3) of angles (..., 3) [rad] (A: I by default)."""
    a = np.asarray(angles, dtype=float)
    Rxy = axis_rotation(0, a[..., 0]) @ axis_rotation(1, a[..., 1])
    return (Rxy if A is None else Rxy @ A) @ axis_rotation(2, a[..., 2])


def chart_rate_matrix(angles, A=None) -> np.ndarray:
    """B(theta) (..., 3, 3): the angular velocity in the chart's reference frame is B thetadot [rad/s]
    (module docstring); columns e_x, Rx e_y, Rx Ry u, u = A e_z."""
    a = np.asarray(angles, dtype=float)
    u = np.array([0.0, 0.0, 1.0]) if A is None else np.asarray(A, dtype=float)[:, 2]
    Rx = axis_rotation(0, a[..., 0])
    B = np.empty(a.shape[:-1] + (3, 3))
    B[..., :, 0] = (1.0, 0.0, 0.0)
    B[..., :, 1] = Rx[..., :, 1]
    B[..., :, 2] = (Rx @ axis_rotation(1, a[..., 1])) @ u
    return B


def chart_margin(model, theta_0) -> float:
    """|det B| - cos(RECHART_ANGLE) at theta_0 [rad] (det B = e_z . Ry(theta_0) A e_z, module docstring): the
    chart is re-charted where it falls to 0 (|theta_0| = RECHART_ANGLE for A = I)."""
    u = root_rotation(model)[:, 2]
    return abs(u[2] * np.cos(theta_0) - u[0] * np.sin(theta_0)) - _DET_MIN


def base_orientation_matrix(model, q, chart=None) -> np.ndarray:
    """R_1 = R_ref C(theta) (..., 3, 3), the world orientation of the base frame T_1, for q (..., N) and
    chart R_ref (..., 3, 3) (default model.base_chart)."""
    R_ref = model.base_chart if chart is None else np.asarray(chart, dtype=float)
    return R_ref @ chart_rotation(base_angles(model, q), root_rotation(model))


def rechart(model, q, qdot):
    """(model', q', qdot') in the chart of the current orientation (module docstring).

    model : Model with a spatial free base; q, qdot : (N,) in its chart [m, rad; m/s, rad/s].
    model' = model.with_base_chart(R_ref'), R_ref' projected back onto a rotation (its polar factor) so
    that round-off does not build up over many re-charts; q' has the angles (0, b*, 0), qdot' the rates
    B(theta')^-1 R_ref'^T R_ref B(theta) thetadot; every other coordinate and rate is unchanged.
    """
    idx = [3, 4, model.theta_index[0]]
    A = root_rotation(model)
    angles = np.asarray(q, dtype=float)[idx]
    new_angles = np.array([0.0, np.arctan2(-A[0, 2], A[2, 2]), 0.0])
    # R_ref' C(theta') = R_ref C(theta): the same orientation in the new chart.
    turn = chart_rotation(angles, A) @ chart_rotation(new_angles, A).T  # R_ref^T R_ref'
    U, _, Vt = np.linalg.svd(model.base_chart @ turn)
    new = model.with_base_chart(U @ Vt)
    q2, qd2 = np.array(q, dtype=float), np.array(qdot, dtype=float)
    q2[idx] = new_angles
    qd2[idx] = np.linalg.solve(chart_rate_matrix(new_angles, A), turn.T @ chart_rate_matrix(angles, A) @ qd2[idx])
    return new, q2, qd2


def quaternion(R) -> np.ndarray:
    """Unit quaternions [w, x, y, z] (..., 4) of rotation matrices R (..., 3, 3), w >= 0 when one matrix,
    and for a sequence (K, 3, 3) each sign chosen so that consecutive ones have q_k . q_(k-1) >= 0 (a
    continuous curve; q and -q are the same rotation). R = I + 2 w [v]x + 2 [v]x^2, v = (x, y, z)."""
    R = np.asarray(R, dtype=float)
    tr = np.trace(R, axis1=-2, axis2=-1)
    # Shepperd: divide by the largest of 4w^2 = 1 + tr, 4x^2 = 1 + 2 R_00 - tr, ... (no cancellation).
    d = np.stack([tr, R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], axis=-1)
    k = np.argmax(d, axis=-1)
    big = np.sqrt(np.maximum(1.0 + 2.0 * np.take_along_axis(d, k[..., None], -1)[..., 0] - tr, 0.0))  # 2|q_k|
    skew = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    sym = np.stack([R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]], -1)
    # 4 q_k q = row k of [[1 + tr, skew], [skew_0, 1 + 2R00 - tr, sym_01, sym_02], ...]
    rows = np.stack([
        np.concatenate([(1.0 + tr)[..., None], skew], -1),
        np.stack([skew[..., 0], 1.0 + 2.0 * R[..., 0, 0] - tr, sym[..., 0], sym[..., 1]], -1),
        np.stack([skew[..., 1], sym[..., 0], 1.0 + 2.0 * R[..., 1, 1] - tr, sym[..., 2]], -1),
        np.stack([skew[..., 2], sym[..., 1], sym[..., 2], 1.0 + 2.0 * R[..., 2, 2] - tr], -1)], -2)
    Q = np.take_along_axis(rows, k[..., None, None], -2)[..., 0, :] / (2.0 * big[..., None])
    Q /= np.linalg.norm(Q, axis=-1, keepdims=True)
    if Q.ndim == 1:
        return Q if Q[0] >= 0.0 else -Q
    if Q.ndim == 2 and len(Q):
        Q[0] *= 1.0 if Q[0, 0] >= 0.0 else -1.0
        flips = np.concatenate([[1.0], np.where(np.sum(Q[1:] * Q[:-1], axis=1) < 0.0, -1.0, 1.0)])
        Q *= np.cumprod(flips)[:, None]
    return Q
