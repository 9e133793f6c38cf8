"""The one compiled entry point ``kernel``: a dispatcher over the kernel's named stages.

    position     frames.chain_frames       frames T, Td, Tdd0 and world twists S_c
    moments      moments.moments           body moments P, Pv, m_r, q_l of every link
    assemble     assemble.assemble         M, h, dV/dq
    solve        _solve                    M qddot = Q - h - dV/dq (linalg: Cholesky)
    observables  observables.*             energies, momenta, contact points, Jacobians, frames

``kernel`` runs position -> moments -> assemble -> solve for the first state when the job
asks for M, h, dV/dq or qddot, then position (-> moments) -> observables for each state when
it asks for observables. The stages share the work arrays B, V and SD of one call
(layout.work_slots), and write into one output array (layout.layout).

One entry point, because numba links and optimises every entry point with all the code it
calls: one entry compiles in about half the time of two. For the same reason the stages are
few separately compiled functions (chain_frames, moments, assemble, link_observables, the
Cholesky solve), each calling the parts it is split into for reading as inline helpers
(layout.inline): every separately compiled layer re-optimises the code it links. The output
is an argument, not a return value: numba boxes a returned array at ~1.3 us a call (a quarter
of forward_dynamics on case 1), a returned float costs nothing.
"""

from __future__ import annotations

import math

import numpy as np

from .assemble import assemble
from .frames import chain_frames
from .layout import (_S_DV, _S_EN, _S_H, _S_M, _S_MO, _S_STATUS, _S_YDOT, JOB_ENERGY, JOB_FINITE, JOB_FRAMES,
                     JOB_H, JOB_JACOBIANS, JOB_M, JOB_MOMENTUM, JOB_POINTS, JOB_QDDOT, JOB_SOLVE, _mmax, inline, layout,
                     work_sizes, work_slots)
from .linalg import _cholesky_solve
from .moments import _sd_stride, moments
from .observables import _extra_points, frame_outputs, link_observables

#: The JOB bits that need the first state's M, h or dV, and those of the observables.
_DYNAMICS = JOB_M | JOB_H | JOB_SOLVE | JOB_QDDOT
_OBSERVABLES = JOB_ENERGY | JOB_MOMENTUM | JOB_POINTS | JOB_JACOBIANS | JOB_FRAMES


def kernel(fdat, idat, qs, qds, Q, job, pris, ends, out):
    """The one compiled entry point: everything the package computes from states.

    qs, qds: K states q and qdot one after the other, (K N,) each; Q: applied
    forces (N,) (with JOB_SOLVE or JOB_QDDOT, for the first state); job: a bit mask of JOB_*; out: the output,
    a float64 array of ``layout(n, N, K, job, n + 1 + X)[10]`` entries (``output``), all of them
    written, laid out as that layout says:

    * status (3,): Cholesky status of M (0 solved; 1 not positive definite;
      2 pivots spread beyond 1e7) and its smallest and largest pivot;
    * JOB_SOLVE: ydot (2N,) = (qdot, qddot), M qddot = Q - h - dV/dq (NaN when
      status != 0, so that an integrator rejects the step); add JOB_M, JOB_H for M, h, dV
      (not copied out otherwise: the right-hand side of an ODE needs ydot only);
      JOB_QDDOT (without JOB_SOLVE): qddot (N,) in ydot's place, and no status section when it
      is the only bit (the output is qddot alone; the pivots need JOB_SOLVE);
    * JOB_M: M (N N,) row-major; JOB_H: h (N,), dV/dq (N,)  (the first state);
    * JOB_ENERGY: (K 3,) kinetic, gravity, strain [J]; JOB_MOMENTUM: (K 9,) as in
      link_observables (L, H0, first moment); JOB_POINTS: contact points (K P 3,) [m], P = n + 1 + X:
      the frame origins O_1 .. O_(n+1), then the tip of every host link whose child joint is
      prismatic (not a frame origin); JOB_JACOBIANS: dO_j/dq (K P 3 N,), dO_j/dq_c = (S_c O_j)[:3]
      when f_c <= j, else 0 (a tip of link h: f_c <= h, and R_h end_t_k for h's own delta_k);
      JOB_FRAMES: T, Tdot, Tddot0 (K 3 (n+1) 16,).

    Returns the status of M's Cholesky factor (0.0 without JOB_SOLVE, JOB_QDDOT); -1.0 when an
    array has the wrong size: qs not K N entries, qds not as many, Q not N (with JOB_SOLVE or
    JOB_QDDOT), out not the layout's (then nothing is written: the kernel does not check bounds
    otherwise); -2.0 with JOB_FINITE when qs or qds has a non-finite entry (nothing written).
    """
    n = idat[0]
    N = idat[1]
    K = qs.shape[0] // N
    L = layout(n, N, K, job, n + 1 + idat[3])
    if out.shape[0] != L[10] or qs.shape[0] != K * N or qds.shape[0] != K * N \
            or ((job & (JOB_SOLVE | JOB_QDDOT)) != 0 and Q.shape[0] != N):
        return -1.0
    if job & JOB_FINITE:
        for i in range(K * N):
            if not (math.isfinite(qs[i]) and math.isfinite(qds[i])):
                return -2.0
    for i in range(L[10]):
        out[i] = 0.0
    dynamics = (job & _DYNAMICS) != 0
    energies = (job & (JOB_ENERGY | JOB_MOMENTUM)) != 0
    mmax = _mmax(idat)
    ws = work_slots(n, N, mmax, idat[7])
    nB, nV = work_sizes(ws, N, energies, dynamics)
    B = np.zeros((nB, 4, 4))
    V = np.zeros((nV, 4))
    SD = np.zeros(n * _sd_stride(mmax) if energies or dynamics else 0)
    q = np.zeros(N)
    qd = np.zeros(N)
    st = 0.0
    if dynamics:  # of the first state
        for i in range(N):
            q[i] = qs[i]
            qd[i] = qds[i]
        vel = (job & (JOB_H | JOB_SOLVE | JOB_QDDOT)) != 0
        chain_frames(fdat, idat, q, qd, vel, B, ws, pris, ends)
        moments(fdat, idat, q, qd, B, V, SD, ws, pris, ends)
        M = np.zeros((N, N))
        h = np.zeros(N)
        dV = np.zeros(N)
        assemble(fdat, idat, q, vel, B, V, SD, ws, M, h, dV, pris, ends)
        _write_assembled(out, L, M, h, dV)
        if job & (JOB_SOLVE | JOB_QDDOT):
            st = _solve(out, L, job, Q, qd, M, h, dV)
    if job & _OBSERVABLES:
        vel = (job & (JOB_ENERGY | JOB_MOMENTUM | JOB_FRAMES)) != 0
        part = np.zeros(12)
        for k in range(K):
            for i in range(N):
                q[i] = qs[N * k + i]
                qd[i] = qds[N * k + i]
            chain_frames(fdat, idat, q, qd, vel, B, ws, pris, ends)
            if energies:
                moments(fdat, idat, q, qd, B, V, SD, ws, pris, ends)
            _observables(fdat, idat, q, qd, job, out, L, B, V, SD, ws, part, k, pris, ends)
    return st


