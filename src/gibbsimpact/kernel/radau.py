"""Compiled Radau IIA steps: one accepted step of the flight equations in one compiled call.

Radau IIA with three stages (order 5, stage order 3, L-stable: R(z) -> 0 as z -> -inf) solves the
collocation system of the step [t, t + h] for the stage increments Z_i = y(t + c_i h) - y (3, n):

    Z = h (A_rk (x) I) F(Z),   F_i = f(t + c_i h, y + Z_i),   y_new = y + Z_3

by simplified Newton in the transformed variables W = (T^-1 (x) I) Z, where T^-1 A_rk^-1 T =
[[mu_r, 0, 0], [0, alpha, beta], [0, -beta, alpha]]: with J ~ df/dy held over the iterations, the
3n x 3n Newton matrix splits into one real n x n system (mu_r / h I - J) and one complex one
((alpha - i beta) / h I - J), each LU-factored once and reused while h and J are unchanged
(E. Hairer, G. Wanner, Solving ODEs II, 2nd ed., Springer 1996, IV.8; the constants below are
theirs, as in their RADAU5 and in scipy's Radau). The error estimate is the embedded one of order 3,

    err = (mu_r / h I - J)^-1 (f(t, y) + (e . Z) / h),   e = (-13 - 7 sqrt 6, -13 + 7 sqrt 6, -1) / 3

(re-evaluated once with f(t, y + err) after a rejection, which filters its stiff components), measured in
the RMS norm scaled by atol + rtol |y|, with the velocity components y[N_POS:2 N_POS] scaled by 1 / min(1, h
VEL_RATE) when st[N_POS] > 0 (RADAU5's scaling of index-2 variables, also in Newton's norm; used with the
filter Pf to step over fast modes, simulation.compiled_radau); and the step size control is Gustafsson's
predictive one with the safety factor of the Newton count.
The dense output is the collocation polynomial y(t + x h) = y + sum_k Q_k x^k, k = 1..3, Q = Z^T P.

The right-hand side inside the step is the flight phase's (gibbsimpact.simulation.equations):

    q' = qdot,   M qddot = Q_in(t, q, qdot) - C qdot - h - dV/dq,   W_in' = qdot . Q_in,
    W_damp' = -qdot . C qdot

with Q_in a table of the closed-form inputs of gibbsimpact.dynamics.inputs (rows ``fin``) and C the
constant structural damping matrix; or, when ``A`` has rows, the linear system y' = A y (for the
tests' closed forms: the same stepper on a system with a known solution).
"""

from __future__ import annotations

import math

import numpy as np

from .jacobian import _accel
from .layout import _mmax, work_sizes, work_slots
from .moments import _sd_stride

_S6 = 6.0 ** 0.5
#: Nodes c_i of the collocation (Radau points of [0, 1]).
NODES = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
#: Weights of the embedded error estimate (e . Z) / h.
ERROR_WEIGHTS = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0
#: The real eigenvalue of A_rk^-1 and the complex one alpha - i beta (Hairer-Wanner IV.8).
MU_REAL = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)
MU_COMPLEX = complex(3.0 + 0.5 * (3.0 ** (1.0 / 3.0) - 3.0 ** (2.0 / 3.0)),
                     -0.5 * (3.0 ** (5.0 / 6.0) + 3.0 ** (7.0 / 6.0)))
#: T and T^-1 of the transformation (module docstring), as in RADAU5.
T_MAT = np.array([[0.09443876248897524, -0.14125529502095421, 0.03002919410514742],
                  [0.25021312296533332, 0.20412935229379994, -0.38294211275726192],
                  [1.0, 1.0, 0.0]])
TI_MAT = np.array([[4.17871859155190428, 0.32768282076106237, 0.52337644549944951],
                   [-4.17871859155190428, -0.32768282076106237, 0.47662355450055044],
                   [0.50287263494578682, -2.57192694985560522, 0.59603920482822492]])
#: Dense output: Z_i = sum_k Q_k c_i^k, so P = (V^-1)^T with V_ik = c_i^k, k = 1..3 (3, 3).
DENSE_P = np.linalg.inv(NODES[:, None] ** np.arange(1, 4)).T
NEWTON_MAXITER = 6
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0

