"""Assemble stage: the mass matrix M, the bias forces h and dV/dq from frames, twists and moments.

Notation (docs/theory.md §2, §6): link i has the frame T_i (4x4),
material points p(x) = T_i r(x), r(x) = r0(x) + sum_l psihat_l(x) delta_l,
psihat_l = (e_{a_l} psi_l(x), 0) with a_l in {y, z} the bending axis of mode l.
The items are numbered as in the derivation of the kernel package's docstring
(a composite-body recursion in the 4x4 form, O(n^2)). Frames and twists (item 1)
come from frames.py, the body moments P_i, Pv_i, m_r,i, q_l (item 5) from moments.py.

2. *Mass matrix.* M = sum_i int mu J^T J dx with J_c = S_c T_i r (c moves
   link i) or T_i psihat_l (c = delta_l, own mode of link i). With the body
   moments P_i = int mu r r^T (plus the rotary pseudo-inertia, item 5) and
   Q_l = int mu r psihat_l^T = q_l e_{a_l}^T:

       M_cd = tr(S_c Pi^c_{f_d} S_d^T)                  f_c <= f_d
            + e_d . (S_c y_d)                           d own mode of link o, f_c <= o
            + M_dd[c, d]                                c, d own modes of one link
       Pi_i = T_i P_i T_i^T,  Pi^c_j = sum_{i >= j} Pi_i   (composite, one backward pass)
       y_d = T_o q_d,  e_d = T_o e_{a_d}   (world 4-vectors)

   Each entry costs O(1): M costs O(N^2), N = O(n).

3. *Bias forces.* h = sum_i int mu J^T a0 dx, a0 = Tdd0_i r + 2 Td_i rdot:

       h_c = tr(S_c F^c_{f_c}) + [c own mode of link o] e_c . (Tdd0_o q_c + 2 Td_o qd_c)
       F_i = T_i P_i Tdd0_i^T + 2 T_i Pv_i Td_i^T,   Pv = int mu r rdot^T = sum_l deltadot_l Q_l
       qd_l = int mu rdot psi_l along a_l (a 4-vector)

4. *Potential.* V = -g~ . sum_i T_i m_r,i + 1/2 delta^T K delta, so

       dV_c = -g~ . (S_c mu^c_{f_c}) + [own] (-c1_c g~ . e_c + (K delta)_c)
       mu_i = T_i m_r,i,  mu^c_j = sum_{i >= j} mu_i,  c1_l = int mu psi_l.

6. *Prismatic joints* (docs/theory.md §7.1, §7.6). A Pb link's d is an own coordinate of
   that link (o_d = i, shape chi, moments.py) as well as a twist coordinate (f_d = i), and
   for every pair

       M_ab = tr(S_a Pi^c_max(f_a, f_b) S_b^T) + [o_b >= 0, f_a <= o_b] e_b.(S_a y_b)
              + [o_a >= 0, f_b <= o_a] e_a.(S_b y_a) + [o_a = o_b] int mu phi_a phi_b

   (for modes f = o + 1, so this is item 2). The convective acceleration r0dd = e_y a0 of
   a Pb link adds int mu r a0 to F and int mu phi_l a0 to the own part of h.
7. *Two twists* (frames.py): S_D(j) = S_D + [j >= f2] S2_D, and every trace above
   is summed over the pieces, each with the composite of its later start frame.
"""

from __future__ import annotations

import numpy as np

from .frames import _W_SIZE, chain_frames
from .layout import _CI, _F_G, _H, _LI, JOINT_PB, _mmax
from .mat4 import _mm, _mmt
from .moments import _link_body, _sd_stride