@inline
def _write_assembled(out, L, M, h, dV):
    """M (N N,) row-major into the M section of out, h and dV into theirs, where layout L has them."""
    N = h.shape[0]
    o = L[_S_M]
    if L[_S_M + 1] > o:
        for i in range(N):
            for j in range(N):
                out[o + N * i + j] = M[i, j]
    o = L[_S_H]
    o2 = L[_S_DV]
    if L[_S_H + 1] > o:
        for i in range(N):
            out[o + i] = h[i]
            out[o2 + i] = dV[i]


@inline
def _solve(out, L, job, Q, qd, M, h, dV):
    """Solve stage: M qddot = Q - h - dV/dq by Cholesky; qddot (NaN unless M is positive
    definite) into the ydot section of out after qdot (JOB_SOLVE) or alone (JOB_QDDOT), the
    status and pivots into the status section when layout L has one. Returns the status."""
    N = qd.shape[0]
    rhs = np.zeros(N)
    for i in range(N):
        rhs[i] = Q[i] - h[i] - dV[i]
    x, status, dmin, dmax = _cholesky_solve(M, rhs)
    if L[_S_STATUS + 1] > 0:
        out[0] = status
        out[1] = dmin
        out[2] = dmax
    o = L[_S_YDOT]
    if job & JOB_SOLVE:
        for i in range(N):
            out[o + i] = qd[i]
        o += N
    for i in range(N):
        out[o + i] = x[i] if status == 0 else math.nan
    return float(status)


@inline
def _observables(fdat, idat, q, qd, job, out, L, B, V, SD, ws, part, k, pris, ends):
    """Observables stage of state k, from its frames (and, for energies and momenta, its body
    moments): the energy, momentum, point, Jacobian and frame sections of out (layout L);
    part (12,) is scratch."""
    npts = idat[0] + 1 + idat[3]
    if job & (JOB_ENERGY | JOB_MOMENTUM):
        link_observables(fdat, idat, q, qd, B, V, SD, ws, part, pris, ends)
        if job & JOB_ENERGY:
            o = L[_S_EN] + 3 * k
            for a in range(3):
                out[o + a] = part[a]
        if job & JOB_MOMENTUM:
            o = L[_S_MO] + 9 * k
            for a in range(9):
                out[o + a] = part[3 + a]
    frame_outputs(idat, B, ws, out, L, job, npts, k)
    if idat[3] > 0 and job & (JOB_POINTS | JOB_JACOBIANS):
        _extra_points(fdat, idat, q, B, ws, out, L, job, npts, k)
