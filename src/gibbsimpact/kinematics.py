"""Recursive 4x4 kinematics of the chain (formulation.md section 2 and 4).

Frames, from the inertial frame outwards::

    Trans(X) -> Rx(theta_-1) -> Ry(theta_0) -> Rz(theta_1)       = T_1 (link 1, free base)
    T_0 -> Rz(theta_1)                                           = T_1 (link 1, fixed base T_0)
    T_i = T_(i-1) E_(i-1)(delta_(i-1)) Rz(theta_i)                i = 2..n
    T_tip = T_n E_n(delta_n)                                     (joint O_(n+1))
    E_i(delta_i) = Trans(l_i + u(l_i), v(l_i), w(l_i)) Rot(phi_i),
    phi_i = (theta_x(l_i), -w'(l_i), v'(l_i))

Each step right-multiplies by a local transform G that depends on a few
local coordinates s only, so with T = T_prev G (dots are time derivatives,
superscript 0 the qddot-free part)::

    dT/dq_k = dT_prev/dq_k G              (q_k upstream of G)
            = T_prev dG/dq_k              (q_k local to G)
    Tdot    = Tdot_prev G + T_prev Gdot,          Gdot = sum_s dG/ds sdot
    Tddot0  = Tddot0_prev G + 2 Tdot_prev Gdot + T_prev Gddot0,
    Gddot0  = sum_st d2G/dsdt sdot tdot
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Frames(NamedTuple):
    """Kinematics of the n link frames and the tip frame (index n).

    T : (n+1, 4, 4) transforms; dT : (n+1, N, 4, 4) their q-derivatives;
    Td : (n+1, 4, 4) time derivatives; Tdd0 : (n+1, 4, 4) qddot-free second
    time derivatives (None when qdot was not given).
    """

    T: np.ndarray
    dT: np.ndarray
    Td: np.ndarray | None
    Tdd0: np.ndarray | None


_ROT_PLANE = [(1, 2), (2, 0), (0, 1)]


def _rot(axis: int, a: float):
    """Elementary rotation about ``axis`` (4x4) with first and second derivatives."""
    c, s = np.cos(a), np.sin(a)
    i, j = _ROT_PLANE[axis]
    R = np.eye(4)
    R1 = np.zeros((4, 4))
    R2 = np.zeros((4, 4))
    # R = [[c, -s], [s, c]] in the (i, j) plane; R1 = dR/da; R2 = d2R/da2 = -(R - identity on the axis).
    R[i, i] = R[j, j] = c
    R[i, j], R[j, i] = -s, s
    R1[i, i] = R1[j, j] = -s
    R1[i, j], R1[j, i] = -c, c
    R2[i, i] = R2[j, j] = -c
    R2[i, j], R2[j, i] = s, -s
    return R, R1, R2


def skew(v) -> np.ndarray:
    """Cross-product matrix, skew(v) @ w = v x w."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


_K_UNIT = np.array([skew(e) for e in np.eye(3)])  # (3, 3, 3): skew(e_i)


_SERIES_N = np.arange(14)
_SERIES_SIGN = (-1.0) ** _SERIES_N
_SERIES_A = np.array([1.0 / np.prod(np.arange(1, 2 * k + 2, dtype=float)) for k in _SERIES_N])  # 1/(2n+1)!
_SERIES_B = _SERIES_A / (2 * _SERIES_N + 2)  # 1/(2n+2)!
_SERIES_A_SIGNED, _SERIES_B_SIGNED = _SERIES_SIGN * _SERIES_A, _SERIES_SIGN * _SERIES_B
_SERIES_N1 = np.maximum(_SERIES_N - 1, 0)
_SERIES_N2 = np.maximum(_SERIES_N - 2, 0)


def _rodrigues_coefficients(s: float):
    """a(s) = sin(t)/t, b(s) = (1 - cos t)/t^2 with t = sqrt(s), and their s-derivatives.

    Returns (a, a_s, a_ss, b, b_s, b_ss). Power series for s < 1 (no 0/0),
    closed forms with the recurrences
    a_s = (cos t - a)/(2s), b_s = (a - 2b)/(2s),
    a_ss = (-a/2 - 3 a_s)/(2s), b_ss = (a_s - 4 b_s)/(2s) otherwise.
    """
    if s < 1.0:
        n = _SERIES_N
        p0 = s**n
        p1 = n * s**_SERIES_N1
        p2 = n * (n - 1) * s**_SERIES_N2
        A, B = _SERIES_A_SIGNED, _SERIES_B_SIGNED
        return float(A @ p0), float(A @ p1), float(A @ p2), float(B @ p0), float(B @ p1), float(B @ p2)
    t = np.sqrt(s)
    a = np.sin(t) / t
    b = (1.0 - np.cos(t)) / s
    a_s = (np.cos(t) - a) / (2 * s)
    b_s = (a - 2 * b) / (2 * s)
    a_ss = (-0.5 * a - 3 * a_s) / (2 * s)
    b_ss = (a_s - 4 * b_s) / (2 * s)
    return a, a_s, a_ss, b, b_s, b_ss


