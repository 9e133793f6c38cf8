"""Gibbs-Appell equations of the flight phase (docs/theory.md §6).

All functions are pure: ``f(model, q, qdot)`` with q, qdot of shape (N,).
They are thin wrappers of the compiled kernel (``kernel.py``, whose module
docstring derives the O(n^2) composite-body recursion):

    M(q) qddot + h(q, qdot) + dV/dq = Q,
    M = sum_i int mu J^T J dx (+ rotary),  h = sum_i int mu J^T a0 dx (+ rotary),
    V = -g~ . sum_i T_i m_r,i + 1/2 delta^T K delta.
"""

from __future__ import annotations

import math
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




def mass_matrix(model, q: np.ndarray) -> np.ndarray:
    """Mass matrix M(q), shape (N, N) [kg, kg m, kg m^2 by block]."""
    N = model.n_dof
    return one_state(model, q, None, _k.JOB_M)[3:3 + N * N].reshape(N, N)


def _h_dV(model, q, qdot):
    N = model.n_dof
    out = one_state(model, q, qdot, _k.JOB_H)
    return out[3:3 + N], out[3 + N:3 + 2 * N]


def bias_forces(model, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """Velocity-product terms h(q, qdot), shape (N,) [N, N m]."""
    return _h_dV(model, q, qdot)[0]


def potential_forces(model, q: np.ndarray) -> np.ndarray:
    """dV/dq of gravity and strain energy, shape (N,) [N, N m]."""
    return _h_dV(model, q, None)[1]


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


_NDARRAY = np.ndarray
_EMPTY = np.empty
_isfinite = math.isfinite
_JOB_QDDOT = _k.JOB_QDDOT


def _singular(model, q, qdot, Q):
    """Raise SingularMassMatrixError for the state where the kernel's q̈ found M singular (its
    pivots from a JOB_SOLVE call)."""
    out = run_kernel(model, states(q, qdot), _k.JOB_SOLVE, Q)
    _raise_singular(model, q, out[0], out[1], out[2])


def forward_dynamics(model, q: np.ndarray, qdot: np.ndarray, Q: np.ndarray | None = None) -> np.ndarray:
    """Generalised accelerations from M qddot = Q - h - dV/dq, shape (N,).

    Parameters
    ----------
    q, qdot : (N,) state [m, rad; m/s, rad/s].
    Q : (N,) optional applied generalised forces [N, N m].

    Raises
    ------
    SingularMassMatrixError
        When M is not positive definite or its Cholesky pivots spread beyond
        1e7 (condition beyond 1e14); the message names the likely cause.
    """
    # The hot path of every simulation (one call per RHS): float64 arrays of the right shape go
    # straight to the kernel, which refuses (TypeError, no recompile) a non-contiguous one or one
    # of another type; only then are they converted. It takes read-only arrays (its signature
    # types q, qdot and Q read-only). The kernel does not check bounds: shapes are.
    f, fdat, idat, zeros, v0, v1, _ = model.kernel_call
    shape, N = zeros.shape, zeros.size
    if Q is None and q.__class__ is _NDARRAY and qdot.__class__ is _NDARRAY and q.shape == shape \
            and qdot.shape == shape:
        out = _EMPTY(N)
        try:
            status = f(fdat, idat, q, qdot, zeros, _JOB_QDDOT, v0, v1, out)
        except TypeError:
            pass
        else:
            if status:
                _singular(model, q, qdot, None)
            return out
    q, qdot = as_vector(q), as_vector(qdot)
    if q.size != N or qdot.size != N:
        raise ValueError(f"forward_dynamics q, qdot have shapes {q.shape}, {qdot.shape}; this model needs "
                         f"({N},) each")
    if Q is not None:
        Q = np.ascontiguousarray(Q, dtype=float)
        if Q.shape != (N,):
            raise ValueError(f"forward_dynamics Q has shape {Q.shape}; this model needs ({N},) generalised forces "
                             f"ordered as {', '.join(model.coordinate_names)}")
    out = _EMPTY(N)
    if f(fdat, idat, q, qdot, zeros if Q is None else Q, _JOB_QDDOT, v0, v1, out) != 0.0:
        _singular(model, q, qdot, Q)
    return out


def checked_forward_dynamics(model, q, qdot) -> np.ndarray:
    """forward_dynamics(model, q, qdot) with q, qdot validated as Model.check_state does (its messages), at
    the cost of one dot product when they are float64 (N,) arrays with finite entries: the call behind
    Model.forward_dynamics. (forward_dynamics itself passes non-finite states through: a solver's trial
    state may be one, and its NaN accelerations make the solver shrink the step.)"""
    shape = model.kernel_call[3].shape
    if q.__class__ is _NDARRAY and qdot.__class__ is _NDARRAY and q.shape == shape and qdot.shape == shape \
            and _isfinite(q.dot(q) + qdot.dot(qdot)):
        return forward_dynamics(model, q, qdot)
    return forward_dynamics(model, *model.check_state(q, qdot))


def energy(model, q: np.ndarray, qdot: np.ndarray) -> Energy:
    """Kinetic, gravitational and strain energy, joules.

    E_k = 1/2 qdot^T M qdot,  V_g = -g~^T sum T_i m_r,i,  V_s = 1/2 delta^T K delta
    """
    kin, grav, strain = one_state(model, q, qdot, _k.JOB_ENERGY)[3:6].tolist()
    return Energy(kin, grav, strain, kin + grav + strain)


def energies(model, qs: np.ndarray, qdots: np.ndarray) -> Energy:
    """Energies of the states qs, qdots (K, N): Energy of arrays (K,) [J], one kernel call."""
    qs = np.asarray(qs, dtype=float)
    E = run_kernel(model, states(qs, qdots), _k.JOB_ENERGY)[3:].reshape(-1, 3)
    return Energy(E[:, 0].copy(), E[:, 1].copy(), E[:, 2].copy(), E.sum(axis=1))


def center_of_mass(model, q: np.ndarray) -> np.ndarray:
    """Mass centre sum T_i m_r,i / m, shape (3,) [m]."""
    return one_state(model, q, None, _k.JOB_MOMENTUM)[9:12] / model.total_mass


def momentum(model, q: np.ndarray, qdot: np.ndarray):
    """Linear momentum L (3,) [kg m/s], angular momentum about the origin H0 (3,)
    [kg m^2/s], and mass centre c (3,) [m].

    L  = sum (Td m_r + T m_rdot),       m_rdot = int mu rdot
    H0 = sum int mu p x pdot (rotary inertia included), int mu p pdot^T = T P Td^T + T Pv T^T
    """
    out = one_state(model, q, qdot, _k.JOB_MOMENTUM)
    return out[3:6], out[6:9], out[9:12] / model.total_mass
