"""Contact terms: wall gaps, the event layer's gaps and skip rule, contact terms, friction solve."""

from __future__ import annotations

import math

import numpy as np

from .layout import (_S_FR, _S_JAC, _S_M, _S_PTS, _S_YDOT, WALL_CIRCLE, WALL_PLANE, WALL_SPHERE, contact_layout,
                     inline)
from .linalg import _cholesky_apply, _cholesky_factor, _svd_solve, _sym_solve


def _wall_gap(wk, wp, w, p0, p1, p2):
    """Gap g [m] of the point (p0, p1, p2) [m] on wall w of the packed walls (wk, wp: contact_terms),
    with d = p - c (its X1-X2 part for a circle; 0 for a plane) and r = |d| [m]:

        g = n_w . (p - p_w) (plane),   g = s (R - |d|) (circle, sphere; s = wp[w, 5]: +1 inside, -1 obstacle)
    """
    kind = wk[w]
    if kind == WALL_PLANE:
        return (p0 - wp[w, 0]) * wp[w, 3] + (p1 - wp[w, 1]) * wp[w, 4] + (p2 - wp[w, 2]) * wp[w, 5], 0.0, 0.0, 0.0, 0.0
    d0 = p0 - wp[w, 1]
    d1 = p1 - wp[w, 2]
    if kind == WALL_CIRCLE:
        r = math.hypot(d0, d1)
        return wp[w, 5] * (wp[w, 0] - r), d0, d1, 0.0, r
    d2 = p2 - wp[w, 3]
    r = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    return wp[w, 5] * (wp[w, 0] - r), d0, d1, d2, r


def _skip_pair(kind, R, gA, gB, lam, D2, r, pts, oa, ob):
    """The skip rule of one (wall, link) pair (contacts.Contacts' docstring: rules (1), (3), (4)).

    kind: WALL_*; R [m] a circle's or a sphere's radius; gA, gB [m] the end joints' gaps; lam =
    Lam, D2 = 2 D_i [m]; r = refine_below [m]; pts: joint positions, the end joints' at
    offsets oa, ob. True when the link column is NOT_INTERIOR or above r.
    """
    m = min(gA, gB)
    if m - D2 > r:                                   # (1)
        return True
    t = min(m, r)
    hA = gA - t                                      # >= 0
    hB = gB - t
    if kind == WALL_PLANE:
        # (3): (sqrt(h_A) + sqrt(h_B))^2 > Lam
        S = math.sqrt(hA) + math.sqrt(hB)
        return S * S > lam
    # (4): 4 T > Lam and S^2 + L^2 > 2 T Lam, T = R - t, S = sqrt(h_A (2 T - h_A)) + sqrt(h_B (2 T - h_B))
    T2 = 2.0 * (R - t)
    if not 2.0 * T2 > lam:
        return False
    dx = pts[ob] - pts[oa]
    dy = pts[ob + 1] - pts[oa + 1]
    L2 = dx * dx + dy * dy                           # |P (B - A)|^2: P drops X3 for a circle
    if kind == WALL_SPHERE:
        dz = pts[ob + 2] - pts[oa + 2]
        L2 += dz * dz
    S = math.sqrt(max(hA * (T2 - hA), 0.0)) + math.sqrt(max(hB * (T2 - hB), 0.0))
    return S * S + L2 > T2 * lam


def _skip_obstacle(kind, wp, w, gA, gB, lam, r, pts, oa, ob):
    """The skip rule of a (wall, link) pair on an obstacle (wp[w, 5] = -1: g = |P (p - c)| - R, convex
    along a line, so rules (1), (3), (4) of contacts.Contacts do not hold; its rule (5)).

    With the chord c(s) between the end joints A, B (offsets oa, ob in pts) and rho_min =
    min over s in [0, 1] of |P (c(s) - c_w)| [m] (the projection of c_w onto the chord, clipped),
    the Lipschitz bound (2) gives G(s) >= rho_min - R - Lam u >= rho_min - R - Lam / 4; the pair
    is skipped when that exceeds t = min(g_A, g_B, r).
    """
    d0 = pts[oa] - wp[w, 1]
    d1 = pts[oa + 1] - wp[w, 2]
    e0 = pts[ob] - pts[oa]
    e1 = pts[ob + 1] - pts[oa + 1]
    d2 = 0.0
    e2 = 0.0
    if kind == WALL_SPHERE:
        d2 = pts[oa + 2] - wp[w, 3]
        e2 = pts[ob + 2] - pts[oa + 2]
    ee = e0 * e0 + e1 * e1 + e2 * e2
    s = 0.0
    if ee > 0.0:
        s = min(max(-(d0 * e0 + d1 * e1 + d2 * e2) / ee, 0.0), 1.0)
    rho = math.sqrt((d0 + s * e0) ** 2 + (d1 + s * e1) ** 2 + (d2 + s * e2) ** 2)
    return rho - wp[w, 0] - 0.25 * lam > min(gA, gB, r)


