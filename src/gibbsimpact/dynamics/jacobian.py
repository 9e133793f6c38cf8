"""The Jacobian of the flight equations for implicit integrators, from the compiled kernel.

For y = (q, qdot) (2N,) and y' = (qdot, qddot), M(q) qddot = Q - h(q, qdot) - dV/dq:

    dy'/dy = [[0, I], [A, D]],   A = d qddot/d q,   D = d qddot/d qdot   (Q fixed)

and an applied force Q(t, q, qdot) adds M^-1 dQ/dq to A and M^-1 dQ/dqdot to D (the caller's:
gibbsimpact.simulation.implicit). A and D are central differences of the kernel's stages inside
one compiled call (kernel/jacobian.py: relative error ~eps^(2/3), D exact to round-off).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import kernel as _k
from .gibbs_appell import SingularMassMatrixError, _singular, diagnose_singular
from .kinematics import as_vector


class AccelerationJacobian(NamedTuple):
    """qddot (N,) [m/s^2, rad/s^2] at a state, its derivatives A = d qddot/d q (N, N) [1/s^2] and
    D = d qddot/d qdot (N, N) [1/s], and M^-1 (N, N) (= d qddot/d Q)."""

    qddot: np.ndarray
    A: np.ndarray
    D: np.ndarray
    M_inv: np.ndarray


def acceleration_jacobian(model, q: np.ndarray, qdot: np.ndarray, Q: np.ndarray | None = None) -> AccelerationJacobian:
    """qddot and its derivatives A = d qddot/d q, D = d qddot/d qdot, M^-1 at (q, qdot) with Q held fixed.

    Parameters
    ----------
    q, qdot : (N,) state [m, rad; m/s, rad/s]
    Q : (N,) applied generalised forces [N, N m] (held fixed), default zero

    Returns
    -------
    AccelerationJacobian (qddot, A, D, M_inv)

    Raises
    ------
    SingularMassMatrixError
        Where M is not positive definite (or its pivots spread beyond 1e7) at the state or at one of
        its perturbations (relative 1e-3), as forward_dynamics does.
    """
    _, fdat, idat, zeros, v0, v1, _ = model.kernel_call
    N = zeros.size
    q, qdot = as_vector(q), as_vector(qdot)
    if q.size != N or qdot.size != N:
        raise ValueError(f"acceleration_jacobian q, qdot have shapes {q.shape}, {qdot.shape}; this model needs "
                         f"({N},) each")
    Q = zeros if Q is None else np.ascontiguousarray(Q, dtype=float)
    if Q.shape != (N,):
        raise ValueError(f"acceleration_jacobian Q has shape {Q.shape}; this model needs ({N},) generalised forces")
    out = np.empty(_k.jacobian_size(N))
    status = _k.jacobian_entry((v0, v1))(fdat, idat, q, qdot, Q, v0, v1, out)
    if status != 0.0:
        _singular(model, q, qdot, Q)  # raises when the state itself is singular ...
        raise SingularMassMatrixError(  # ... else a perturbation of it (relative 6e-6) is
            f"mass matrix is singular within a relative 1e-3 of the state: {diagnose_singular(model, q)}")
    blocks = out[1 + N:].reshape(3, N, N)
    return AccelerationJacobian(out[1:1 + N].copy(), blocks[0].copy(), blocks[1].copy(), blocks[2].copy())
