"""Kinematics of the chain (docs/theory.md §2, §6), computed by the compiled kernel.

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

from .. import kernel as _k


class Frames(NamedTuple):
    """Kinematics of the n link frames and the tip frame (index n).

    T : (n+1, 4, 4) transforms; Td : (n+1, 4, 4) time derivatives; Tdd0 :
    (n+1, 4, 4) qddot-free second time derivatives (Td, Tdd0 None when qdot
    was not given).
    """

    T: np.ndarray
    Td: np.ndarray | None
    Tdd0: np.ndarray | None


def _wrong_states(model, qs, qds) -> ValueError:
    N = model.n_dof
    return ValueError(f"states of shapes {qs.shape}, {qds.shape}: this model needs q and qdot of {N} entries "
                      f"each ({', '.join(model.coordinate_names)})")


def run_kernel(model, st, job: int, Q: np.ndarray | None = None) -> np.ndarray:
    """Call the compiled kernel on the states st = (qs, qds) (K N,) each for the JOB_* bits ``job``."""
    fdat, idat, zeros, v = model.kernel_data
    qs, qds = st
    # The compiled kernel does not check bounds: states of the wrong size are refused here.
    N = zeros.size
    if qs.size != qds.size or qs.size == 0 or qs.size % N:
        raise _wrong_states(model, qs, qds)
    return _k.run(v, fdat, idat, qs, qds, zeros if Q is None else Q, job)


def one_state(model, q, qdot, job: int, Q: np.ndarray | None = None, check: bool = False) -> np.ndarray:
    """The kernel's output (kernel.layout) for one state q, qdot (N,) (qdot None: zeros) and the JOB_*
    bits ``job``, in a new array: the hot path of the documented single-state functions.

    q, qdot go straight to the kernel, which checks their sizes (and with ``check``, JOB_FINITE,
    that every entry is finite) and refuses, with a TypeError and no recompile, an array of another
    type or memory layout; only then are they validated and converted here (_refused). With
    ``check`` a non-finite entry raises Model.check_state's ValueError naming its coordinates.
    """
    f, fdat, idat, zeros, v0, v1, sizes = model.kernel_call
    if check:
        job |= _FINITE
    try:
        out = _EMPTY(sizes[job])
    except KeyError:
        out = model.kernel_output(job)
    try:
        status = f(fdat, idat, q, zeros if qdot is None else qdot, zeros if Q is None else Q, job, v0, v1, out)
    except TypeError:
        status = -1.0
    return out if status >= 0.0 else _refused(model, q, qdot, job, Q, check)


def _refused(model, q, qdot, job, Q, check) -> np.ndarray:
    """one_state for a state the kernel refused (of another type, size or layout, or non-finite):
    Model.check_state's ValueError (check) or _wrong_states, else the call on its converted copy."""
    if check:
        q, qdot = model.check_state(q, qdot) if qdot is not None else (model.check_state(q), None)
    q, qd = states(q, qdot)
    if q.size != model.n_dof or qd.size != model.n_dof:
        raise _wrong_states(model, q, qd)
    f, fdat, idat, zeros, v0, v1, _ = model.kernel_call
    out = model.kernel_output(job)
    if f(fdat, idat, q, qd, zeros if Q is None else Q, job, v0, v1, out) < 0.0:  # pragma: no cover - checked above
        raise RuntimeError("the kernel refused a validated state")
    return out


def section(model, out: np.ndarray, K: int, job: int, name: str) -> np.ndarray:
    """The flat section ``name`` (kernel.SECTIONS) of a kernel output."""
    off = _k.layout(model.n_links, model.n_dof, K, job, model.n_joints)
    i = _k.SECTIONS.index(name)
    return out[off[i]:off[i + 1]]


_F64 = np.dtype(np.float64)
_EMPTY = np.empty
_FINITE = _k.JOB_FINITE
_JOB_POINTS_JACOBIANS = _k.JOB_POINTS | _k.JOB_JACOBIANS


def as_vector(a) -> np.ndarray:
    """``a`` as the kernel takes it: a writable, C-contiguous float64 array, flattened.

    Already such an array (the common case) costs four attribute reads, no copy.
    """
    if a.__class__ is np.ndarray and a.dtype is _F64:
        f = a.flags
        if f.c_contiguous and f.writeable:
            return a.reshape(-1) if a.ndim != 1 else a
    return np.array(a, dtype=float, order="C").reshape(-1)


def states(q, qdot=None) -> tuple[np.ndarray, np.ndarray]:
    """Kernel input (qs, qds), (K N,) each, from q (N,) or (K, N) and qdot of the same shape (zeros if None)."""
    qs = as_vector(q)
    return qs, (np.zeros(qs.size) if qdot is None else as_vector(qdot))


def skew(v) -> np.ndarray:
    """Cross-product matrix, skew(v) @ w = v x w."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rodrigues_coefficients(s: float):
    """(a, a_s, a_ss, b, b_s, b_ss) of R = I + a K + b K^2 at s = |phi|^2 (kernel.rodrigues_coefficients)."""
    return tuple(float(c) for c in _k.rodrigues_coefficients(float(s)))


def _directional(phi, u, w):
    """R(phi), dR[u], d2R[w, w] (3, 3) each, from the kernel's Rodrigues function."""
    B = np.zeros((7, 4, 4))
    B[0, 0, :3], B[0, 1, :3], B[0, 2, :3] = phi, u, w
    _k.rodrigues_directional(B, 0, 0, 1, 2, 1, 2, 3, 4)
    return B[1, :3, :3].copy(), B[2, :3, :3].copy(), B[3, :3, :3].copy()