def event_gaps(pts, P, wk, wp, E, rules, refine):
    """The event layer's gaps of K states (contacts.Contacts.gaps_batch): every joint point on
    every wall, and the link skip rule of every (link, wall) pair.

    pts (K P 3,) [m]: the P contact points of each state (the kernel's JOB_POINTS section);
    wk (W,), wp (W, 6): the packed walls (contact_terms); E (K, 2 F) [m]: Lam of link column f
    in column f, 2 D_f in column F + f; rules (R, 4) int64: (f, w, a, b) per (link, wall) pair,
    a, b its end joints (-1: a link without one, never skipped); refine [m]: refine_below.
    Returns g (K W P,) [m], then skip (K R,): 1.0 where _skip_pair skips the pair, else 0.0,
    then search (K,): 1.0 for a state with a pair that is not skipped (it needs a link search).
    """
    W = wk.shape[0]
    K = pts.shape[0] // (3 * P)
    R = rules.shape[0]
    F = E.shape[1] // 2
    res = np.zeros(K * W * P + K * R + K)
    for k in range(K):
        for w in range(W):
            o = (k * W + w) * P
            for j in range(P):
                res[o + j] = _wall_gap(wk, wp, w, pts[3 * (P * k + j)], pts[3 * (P * k + j) + 1],
                                       pts[3 * (P * k + j) + 2])[0]
        for i in range(R):
            f = rules[i, 0]
            w = rules[i, 1]
            a = rules[i, 2]
            b = rules[i, 3]
            if a >= 0 and b >= 0:
                o = (k * W + w) * P
                if wk[w] != WALL_PLANE and wp[w, 5] < 0.0:
                    skip = _skip_obstacle(wk[w], wp, w, res[o + a], res[o + b], E[k, f], refine, pts,
                                          3 * (P * k + a), 3 * (P * k + b))
                else:
                    skip = _skip_pair(wk[w], wp[w, 0], res[o + a], res[o + b], E[k, f], E[k, F + f], refine, pts,
                                      3 * (P * k + a), 3 * (P * k + b))
                if skip:
                    res[K * W * P + k * R + i] = 1.0
                    continue
            res[K * W * P + K * R + k] = 1.0
    return res


def contact_terms(out, off, qd, pairs, wk, wp, vel):
    """Equations (1)-(2) of resting.py for k (wall, point) pairs, from one kernel output.

    out: the kernel's output for one state with JOB_M | JOB_POINTS | JOB_JACOBIANS (and, for
    vel = 1, JOB_SOLVE | JOB_FRAMES); off (11,): its layout; qd (N,) [m/s, rad/s]; pairs (k, 2):
    wall index, contact point index; wk (W,): WALL_* kinds; wp (W, 6): a plane's point and unit
    normal [m], a circle's (R, c1, c2) [m], a sphere's (R, c1, c2, c3) [m] (walls.py).

    Per pair a at point p [m] with Jacobian J (3, N), point velocity pd = J qd [m/s] and
    a0 = Jdot qd [m/s^2] (Tddot0's translation column, vel = 1):

        g = R - |d| (d = p - c, its X1-X2 part for a circle),  n = -d / |d| (0 at d = 0)
        g = n_w . (p - p_w), n = n_w (plane)
        pd^T H pd = -(|pd|^2 - (d . pd)^2 / |d|^2) / |d| (circle: X1-X2 parts; plane: 0)
        W[:, a] = J^T n,   c_a = n . a0 + pd^T H pd,   v_a = n . pd

    and M^-1 W by Cholesky, G = W^T M^-1 W (symmetrised). vel = 0: positions only (c, v,
    pd, a0 zero). vel = 2: also equation (3) of resting.py without friction, with
    qdd_free = M^-1 (Q - h - dV/dq) the kernel's qddot,

        G lambda = -(W^T qdd_free + c)   (_sym_solve),   qddot = qdd_free + M^-1 W lambda

    (the right-hand side of a frictionless contact phase in this one call). Returns one float64
    array: status (1,) (0, or 1 when M is not positive definite), W (N k) and M^-1 W (N k)
    row-major (N, k), G (k k), c, g, v (k each), then n, pd, a0 (k 3 each), then lambda (k)
    [N] and qddot (N) (zero unless vel = 2).
    """
    N = qd.shape[0]
    k = pairs.shape[0]
    o = contact_layout(N, k)
    res = np.zeros(o[11])
    for a in range(k):
        _pair_terms(out, off, qd, pairs[a, 0], pairs[a, 1], wk, wp, vel, a, k, res, o)
    M = np.zeros((N, N))
    for i in range(N):
        for c in range(N):
            M[i, c] = out[off[_S_M] + N * i + c]
    L, status, dmin, dmax = _cholesky_factor(M)
    if status == 1:
        res[0] = 1.0
        return res
    # M^-1 W: one Cholesky factor, k solves; G = W^T M^-1 W, symmetrised.
    oW = o[0]
    oMW = o[1]
    col = np.zeros(N)
    for a in range(k):
        for c in range(N):
            col[c] = res[oW + c * k + a]
        x = _cholesky_apply(L, col)
        for c in range(N):
            res[oMW + c * k + a] = x[c]
    for a in range(k):
        for b in range(a, k):
            s1 = 0.0
            s2 = 0.0
            for c in range(N):
                s1 += res[oW + c * k + a] * res[oMW + c * k + b]
                s2 += res[oW + c * k + b] * res[oMW + c * k + a]
            res[o[2] + a * k + b] = 0.5 * (s1 + s2)
            res[o[2] + b * k + a] = 0.5 * (s1 + s2)
    if vel == 2:
        _frictionless_solve(out, off[_S_YDOT] + N, N, k, res, o)
    return res