# Slots of the state array ``st`` shared with the Python driver (simulation.compiled_radau).
T, T_BOUND, H, H_OLD, ERR_OLD, MAX_STEP, RTOL, NEWTON_TOL = 0, 1, 2, 3, 4, 5, 6, 7
JAC_CURRENT, LU_OK, HAS_SOL, T_OLD, H_LAST, NFEV, N_LU, RECOMPUTE = 8, 9, 10, 11, 12, 13, 14, 15
BUSY, LOCAL_H, LOCAL_H_OLD, LOCAL_ERR_OLD, REJECTED = 16, 17, 18, 19, 20
#: The velocity weighting of the error estimate (_velocity_weight): y[N_POS:2 N_POS] are the velocities of
#: y[:N_POS] (N_POS = 0: no weighting); their errors count min(1, h VEL_RATE) of the positions'.
N_POS, VEL_RATE = 21, 22
SLOTS = 23
#: Return codes of radau_step.
ACCEPTED, NEED_JACOBIAN, STEP_TOO_SMALL, BAD_SIZE = 0.0, 1.0, 2.0, -1.0
#: Input kinds of the rows of ``fin`` (kind, k, a, b, c, d): Q_k += ...
IN_CONSTANT, IN_SINE, IN_RAMP, IN_PD = 0, 1, 2, 3


def radau_step(fdat, idat, fin, C, A, atol, Pf, y, f, J, LUr, pr, LUc, pc, Z, Qd, ynew, fnew, st, pris, ends):
    """Compiled entry point: one accepted Radau IIA step from (st[T], y) (module docstring).

    fin (m, 6): input rows (kind, k, a, b, c, d) [N, N m; per their kinds]; C (N, N) damping [N s/m ...];
    A (n, n) a linear system's matrix (0 rows: the chain); atol (n,); y, f (n,): the state and f(t, y);
    Pf (n, n) the error filter (0 rows: none): the estimate is Pf err, Pf = I - (projector on the modes
    above the cutoff frequency; simulation.compiled_radau.slow_projector); J (n, n) df/dy; LUr, LUc (n, n)
    float and complex, pr, pc (n,) int64: the factors and pivots kept
    between calls (st[LU_OK]); Z (3, n) the stage increments and Qd (n, 3) the dense output's
    coefficients (in: the last step's, for the predictor; out: this step's); ynew, fnew (n,) out; st
    (SLOTS,) the driver's state (slot names above). Returns ACCEPTED (st[T] is the new time),
    NEED_JACOBIAN (Newton failed with an old J: put df/dy at (st[T], y) in J, set st[JAC_CURRENT] = 1,
    st[LU_OK] = 0, call again), STEP_TOO_SMALL, or BAD_SIZE (nothing done).
    """
    n = y.shape[0]
    if st.shape[0] != SLOTS or J.shape[0] != n or Z.shape[1] != n or atol.shape[0] != n or \
            (A.shape[0] == 0 and (n < 2 * idat[1] or C.shape[0] != idat[1])):
        return BAD_SIZE
    wk = _workspace(idat)
    t = st[T]
    min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
    if st[BUSY] == 0.0:
        h_abs, h_old, e_old = st[H], st[H_OLD], st[ERR_OLD]
        if h_abs > st[MAX_STEP] or h_abs < min_step:
            h_abs, h_old, e_old = min(max(h_abs, min_step), st[MAX_STEP]), -1.0, -1.0
        st[REJECTED] = 0.0
    else:
        h_abs, h_old, e_old = st[LOCAL_H], st[LOCAL_H_OLD], st[LOCAL_ERR_OLD]
    scale = np.empty(n)
    F = np.empty((3, n))
    err = np.empty(n)
    while True:
        if h_abs < min_step:
            return STEP_TOO_SMALL
        t_new = min(t + h_abs, st[T_BOUND])
        h = t_new - t
        h_abs = abs(h)
        _predict_stages(st, t, h, Qd, Z)
        for j in range(n):
            scale[j] = atol[j] + abs(y[j]) * st[RTOL]
        _velocity_weight(st, h_abs, scale)
        converged, n_iter, rate = _newton(fdat, idat, fin, C, A, wk, t, y, h, J, LUr, pr, LUc, pc, Z, F, scale, st,
                                          pris, ends)
        if not converged and st[JAC_CURRENT] == 0.0:
            st[BUSY], st[LOCAL_H], st[LOCAL_H_OLD], st[LOCAL_ERR_OLD] = 1.0, h_abs, h_old, e_old
            return NEED_JACOBIAN
        if not converged:
            h_abs *= 0.5
            st[LU_OK] = 0.0
            continue
        for j in range(n):
            ynew[j] = y[j] + Z[2, j]
            scale[j] = atol[j] + max(abs(y[j]), abs(ynew[j])) * st[RTOL]
        _velocity_weight(st, h_abs, scale)
        e_norm = _error_norm(fdat, idat, fin, C, A, wk, t, y, f, h, Z, LUr, pr, Pf, scale, st, err, fnew, pris,
                             ends)
        safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
        if e_norm <= 1.0:
            break
        h_abs *= max(MIN_FACTOR, safety * _step_factor(h_abs, h_old, e_norm, e_old))
        st[LU_OK] = 0.0
        st[REJECTED] = 1.0
    _accept(fdat, idat, fin, C, A, wk, st, t, t_new, h, h_abs, h_old, e_norm, e_old, safety, n_iter, rate, Z, Qd,
            ynew, fnew, pris, ends)
    return ACCEPTED


