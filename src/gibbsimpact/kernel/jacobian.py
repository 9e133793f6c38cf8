"""Jacobian stage: the derivatives of qddot for an implicit integrator, by central differences in compiled code.

For the first-order form y = (q, qdot) (2N,), y' = (qdot, qddot(q, qdot)) with
M(q) qddot = Q - h(q, qdot) - dV/dq (Q held fixed), the Jacobian of y' is

    J = [[0, I], [A, D]],   A = d qddot / d q (N, N),   D = d qddot / d qdot (N, N)

and the applied forces enter through d qddot / d Q = M^-1 (the caller adds M^-1 dQ/dq, M^-1 dQ/dqdot).

A and D are central differences of the kernel's own stages (position -> moments -> assemble ->
Cholesky solve) inside one compiled call (6N evaluations, no Python in the loop). A is
Richardson-extrapolated from the steps e_j and e_j / 2:

    C_j(e) = (qddot(q + e e_j, qdot) - qddot(q - e e_j, qdot)) / (2 e)
    A[:, j] = (4 C_j(e_j / 2) - C_j(e_j)) / 3,   e_j = STEP (1 + |q_j|),   STEP = 1e-3

which cancels the e^2 term of the truncation error and leaves ~ e^4 d^5 qddot / dq^5 / 480, with a
round-off ~ eta |qddot| / e: eta is the relative round-off of qddot, eps times an amplification
by M's conditioning that is ~1e4 on stiff spatial chains of finite elements (measured: a plain
central difference with e = eps^(1/3) missed by 1e-6 there, this by ~1e-8, a plain one with
e = 1e-3 by 2e-4; the conditioning is why a larger step, and its truncation why the extrapolation).
D = d qddot / d qdot is one central difference with steps STEP (1 + |qdot_j|) and no truncation
error: qddot is quadratic in qdot (h is), and a central difference of a quadratic is exact.
An analytic derivative of the recursion would be exact for A too, at the cost of differentiating
every stage (frames, moments, the Pb shape integrals); this is what the kernel's stages give
without touching them.
"""

from __future__ import annotations

import numpy as np

from .assemble import assemble
from .frames import chain_frames
from .layout import _mmax, work_sizes, work_slots
from .linalg import _cholesky_apply, _cholesky_factor
from .moments import _sd_stride, moments

#: Relative step of the differences (module docstring): A's larger one, halved for the extrapolation, and D's.
STEP = 1e-3


def jacobian_size(N):
    """Entries of state_jacobian's output for N coordinates: status, qddot, A, D, M^-1."""
    return 1 + N + 3 * N * N