@inline
def _pair_terms(out, off, qd, w, j, wk, wp, vel, a, k, res, o):
    """Pair a of contact_terms (wall w, contact point j) into res (contact_layout o): its gap g,
    normal n, and with vel its point velocity pd = J qd, a0 = Jdot qd (Tddot0's translation
    column), c = n . a0 + pd^T H pd and v = n . pd; and the column W[:, a] = J^T n."""
    N = qd.shape[0]
    oJ = off[_S_JAC]
    gap, d0, d1, d2, dist = _wall_gap(wk, wp, w, out[off[_S_PTS] + 3 * j], out[off[_S_PTS] + 3 * j + 1],
                                      out[off[_S_PTS] + 3 * j + 2])
    res[o[4] + a] = gap
    opd = o[7] + 3 * a
    oa0 = o[8] + 3 * a
    if vel:
        for r in range(3):
            s = 0.0
            for c in range(N):
                s += out[oJ + (3 * j + r) * N + c] * qd[c]
            res[opd + r] = s
            # Tddot0 of frame j, row r, column 3 (frames section: T, Td, Tdd0 per frame).
            res[oa0 + r] = out[off[_S_FR] + 48 * j + 32 + 4 * r + 3]
    n0, n1, n2, curv = _wall_normal(wk[w], wp, w, d0, d1, d2, dist, res[opd], res[opd + 1], res[opd + 2])
    res[o[6] + 3 * a] = n0
    res[o[6] + 3 * a + 1] = n1
    res[o[6] + 3 * a + 2] = n2
    if vel:
        res[o[3] + a] = (n0 * res[oa0] + n1 * res[oa0 + 1] + n2 * res[oa0 + 2]) + curv
        res[o[5] + a] = n0 * res[opd] + n1 * res[opd + 1] + n2 * res[opd + 2]
    for c in range(N):
        res[o[0] + c * k + a] = (out[oJ + 3 * j * N + c] * n0 + out[oJ + (3 * j + 1) * N + c] * n1
                                 + out[oJ + (3 * j + 2) * N + c] * n2)


@inline
def _wall_normal(kind, wp, w, d0, d1, d2, dist, v0, v1, v2):
    """(n, pd^T H pd) at a point of wall w with d = p - c, dist = |d| [m] (_wall_gap) and point
    velocity v [m/s]: n = n_w, 0 (plane); n = -s d / |d| (0 at d = 0),
    pd^T H pd = -s (|v|^2 - (d . v)^2 / |d|^2) / |d| (circle: the X1-X2 parts of d and v; sphere),
    s = wp[w, 5] (+1 inside, -1 obstacle)."""
    if kind == WALL_PLANE:
        return wp[w, 3], wp[w, 4], wp[w, 5], 0.0
    if not dist > 0.0:
        return 0.0, 0.0, 0.0, 0.0
    s = wp[w, 5]
    vz = v2 if kind == WALL_SPHERE else 0.0
    dv = d0 * v0 + d1 * v1 + d2 * vz
    curv = -s * ((v0 * v0 + v1 * v1 + vz * vz) - dv * dv / (dist * dist)) / dist
    return -s * (d0 / dist), -s * (d1 / dist), -s * (d2 / dist), curv


