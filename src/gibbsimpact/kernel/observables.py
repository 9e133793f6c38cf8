"""Observables stage: energies, momenta and first moment per link, frames, points, Jacobians.

Kinetic energy per link: 1/2 tr(Td P Td^T) + tr(Td Pv T^T) + 1/2 int mu vdot^2
(P, Pv from moments.py; the frames from frames.py).
"""

from __future__ import annotations

from .layout import (_CI, _F_G, _H, _LI, _S_FR, _S_JAC, _S_PTS, JOB_FRAMES, JOB_JACOBIANS, JOB_POINTS, JOINT_PB,
                     JOINT_R, _anc, _mmax, _piece, _tree_tables, inline)
from .mat4 import _mm, _mmt
from .moments import _fs_offsets, _fs_tables, _own, _own_source, _sd_offsets, _sd_stride


def link_observables(fdat, idat, q, qd, B, V, SD, ws, out, pris, ends):
    """out (12,): kinetic, gravity, strain energy [J]; linear momentum L [kg m/s];
    angular momentum about the origin H0 [kg m^2/s]; first moment sum T m_r [kg m].

    From the frames (position stage) and body moments (moments stage) in B, V, SD (work_slots ws):
    E_k = sum 1/2 tr(Td P Td^T) + tr(Td Pv T^T) + 1/2 deltadot^T M_dd deltadot,
    V_g = -g~ . sum T m_r,  V_s = 1/2 delta^T K delta,
    L = sum (Td m_r + T m_rdot),  H0 = sum vee(X),  X = T P Td^T + T Pv T^T = int mu p pdot^T;
    a stiffened link (formulation §15) adds 1/2 deltadot^T Mfs deltadot = 1/2 int mu rho^2 to E_k
    and int mu rho = Pv[3, 0] to m_rdot[0] (moments._fs_moments).
    """
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    N = idat[1]
    mmax = _mmax(idat)
    SDS = _sd_stride(mmax)
    kX = WK + 22
    kA = WK + 23
    for a in range(12):
        out[a] = 0.0
    for i in range(idat[0]):
        base = _H + _CI * N + _LI * i
        m = idat[base]
        d0 = idat[base + 1]
        off = idat[base + 3]
        ms, src, o_cx = _own_source(fdat, idat, i, SD, i * SDS, pris)
        T = TS + i
        Td = TDS + i
        # Kinetic energy: 1/2 tr(Td P Td^T) + tr(Td Pv T^T) here, the modal part below.
        for a in range(4):
            for b in range(4):
                x = 0.0
                z = 0.0
                for c in range(4):
                    x += B[Td, a, c] * B[PS + i, c, b]
                    z += B[Td, a, c] * B[PVS + i, c, b]
                out[0] += 0.5 * x * B[Td, a, b] + z * B[T, a, b]
        o_K = off + 21 + 2 * m + m * m
        for a in range(4):
            V[MRD + i, a] = 0.0
        for l in range(ms):
            al, dl, vl = _own(idat, i, q, qd, l)
            out[0] += 0.5 * vl * V[QDV + (mmax + 1) * i + l, al]
            V[MRD + i, al] += vl * src[o_cx + ms + l]
        if ends is not None and idat[base + 6] >= 0:
            o_M = _fs_offsets(i * SDS, mmax)[3]
            V[MRD + i, 0] += B[PVS + i, 3, 0]
            for l in range(m):
                for k in range(m):
                    out[0] += 0.5 * qd[d0 + l] * SD[o_M + mmax * l + k] * qd[d0 + k]
        if pris is not None and idat[base + 5] == JOINT_PB:
            out[2] += SD[_sd_offsets(i * SDS, m)[5] + 1]
        else:
            for l in range(m):
                for k in range(m):
                    out[2] += 0.5 * q[d0 + l] * fdat[o_K + m * l + k] * q[d0 + k]
        for a in range(3):
            s = 0.0
            p = 0.0
            for b in range(4):
                s += B[Td, a, b] * V[MR + i, b] + B[T, a, b] * V[MRD + i, b]
                p += B[T, a, b] * V[MR + i, b]
            out[3 + a] += s
            out[9 + a] += p
            out[1] -= fdat[_F_G + a] * p
        # X = T P Td^T + (T Pv) T^T
        _mm(B, T, PS + i, kA)
        _mmt(B, kA, Td, kX)
        _mm(B, T, PVS + i, kA)
        for a in range(3):
            for b in range(3):
                s = 0.0
                for c in range(4):
                    s += B[kA, a, c] * B[T, b, c]
                B[kX, a, b] += s
        out[6] += B[kX, 1, 2] - B[kX, 2, 1]
        out[7] += B[kX, 2, 0] - B[kX, 0, 2]
        out[8] += B[kX, 0, 1] - B[kX, 1, 0]