def rotation(phi) -> np.ndarray:
    """R = I + a K + b K^2 (3, 3) for the rotation vector phi (3,) [rad], no derivatives."""
    phi = np.asarray(phi, dtype=float)
    s = float(phi @ phi)
    if s < 1.0:
        p0 = s**_SERIES_N
        a, b = float(_SERIES_A_SIGNED @ p0), float(_SERIES_B_SIGNED @ p0)
    else:
        t = np.sqrt(s)
        a, b = np.sin(t) / t, (1.0 - np.cos(t)) / s
    K = skew(phi)
    return np.eye(3) + a * K + b * (K @ K)


def rodrigues(phi) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotation by the vector ``phi`` and its first and second derivatives.

    R = I + a K + b K^2,  K = skew(phi),  s = phi.phi
    dR/dphi_i = 2 phi_i a_s K + a K_i + 2 phi_i b_s K^2 + b (K_i K + K K_i)
    d2R/dphi_i dphi_j = derivative of the above (product rule), K_i = skew(e_i)

    Returns
    -------
    R : (3, 3); dR : (3, 3, 3) indexed [i]; d2R : (3, 3, 3, 3) indexed [i, j]
    """
    phi = np.asarray(phi, dtype=float)
    s = float(phi @ phi)
    a, a_s, a_ss, b, b_s, b_ss = _rodrigues_coefficients(s)
    K = skew(phi)
    K2 = K @ K
    R = np.eye(3) + a * K + b * K2
    Ki = _K_UNIT
    KiK = Ki @ K + K @ Ki  # (3,3,3): K_i K + K K_i
    dR = (2 * a_s * phi)[:, None, None] * K + a * Ki + (2 * b_s * phi)[:, None, None] * K2 + b * KiK
    eye = np.eye(3)
    pp = np.outer(phi, phi)
    d2R = (
        (2 * a_s * eye + 4 * a_ss * pp)[:, :, None, None] * K
        + 2 * a_s * (phi[:, None, None, None] * Ki[None, :] + phi[None, :, None, None] * Ki[:, None])
        + (2 * b_s * eye + 4 * b_ss * pp)[:, :, None, None] * K2
        + 2 * b_s * (phi[:, None, None, None] * KiK[None, :] + phi[None, :, None, None] * KiK[:, None])
        + b * (Ki[:, None] @ Ki[None, :] + Ki[None, :] @ Ki[:, None])
    )
    return R, dR, d2R


def _end_transform(ld, delta, delta_dot):
    """Local transform E(delta) of a link end with its derivatives.

    Returns G (4,4), dG (m,4,4), and if delta_dot is given also
    Gdot (4,4) and Gddot0 (4,4).
    E = Trans(l e_1 + sum_k t_k delta_k) Rot(sum_k phi_k delta_k)
    """
    m = delta.shape[0]
    G = ld.E0.copy()
    G[:3, 3] += ld.end_t.T @ delta
    dG = np.zeros((m, 4, 4))
    dG[:, :3, 3] = ld.end_t
    if not np.any(ld.end_phi):
        # Pure translation: d2G = 0.
        if delta_dot is None:
            return G, dG, None, None
        Gd = np.zeros((4, 4))
        Gd[:3, 3] = ld.end_t.T @ delta_dot
        return G, dG, Gd, np.zeros((4, 4))
    phi = ld.end_phi.T @ delta
    R, dR, d2R = rodrigues(phi)
    G[:3, :3] = R
    # dG/ddelta_k = [[sum_a dR/dphi_a phi_k,a, t_k], [0, 0]]
    dG[:, :3, :3] = np.einsum("ka,aij->kij", ld.end_phi, dR)
    if delta_dot is None:
        return G, dG, None, None
    tdot = ld.end_t.T @ delta_dot
    phidot = ld.end_phi.T @ delta_dot
    Gd = np.zeros((4, 4))
    dR_dot = np.einsum("a,aij->ij", phidot, dR)
    Gd[:3, :3] = dR_dot
    Gd[:3, 3] = tdot
    # G = [[R(phi), t], [0, 1]] with t linear in delta, so
    # Gddot0 = [[d2R(phidot, phidot), 0], [0, 0]].
    Gdd0 = np.zeros((4, 4))
    Gdd0[:3, :3] = np.einsum("a,b,abij->ij", phidot, phidot, d2R)
    return G, dG, Gd, Gdd0


def frames(model, q: np.ndarray, qdot: np.ndarray | None = None) -> Frames:
    """Transforms of every link frame and of the tip, with derivatives.

    Parameters
    ----------
    model : Model
    q : (N,) generalised coordinates [m, rad, m]
    qdot : (N,) generalised velocities, optional

    Returns
    -------
    Frames with T (n+1, 4, 4), dT (n+1, N, 4, 4), Td and Tdd0 (n+1, 4, 4).
    """
    N = q.shape[0]
    n = model.n_links
    vel = qdot is not None
    Ts = np.empty((n + 1, 4, 4))
    dTs = np.empty((n + 1, N, 4, 4))
    Tds = np.empty((n + 1, 4, 4)) if vel else None
    Tdds = np.empty((n + 1, 4, 4)) if vel else None

    dT = np.zeros((N, 4, 4))
    Td = np.zeros((4, 4)) if vel else None
    Tdd0 = np.zeros((4, 4)) if vel else None
    if model.free_base:
        # Trans(X): T = [I X; 0 1], dT/dX_a = e_a in the translation column.
        T = np.eye(4)
        T[:3, 3] = q[:3]
        dT[0, 0, 3] = dT[1, 1, 3] = dT[2, 2, 3] = 1.0
        if vel:
            Td[:3, 3] = qdot[:3]
    else:
        T = model.base_transform.copy()  # constant: no derivatives

    def step_single(T, dT, Td, Tdd0, k, axis):
        G, G1, G2 = _rot(axis, q[k])
        dT_new = dT @ G
        dT_new[k] = T @ G1
        if not vel:
            return T @ G, dT_new, None, None
        Gd = G1 * qdot[k]
        Gdd0 = G2 * qdot[k] ** 2
        return T @ G, dT_new, Td @ G + T @ Gd, Tdd0 @ G + 2.0 * Td @ Gd + T @ Gdd0

    def step_end(T, dT, Td, Tdd0, i):
        ld = model.link_data[i]
        idx = model.delta_index[i]
        if ld.end_is_rigid:
            G = ld.E0
            return T @ G, dT @ G, (Td @ G if vel else None), (Tdd0 @ G if vel else None)
        G, dG, Gd, Gdd0 = _end_transform(ld, q[idx], qdot[idx] if vel else None)
        dT_new = dT @ G
        dT_new[idx] = T @ dG
        if not vel:
            return T @ G, dT_new, None, None
        return T @ G, dT_new, Td @ G + T @ Gd, Tdd0 @ G + 2.0 * Td @ Gd + T @ Gdd0

    theta = model.theta_index
    if model.free_base:
        T, dT, Td, Tdd0 = step_single(T, dT, Td, Tdd0, 3, 0)
        T, dT, Td, Tdd0 = step_single(T, dT, Td, Tdd0, 4, 1)
    T, dT, Td, Tdd0 = step_single(T, dT, Td, Tdd0, theta[0], 2)
    for i in range(n):
        Ts[i], dTs[i] = T, dT
        if vel:
            Tds[i], Tdds[i] = Td, Tdd0
        T, dT, Td, Tdd0 = step_end(T, dT, Td, Tdd0, i)
        if i + 1 < n:
            T, dT, Td, Tdd0 = step_single(T, dT, Td, Tdd0, theta[i + 1], 2)
    Ts[n], dTs[n] = T, dT
    if vel:
        Tds[n], Tdds[n] = Td, Tdd0
    return Frames(Ts, dTs, Tds, Tdds)


def _end_translation_rotation(ld, delta):
    """E(delta) (4, 4) without derivatives."""
    if ld.end_is_rigid:
        return ld.E0
    G = ld.E0.copy()
    G[:3, 3] += ld.end_t.T @ delta
    if np.any(ld.end_phi):
        G[:3, :3] = rotation(ld.end_phi.T @ delta)
    return G


def transforms(model, q: np.ndarray) -> np.ndarray:
    """Link frames T_1 ... T_n and the tip frame, shape (n+1, 4, 4), no derivatives.

    The cheap path for event functions and plotting.
    """
    n = model.n_links
    out = np.empty((n + 1, 4, 4))
    theta = model.theta_index
    if model.free_base:
        T = np.eye(4)
        T[:3, 3] = q[:3]
        T = T @ _rot(0, q[3])[0] @ _rot(1, q[4])[0]
    else:
        T = model.base_transform
    T = T @ _rot(2, q[theta[0]])[0]
    for i in range(n):
        out[i] = T
        T = T @ _end_translation_rotation(model.link_data[i], q[model.delta_index[i]])
        if i + 1 < n:
            T = T @ _rot(2, q[theta[i + 1]])[0]
    out[n] = T
    return out


def joint_positions(model, q: np.ndarray) -> np.ndarray:
    """Joint points O_1 ... O_(n+1) in the inertial frame, shape (n+1, 3) [m]."""
    return transforms(model, q)[:, :3, 3].copy()


def joint_positions_and_jacobians(model, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """O_1 ... O_(n+1), shape (n+1, 3) [m], and d O_j / d q, shape (n+1, 3, N), from one recursion."""
    fr = frames(model, q)
    return fr.T[:, :3, 3].copy(), np.ascontiguousarray(np.swapaxes(fr.dT[:, :, :3, 3], 1, 2))


def joint_jacobians(model, q: np.ndarray) -> np.ndarray:
    """d O_j / d q for j = 1 ... n+1, shape (n+1, 3, N)."""
    return joint_positions_and_jacobians(model, q)[1]