@inline
def _frictionless_solve(out, oy, N, k, res, o):
    """Equation (3) of resting.py without friction, into res's lambda and qddot sections (contact_layout o):

        G lambda = -(W^T qdd_free + c)   (_sym_solve),   qddot = qdd_free + M^-1 W lambda

    qdd_free: the kernel's qddot, at out[oy:oy + N].
    """
    G = np.empty((k, k))
    rhs = np.empty(k)
    for a in range(k):
        s1 = res[o[3] + a]
        for c in range(N):
            s1 += res[o[0] + c * k + a] * out[oy + c]
        rhs[a] = -s1
        for b in range(k):
            G[a, b] = res[o[2] + a * k + b]
    lam = _sym_solve(G, rhs)
    for a in range(k):
        res[o[9] + a] = lam[a]
    for c in range(N):
        s1 = out[oy + c]
        for a in range(k):
            s1 += res[o[1] + c * k + a] * lam[a]
        res[o[10] + c] = s1


def friction_solve(M, W, J, nrm, pd, a0, c, qf, mu, stick, sdir, v_tol):
    """Equations (6)-(7) of resting.py: the accelerations and forces of k resting pairs of which
    some are on walls with friction, from the contact terms of one state.

    M (N, N); W (N, k); J (k, 3, N) the points' Jacobians; nrm, pd, a0 (k, 3): normals, point
    velocities [m/s], Jdot qdot [m/s^2]; c (k,) [m/s^2]; qf (N,) = qdd_free; mu (k,) Coulomb's
    coefficients; stick (k,) int64 (1: a frictional pair sticks, 0: it slips); sdir (k, 3) the
    direction s0 of (7); v_tol [m/s].

    Constraint rows C and force columns B: the normal columns W_a (for a slipping pair
    B_a = W_a - mu_a J_a^T s_a, s_a = (v_t + v_tol s0) / |v_t + v_tol s0|, v_t = pd - (pd . n) n);
    two tangent rows and columns J_a^T t_1, J_a^T t_2 per sticking pair (tangent basis as
    walls.tangent_basis: t1 = e x n / |e x n|, e = e3, or e1 when |n_3| >= 0.9; t2 = n x t1),
    c extended by t . a0. Then

        (C^T M^-1 B) lambda = -(C^T qf + c)  (_svd_solve),   qddot = qf + M^-1 B lambda

    Returns one float64 array: qddot (N), lambda_n (k) [N], F_t (k 3) [N] (slip: -mu lambda_n
    s_a; stick: lambda_t . T), lambda_t (k 2) [N] of sticking pairs, friction power F_t . pd (k) [W].
    """
    N = M.shape[0]
    k = W.shape[1]
    ns = 0
    for a in range(k):
        if mu[a] > 0.0 and stick[a] != 0:
            ns += 1
    m = k + 2 * ns
    C = np.zeros((N, m))
    B = np.zeros((N, m))
    cc = np.zeros(m)
    s_hat = np.zeros((k, 3))
    T = np.zeros((k, 2, 3))
    _friction_columns(W, J, nrm, pd, a0, c, mu, stick, sdir, v_tol, C, B, cc, s_hat, T)
    res = np.zeros(N + 7 * k)
    L, status, dmin, dmax = _cholesky_factor(M)
    if status == 1:
        for i in range(N):
            res[i] = math.nan
        return res
    MinvB = np.zeros((N, m))
    colv = np.zeros(N)
    for j in range(m):
        for i in range(N):
            colv[i] = B[i, j]
        x = _cholesky_apply(L, colv)
        for i in range(N):
            MinvB[i, j] = x[i]
    # (C^T M^-1 B) lambda = -(C^T qf + c)
    A = np.zeros((m, m))
    rhs = np.zeros(m)
    for r in range(m):
        s1 = cc[r]
        for i in range(N):
            s1 += C[i, r] * qf[i]
        rhs[r] = -s1
        for j in range(m):
            s2 = 0.0
            for i in range(N):
                s2 += C[i, r] * MinvB[i, j]
            A[r, j] = s2
    lam = _svd_solve(A, rhs)
    for i in range(N):
        s1 = qf[i]
        for j in range(m):
            s1 += MinvB[i, j] * lam[j]
        res[i] = s1
    _friction_forces(lam, mu, stick, s_hat, T, pd, N, k, res)
    return res