@inline
def frame_outputs(idat, B, ws, out, L, job, npts, k):
    """State k's frame outputs of the kernel (layout L): JOB_POINTS the origins O_j = T_j[:3, 3]
    (K P 3,), JOB_FRAMES T, Td, Tdd0 (K (n+1) 48,), JOB_JACOBIANS dO_j/dq (K P 3 N,):

        dO_j/dq_c = (S_c O_j)[:3] (+ (S2_c O_j)[:3] when f2_c <= j) for f_c <= j, else 0

    From the position stage's frames and twists in B (work_slots ws).
    """
    ts, tds, tdds, ss, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    n = idat[0]
    N = idat[1]
    for j in range(n + 1):
        if job & JOB_POINTS:
            o = L[_S_PTS] + 3 * (npts * k + j)
            for a in range(3):
                out[o + a] = B[ts + j, a, 3]
        if job & JOB_FRAMES:
            o = L[_S_FR] + 48 * ((n + 1) * k + j)
            for a in range(4):
                for b in range(4):
                    out[o + 4 * a + b] = B[ts + j, a, b]
                    out[o + 16 + 4 * a + b] = B[tds + j, a, b]
                    out[o + 32 + 4 * a + b] = B[tdds + j, a, b]
        if job & JOB_JACOBIANS:
            _point_jacobian(idat, B, ss, B[ts + j, 0, 3], B[ts + j, 1, 3], B[ts + j, 2, 3], j, out,
                            L[_S_JAC] + 3 * N * (npts * k + j))


def _point_jacobian(idat, B, ss, p0, p1, p2, j, out, o):
    """dp/dq (3, N) into out[o:] (row-major) for a point p [m] fixed to frame j: for every coordinate
    c, the sum of (S p)[:3] over the pieces S of c's twist (assemble._piece) whose start frame is j
    or an ancestor of j (layout._anc); 0 where none is."""
    N = idat[1]
    for c in range(N):
        for a in range(3):
            out[o + N * a + c] = 0.0
        for piece in range(2 + idat[_H + _CI * c + 7]):
            sl, f = _piece(idat, N, c, piece)
            if sl < 0 or not _anc(idat, f, j):
                continue
            for a in range(3):
                x = out[o + N * a + c] + B[ss + sl, a, 3]
                x += B[ss + sl, a, 0] * p0
                x += B[ss + sl, a, 1] * p1
                x += B[ss + sl, a, 2] * p2
                out[o + N * a + c] = x


def _extra_points(fdat, idat, q, B, ws, out, L, job, npts, k):
    """State k's extra contact points into the point and Jacobian sections of out (layout L): the
    tips of host links whose child joint is prismatic (contact points n + 1 ..), then the tips of
    a tree's leaves but the last link (formulation §17: every link end that carries no child;
    _tree_tables), each by _tip_point."""
    n = idat[0]
    N = idat[1]
    x = n + 1
    for i in range(1, n):
        if idat[_H + _CI * N + _LI * i + 5] == JOINT_R or idat[_H + _CI * N + _LI * i + 5] > JOINT_PB:
            continue
        _tip_point(fdat, idat, q, B, ws, out, L, job, npts, k, i - 1, x)
        x += 1
    o = _tree_tables(idat) + (n + 1) * (n + 2) + idat[7]
    for r in range(idat[o]):
        _tip_point(fdat, idat, q, B, ws, out, L, job, npts, k, idat[o + 1 + r], x)
        x += 1


def _tip_point(fdat, idat, q, B, ws, out, L, job, npts, k, h, x):
    """Contact point x of state k: the tip of link h, which is no frame origin (_extra_points):
    p = T_h (l_h e_x + sum end_t_k delta_k, 1),  dp/dq_c = (S_c p)[:3] for the twists that move
    frame h (_point_jacobian), R_h end_t_k for h's own delta_k (docs/theory.md §7.1: E_h is not on
    the chain's path); a stiffened host adds u_f(l) = -1/2 delta^T H(l) delta along e_x and
    -(H(l) delta)_k to end_t_k's x."""
    ts, TDS, TDDS, ss, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    N = idat[1]
    hb = _H + _CI * N + _LI * h
    m = idat[hb]
    d0 = idat[hb + 1]
    off = idat[hb + 3]
    o_t = off + 21 + 2 * m + 2 * m * m
    t0 = fdat[off + 20]
    t1 = 0.0
    t2 = 0.0
    oHl = -1 if idat[hb + 6] < 0 else _fs_tables(fdat, idat[hb + 6], m)[8]
    for c in range(m):
        for j in range(m if oHl >= 0 else 0):
            t0 -= 0.5 * q[d0 + c] * fdat[oHl + m * c + j] * q[d0 + j]
        t0 += fdat[o_t + 3 * c] * q[d0 + c]
        t1 += fdat[o_t + 3 * c + 1] * q[d0 + c]
        t2 += fdat[o_t + 3 * c + 2] * q[d0 + c]
    p0 = B[ts + h, 0, 0] * t0 + B[ts + h, 0, 1] * t1 + B[ts + h, 0, 2] * t2 + B[ts + h, 0, 3]
    p1 = B[ts + h, 1, 0] * t0 + B[ts + h, 1, 1] * t1 + B[ts + h, 1, 2] * t2 + B[ts + h, 1, 3]
    p2 = B[ts + h, 2, 0] * t0 + B[ts + h, 2, 1] * t1 + B[ts + h, 2, 2] * t2 + B[ts + h, 2, 3]
    if job & JOB_POINTS:
        o = L[_S_PTS] + 3 * (npts * k + x)
        out[o] = p0
        out[o + 1] = p1
        out[o + 2] = p2
    if job & JOB_JACOBIANS:
        o = L[_S_JAC] + 3 * N * (npts * k + x)
        _point_jacobian(idat, B, ss, p0, p1, p2, h, out, o)
        for c in range(m):
            eta = 0.0
            for j in range(m if oHl >= 0 else 0):
                eta += fdat[oHl + m * c + j] * q[d0 + j]
            for a in range(3):
                s = -B[ts + h, a, 0] * eta
                for b in range(3):
                    s += B[ts + h, a, b] * fdat[o_t + 3 * c + b]
                out[o + N * a + d0 + c] = s