def assemble(fdat, idat, q, qd, vel, M, h, dV, pris, ends):
    """M (N, N), and h (N,) when vel, and dV/dq (N,) (module docstring, items 2-4).

    h and dV must be zero on entry.
    """
    n = idat[0]
    N = idat[1]
    mmax = _mmax(idat)
    n1 = n + 1
    # B: 4x4 matrices by index (frames, composites, twists, X_d, work); V: 4-vectors.
    TS = 0
    TDS = n1
    TDDS = 2 * n1
    PIC = 3 * n1
    FC = 4 * n1
    SS = 5 * n1
    XS = SS + 2 * N  # twists, then second twists (B[SS + N + c], used where idat's f2_c >= 0)
    WK = XS + N
    B = np.zeros((WK + _W_SIZE, 4, 4))
    kP = WK + 20
    kPv = WK + 21
    kX = WK + 22
    chain_frames(fdat, idat, q, qd, vel, B, TS, TDS, TDDS, SS, WK, pris, ends)
    MUC = 0
    YY = n1
    EE = n1 + N
    QV = n1 + 2 * N
    QDV = QV + mmax + 1
    MR = QDV + mmax + 1
    V = np.zeros((MR + 1, 4))
    SDS = _sd_stride(mmax)
    SD = np.zeros(n * SDS)
    for i in range(n):
        base = _H + _CI * N + _LI * i
        m = idat[base]
        d0 = idat[base + 1]
        off = idat[base + 3]
        pb = pris is not None and idat[base + 5] == JOINT_PB
        so = i * SDS
        ms, src, o_cx = _link_body(fdat, idat, i, q, qd, B, kP, kPv, V, MR, QV, QDV, SD, so, pris)
        # Pi_i = T P T^T;  mu_i = T m_r
        _mm(B, TS + i, kP, kX)
        _mmt(B, kX, TS + i, PIC + i)
        for a in range(4):
            s = 0.0
            for b in range(4):
                s += B[TS + i, a, b] * V[MR, b]
            V[MUC + i, a] = s
        if vel:
            # F_i = T P Tdd0^T + 2 T Pv Td^T (+ (T qa)(T e_y)^T for a Pb link: r0dd = e_y a0)
            _mmt(B, kX, TDDS + i, FC + i)
            _mm(B, TS + i, kPv, kX)
            for a in range(4):
                for b in range(4):
                    s = 0.0
                    for c in range(4):
                        s += B[kX, a, c] * B[TDS + i, b, c]
                    B[FC + i, a, b] += 2.0 * s
            if pb:
                o_qa = so + 2 * ms + ms * ms
                for a in range(4):
                    s = 0.0
                    for b in range(4):
                        s += B[TS + i, a, b] * SD[o_qa + b]
                    for b in range(4):
                        B[FC + i, a, b] += s * B[TS + i, b, 1]
        o_c1 = o_cx + ms
        o_K = off + 21 + 2 * m + m * m
        for l in range(ms):
            c = d0 + l if l < m else idat[base + 2]
            al = 1 if l == m else idat[_H + _CI * c + 1]
            # y_c = T q_c;  e_c = T e_{a_c}
            for a in range(4):
                s = 0.0
                for b in range(4):
                    s += B[TS + i, a, b] * V[QV + l, b]
                V[YY + c, a] = s
                V[EE + c, a] = B[TS + i, a, al]
            # own part of dV: -c1_l g~.e_l + (K delta)_l  (Pb: K(d) delta, and dV_s/dd for chi)
            s = 0.0
            for a in range(3):
                s += fdat[_F_G + a] * V[EE + c, a]
            if pb:
                kd = SD[so + 3 * ms + ms * ms + 4 + l]
            else:
                kd = 0.0
                for k in range(m):
                    kd += fdat[o_K + m * l + k] * q[d0 + k]
            dV[c] = -src[o_c1 + l] * s + kd
            if vel:
                # own part of h: e_l . (Tdd0 q_l + 2 Td qd_l)  (+ int mu phi_l a0 for a Pb link)
                s = 0.0
                for a in range(3):
                    x = 0.0
                    for b in range(4):
                        x += B[TDDS + i, a, b] * V[QV + l, b] + 2.0 * B[TDS + i, a, b] * V[QDV + l, b]
                    s += V[EE + c, a] * x
                if pb:
                    s += SD[so + 2 * ms + ms * ms + 4 + l]
                h[c] = s
    # Composites: sums over the links from frame j outwards.
    for i in range(n - 1, -1, -1):
        for a in range(4):
            V[MUC + i, a] += V[MUC + i + 1, a]
            for b in range(4):
                B[PIC + i, a, b] += B[PIC + i + 1, a, b]
                B[FC + i, a, b] += B[FC + i + 1, a, b]
    # X_d = Pi^c_{f_d} S_d^T
    for d in range(N):
        _mmt(B, PIC + idat[_H + _CI * d + 2], SS + d, XS + d)
    # M_ab = tr(S_a Pi^c_max(f_a, f_b) S_b^T) + [o_b >= 0, f_a <= o_b] e_b.(S_a y_b)
    #        + [o_a >= 0, f_b <= o_a] e_a.(S_b y_a) + [o_a = o_b] Mpsi_(l_a l_b)
    # (o: the link whose material the coordinate deforms, -1 if none; f: first frame it moves)
    for c in range(N):
        fc = idat[_H + _CI * c + 2]
        for d in range(c, N):
            fd = idat[_H + _CI * d + 2]
            if fc <= fd:
                a = c
                b = d
            else:
                a = d
                b = c
            fa = idat[_H + _CI * a + 2]
            fb = idat[_H + _CI * b + 2]
            # tr(S_a X_b); S has a zero last row
            val = 0.0
            for r in range(3):
                for k in range(4):
                    val += B[SS + a, r, k] * B[XS + b, k, r]
            ob = idat[_H + _CI * b + 3]
            oa = idat[_H + _CI * a + 3]
            if ob >= 0 and fa <= ob:
                # e_b . (S_a y_b): a moves the link that b deforms
                val += _e_sy(B, V, SS + a, YY + b, EE + b)
            if oa >= 0 and fb <= oa:
                val += _e_sy(B, V, SS + b, YY + a, EE + a)
            if ob >= 0 and oa == ob:
                bl = _H + _CI * N + _LI * ob
                m = idat[bl]
                la = idat[_H + _CI * a + 4]
                lb = idat[_H + _CI * b + 4]
                if idat[bl + 5] == JOINT_PB:
                    ms = m + 1
                    val += SD[ob * SDS + 2 * ms + ms * la + lb]
                elif idat[_H + _CI * a + 1] == idat[_H + _CI * b + 1]:
                    # Mpsi of two modes of one link along one axis
                    val += fdat[idat[bl + 3] + 21 + 2 * m + m * la + lb]
            f2a = idat[_H + _CI * a + 5]
            f2b = idat[_H + _CI * b + 5]
            if pris is not None and (f2a >= 0 or f2b >= 0):
                # second twists: S_a(j) = S_a + [j >= f2_a] S2_a on frame j
                for pa in range(2):
                    if pa == 1 and f2a < 0:
                        continue
                    sa = SS + a + pa * N
                    st_a = fa if pa == 0 else f2a
                    for pb_ in range(2):
                        if (pb_ == 1 and f2b < 0) or (pa == 0 and pb_ == 0):
                            continue
                        st = max(st_a, fb if pb_ == 0 else f2b)
                        val += _tr_sps(B, sa, PIC + st, SS + b + pb_ * N)
                if f2a >= 0 and ob >= 0 and f2a <= ob:
                    val += _e_sy(B, V, SS + N + a, YY + b, EE + b)
                if f2b >= 0 and oa >= 0 and f2b <= oa:
                    val += _e_sy(B, V, SS + N + b, YY + a, EE + a)
            M[c, d] = val
            M[d, c] = val
    for c in range(N):
        fc = idat[_H + _CI * c + 2]
        # dV_c += -g~ . (S_c mu^c_{f_c})
        s = 0.0
        for r in range(3):
            x = 0.0
            for k in range(4):
                x += B[SS + c, r, k] * V[MUC + fc, k]
            s += fdat[_F_G + r] * x
        dV[c] -= s
        if vel:
            # h_c += tr(S_c F^c_{f_c})
            x = 0.0
            for r in range(3):
                for k in range(4):
                    x += B[SS + c, r, k] * B[FC + fc, k, r]
            h[c] += x
        f2 = idat[_H + _CI * c + 5]
        if pris is not None and f2 >= 0:
            # the second twist's share: -g~ . (S2_c mu^c_f2) and tr(S2_c F^c_f2)
            s = 0.0
            for r in range(3):
                x = 0.0
                for k in range(4):
                    x += B[SS + N + c, r, k] * V[MUC + f2, k]
                s += fdat[_F_G + r] * x
            dV[c] -= s
            if vel:
                x = 0.0
                for r in range(3):
                    for k in range(4):
                        x += B[SS + N + c, r, k] * B[FC + f2, k, r]
                h[c] += x


def _tr_sps(B, sa, k, sb):
    """tr(B[sa] B[k] B[sb]^T) for twists B[sa], B[sb] (zero last row)."""
    val = 0.0
    for r in range(3):
        for i in range(4):
            x = 0.0
            for j in range(4):
                x += B[k, i, j] * B[sb, r, j]
            val += B[sa, r, i] * x
    return val


def _e_sy(B, V, s, y, e):
    """V[e] . (B[s] V[y]) over the first three rows: e_b . (S_a y_b)."""
    val = 0.0
    for r in range(3):
        x = 0.0
        for k in range(4):
            x += B[s, r, k] * V[y, k]
        val += V[e, r] * x
    return val