def _accept(fdat, idat, fin, C, A, wk, st, t, t_new, h, h_abs, h_old, e_norm, e_old, safety, n_iter, rate, Z, Qd,
            ynew, fnew, pris, ends):
    """Bookkeeping of an accepted step: the next step size (kept unless it grows by 1.2 or more, so that the
    LU factors are reused), whether J is to be re-evaluated (Newton contracted slowly: more than two
    iterations at a rate above 1e-3), f(t_new, y_new) into fnew, the dense output Qd = Z^T P (n, 3)."""
    recompute = n_iter > 2 and rate > 1e-3
    factor = min(MAX_FACTOR, safety * _step_factor(h_abs, h_old, e_norm, e_old))
    if not recompute and factor < 1.2:
        factor = 1.0
    else:
        st[LU_OK] = 0.0
    _rhs(fdat, idat, fin, C, A, wk, t_new, ynew, fnew, pris, ends)
    st[NFEV] += 1.0
    st[H_OLD], st[ERR_OLD], st[H] = st[H], e_norm, h_abs * factor
    st[RECOMPUTE] = 1.0 if recompute else 0.0
    st[JAC_CURRENT] = 0.0
    st[T_OLD], st[T], st[H_LAST], st[HAS_SOL], st[BUSY] = t, t_new, h, 1.0, 0.0
    n = ynew.shape[0]
    for j in range(n):
        for k in range(3):
            Qd[j, k] = Z[0, j] * DENSE_P[0, k] + Z[1, j] * DENSE_P[1, k] + Z[2, j] * DENSE_P[2, k]


def _step_factor(h_abs, h_old, e_norm, e_old):
    """Gustafsson's predictive factor: min(1, (h / h_old) (e_old / e)^(1/4)) e^(-1/4) (1 without the old
    step; MAX_FACTOR-worth of growth for a zero error)."""
    if e_norm == 0.0:
        return MAX_FACTOR
    mult = 1.0
    if h_old > 0.0 and e_old > 0.0:
        mult = h_abs / h_old * (e_old / e_norm) ** 0.25
    return min(1.0, mult) * e_norm ** -0.25


def _predict_stages(st, t, h, Qd, Z):
    """Newton's starting point Z_i (3, n): the last step's collocation polynomial at t + c_i h minus
    y = its value at x = 1 (zeros on a first step)."""
    n = Z.shape[1]
    if st[HAS_SOL] == 0.0:
        Z[:] = 0.0
        return
    for i in range(3):
        x = (t + NODES[i] * h - st[T_OLD]) / st[H_LAST]
        for j in range(n):
            Z[i, j] = Qd[j, 0] * (x - 1.0) + Qd[j, 1] * (x * x - 1.0) + Qd[j, 2] * (x * x * x - 1.0)


