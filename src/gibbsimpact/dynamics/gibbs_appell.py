"""Gibbs-Appell equations of the flight phase (docs/theory.md §6).

All functions are pure: ``f(model, q, qdot)`` with q, qdot of shape (N,).
Each is one call of the compiled kernel (``gibbsimpact.kernel``, whose package
docstring derives the O(n^2) composite-body recursion). With ``check=True``
(what the Model methods pass) a non-finite entry of q or qdot raises
Model.check_state's ValueError naming its coordinates, checked inside the
compiled call; without it non-finite states pass through (NaN results).

    M(q) qddot + h(q, qdot) + dV/dq = Q,
    M = sum_i int mu J^T J dx (+ rotary),  h = sum_i int mu J^T a0 dx (+ rotary),
    V = -g~ . sum_i T_i m_r,i + 1/2 delta^T K delta.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import kernel as _k
from .kinematics import as_vector, joint_positions, one_state, run_kernel, states


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




def mass_matrix(model, q: np.ndarray, *, check: bool = False) -> np.ndarray:
    """Mass matrix M(q), shape (N, N) [kg, kg m, kg m^2 by block]: M = sum_i int mu J^T J dx (+ rotary)."""
    N = model.n_dof
    return one_state(model, q, None, _JOB_M, None, check)[3:3 + N * N].reshape(N, N)


def bias_forces(model, q: np.ndarray, qdot: np.ndarray, *, check: bool = False) -> np.ndarray:
    """Velocity-product terms h(q, qdot), shape (N,) [N, N m]: h = sum_i int mu J^T a0 dx (+ rotary)."""
    return one_state(model, q, qdot, _JOB_H, None, check)[3:3 + model.n_dof]


def potential_forces(model, q: np.ndarray, *, check: bool = False) -> np.ndarray:
    """dV/dq of gravity and strain energy, shape (N,) [N, N m]."""
    N = model.n_dof
    return one_state(model, q, None, _JOB_H, None, check)[3 + N:3 + 2 * N]


def diagnose_singular(model, q: np.ndarray) -> str:
    """A sentence naming the likely cause of a singular mass matrix at q."""
    causes = []
    if model.chain.base == "free" and abs(np.cos(q[4])) < 1e-6:
        causes.append(
            f"gimbal lock: theta_0 = {q[4]:.6g} rad is at +-pi/2 where Rx(theta_-1) Ry(theta_0) Rz(theta_1) "
            "loses a rotation, a singularity of this chart of the base's orientation, not of the motion: simulate "
            "runs through it (it re-charts the base, formulation §18); for one state, take the same orientation "
            "in another chart (gibbsimpact.dynamics.base_chart.rechart, Model.with_base_chart)"
        )
    if model.chain.base == "free" and model.n_links == 1 and model.link_data[0].J_body[0, 0] == 0.0:
        causes.append(
            "a single link has no inertia about its own axis (rotary_inertia j_x = 0): give the link a "
            "rotary_inertia=(j_x, j_y, j_z) with j_x > 0"
        )
    lds = model.link_data
    if model.chain.base == "free" and all(np.count_nonzero(ld.J_body) == 0 for ld in lds) and model.n_links > 1:
        pos = joint_positions(model, q)
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


def _raise_singular(model, q, status, dmin, dmax):
    if status == 1:
        raise SingularMassMatrixError(f"mass matrix is not positive definite: {diagnose_singular(model, q)}")
    raise SingularMassMatrixError(
        f"mass matrix is numerically singular (condition ~{(dmax / dmin) ** 2:.1e}): {diagnose_singular(model, q)}")


_EMPTY = np.empty
_TUPLE_NEW = tuple.__new__
_JOB_QDDOT, _JOB_M, _JOB_H, _JOB_ENERGY, _JOB_MOMENTUM = _k.JOB_QDDOT, _k.JOB_M, _k.JOB_H, _k.JOB_ENERGY, _k.JOB_MOMENTUM
_CHECKED_QDDOT = _k.JOB_QDDOT | _k.JOB_FINITE


def _singular(model, q, qdot, Q):
    """Raise SingularMassMatrixError for the state where the kernel's q̈ found M singular (its
    pivots from a JOB_SOLVE call)."""
    out = run_kernel(model, states(q, qdot), _k.JOB_SOLVE, Q)
    _raise_singular(model, q, out[0], out[1], out[2])


def forward_dynamics(model, q: np.ndarray, qdot: np.ndarray, Q: np.ndarray | None = None, *,
                     check: bool = False) -> np.ndarray:
    """Generalised accelerations from M qddot = Q - h - dV/dq, shape (N,).

    Parameters
    ----------
    q, qdot : (N,) state [m, rad; m/s, rad/s].
    Q : (N,) optional applied generalised forces [N, N m].
    check : validate q, qdot as Model.check_state does (what Model.forward_dynamics passes); without
        it a non-finite state gives NaN accelerations (a solver's trial state may be one: its NaN
        accelerations make the solver shrink the step).

    Raises
    ------
    SingularMassMatrixError
        When M is not positive definite or its Cholesky pivots spread beyond
        1e7 (condition beyond 1e14); the message names the likely cause.
    """
    # The hot path of every simulation (one call per RHS): the arrays go straight to the kernel, which
    # checks their sizes (and with check, their entries) and refuses (TypeError, no recompile) one of
    # another type or memory layout; only then are they validated and converted (_forward_refused).
    f, fdat, idat, zeros, v0, v1, _ = model.kernel_call
    out = _EMPTY(zeros.size)
    try:
        status = f(fdat, idat, q, qdot, zeros if Q is None else Q, _CHECKED_QDDOT if check else _JOB_QDDOT, v0, v1,
                   out)
    except TypeError:
        status = -1.0
    if status == 0.0:
        return out
    if status > 0.0:
        _singular(model, q, qdot, Q)
    return _forward_refused(model, q, qdot, Q, check)


def _forward_refused(model, q, qdot, Q, check) -> np.ndarray:
    """forward_dynamics of a state (or Q) the kernel refused: Model.check_state's ValueError (check), a
    ValueError naming the shapes, or the accelerations of the converted copies."""
    N = model.n_dof
    if check:
        q, qdot = model.check_state(q, qdot)
    q, qdot = as_vector(q), as_vector(qdot)
    if q.size != N or qdot.size != N:
        raise ValueError(f"forward_dynamics q, qdot have shapes {q.shape}, {qdot.shape}; this model needs "
                         f"({N},) each")
    if Q is not None:
        Q = np.ascontiguousarray(Q, dtype=float)
        if Q.shape != (N,):
            raise ValueError(f"forward_dynamics Q has shape {Q.shape}; this model needs ({N},) generalised forces "
                             f"ordered as {', '.join(model.coordinate_names)}")
    return forward_dynamics(model, q, qdot, Q)


def energy(model, q: np.ndarray, qdot: np.ndarray, *, check: bool = False) -> Energy:
    """Kinetic, gravitational and strain energy, joules.

    E_k = 1/2 qdot^T M qdot,  V_g = -g~^T sum T_i m_r,i,  V_s = 1/2 delta^T K delta
    """
    kin, grav, strain = one_state(model, q, qdot, _JOB_ENERGY, None, check)[3:6].tolist()
    # = Energy(kin, grav, strain, total), without the Python frame of a NamedTuple's __new__ (~0.2 us)
    return _TUPLE_NEW(Energy, (kin, grav, strain, kin + grav + strain))


def energies(model, qs: np.ndarray, qdots: np.ndarray) -> Energy:
    """Energies of the states qs, qdots (K, N): Energy of arrays (K,) [J], one kernel call."""
    qs = np.asarray(qs, dtype=float)
    E = run_kernel(model, states(qs, qdots), _k.JOB_ENERGY)[3:].reshape(-1, 3)
    return Energy(E[:, 0].copy(), E[:, 1].copy(), E[:, 2].copy(), E.sum(axis=1))


def center_of_mass(model, q: np.ndarray, *, check: bool = False) -> np.ndarray:
    """Mass centre sum T_i m_r,i / m, shape (3,) [m]."""
    return one_state(model, q, None, _JOB_MOMENTUM, None, check)[9:12] / model.total_mass


def linear_momentum(model, q: np.ndarray, qdot: np.ndarray, *, check: bool = False) -> np.ndarray:
    """Linear momentum L = sum (Td m_r + T m_rdot), shape (3,) [kg m/s] (momentum's first item)."""
    return one_state(model, q, qdot, _JOB_MOMENTUM, None, check)[3:6]


def momentum(model, q: np.ndarray, qdot: np.ndarray, *, check: bool = False):
    """Linear momentum L (3,) [kg m/s], angular momentum about the origin H0 (3,)
    [kg m^2/s], and mass centre c (3,) [m].

    L  = sum (Td m_r + T m_rdot),       m_rdot = int mu rdot
    H0 = sum int mu p x pdot (rotary inertia included), int mu p pdot^T = T P Td^T + T Pv T^T
    """
    out = one_state(model, q, qdot, _JOB_MOMENTUM, None, check)
    return out[3:6], out[6:9], out[9:12] / model.total_mass
