"""Equations of motion with prescribed coordinates (docs/theory.md, prescribed joint motion; formulation §16).

With q = (q_f, q_p), q_p(t) given with its derivatives, the Gibbs-Appell equations
M qddot = Q - h - dV/dq split into the free rows, which give qddot_f, and the prescribed rows,
which give the generalised force the actuator must apply (its effort):

    M_ff qddot_f = Q_f - h_f - dV/dq_f - M_fp qddot_p
    Q_p          = M_pf qddot_f + M_pp qddot_p + h_p + dV/dq_p - Q_p(given)

Pure functions of (model, q, qdot); one kernel call for M, h and dV/dq together.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from .. import kernel as _k
from .gibbs_appell import SingularMassMatrixError, diagnose_singular
from .kinematics import one_state

_JOB_MH = _k.JOB_M | _k.JOB_H


def mass_and_forces(model, q: np.ndarray, qdot: np.ndarray):
    """(M (N, N) [kg, kg m, kg m^2], h (N,), dV/dq (N,) [N, N m]) at (q, qdot) (N,) in one kernel call."""
    N = model.n_dof
    out = one_state(model, q, qdot, _JOB_MH)
    return (out[3:3 + N * N].reshape(N, N), out[3 + N * N:3 + N * N + N],
            out[3 + N * N + N:3 + N * N + 2 * N])


def partitioned_dynamics(model, q: np.ndarray, qdot: np.ndarray, prescribed: np.ndarray, qddot_p: np.ndarray,
                         Q: np.ndarray | None = None):
    """Accelerations and actuator efforts with the coordinates ``prescribed`` given (module docstring).

    Parameters
    ----------
    q, qdot : (N,) the full state, the prescribed entries already set to q_p(t), qdot_p(t) [m, rad; m/s, rad/s]
    prescribed : (n_p,) int, indices of the prescribed coordinates in q (sorted, unique)
    qddot_p : (n_p,) their accelerations [m/s^2, rad/s^2]
    Q : (N,) or None, applied generalised forces [N, N m] (inputs, damping)

    Returns
    -------
    qddot : (N,) with qddot[prescribed] = qddot_p; effort : (n_p,) Q_p [N m on an angle, N on a length]

    Raises SingularMassMatrixError when M_ff is not positive definite.
    """
    M, h, dV = mass_and_forces(model, q, qdot)
    r = -h - dV if Q is None else Q - h - dV
    free = np.ones(q.size, dtype=bool)
    free[prescribed] = False
    qddot = np.empty(q.size)
    qddot[prescribed] = qddot_p
    M_fp = M[np.ix_(free, prescribed)]
    if not free.any():  # every coordinate prescribed: only the efforts are unknown
        return qddot, M @ qddot - r
    try:
        qddot[free] = cho_solve(cho_factor(M[np.ix_(free, free)]), r[free] - M_fp @ qddot_p)
    except np.linalg.LinAlgError:
        raise SingularMassMatrixError(f"the free block M_ff of the mass matrix is not positive definite: "
                                      f"{diagnose_singular(model, q)}") from None
    effort = M[prescribed] @ qddot - r[prescribed]
    return qddot, effort