def _newton(fdat, idat, fin, C, A, wk, t, y, h, J, LUr, pr, LUc, pc, Z, F, scale, st, pris, ends):
    """Simplified Newton on the collocation system (module docstring), Z (3, n) from the predictor to the
    solution; factors (mu / h I - J) first when st[LU_OK] is 0. Stops when the contraction rate says the
    iteration will not reach st[NEWTON_TOL] (in the scaled RMS norm) within NEWTON_MAXITER iterations.
    Returns (converged, iterations, rate; rate -1 when one iteration was made)."""
    n = y.shape[0]
    if st[LU_OK] == 0.0:
        for i in range(n):
            for j in range(n):
                LUr[i, j] = -J[i, j]
                LUc[i, j] = -J[i, j]
            LUr[i, i] += MU_REAL / h
            LUc[i, i] += MU_COMPLEX / h
        _lu_factor(LUr, pr)
        _lu_factor(LUc, pc)
        st[LU_OK] = 1.0
        st[N_LU] += 1.0
    W = np.zeros((3, n))
    for i in range(3):
        for j in range(n):
            W[i, j] = TI_MAT[i, 0] * Z[0, j] + TI_MAT[i, 1] * Z[1, j] + TI_MAT[i, 2] * Z[2, j]
    fr = np.empty(n)
    fc = np.empty(n, dtype=np.complex128)
    yi = np.empty(n)
    mr, mc = MU_REAL / h, MU_COMPLEX / h
    old, rate, k = -1.0, -1.0, 0
    for k in range(NEWTON_MAXITER):
        for i in range(3):
            for j in range(n):
                yi[j] = y[j] + Z[i, j]
            _rhs(fdat, idat, fin, C, A, wk, t + NODES[i] * h, yi, F[i], pris, ends)
        st[NFEV] += 3.0
        if not np.all(np.isfinite(F)):
            break
        for j in range(n):
            fr[j] = TI_MAT[0, 0] * F[0, j] + TI_MAT[0, 1] * F[1, j] + TI_MAT[0, 2] * F[2, j] - mr * W[0, j]
            fc[j] = (complex(TI_MAT[1, 0], TI_MAT[2, 0]) * F[0, j] + complex(TI_MAT[1, 1], TI_MAT[2, 1]) * F[1, j]
                     + complex(TI_MAT[1, 2], TI_MAT[2, 2]) * F[2, j] - mc * complex(W[1, j], W[2, j]))
        _lu_solve(LUr, pr, fr)
        _lu_solve(LUc, pc, fc)
        dn = 0.0
        for j in range(n):
            dn += (fr[j] ** 2 + fc[j].real ** 2 + fc[j].imag ** 2) / scale[j] ** 2
        dn = math.sqrt(dn / (3 * n))
        if old >= 0.0:
            rate = dn / old
        if rate >= 0.0 and (rate >= 1.0 or rate ** (NEWTON_MAXITER - k) / (1.0 - rate) * dn > st[NEWTON_TOL]):
            return False, k + 1, rate
        for j in range(n):
            W[0, j] += fr[j]
            W[1, j] += fc[j].real
            W[2, j] += fc[j].imag
            for i in range(3):
                Z[i, j] = T_MAT[i, 0] * W[0, j] + T_MAT[i, 1] * W[1, j] + T_MAT[i, 2] * W[2, j]
        if dn == 0.0 or (rate >= 0.0 and rate / (1.0 - rate) * dn < st[NEWTON_TOL]):
            return True, k + 1, rate
        old = dn
    return False, k + 1, rate


def _error_norm(fdat, idat, fin, C, A, wk, t, y, f, h, Z, LUr, pr, Pf, scale, st, err, scratch, pris, ends):
    """The scaled RMS norm of the embedded error estimate (module docstring), filtered by Pf (n, n) when it has
    rows; err (n,) holds the estimate, scratch (n,) is overwritten. After a rejection a norm above 1 is
    re-evaluated once with f(t, y + err)."""
    n = y.shape[0]
    ze = np.empty(n)
    for j in range(n):
        ze[j] = (ERROR_WEIGHTS[0] * Z[0, j] + ERROR_WEIGHTS[1] * Z[1, j] + ERROR_WEIGHTS[2] * Z[2, j]) / h
        err[j] = f[j] + ze[j]
    _lu_solve(LUr, pr, err)
    _filter(Pf, err, scratch)
    e_norm = _rms(err, scale)
    if st[REJECTED] > 0.0 and e_norm > 1.0:
        for j in range(n):
            err[j] += y[j]
        _rhs(fdat, idat, fin, C, A, wk, t, err, scratch, pris, ends)
        st[NFEV] += 1.0
        for j in range(n):
            err[j] = scratch[j] + ze[j]
        _lu_solve(LUr, pr, err)
        _filter(Pf, err, scratch)
        e_norm = _rms(err, scale)
    return e_norm


def _velocity_weight(st, h_abs, scale):
    """scale[N_POS:2 N_POS] /= w, w = min(1, h VEL_RATE) (RADAU5's scaling of index-2 variables, VEL_RATE =
    1/s: a velocity error of y' = (qdot, qddot) counts as the position error h err_qdot it makes over the
    step); w = 0 (VEL_RATE = 0): the velocities are left out of the error norm; nothing when st[N_POS] = 0."""
    n_pos = int(st[N_POS])
    if n_pos == 0:
        return
    w = min(1.0, h_abs * st[VEL_RATE])
    for j in range(n_pos, 2 * n_pos):
        scale[j] = scale[j] / w if w > 0.0 else math.inf


