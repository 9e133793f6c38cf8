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
9. *Trees* (formulation §17, docs/theory.md §6.5.1). Composites sum over subtrees (each frame's
   added to its parent's), f_a <= f_b reads "f_a is f_b or an ancestor" (layout._anc): M_ab's
   first term is skipped, an exact zero, where the two share no frame; a parent's delta has one
   twist piece per child (layout._piece), summed like the second twists of item 7.
8. *Foreshortening* (formulation §15; moments._fs_moments). A stiffened link's own shapes are
   phi_l = e_{a_l} psi_l - e_x eta_l(x), eta = H(x) delta, and rddot0 = -beta e_x: with
   s_l = int mu eta_l r, sd_l = int mu eta_l rdot, z_l = T s_l, x_o = T e_x (world),

       M_cd += -x_o . (S_c z_d)  (as e_d . (S_c y_d), item 2),   M_kl += int mu eta_k eta_l,
       h_l  += -x_o . (Tdd0 s_l + 2 Td sd_l) + int mu eta_l beta,   F_i += (T qa) x_o^T,
       dV_l += (int mu eta_l) g~ . x_o,    qa = -int mu beta r

   (P, Pv, m_r, q_l, qd_l already hold the foreshortened r, rdot).
"""

from __future__ import annotations

from .layout import _CI, _F_G, _H, _LI, JOINT_PB, _anc, _mmax, _piece, _tree_tables, inline
from .mat4 import _mm, _mmt
from .moments import _fs_offsets, _own_source, _sd_offsets, _sd_stride


def assemble(fdat, idat, q, vel, B, V, SD, ws, M, h, dV, pris, ends):
    """Assemble stage: M (N, N), and h (N,) when vel, and dV/dq (N,) (items 2-4, 6, 7 above).

    From the position stage's frames and twists and the moments stage's body moments in the
    work arrays B, V, SD (work_slots ws, moments); h and dV must be zero on entry.
    """
    n = idat[0]
    N = idat[1]
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    mmax = _mmax(idat)
    SDS = _sd_stride(mmax)
    _link_shares(idat, B, V, SD, SDS, ws, vel, pris, ends)
    _own_terms(fdat, idat, q, vel, B, V, SD, SDS, mmax + 1, ws, dV, h, pris)
    if ends is not None:
        _fs_own_terms(fdat, idat, vel, B, SD, SDS, ws, dV, h)
    # Composites: sums over the subtree of frame j (one backward pass: children come after their
    # parent, so each frame's composite is complete when it is added to its parent's; serial: j - 1).
    tt = _tree_tables(idat)
    for j in range(n, 0, -1):
        i = idat[tt + j]
        if i < 0:
            continue
        for a in range(4):
            V[MUC + i, a] += V[MUC + j, a]
            for b in range(4):
                B[PIC + i, a, b] += B[PIC + j, a, b]
                B[FC + i, a, b] += B[FC + j, a, b]
    # X_d = Pi^c_{f_d} S_d^T
    for d in range(N):
        _mmt(B, PIC + idat[_H + _CI * d + 2], SS + d, XS + d)
    _mass_matrix(fdat, idat, B, V, SD, SDS, ws, M, pris, ends)
    _twist_forces(fdat, idat, B, V, ws, vel, dV, h, pris)


@inline
def _link_shares(idat, B, V, SD, SDS, ws, vel, pris, ends):
    """Each link's shares of the composites (items 2-4, 6, 8): Pi_i = T P T^T, mu_i = T m_r and,
    when vel, F_i = T P Tdd0^T + 2 T Pv Td^T (+ (T qa)(T e_y)^T for a Pb link: r0dd = e_y a0;
    + (T qa)(T e_x)^T for a stiffened link: rddot0 = -beta e_x, _fs_moments),
    into B[PIC + i], V[MUC + i], B[FC + i] (work_slots ws; a Pb link's qa in SD, _pb_moments;
    B[WK + 22], B[WK + 23] scratch)."""
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    kX = WK + 22
    for i in range(idat[0]):
        _mm(B, TS + i, PS + i, kX)
        _mmt(B, kX, TS + i, PIC + i)
        for a in range(4):
            s = 0.0
            for b in range(4):
                s += B[TS + i, a, b] * V[MR + i, b]
            V[MUC + i, a] = s
        if vel:
            _mmt(B, kX, TDDS + i, FC + i)
            _mm(B, TS + i, PVS + i, kX)
            _mmt(B, kX, TDS + i, kX + 1)
            for a in range(4):
                for b in range(4):
                    B[FC + i, a, b] += 2.0 * B[kX + 1, a, b]
            base = _H + _CI * idat[1] + _LI * i
            o_qa = -1
            ax = 1
            if pris is not None and idat[base + 5] == JOINT_PB:
                o_qa = _sd_offsets(i * SDS, idat[base])[2]
            elif ends is not None and idat[base + 6] >= 0:
                o_qa = _fs_offsets(i * SDS, _mmax(idat))[5]
                ax = 0
            if o_qa >= 0:
                for a in range(4):
                    s = 0.0
                    for b in range(4):
                        s += B[TS + i, a, b] * SD[o_qa + b]
                    for b in range(4):
                        B[FC + i, a, b] += s * B[TS + i, b, ax]


@inline
def _own_terms(fdat, idat, q, vel, B, V, SD, SDS, R, ws, dV, h, pris):
    """The parts of dV and h of each link's own coordinates c (its deltas, and a Pb link's d):

        y_c = T q_c,  e_c = T e_{a_c}  (into V[YY + c], V[EE + c], for _mass_matrix)
        dV_c = -c1_c g~ . e_c + (K delta)_c      (a Pb link: K(d) delta, and dV_s/dd for chi)
        h_c = e_c . (Tdd0 q_c + 2 Td qd_c)       (a Pb link: + int mu phi_c a0)

    SD: the Pb links' shape data (_pb_moments, stride SDS); R = mmax + 1; work_slots ws.
    """
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    N = idat[1]
    for i in range(idat[0]):
        base = _H + _CI * N + _LI * i
        m = idat[base]
        d0 = idat[base + 1]
        off = idat[base + 3]
        pb = pris is not None and idat[base + 5] == JOINT_PB
        ms, src, o_cx = _own_source(fdat, idat, i, SD, i * SDS, pris)
        o_K = off + 21 + 2 * m + m * m
        o_c1, o_M, o_qa, o_ha, o_Kd, o_dK = _sd_offsets(i * SDS, m)
        for l in range(ms):
            c = d0 + l if l < m else idat[base + 2]
            al = 1 if l == m else idat[_H + _CI * c + 1]
            kq = QV + R * i + l
            for a in range(4):
                s = 0.0
                for b in range(4):
                    s += B[TS + i, a, b] * V[kq, b]
                V[YY + c, a] = s
                V[EE + c, a] = B[TS + i, a, al]
            s = 0.0
            for a in range(3):
                s += fdat[_F_G + a] * V[EE + c, a]
            if pb:
                kd = SD[o_Kd + l]
            else:
                kd = 0.0
                for k in range(m):
                    kd += fdat[o_K + m * l + k] * q[d0 + k]
            dV[c] = -src[o_cx + ms + l] * s + kd
            if vel:
                s = 0.0
                for a in range(3):
                    x = 0.0
                    for b in range(4):
                        x += B[TDDS + i, a, b] * V[kq, b] + 2.0 * B[TDS + i, a, b] * V[QDV + R * i + l, b]
                    s += V[EE + c, a] * x
                if pb:
                    s += SD[o_ha + l]
                h[c] = s


@inline
def _fs_own_terms(fdat, idat, vel, B, SD, SDS, ws, dV, h):
    """The foreshortening parts of dV and h of each stiffened link's own coordinates (item 8):

        z_l = T s_l (into SD, for _mass_matrix),  dV_l += (int mu eta_l) g~ . x_o,
        h_l += -x_o . (Tdd0 s_l + 2 Td sd_l) + hfs_l     (x_o = T e_x; _fs_moments' SD terms)
    """
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    mmax = _mmax(idat)
    for i in range(idat[0]):
        base = _H + _CI * idat[1] + _LI * i
        if idat[base + 6] < 0:
            continue
        d0 = idat[base + 1]
        o_s, o_sd, o_z, o_M, o_h, o_qa, o_eta, o_zeta = _fs_offsets(i * SDS, mmax)
        gx = 0.0
        for a in range(3):
            gx += fdat[_F_G + a] * B[TS + i, a, 0]
        for l in range(idat[base]):
            for a in range(4):
                s = 0.0
                for b in range(4):
                    s += B[TS + i, a, b] * SD[o_s + 4 * l + b]
                SD[o_z + 4 * l + a] = s
            dV[d0 + l] += SD[o_s + 4 * l + 3] * gx
            if vel:
                s = SD[o_h + l]
                for a in range(3):
                    x = 0.0
                    for b in range(4):
                        x += B[TDDS + i, a, b] * SD[o_s + 4 * l + b] + 2.0 * B[TDS + i, a, b] * SD[o_sd + 4 * l + b]
                    s -= B[TS + i, a, 0] * x
                h[d0 + l] += s


def _fs_sz(idat, B, SD, SDS, TS, s, b):
    """-x_o . (B[s] z_b) for b an own coordinate of a stiffened link o (x_o = T_o e_x, z_b = T_o s_b;
    item 8): the foreshortening part of M_ab for a twist B[s] that moves link o; 0 when b deforms
    no stiffened link."""
    o = idat[_H + _CI * b + 3]
    if o < 0 or idat[_H + _CI * idat[1] + _LI * o + 6] < 0:
        return 0.0
    oz = _fs_offsets(o * SDS, _mmax(idat))[2] + 4 * idat[_H + _CI * b + 4]
    val = 0.0
    for r in range(3):
        x = 0.0
        for k in range(4):
            x += B[s, r, k] * SD[oz + k]
        val -= B[TS + o, r, 0] * x
    return val


@inline
def _mass_matrix(fdat, idat, B, V, SD, SDS, ws, M, pris, ends):
    """M (N, N) (items 2, 6, 7): for each pair c, d, with a, b = c, d ordered so that f_a <= f_b,

        M_ab = tr(S_a Pi^c_{f_b} S_b^T) + [o_b >= 0, f_a <= o_b] e_b.(S_a y_b)
               + [o_a >= 0, f_b <= o_a] e_a.(S_b y_a) + [o_a = o_b] Mpsi_(l_a l_b)
               + the other pieces' terms (second twists, a tree's extra entries: _piece_mass)

    (o: the link whose material the coordinate deforms, -1 if none; f: first frame it moves;
    "f_a <= f_b" read as "f_a is f_b or an ancestor of it" (_anc; on a serial chain the same): the
    first term vanishes when neither is, the branch-induced sparsity of formulation §17;
    X_b = Pi^c_{f_b} S_b^T in B[XS + b]). One loop with no call per entry but _e_sy's: a call
    passing arrays costs a reference count each.
    """
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    N = idat[1]
    for c in range(N):
        fc = idat[_H + _CI * c + 2]
        for d in range(c, N):
            fd = idat[_H + _CI * d + 2]
            nested = True
            if _anc(idat, fc, fd):
                a = c
                b = d
            else:
                a = d
                b = c
                nested = _anc(idat, fd, fc)  # False: two branches of a tree, no frame in common
            fa = idat[_H + _CI * a + 2]
            fb = idat[_H + _CI * b + 2]
            # tr(S_a X_b); S has a zero last row
            val = 0.0
            if nested:
                for r in range(3):
                    for k in range(4):
                        val += B[SS + a, r, k] * B[XS + b, k, r]
            ob = idat[_H + _CI * b + 3]
            oa = idat[_H + _CI * a + 3]
            if ob >= 0 and _anc(idat, fa, ob):
                # e_b . (S_a y_b): a moves the link that b deforms
                val += _e_sy(B, V, SS + a, YY + b, EE + b)
                if ends is not None:
                    val += _fs_sz(idat, B, SD, SDS, TS, SS + a, b)
            if oa >= 0 and _anc(idat, fb, oa):
                val += _e_sy(B, V, SS + b, YY + a, EE + a)
                if ends is not None:
                    val += _fs_sz(idat, B, SD, SDS, TS, SS + b, a)
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
                if ends is not None and idat[bl + 6] >= 0:
                    mmax = _mmax(idat)
                    val += SD[_fs_offsets(ob * SDS, mmax)[3] + mmax * la + lb]
            if (pris is not None and (idat[_H + _CI * a + 5] >= 0 or idat[_H + _CI * b + 5] >= 0)) \
                    or idat[_H + _CI * a + 7] > 0 or idat[_H + _CI * b + 7] > 0:
                val = _piece_mass(idat, B, V, SD, SDS, ws, a, b, val)
            M[c, d] = val
            M[d, c] = val


def _piece_mass(idat, B, V, SD, SDS, ws, a, b, val):
    """val plus the terms of M_ab from the pieces of the twists but (S_a, S_b) (items 2, 7;
    _mass_matrix's a, b): with S_a(j) = sum of the pieces (_piece) whose start frame is j or an
    ancestor of j, every pair of pieces but the first two adds tr(S_a' Pi^c_s S_b'^T) where the
    starts are nested (s the deeper one), and e_b.(S_a' y_b), e_a.(S_b' y_a) where the piece's
    start is the deformed link o or an ancestor of it."""
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    N = idat[1]
    oa = idat[_H + _CI * a + 3]
    ob = idat[_H + _CI * b + 3]
    for pa in range(2 + idat[_H + _CI * a + 7]):
        sa, st_a = _piece(idat, N, a, pa)
        if sa < 0:
            continue
        for pb_ in range(2 + idat[_H + _CI * b + 7]):
            sb, st_b = _piece(idat, N, b, pb_)
            if sb < 0 or (pa == 0 and pb_ == 0):
                continue
            if _anc(idat, st_a, st_b):
                val += _tr_sps(B, SS + sa, PIC + st_b, SS + sb)
            elif _anc(idat, st_b, st_a):
                val += _tr_sps(B, SS + sa, PIC + st_a, SS + sb)
        if pa > 0 and ob >= 0 and _anc(idat, st_a, ob):
            val += _e_sy(B, V, SS + sa, YY + b, EE + b) + _fs_sz(idat, B, SD, SDS, TS, SS + sa, b)
    for pb_ in range(1, 2 + idat[_H + _CI * b + 7]):
        sb, st_b = _piece(idat, N, b, pb_)
        if sb >= 0 and oa >= 0 and _anc(idat, st_b, oa):
            val += _e_sy(B, V, SS + sb, YY + a, EE + a) + _fs_sz(idat, B, SD, SDS, TS, SS + sb, a)
    return val


@inline
def _twist_forces(fdat, idat, B, V, ws, vel, dV, h, pris):
    """The twist parts of dV and h (items 3, 4, 7): for every coordinate c,

        dV_c -= g~ . (S_c mu^c_{f_c}),  h_c += tr(S_c F^c_{f_c})

    then the same with the second twist S2_c and the composites of f2_c where c has one.
    """
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    N = idat[1]
    for c in range(N):
        for piece in range(2 + idat[_H + _CI * c + 7]):
            if piece == 1 and pris is None:
                continue
            s, f = _piece(idat, N, c, piece)
            if s < 0:
                continue
            s += SS
            g = 0.0
            for r in range(3):
                x = 0.0
                for k in range(4):
                    x += B[s, r, k] * V[MUC + f, k]
                g += fdat[_F_G + r] * x
            dV[c] -= g
            if vel:
                x = 0.0
                for r in range(3):
                    for k in range(4):
                        x += B[s, r, k] * B[FC + f, k, r]
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
