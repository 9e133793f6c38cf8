"""Gibbs-Appell equations of the flight phase (formulation.md section 4).

All functions are pure: ``f(model, q, qdot)`` with q, qdot of shape (N,).

For a point of link i, p(x) = T_i r(x), r(x) = r0(x) + sum_k psihat_k(x) delta_k
with r0 = (x, 0, 0, 1) and psihat_k = (e_dir psi_k(x), 0). Its acceleration is
p'' = J(x) qddot + a0(x) with J columns A_j r (A_j = dT_i/dq_j, upstream q_j)
and T_i psihat_l (own modes l), and a0 = Tdd0_i r + 2 Td_i rdot.

The Gibbs function S = 1/2 sum int mu |p''|^2 dx + rotary part gives
dS/dqddot = M qddot + h. Because J and a0 are linear in r, every integral over
x is a trace against the precomputed moments of the link (model.LinkData):

    P   = int mu r r^T     = P0 + sum_k delta_k (C_k + C_k^T) + sum_kl delta_k delta_l D_kl
    Q_l = int mu r psihat_l^T = C_l + sum_k delta_k D_kl
    Pv  = int mu r rdot^T  = sum_l deltadot_l Q_l
    Qd_l = int mu rdot psihat_l^T = sum_k deltadot_k D_kl

    M_jk   += tr(A_j P A_k^T)                    (j, k upstream)
    M_jl   += tr(A_j Q_l T^T)                    (j upstream, l own mode)
    M_kl   += tr(D_kl)                           (own modes; constant)
    h_j    += tr(A_j (P Tdd0^T + 2 Pv Td^T))
    h_l    += tr(Tdd0 Q_l T^T) + 2 tr(Td Qd_l T^T)

Rotary inertia of the link frame, with body angular velocity
omega = W qdot, W_j = vee(R^T dR/dq_j), body angular acceleration
alpha = W qddot + alpha0, alpha0 = vee(skew part of R^T Rdd0):

    S_rot = 1/2 alpha.J alpha + alpha.(omega x J omega)
    M += W^T J W,   h += W^T (J alpha0 + omega x J omega)

Potential V = -g~^T sum T_i m_r,i + 1/2 delta^T K delta, g~ = (g, 0),
m_r = int mu r = m_r0 + sum_k delta_k m_psi,k.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from scipy.linalg.lapack import dposv as _dposv

from .kinematics import frames


class SingularMassMatrixError(np.linalg.LinAlgError, ValueError):
    """The mass matrix is singular or not positive definite at this state."""


class Energy(NamedTuple):
    """Energies in joules (scalars, or arrays (K,) for a trajectory)."""

    kinetic: float
    gravity: float
    strain: float
    total: float


def _vee_skew(S: np.ndarray) -> np.ndarray:
    """vee of the skew-symmetric part of S (..., 3, 3) -> (..., 3)."""
    return 0.5 * np.stack(
        [S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]], axis=-1
    )


def _link_moments(ld, delta, delta_dot=None):
    """P (4,4), Q (m,4,4), m_r (4,) and, with delta_dot, Pv (4,4), Qd (m,4,4)."""
    Cd = np.einsum("k,kij->ij", delta, ld.C)
    Q = ld.C + np.einsum("k,klij->lij", delta, ld.D)
    # P = P0 + sum_k d_k (C_k + C_k^T) + sum_kl d_k d_l D_kl
    P = ld.P0 + Cd + Cd.T + np.einsum("l,lij->ij", delta, Q - ld.C)
    m_r = ld.m_r0 + delta @ ld.m_psi
    if delta_dot is None:
        return P, Q, m_r, None, None
    Pv = np.einsum("l,lij->ij", delta_dot, Q)
    Qd = np.einsum("k,klij->lij", delta_dot, ld.D)
    return P, Q, m_r, Pv, Qd


def _assemble(model, q, qdot, want_h: bool, want_dV: bool):
    """M (N,N), h (N,) or None, dV/dq (N,) or None."""
    N = q.shape[0]
    fr = frames(model, q, qdot if want_h else None)
    M = np.zeros((N, N))
    h = np.zeros(N) if want_h else None
    dV = model.stiffness_matrix @ q if want_dV else None
    gt = np.append(model.gravity, 0.0)
    for i, ld in enumerate(model.link_data):
        idx = model.delta_slice[i]
        m = idx.stop - idx.start
        T, A = fr.T[i], fr.dT[i]
        delta = q[idx]
        P, Q, m_r, Pv, Qd = _link_moments(ld, delta, qdot[idx] if want_h else None)
        A2 = A.reshape(N, 16)
        # M_jk += tr(A_j P A_k^T) = sum_ab (A_j P)_ab (A_k)_ab
        M += (A @ P).reshape(N, 16) @ A2.T
        if m:
            # M_jl += tr(A_j Q_l T^T) = sum_ab (A_j)_ab (T Q_l^T)_ab
            F = (T @ np.swapaxes(Q, 1, 2)).reshape(m, 16)
            cross = A2 @ F.T
            M[:, idx] += cross
            M[idx, :] += cross.T
            # A_l = 0 for the link's own modes, so the own block is only tr(D_kl).
            M[idx, idx] += ld.M_dd
        if want_h:
            Td, Tdd0 = fr.Td[i], fr.Tdd0[i]
            # h_j += tr(A_j (P Tdd0^T + 2 Pv Td^T)) = sum_ab A_ab (Tdd0 P^T + 2 Td Pv^T)_ab
            h += A2 @ (Tdd0 @ P.T + 2.0 * Td @ Pv.T).ravel()
            if m:
                # h_l += tr(Tdd0 Q_l T^T) + 2 tr(Td Qd_l T^T)
                h[idx] += F @ Tdd0.ravel() + 2.0 * (T @ np.swapaxes(Qd, 1, 2)).reshape(m, 16) @ Td.ravel()
        if want_dV:
            # V_g = -g~^T T m_r:  dV/dq_j = -g~^T A_j m_r,  dV/ddelta_l = -g~^T T m_psi,l
            dV -= (A @ m_r) @ gt
            if m:
                dV[idx] -= (ld.m_psi @ T.T) @ gt
        if ld.has_rotary:
            R = T[:3, :3]
            W = _vee_skew(np.einsum("ba,jbc->jac", R, A[:, :3, :3]))  # (N, 3)
            Jb = ld.J_body
            M += W @ Jb @ W.T
            if want_h:
                w = W.T @ qdot
                alpha0 = _vee_skew(R.T @ fr.Tdd0[i][:3, :3])
                h += W @ (Jb @ alpha0 + np.cross(w, Jb @ w))
    return M, h, dV


def mass_matrix(model, q: np.ndarray) -> np.ndarray:
    """Mass matrix M(q) = sum int mu J^T J dx + sum W^T J W, shape (N, N)."""
    return _assemble(model, q, None, False, False)[0]


def bias_forces(model, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """Velocity-product terms h(q, qdot) = sum int mu J^T a0 dx + rotary, shape (N,)."""
    return _assemble(model, q, qdot, True, False)[1]


def potential_forces(model, q: np.ndarray) -> np.ndarray:
    """dV/dq of gravity and strain energy, shape (N,)."""
    return _assemble(model, q, None, False, True)[2]


def diagnose_singular(model, q: np.ndarray) -> str:
    """A sentence naming the likely cause of a singular mass matrix at q."""
    causes = []
    if model.free_base and abs(np.cos(q[4])) < 1e-6:
        causes.append(
            f"gimbal lock: theta_0 = {q[4]:.6g} rad is at +-pi/2 where Rx(theta_-1) Ry(theta_0) Rz(theta_1) "
            "loses a rotation; start away from it"
        )
    if model.free_base and model.n_links == 1 and model.link_data[0].J_body[0, 0] == 0.0:
        causes.append(
            "a single link has no inertia about its own axis (rotary_inertia j_x = 0): give the link a "
            "rotary_inertia=(j_x, j_y, j_z) with j_x > 0"
        )
    lds = model.link_data
    if model.free_base and all(np.count_nonzero(ld.J_body) == 0 for ld in lds) and model.n_links > 1:
        pos = frames(model, q).T[:, :3, 3]
        d = pos[1:] - pos[0]
        if np.linalg.matrix_rank(d, tol=1e-9 * max(1.0, np.abs(d).max())) <= 1 and not any(
            np.any(q[i]) for i in model.delta_index
        ):
            causes.append(
                "the chain is straight and undeformed with no rotary inertia, so nothing resists spinning "
                "about its axis: give the links rotary_inertia or start from a bent configuration"
            )
    if not causes:
        causes.append("the configuration gives a rank-deficient mass matrix (check rotary_inertia and theta_0)")
    return "; ".join(causes)


def forward_dynamics(model, q: np.ndarray, qdot: np.ndarray, Q: np.ndarray | None = None) -> np.ndarray:
    """Generalised accelerations from M qddot = Q - h - dV/dq, shape (N,).

    Parameters
    ----------
    Q : (N,) optional applied generalised forces [N, N m].

    Raises
    ------
    SingularMassMatrixError
        When M is not positive definite; the message names the likely cause.
    """
    M, h, dV = _assemble(model, q, qdot, True, True)
    rhs = -h - dV
    if Q is not None:
        rhs = rhs + Q
    # Cholesky factor and solve in one LAPACK call; info > 0: not positive definite.
    c, x, info = _dposv(M, rhs, lower=1)
    if info != 0:
        raise SingularMassMatrixError(f"mass matrix is not positive definite: {diagnose_singular(model, q)}")
    d = np.diag(c)
    if d.min() < 1e-7 * d.max():
        raise SingularMassMatrixError(
            f"mass matrix is numerically singular (condition ~{(d.max() / d.min())**2:.1e}): "
            f"{diagnose_singular(model, q)}"
        )
    return x


def energy(model, q: np.ndarray, qdot: np.ndarray) -> Energy:
    """Kinetic, gravitational and strain energy, joules.

    E_k = 1/2 qdot^T M qdot,  V_g = -g~^T sum T_i m_r,i,  V_s = 1/2 delta^T K delta
    """
    M = mass_matrix(model, q)
    return _energy_from(model, q, qdot, M)


def _energy_from(model, q, qdot, M) -> Energy:
    kin = 0.5 * qdot @ M @ qdot
    grav = -model.gravity @ center_of_mass(model, q) * model.total_mass
    strain = 0.5 * q @ model.stiffness_matrix @ q
    return Energy(float(kin), float(grav), float(strain), float(kin + grav + strain))


def center_of_mass(model, q: np.ndarray) -> np.ndarray:
    """Mass centre sum T_i m_r,i / m, shape (3,) [m]."""
    fr = frames(model, q)
    s = np.zeros(4)
    for i, ld in enumerate(model.link_data):
        s += fr.T[i] @ (ld.m_r0 + q[model.delta_index[i]] @ ld.m_psi)
    return s[:3] / model.total_mass


def momentum(model, q: np.ndarray, qdot: np.ndarray):
    """Linear momentum L (3,) [kg m/s], angular momentum about the origin H0 (3,)
    [kg m^2/s], and mass centre c (3,) [m].

    L  = sum (Td m_r + T m_rdot),       m_rdot = int mu rdot
    H0 = sum int mu p x pdot + R J omega, int mu p pdot^T = T P Td^T + T Pv T^T
    """
    fr = frames(model, q, qdot)
    L = np.zeros(3)
    H = np.zeros(3)
    s = np.zeros(4)
    for i, ld in enumerate(model.link_data):
        idx = model.delta_index[i]
        T, Td = fr.T[i], fr.Td[i]
        P, Q, m_r, Pv, Qd = _link_moments(ld, q[idx], qdot[idx])
        L += (Td @ m_r + T @ (qdot[idx] @ ld.m_psi))[:3]
        s += T @ m_r
        X = (T @ P @ Td.T + T @ Pv @ T.T)[:3, :3]
        H += np.array([X[1, 2] - X[2, 1], X[2, 0] - X[0, 2], X[0, 1] - X[1, 0]])
        if ld.has_rotary:
            R = T[:3, :3]
            w = _vee_skew(R.T @ Td[:3, :3])
            H += R @ (ld.J_body @ w)
    return L, H, s[:3] / model.total_mass