def _filter(Pf, err, scratch):
    """err <- Pf err (n,) when Pf (n, n) has rows; scratch (n,) is overwritten."""
    n = err.shape[0]
    if Pf.shape[0] == 0:
        return
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += Pf[i, j] * err[j]
        scratch[i] = s
    for i in range(n):
        err[i] = scratch[i]


def _rms(x, scale):
    """sqrt(mean((x / scale)^2)) of x, scale (n,)."""
    s = 0.0
    for j in range(x.shape[0]):
        s += (x[j] / scale[j]) ** 2
    return math.sqrt(s / x.shape[0])


def _workspace(idat):
    """The kernel's work arrays of one right-hand side (as jacobian.state_jacobian's): (ws, B, V, SD, M, h, dV, Q)."""
    n_links, N = idat[0], idat[1]
    mmax = _mmax(idat)
    ws = work_slots(n_links, N, mmax)
    nB, nV = work_sizes(ws, N, True, True)
    return (ws, np.zeros((nB, 4, 4)), np.zeros((nV, 4)), np.zeros(n_links * _sd_stride(mmax)), np.zeros((N, N)),
            np.zeros(N), np.zeros(N), np.zeros(N))


def _rhs(fdat, idat, fin, C, A, wk, t, y, out, pris, ends):
    """f(t, y) (n,) into out (module docstring): the linear y' = A y when A has rows, else the flight
    equations with the input rows fin and damping C; qddot NaN where M is singular or ill-conditioned
    (status != 0, as the Python right-hand side), so that Newton fails and the step shrinks."""
    n = y.shape[0]
    if A.shape[0] > 0:
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += A[i, j] * y[j]
            out[i] = s
        return
    ws, B, V, SD, M, hv, dV, Q = wk
    N = idat[1]
    q = y[:N].copy()
    qd = y[N:2 * N].copy()
    _inputs(fin, t, q, qd, Q)
    w_in = 0.0
    w_damp = 0.0
    for i in range(N):
        w_in += qd[i] * Q[i]
        cq = 0.0
        for j in range(N):
            cq += C[i, j] * qd[j]
        Q[i] -= cq
        w_damp -= qd[i] * cq
    qdd = out[N:2 * N]
    status = _accel(fdat, idat, q, qd, Q, B, V, SD, ws, M, hv, dV, pris, ends, qdd)
    for i in range(N):
        out[i] = qd[i]
        if status != 0:
            out[N + i] = math.nan
    if n > 2 * N:
        out[2 * N] = w_in
        out[2 * N + 1] = w_damp


def _inputs(fin, t, q, qd, Q):
    """Q_in (N,) into Q from the rows (kind, k, a, b, c, d) of fin: constant a; sine d + a sin(b t + c);
    ramp a (min(max(t, b), c) - b); pd a (b - q_k) - c qdot_k (gibbsimpact.dynamics.inputs)."""
    Q[:] = 0.0
    for r in range(fin.shape[0]):
        kind, k = int(fin[r, 0]), int(fin[r, 1])
        a, b, c, d = fin[r, 2], fin[r, 3], fin[r, 4], fin[r, 5]
        if kind == IN_CONSTANT:
            Q[k] += a
        elif kind == IN_SINE:
            Q[k] += d + a * math.sin(b * t + c)
        elif kind == IN_RAMP:
            Q[k] += a * (min(max(t, b), c) - b)
        else:
            Q[k] += a * (b - q[k]) - c * qd[k]


def _lu_factor(a, piv):
    """LU factors of a (n, n), real or complex, in place with partial pivoting (rows swapped whole); piv (n,)
    the row exchanged with row k at step k."""
    n = a.shape[0]
    for k in range(n):
        p = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big, p = abs(a[i, k]), i
        piv[k] = p
        if p != k:
            for j in range(n):
                a[k, j], a[p, j] = a[p, j], a[k, j]
        if a[k, k] == 0:
            continue
        for i in range(k + 1, n):
            a[i, k] /= a[k, k]
            for j in range(k + 1, n):
                a[i, j] -= a[i, k] * a[k, j]


def _lu_solve(a, piv, b):
    """x of (LU) x = P b into b (n,), from _lu_factor's a and piv."""
    n = a.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        for j in range(i):
            b[i] -= a[i, j] * b[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            b[i] -= a[i, j] * b[j]
        b[i] /= a[i, i]