def rotation(phi) -> np.ndarray:
    """R = I + a K + b K^2 (3, 3) for the rotation vector phi (3,) [rad]."""
    return _directional(phi, np.zeros(3), np.zeros(3))[0]


def rodrigues(phi) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotation by the vector ``phi`` and its first and second derivatives.

    Built from the kernel's directional derivatives dR[u], d2R[w, w]:
    dR/dphi_i = dR[e_i], d2R/dphi_i dphi_j = (d2R[e_i + e_j] - d2R[e_i] - d2R[e_j]) / 2.

    Returns
    -------
    R : (3, 3); dR : (3, 3, 3) indexed [i]; d2R : (3, 3, 3, 3) indexed [i, j]
    """
    phi = np.asarray(phi, dtype=float)
    eye = np.eye(3)
    R = rotation(phi)
    dR = np.array([_directional(phi, eye[i], eye[i])[1] for i in range(3)])
    sq = np.array([_directional(phi, eye[i], eye[i])[2] for i in range(3)])
    d2R = np.empty((3, 3, 3, 3))
    for i in range(3):
        for j in range(3):
            d2R[i, j] = sq[i] if i == j else 0.5 * (_directional(phi, eye[i], eye[i] + eye[j])[2] - sq[i] - sq[j])
    return R, dR, d2R


def frames(model, q: np.ndarray, qdot: np.ndarray | None = None) -> Frames:
    """Transforms of every link frame and of the tip, with time derivatives.

    Parameters
    ----------
    model : Model
    q : (N,) generalised coordinates [m, rad, m]
    qdot : (N,) generalised velocities, optional

    Returns
    -------
    Frames with T, Td and Tdd0 (n+1, 4, 4).
    """
    job = _k.JOB_FRAMES
    out = section(model, one_state(model, q, qdot, job), 1, job, "frames")
    F = out.reshape(model.n_links + 1, 3, 4, 4)
    T = F[:, 0].copy()
    if qdot is None:
        return Frames(T, None, None)
    return Frames(T, F[:, 1].copy(), F[:, 2].copy())


def transforms(model, q: np.ndarray) -> np.ndarray:
    """Link frames T_1 ... T_n and the tip frame, shape (n+1, 4, 4), no derivatives."""
    return frames(model, q).T


def joint_positions(model, q: np.ndarray, *, check: bool = False) -> np.ndarray:
    """Contact points O_1 ... O_P in the inertial frame, shape (P, 3) [m], P = model.n_joints.

    O_1 ... O_(n+1) are the frame origins (the joints and the last tip); with prismatic
    joints the tips of their host links follow (Model.n_joints). check: validate q as
    Model.check_state does (gibbs_appell's module docstring).
    """
    return one_state(model, q, None, _k.JOB_POINTS, None, check)[3:].reshape(model.n_joints, 3)


def joint_positions_batch(model, qs: np.ndarray) -> np.ndarray:
    """Contact points of the states qs (K, N): shape (K, P, 3) [m]."""
    qs = np.asarray(qs, dtype=float)
    out = run_kernel(model, states(qs), _k.JOB_POINTS)
    return out[3:].reshape(qs.shape[0], model.n_joints, 3)


def joint_positions_and_jacobians(model, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """O_1 ... O_P, shape (P, 3) [m], and d O_j / d q, shape (P, 3, N), from one recursion."""
    n1, N = model.n_joints, model.n_dof
    out = one_state(model, q, None, _JOB_POINTS_JACOBIANS)
    return out[3:3 + 3 * n1].reshape(n1, 3), out[3 + 3 * n1:].reshape(n1, 3, N)


def joint_velocities_batch(model, qs: np.ndarray, qdots: np.ndarray, chunk: int = 512) -> np.ndarray:
    """Joint velocities dO_j/dt = J_j(q) qdot of the states qs, qdots (K, N): (K, n+1, 3) [m/s].

    One kernel call per ``chunk`` states (the Jacobians of a chunk are (chunk, n+1, 3, N)).
    """
    qs, qdots = np.asarray(qs, dtype=float), np.asarray(qdots, dtype=float)
    n1, N = model.n_joints, model.n_dof
    out = np.empty((qs.shape[0], n1, 3))
    for a in range(0, qs.shape[0], chunk):
        b = min(a + chunk, qs.shape[0])
        J = run_kernel(model, states(qs[a:b]), _k.JOB_JACOBIANS)[3:].reshape(b - a, n1, 3, N)
        out[a:b] = np.einsum("kjcn,kn->kjc", J, qdots[a:b])
    return out


def joint_jacobians(model, q: np.ndarray, *, check: bool = False) -> np.ndarray:
    """d O_j / d q for j = 1 ... P, shape (P, 3, N) (joint_positions; check as there)."""
    n1 = model.n_joints
    return one_state(model, q, None, _JOB_POINTS_JACOBIANS, None, check)[3 + 3 * n1:].reshape(n1, 3, model.n_dof)
