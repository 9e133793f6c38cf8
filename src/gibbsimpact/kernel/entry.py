"""The one compiled entry point ``kernel``: everything the package computes from states."""

from __future__ import annotations

import math

import numpy as np

from .assemble import assemble
from .frames import _W_SIZE, chain_frames
from .layout import (_CI, _H, _S_DV, _S_EN, _S_FR, _S_H, _S_JAC, _S_M, _S_MO, _S_PTS, _S_STATUS, _S_YDOT, JOB_ENERGY,
                     JOB_FRAMES, JOB_H, JOB_JACOBIANS, JOB_M, JOB_MOMENTUM, JOB_POINTS, JOB_QDDOT, JOB_SOLVE, _mmax,
                     layout)
from .linalg import _cholesky_solve
from .moments import _sd_stride
from .observables import _extra_points, _link_observables


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
      _link_observables (L, H0, first moment); JOB_POINTS: contact points (K P 3,) [m], P = n + 1 + X:
      the frame origins O_1 .. O_(n+1), then the tip of every host link whose child joint is
      prismatic (not a frame origin); JOB_JACOBIANS: dO_j/dq (K P 3 N,), dO_j/dq_c = (S_c O_j)[:3]
      when f_c <= j, else 0 (a tip of link h: f_c <= h, and R_h end_t_k for h's own delta_k);
      JOB_FRAMES: T, Tdot, Tddot0 (K 3 (n+1) 16,).

    Returns the status of M's Cholesky factor (0.0 without JOB_SOLVE, JOB_QDDOT), or -1.0 when
    out has the wrong size (then nothing is written: the kernel does not check bounds otherwise).

    One entry point, because numba links and optimises every entry point with
    all the code it calls: one entry compiles in about half the time of two. The output is
    an argument, not a return value: numba boxes a returned array at ~1.3 us a call (a quarter
    of forward_dynamics on case 1), a returned float costs nothing.
    """
    n = idat[0]
    N = idat[1]
    K = qs.shape[0] // N
    npts = n + 1 + idat[3]
    L = layout(n, N, K, job, npts)
    if out.shape[0] != L[10]:
        return -1.0
    for i in range(L[10]):
        out[i] = 0.0
    q = np.zeros(N)
    qd = np.zeros(N)
    st = 0.0
    if job & (JOB_M | JOB_H | JOB_SOLVE | JOB_QDDOT):
        for i in range(N):
            q[i] = qs[i]
            qd[i] = qds[i]
        M = np.zeros((N, N))
        h = np.zeros(N)
        dV = np.zeros(N)
        assemble(fdat, idat, q, qd, (job & (JOB_H | JOB_SOLVE | JOB_QDDOT)) != 0, M, h, dV, pris, ends)
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
        if job & (JOB_SOLVE | JOB_QDDOT):
            rhs = np.zeros(N)
            for i in range(N):
                rhs[i] = Q[i] - h[i] - dV[i]
            x, status, dmin, dmax = _cholesky_solve(M, rhs)
            st = float(status)
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
    obs = job & (JOB_ENERGY | JOB_MOMENTUM | JOB_POINTS | JOB_JACOBIANS | JOB_FRAMES)
    if obs == 0:
        return st
    vel = (job & (JOB_ENERGY | JOB_MOMENTUM | JOB_FRAMES)) != 0
    TS = 0
    TDS = n + 1
    TDDS = 2 * n + 2
    SS = 3 * n + 3
    WK = SS + 2 * N
    B = np.zeros((WK + _W_SIZE, 4, 4))
    V = np.zeros((2 * _mmax(idat) + 4, 4))
    SD = np.zeros(n * _sd_stride(_mmax(idat)))
    part = np.zeros(12)
    for k in range(K):
        for i in range(N):
            q[i] = qs[N * k + i]
            qd[i] = qds[N * k + i]
        chain_frames(fdat, idat, q, qd, vel, B, TS, TDS, TDDS, SS, WK, pris, ends)
        if job & (JOB_ENERGY | JOB_MOMENTUM):
            _link_observables(fdat, idat, q, qd, B, TS, TDS, WK, V, part, SD, pris)
            if job & JOB_ENERGY:
                o = L[_S_EN] + 3 * k
                for a in range(3):
                    out[o + a] = part[a]
            if job & JOB_MOMENTUM:
                o = L[_S_MO] + 9 * k
                for a in range(9):
                    out[o + a] = part[3 + a]
        for j in range(n + 1):
            if job & JOB_POINTS:
                o = L[_S_PTS] + 3 * (npts * k + j)
                for a in range(3):
                    out[o + a] = B[TS + j, a, 3]
            if job & JOB_FRAMES:
                o = L[_S_FR] + 48 * ((n + 1) * k + j)
                for a in range(4):
                    for b in range(4):
                        out[o + 4 * a + b] = B[TS + j, a, b]
                        out[o + 16 + 4 * a + b] = B[TDS + j, a, b]
                        out[o + 32 + 4 * a + b] = B[TDDS + j, a, b]
            if job & JOB_JACOBIANS:
                o = L[_S_JAC] + 3 * N * (npts * k + j)
                for c in range(N):
                    if idat[_H + _CI * c + 2] <= j:
                        f2 = idat[_H + _CI * c + 5]
                        for a in range(3):
                            s = B[SS + c, a, 3]
                            for b in range(3):
                                s += B[SS + c, a, b] * B[TS + j, b, 3]
                            if 0 <= f2 <= j:
                                s += B[SS + N + c, a, 3]
                                for b in range(3):
                                    s += B[SS + N + c, a, b] * B[TS + j, b, 3]
                            out[o + N * a + c] = s
        if pris is not None and job & (JOB_POINTS | JOB_JACOBIANS):
            _extra_points(fdat, idat, q, B, TS, SS, out, L[_S_PTS], L[_S_JAC], job, npts, k)
    return st