def state_jacobian(fdat, idat, q, qd, Q, pris, ends, out):
    """Compiled entry point: qddot (N,), A = d qddot/d q, D = d qddot/d qdot and M^-1 (N, N each) at (q, qd).

    q, qd: the state (N,) [m, rad; m/s, rad/s]; Q: applied forces (N,) [N, N m], held fixed;
    out (jacobian_size(N),): [status, qddot, A row-major, D row-major, M^-1 row-major]; status 0
    solved, 1 M not positive definite, 2 pivots spread beyond 1e7 (at (q, qd) or a perturbed
    state; then the rest of out is not meaningful). Units: A [1/s^2], D [1/s], M^-1 [1/kg ...].
    Returns the status, or -1.0 when out has the wrong size (nothing written).
    """
    N = idat[1]
    if out.shape[0] != jacobian_size(N):
        return -1.0
    n = idat[0]
    mmax = _mmax(idat)
    ws = work_slots(n, N, mmax, idat[7])
    nB, nV = work_sizes(ws, N, True, True)
    B = np.zeros((nB, 4, 4))
    V = np.zeros((nV, 4))
    SD = np.zeros(n * _sd_stride(mmax))
    M = np.zeros((N, N))
    h = np.zeros(N)
    dV = np.zeros(N)
    x = np.zeros(N)
    xd = np.zeros(N)
    for i in range(N):
        x[i] = q[i]
        xd[i] = qd[i]
    qdd = np.zeros(N)  # qddot at (q, qd), then the scratch of the extrapolation
    plus = np.zeros(N)
    minus = np.zeros(N)
    status = _accel(fdat, idat, x, xd, Q, B, V, SD, ws, M, h, dV, pris, ends, qdd)
    for i in range(N):
        out[1 + i] = qdd[i]
    _inverse(M, out, 1 + N + 2 * N * N)
    for col in range(2 * N):
        v = x if col < N else xd
        j = col % N
        v0 = v[j]
        e = STEP * (1.0 + abs(v0))
        status = max(status, _central(fdat, idat, x, xd, Q, B, V, SD, ws, M, h, dV, pris, ends, v, j, e, plus, minus))
        if col < N:  # Richardson: (4 C(e / 2) - C(e)) / 3
            for i in range(N):
                qdd[i] = plus[i]
            status = max(status, _central(fdat, idat, x, xd, Q, B, V, SD, ws, M, h, dV, pris, ends, v, j, 0.5 * e,
                                          plus, minus))
            for i in range(N):
                plus[i] = (4.0 * plus[i] - qdd[i]) / 3.0
        o = 1 + N + (0 if col < N else N * N)
        for i in range(N):
            out[o + N * i + j] = plus[i]
    out[0] = status
    return float(status)


def _central(fdat, idat, q, qd, Q, B, V, SD, ws, M, h, dV, pris, ends, v, j, e, d, scratch):
    """(qddot(v_j + e) - qddot(v_j - e)) / (2 e) (N,) into d, v being q or qd (restored after);
    scratch (N,). Returns the worse Cholesky status of the two states."""
    v0 = v[j]
    v[j] = v0 + e
    s1 = _accel(fdat, idat, q, qd, Q, B, V, SD, ws, M, h, dV, pris, ends, d)
    v[j] = v0 - e
    s2 = _accel(fdat, idat, q, qd, Q, B, V, SD, ws, M, h, dV, pris, ends, scratch)
    v[j] = v0
    for i in range(d.shape[0]):
        d[i] = (d[i] - scratch[i]) / (2.0 * e)
    return max(s1, s2)


def _accel(fdat, idat, q, qd, Q, B, V, SD, ws, M, h, dV, pris, ends, qdd):
    """qddot (N,) into qdd from M qddot = Q - h - dV/dq at (q, qd): the kernel's position, moments,
    assemble and solve stages on zeroed work arrays. Returns the Cholesky status (0, 1, 2); M holds
    the mass matrix at (q, qd) afterwards."""
    N = q.shape[0]
    B[:] = 0.0
    V[:] = 0.0
    SD[:] = 0.0
    h[:] = 0.0
    dV[:] = 0.0
    chain_frames(fdat, idat, q, qd, True, B, ws, pris, ends)
    moments(fdat, idat, q, qd, B, V, SD, ws, pris, ends)
    assemble(fdat, idat, q, True, B, V, SD, ws, M, h, dV, pris, ends)
    L, status, dmin, dmax = _cholesky_factor(M)
    if status == 1:
        return 1
    rhs = np.zeros(N)
    for i in range(N):
        rhs[i] = Q[i] - h[i] - dV[i]
    x = _cholesky_apply(L, rhs)
    for i in range(N):
        qdd[i] = x[i]
    return status


def _inverse(M, out, o):
    """M^-1 (N, N) row-major into out[o:], by Cholesky (N solves); zeros when M is not positive definite.
    """
    N = M.shape[0]
    L, status, dmin, dmax = _cholesky_factor(M)
    if status == 1:
        return
    e = np.zeros(N)
    for j in range(N):
        e[:] = 0.0
        e[j] = 1.0
        c = _cholesky_apply(L, e)
        for i in range(N):
            out[o + N * i + j] = c[i]
