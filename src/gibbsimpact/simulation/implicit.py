"""The Jacobian of a run's right-hand side, for the implicit methods (Radau, BDF, LSODA).

For a flight phase, y = (q, qdot) (2N,) or (q, qdot, W_in, W_damp) (2N + 2,) for a driven run
(gibbsimpact.simulation.equations):

    q' = qdot,   M qddot = Q - h - dV/dq,   Q = Q_in(t, q, qdot) + Q_damp(q, qdot)
    W_in' = qdot . Q_in,   W_damp' = qdot . Q_damp

    df/dy = [[0,                           I,                               0],
             [A + M^-1 dQ/dq,               D + M^-1 dQ/dqdot,               0],
             [qdot^T dQ_in/dq,             Q_in + qdot^T dQ_in/dqdot,       0],
             [qdot^T dQ_damp/dq,           Q_damp + qdot^T dQ_damp/dqdot,   0]]

A = d qddot/d q, D = d qddot/d qdot at fixed Q, and M^-1 come from the compiled kernel
(gibbsimpact.dynamics.jacobian); dQ/dq, dQ/dqdot are forward differences of the applied forces,
user callbacks evaluated in Python (forward differences: 2N calls, the cost of scipy's own
differences of the right-hand side, which the kernel's part replaces).
The work rows are first-order in the small quantities and never stiff; the W columns are zero
because nothing depends on the work.

A resting-contact phase has its own right-hand side (constrained accelerations,
gibbsimpact.contact.resting): there the solver builds its Jacobian by finite differences of
that right-hand side (scipy's default), as before.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.jacobian import acceleration_jacobian

#: The methods that use a Jacobian (scipy's implicit solvers; LSODA in its stiff mode).
IMPLICIT = ("Radau", "BDF", "LSODA")
#: Relative step of the applied forces' forward differences: sqrt(eps) balances truncation and round-off.
FORCE_STEP = 1.4901161193847656e-08


def _force_derivatives(forces, t, q, qd, f0):
    """(dQ_in/dq, dQ_in/dqdot, dQ_damp/dq, dQ_damp/dqdot), each (N, N), by forward differences of
    forces(t, q, qd) -> (Q_in, Q_damp) (N,) each, f0 = forces(t, q, qd): 2N calls of the callbacks
    (steps FORCE_STEP (1 + |x_j|), error ~ FORCE_STEP |d^2 Q| ~ 1e-8 relative for forces smooth on the
    scale of the state)."""
    N = q.size
    out = np.zeros((4, N, N))
    for which, x in ((0, q), (1, qd)):
        for j in range(N):
            e = FORCE_STEP * (1.0 + abs(x[j]))
            xp = x.copy()
            xp[j] += e
            fp = forces(t, xp, qd) if which == 0 else forces(t, q, xp)
            out[which, :, j] = (fp[0] - f0[0]) / e
            out[2 + which, :, j] = (fp[1] - f0[1]) / e
    return out


def rhs_jacobian(equations, t: float, y: np.ndarray) -> np.ndarray:
    """df/dy (n, n) of the flight right-hand side ``equations(t, y)`` at (t, y), n = y.size = 2N or 2N + 2
    (module docstring): [[0, I], [A, D]] from the kernel, with the applied forces' derivatives added.

    Units follow y: d qdot/d q [1/s], d qddot/d q [1/s^2], d qddot/d qdot [1/s], work rows [N, N s].
    Raises SingularMassMatrixError where M is singular at y (the solver then stops as for a singular
    right-hand side).
    """
    N = equations.N
    q, qd = np.ascontiguousarray(y[:N]), np.ascontiguousarray(y[N:2 * N])
    J = np.zeros((y.size, y.size))
    J[:N, N:2 * N] = np.eye(N)
    forces = equations.forces(t, q, qd)
    if forces is None:
        jac = acceleration_jacobian(equations.model, q, qd)
        J[N:2 * N, :N], J[N:2 * N, N:2 * N] = jac.A, jac.D
        return J
    Qi, Qd = forces
    jac = acceleration_jacobian(equations.model, q, qd, Qi + Qd)
    dQi_q, dQi_qd, dQd_q, dQd_qd = _force_derivatives(equations.forces, t, q, qd, forces)
    J[N:2 * N, :N] = jac.A + jac.M_inv @ (dQi_q + dQd_q)
    J[N:2 * N, N:2 * N] = jac.D + jac.M_inv @ (dQi_qd + dQd_qd)
    if y.size == 2 * N + 2:
        J[2 * N, :N], J[2 * N, N:2 * N] = qd @ dQi_q, Qi + qd @ dQi_qd
        J[2 * N + 1, :N], J[2 * N + 1, N:2 * N] = qd @ dQd_q, Qd + qd @ dQd_qd
    return J