@inline
def _friction_columns(W, J, nrm, pd, a0, c, mu, stick, sdir, v_tol, C, B, cc, s_hat, T):
    """Constraint rows C (N, m), force columns B (N, m) and their c (m,) of friction_solve:
    the normal columns W_a first, then for each sticking pair its two tangent rows and columns
    J_a^T t_r (c: t_r . a0); a slipping pair's column becomes B_a = W_a - mu_a J_a^T s_a, its slip
    direction (7) into s_hat[a]; a sticking pair's tangent basis into T[a] (2, 3)."""
    N = W.shape[0]
    k = W.shape[1]
    for a in range(k):
        for i in range(N):
            C[i, a] = W[i, a]
            B[i, a] = W[i, a]
        cc[a] = c[a]
    col = k
    for a in range(k):
        if not mu[a] > 0.0:
            continue
        if stick[a] == 0:
            _slip_direction(pd, nrm, sdir, v_tol, a, s_hat)
            for i in range(N):
                B[i, a] -= (J[a, 0, i] * s_hat[a, 0] + J[a, 1, i] * s_hat[a, 1] + J[a, 2, i] * s_hat[a, 2]) * mu[a]
            continue
        _tangent_basis(nrm[a, 0], nrm[a, 1], nrm[a, 2], T, a)
        for r in range(2):
            for i in range(N):
                w = J[a, 0, i] * T[a, r, 0] + J[a, 1, i] * T[a, r, 1] + J[a, 2, i] * T[a, r, 2]
                C[i, col] = w
                B[i, col] = w
            cc[col] = T[a, r, 0] * a0[a, 0] + T[a, r, 1] * a0[a, 1] + T[a, r, 2] * a0[a, 2]
            col += 1


@inline
def _slip_direction(pd, nrm, sdir, v_tol, a, s_hat):
    """(7): s_hat[a] = (v_t + v_tol s0) / |v_t + v_tol s0|, v_t = pd - (pd . n) n: the slip
    direction of pair a, smooth through v_t = 0 (s0 = sdir[a])."""
    n0 = nrm[a, 0]
    n1 = nrm[a, 1]
    n2 = nrm[a, 2]
    vn = pd[a, 0] * n0 + pd[a, 1] * n1 + pd[a, 2] * n2
    s0 = pd[a, 0] - vn * n0 + v_tol * sdir[a, 0]
    s1 = pd[a, 1] - vn * n1 + v_tol * sdir[a, 1]
    s2 = pd[a, 2] - vn * n2 + v_tol * sdir[a, 2]
    sn = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    s_hat[a, 0] = s0 / sn
    s_hat[a, 1] = s1 / sn
    s_hat[a, 2] = s2 / sn


@inline
def _tangent_basis(n0, n1, n2, T, a):
    """T[a] = (t1, t2) for the normal n (walls.tangent_basis): t1 = e x n / |e x n|, e = e3, or
    e1 when |n_3| >= 0.9; t2 = n x t1."""
    e0 = 0.0
    e2 = 1.0
    if not abs(n2) < 0.9:
        e0 = 1.0
        e2 = 0.0
    t0 = -e2 * n1
    t1 = e2 * n0 - e0 * n2
    t2 = e0 * n1
    tn = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    T[a, 0, 0] = t0 / tn
    T[a, 0, 1] = t1 / tn
    T[a, 0, 2] = t2 / tn
    T[a, 1, 0] = n1 * T[a, 0, 2] - n2 * T[a, 0, 1]
    T[a, 1, 1] = n2 * T[a, 0, 0] - n0 * T[a, 0, 2]
    T[a, 1, 2] = n0 * T[a, 0, 1] - n1 * T[a, 0, 0]


@inline
def _friction_forces(lam, mu, stick, s_hat, T, pd, N, k, res):
    """friction_solve's forces after qddot (N,) in res: lambda_n (k) [N], F_t (k 3) [N] (slip:
    -mu lambda_n s_a; stick: lambda_t . T), lambda_t (k 2) [N] of sticking pairs, friction power
    F_t . pd (k) [W]."""
    oF = N + k
    oT = N + 4 * k
    oP = N + 6 * k
    col = k
    for a in range(k):
        res[N + a] = lam[a]
        if mu[a] > 0.0 and stick[a] != 0:
            for r in range(2):
                res[oT + 2 * a + r] = lam[col + r]
            for d in range(3):
                res[oF + 3 * a + d] = lam[col] * T[a, 0, d] + lam[col + 1] * T[a, 1, d]
            col += 2
        else:
            for d in range(3):
                res[oF + 3 * a + d] = -mu[a] * lam[a] * s_hat[a, d]
        res[oP + a] = res[oF + 3 * a] * pd[a, 0] + res[oF + 3 * a + 1] * pd[a, 1] + res[oF + 3 * a + 2] * pd[a, 2]
