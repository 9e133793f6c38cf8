"""Moments stage: the body moments of each link (P, Pv, m_r, q_l), a Pb link's by a Gauss rule.

Notation (docs/theory.md §2, §6): link i has the frame T_i (4x4),
material points p(x) = T_i r(x), r(x) = r0(x) + sum_l psihat_l(x) delta_l,
psihat_l = (e_{a_l} psi_l(x), 0) with a_l in {y, z} the bending axis of mode l.
The items are numbered as in the derivation of the kernel package's docstring
(a composite-body recursion in the 4x4 form, O(n^2)).

5. *Rotary inertia* J = l diag(j_x, j_y, j_z) about the link frame enters as the
   pseudo-inertia Sigma = tr(J)/2 I - J added to P_i[:3, :3]: a body with
   second moment Sigma has angular momentum J omega and Gibbs function
   1/2 alpha.J alpha + alpha.(omega x J omega), the term of docs/theory.md §6 (Gibbs-Appell of a
   rigid body is linear in its pseudo-inertia). (pack writes P0 + Sigma into fdat.)

6. *Prismatic joints* (docs/theory.md §7.4, §7.6). A Pb link's d also deforms the link's own
   material (chi = dv/dd at fixed x): d is then an *own* coordinate of that link
   (o_d = i, shape chi, velocity coefficient ddot). The Pb link's moments depend on d
   and come from an exact Gauss rule per call (_pb_moments), with the
   convective acceleration r0dd = e_y a0 adding int mu r a0 to F and
   int mu phi_l a0 to the own part of h (assemble.py).
"""

from __future__ import annotations

import numpy as np

from .layout import _CI, _F_JOINT, _GAUSS, _H, _LI, JOINT_PB, _mmax, inline


def moments(fdat, idat, q, qd, B, V, SD, ws, pris, ends):
    """Moments stage: the body moments of every link i at q, qdot (_link_body) into the work
    arrays of work_slots ws: B[PS + i] = P_i, B[PVS + i] = Pv_i, V[MR + i] = m_r,i, and for its
    own shapes l V[QV + R i + l] = q_l, V[QDV + R i + l] = qd_l, R = mmax + 1; a Pb link's shape
    data in SD[S i:], S = _sd_stride(mmax) (_pb_moments); a stiffened link's foreshortening terms
    (_fs_moments; only in the variant with moving link ends, ends not None).
    """
    TS, TDS, TDDS, SS, WK, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    mmax = _mmax(idat)
    R = mmax + 1
    S = _sd_stride(mmax)
    for i in range(idat[0]):
        _link_body(fdat, idat, i, q, qd, B, PS + i, PVS + i, V, MR + i, QV + R * i, QDV + R * i, SD, S * i, pris)
        if ends is not None and idat[_H + _CI * idat[1] + _LI * i + 6] >= 0:
            _fs_moments(fdat, idat, i, q, qd, B, PS + i, PVS + i, V, MR + i, QV + R * i, QDV + R * i, SD,
                        _fs_offsets(S * i, mmax))


def _sd_stride(mmax):
    """Per-link stride of the per-call shape data SD: a Pb link's (_pb_moments), then a stiffened
    link's foreshortening terms (_fs_offsets)."""
    ms = mmax + 1
    return 2 * ms + ms * ms + 4 + ms + mmax + 2 + mmax * mmax + 15 * mmax + 4


def _fs_offsets(o, mmax):
    """Offsets of a stiffened link's foreshortening terms in the link's shape data at SD[o:]
    (_fs_moments), each own coordinate l < mmax: (s_l (4), sd_l (4), z_l (4), Mfs (mmax, mmax),
    hfs (mmax), qa (4), eta, zeta (mmax each))."""
    ms = mmax + 1
    o_s = o + 2 * ms + ms * ms + 4 + ms + mmax + 2
    o_M = o_s + 12 * mmax
    o_h = o_M + mmax * mmax
    o_qa = o_h + mmax
    return o_s, o_s + 4 * mmax, o_s + 8 * mmax, o_M, o_h, o_qa, o_qa + 4, o_qa + 4 + mmax


def _sd_offsets(o, m):
    """Offsets of a Pb link's shape data at SD[o:] (_pb_moments' layout), m = its number of
    deltas: (c1, Mpsi, qa, ha, K delta, dV_s/dd); cx starts at o, V_s follows dV_s/dd."""
    ms = m + 1
    o_c1 = o + ms
    o_M = o_c1 + ms
    o_qa = o_M + ms * ms
    o_ha = o_qa + 4
    o_K = o_ha + ms
    return o_c1, o_M, o_qa, o_ha, o_K, o_K + m


@inline
def _own_source(fdat, idat, link, SD, so, pris):
    """(ms, src, o_cx): the number of own shapes of ``link`` and where their moments cx (ms),
    c1 (ms), Mpsi (ms ms) live: src[o_cx:], fdat for a link of R or Pa joint, SD[so:] for a Pb
    link (whose chi is an own shape more, _pb_moments)."""
    base = _H + _CI * idat[1] + _LI * link
    if pris is not None and idat[base + 5] == JOINT_PB:
        return idat[base] + 1, SD, so
    return idat[base], fdat, idat[base + 3] + 21


def _pb_moments(fdat, idat, link, q, qd, SD, o):
    """Shape moments of a Pb link at the current d (docs/theory.md §7.4, §7.6) into SD[o:].

    Own shapes phi_l (l < m: Phi_l = d^a_l N_l(xi); l = m: chi = dv/dd at fixed x =
    sum_k delta_k rho_k, rho_k = d^(a_k - 1) F_k, F_k = a_k N_k + (1 - xi) N_k'), on the
    protruding part sigma = d xi (x = l - d + sigma); the rear part has v = 0. Exact Gauss rule
    in xi (4 points per stretching element, degree <= 7):
      cx_l = int mu x phi_l,  c1_l = int mu phi_l,  Mpsi_lk = int mu phi_l phi_k       (m+1 each)
      a0 = ddot^2 sum delta_k d rho_k/dd + 2 ddot sum deltadot_k rho_k   (r0dd = e_y a0)
      d rho_k/dd = d^(a_k - 2) [(a_k - 1) F_k + (1 - xi) F_k'],  F_k' = (a_k - 1) N_k' + (1 - xi) N_k''
      qa = int mu r a0 (4,),  ha_l = int mu phi_l a0
      K(d)_kl = EI d^(a_k + a_l - 3) Kunit_kl:  (K delta)_k,  1/2 delta^T K delta,
      dV_s/dd = 1/2 delta^T K' delta,  K'_kl = (a_k + a_l - 3) K_kl / d
    Layout: cx (m+1), c1 (m+1), Mpsi ((m+1)^2), qa (4), ha (m+1), K delta (m), dV_s/dd, V_s.
    """
    base = _H + _CI * idat[1] + _LI * link
    m = idat[base]
    d0 = idat[base + 1]
    jd = idat[base + 2]
    off = idat[base + 3]
    o_c1, o_M, o_qa, o_ha, o_K, o_dK = _sd_offsets(o, m)
    for k in range(o, o_dK + 2):
        SD[k] = 0.0
    if m == 0:
        return
    ox = off + 21 + 8 * m + 2 * m * m
    ne = int(fdat[ox + 2])
    mu = fdat[ox + 3]
    EI = fdat[ox + 4]
    l = fdat[off + 20]
    G = _GAUSS * ne
    oxi = ox + _F_JOINT  # the tables: xi (G), w (G), N, N', N'' (G m each), Kunit (m m), a (m)
    oKu = oxi + 2 * G + 3 * G * m
    _pb_gauss(fdat, q, qd, d0, m, oxi, G, mu, l, q[jd], qd[jd], SD, o)
    _pb_stiffness(fdat, q, d0, m, oKu + m * m, oKu, EI, q[jd], SD, o_K, o_dK)


@inline
def _pb_gauss(fdat, q, qd, d0, m, oxi, G, mu, l, d, dd, SD, o):
    """The Gauss rule of _pb_moments: its G points xi_g, weights w_g and shape tables N, N', N''
    (G m each), a_k (m) from fdat[oxi:] (pack's layout); at each point, with W = mu d w_g [kg],
    x = l - d + d xi [m],

        phi_k = d^a_k N_k,  chi = phi_m = sum_k delta_k rho_k,  v = sum_k phi_k delta_k,
        a0 = ddot^2 sum delta_k d rho_k/dd + 2 ddot sum deltadot_k rho_k,
        cx_l += W phi_l x,  c1_l += W phi_l,  ha_l += W phi_l a0,  Mpsi_lk += W phi_l phi_k,
        qa += W a0 (x, v, 0, 1)

    into the shape data SD[o:] (_sd_offsets); d [m], dd [m/s] the protruding length and its rate.
    """
    ms = m + 1
    o_c1, o_M, o_qa, o_ha, o_K, o_dK = _sd_offsets(o, m)
    ow = oxi + G
    oN = ow + G
    oN1 = oN + G * m
    oN2 = oN1 + G * m
    oa = oN2 + G * m + m * m
    phi = np.zeros(ms)
    for g in range(G):
        xi = fdat[oxi + g]
        W = mu * d * fdat[ow + g]
        x = l - d + d * xi
        v = 0.0
        chi = 0.0
        acc = 0.0
        for k in range(m):
            Nk = fdat[oN + g * m + k]
            N1 = fdat[oN1 + g * m + k]
            N2 = fdat[oN2 + g * m + k]
            if Nk == 0.0 and N1 == 0.0 and N2 == 0.0:
                phi[k] = 0.0
                continue
            ak = fdat[oa + k]
            dpow = d if ak == 1.0 else 1.0
            F = ak * Nk + (1.0 - xi) * N1
            rho = dpow / d * F
            F1 = (ak - 1.0) * N1 + (1.0 - xi) * N2
            drho = dpow / (d * d) * ((ak - 1.0) * F + (1.0 - xi) * F1)
            phi[k] = dpow * Nk
            v += phi[k] * q[d0 + k]
            chi += rho * q[d0 + k]
            acc += dd * dd * drho * q[d0 + k] + 2.0 * dd * rho * qd[d0 + k]
        phi[m] = chi
        for a in range(ms):
            wa = W * phi[a]
            if wa == 0.0:
                continue
            SD[o + a] += wa * x
            SD[o_c1 + a] += wa
            SD[o_ha + a] += wa * acc
            for b in range(ms):
                SD[o_M + ms * a + b] += wa * phi[b]
        SD[o_qa] += W * x * acc
        SD[o_qa + 1] += W * v * acc
        SD[o_qa + 3] += W * acc


@inline
def _pb_stiffness(fdat, q, d0, m, oa, oKu, EI, d, SD, o_K, o_dK):
    """A Pb link's stiffness terms at its protruding length d [m] (_pb_moments):

        K(d)_kj = EI d^(a_k + a_j - 3) Kunit_kj:  SD[o_K + k] = (K delta)_k,
        SD[o_dK] = dV_s/dd = 1/2 delta^T K' delta,  K'_kj = (a_k + a_j - 3) K_kj / d,
        SD[o_dK + 1] = V_s = 1/2 delta^T K delta
    """
    for k in range(m):
        ak = fdat[oa + k]
        for j in range(m):
            e = ak + fdat[oa + j] - 3.0
            Kkj = EI * d ** e * fdat[oKu + m * k + j]
            SD[o_K + k] += Kkj * q[d0 + j]
            SD[o_dK] += 0.5 * e / d * Kkj * q[d0 + k] * q[d0 + j]
            SD[o_dK + 1] += 0.5 * Kkj * q[d0 + k] * q[d0 + j]


def _own(idat, link, q, qd, k):
    """Own shape k of ``link``: (axis, position coefficient, velocity coefficient);
    k < m: delta_k; k = m (Pb only): chi with coefficients (0, ddot)."""
    N = idat[1]
    base = _H + _CI * N + _LI * link
    m = idat[base]
    if k < m:
        c = idat[base + 1] + k
        return idat[_H + _CI * c + 1], q[c], qd[c]
    return 1, 0.0, qd[idat[base + 2]]


def _link_body(fdat, idat, link, q, qd, B, kP, kPv, V, kmr, kqv, kqdv, SD, so, pris):
    """Body moments of ``link`` at delta, deltadot (and a Pb link's shape data in SD[so:]).

    B[kP] = P = P0 + Cd^T + sum_l delta_l Q_l (rotary pseudo-inertia included),
    V[kmr] = m_r, V[kqv + l] = q_l = c0_l + sum_k delta_k Mpsi_kl e_{a_k}, c0_l = (cx_l, 0, 0, c1_l),
    V[kqdv + l] = sum_k deltadot_k Mpsi_kl e_{a_k}, B[kPv] = Pv = sum_l deltadot_l q_l e_{a_l}^T
    (over the own shapes, _own_source; a Pb link adds chi with velocity coefficient ddot, _pb_moments).
    """
    base = _H + _CI * idat[1] + _LI * link
    off = idat[base + 3]
    if pris is not None and idat[base + 5] == JOINT_PB:
        _pb_moments(fdat, idat, link, q, qd, SD, so)
    ms, src, o_cx = _own_source(fdat, idat, link, SD, so, pris)
    for a in range(4):
        V[kmr, a] = fdat[off + 16 + a]
        for b in range(4):
            B[kP, a, b] = fdat[off + 4 * a + b]
            B[kPv, a, b] = 0.0
    o_c1 = o_cx + ms
    o_M = o_c1 + ms
    for l in range(ms):
        V[kqv + l, 0] = src[o_cx + l]
        V[kqv + l, 1] = 0.0
        V[kqv + l, 2] = 0.0
        V[kqv + l, 3] = src[o_c1 + l]
        for a in range(4):
            V[kqdv + l, a] = 0.0
    for k in range(ms):
        ak, dk, vk = _own(idat, link, q, qd, k)
        for l in range(ms):
            Mkl = src[o_M + ms * k + l]
            V[kqv + l, ak] += dk * Mkl
            V[kqdv + l, ak] += vk * Mkl
    for l in range(ms):
        al, dl, vl = _own(idat, link, q, qd, l)
        V[kmr, al] += dl * src[o_c1 + l]
        for r in range(4):
            B[kP, r, al] += dl * V[kqv + l, r]
            B[kPv, r, al] += vl * V[kqv + l, r]
        B[kP, al, 0] += dl * src[o_cx + l]
        B[kP, al, 3] += dl * src[o_c1 + l]


def _fs_tables(fdat, of, m):
    """Offsets of a stiffened link's foreshortening tables at fdat[of:] (packing._fs_tables), m its
    number of deltas: (G, P, x, w mu, psi, k, l, H_p, H(l)): G points, P pairs k <= l; in the
    tensor form G = P = 0 and A0, A1, B, A4 follow H(l) (_fs_tensor_offsets)."""
    G = int(fdat[of])
    P = int(fdat[of + 1])
    ox = of + 3
    opsi = ox + 2 * G
    opk = opsi + G * m
    oH = opk + 2 * P
    return G, P, ox, ox + G, opsi, opk, opk + P, oH, oH + G * P


@inline
def _fs_eta(fdat, q, qd, d0, m, P, opk, opl, oHg, SD, o_eta, o_zeta):
    """eta = H delta and zeta = H deltadot (m each) at one point into SD[o_eta:], SD[o_zeta:], from
    the P pairs (k <= l) of H at fdat[oHg:] (_fs_tables); delta = q[d0:d0 + m]."""
    for k in range(m):
        SD[o_eta + k] = 0.0
        SD[o_zeta + k] = 0.0
    for p in range(P):
        H = fdat[oHg + p]
        if H == 0.0:
            continue
        k = int(fdat[opk + p])
        l = int(fdat[opl + p])
        SD[o_eta + k] += H * q[d0 + l]
        SD[o_zeta + k] += H * qd[d0 + l]
        if k != l:
            SD[o_eta + l] += H * q[d0 + k]
            SD[o_zeta + l] += H * qd[d0 + k]


@inline
def _fs_own(fdat, m, opsig, W, r, rd, beta, V, kqv, kqdv, SD, fo):
    """One quadrature point's share of the own-coordinate terms of _fs_moments (point weight
    W = w mu [kg], r = (x + u_f, v, w, 1), rd = (rho, vdot, wdot, 0), beta; psi_k at fdat[opsig:]):
    q_l[0] += W u_f psi_l, qd_l[0] += W rho psi_l, s_l += W eta_l r, sd_l += W eta_l rd,
    hfs_l += W eta_l beta, Mfs_kl += W eta_k eta_l, qa -= W beta r."""
    o_s, o_sd, o_z, o_M, o_h, o_qa, o_eta, o_zeta = fo
    mm = (o_sd - o_s) // 4
    uf = r[0] - r[4]
    for k in range(m):
        ps = fdat[opsig + k]
        if ps != 0.0:
            V[kqv + k, 0] += W * uf * ps
            V[kqdv + k, 0] += W * rd[0] * ps
        We = W * SD[o_eta + k]
        if We == 0.0:
            continue
        for a in range(4):
            SD[o_s + 4 * k + a] += We * r[a]
            SD[o_sd + 4 * k + a] += We * rd[a]
        SD[o_h + k] += We * beta
        for l in range(m):
            SD[o_M + mm * k + l] += We * SD[o_eta + l]
    for a in range(4):
        SD[o_qa + a] -= W * beta * r[a]


def _fs_moments(fdat, idat, link, q, qd, B, kP, kPv, V, kmr, kqv, kqdv, SD, fo):
    """Foreshortening of a stiffened link (formulation §15) added to its body moments (_link_body's
    B[kP], B[kPv], V[kmr], V[kqv + l], V[kqdv + l]), and its own coordinates' extra terms into SD
    (offsets fo = _fs_offsets). With r = (x + u_f, v, w, 1), u_f = -1/2 delta^T H(x) delta,
    eta = H delta, rho = du_f/dt = -eta . deltadot, beta = deltadot^T H deltadot (so that
    rddot0 = -beta e_x) and the own shapes dr/d delta_l = e_{a_l} psi_l - e_x eta_l, summed over
    the link's quadrature points x_g with weights W_g = w mu [kg] (packing._fs_tables):

        P += sum W (r r^T - r_lin r_lin^T)  (row and column 0: 2 x u_f + u_f^2, u_f v, u_f w, u_f),
        m_r[0] += sum W u_f,  Pv += sum W (u_f e_x rdot_lin^T + r rho e_x^T),
        s_l = sum W eta_l r,  sd_l = sum W eta_l rdot,  Mfs_kl = sum W eta_k eta_l,
        hfs_l = sum W eta_l beta,  qa = -sum W beta r  (and q_l, qd_l: _fs_own)

    The points are those of the modal integrals (model.shapes.mass_points): the model is the exact
    holonomic system of these material points, so energy is conserved to round-off.
    """
    base = _H + _CI * idat[1] + _LI * link
    m = idat[base]
    d0 = idat[base + 1]
    G, P, ox, oW, opsi, opk, opl, oH, oHl = _fs_tables(fdat, idat[base + 6], m)
    o_s, o_sd, o_z, o_M, o_h, o_qa, o_eta, o_zeta = fo
    for k in range(o_s, o_zeta + m):
        SD[k] = 0.0
    acc = np.zeros(10)
    if fdat[idat[base + 6] + 2] == 1.0:
        _fs_tensor_moments(fdat, idat, d0, m, oHl + m * m, q, qd, V, kqv, kqdv, SD, fo, acc)
    r = np.zeros(5)  # (x + u_f, v, w, 1, x)
    rd = np.zeros(4)  # (rho, vdot, wdot, 0)
    for g in range(G):
        x = fdat[ox + g]
        W = fdat[oW + g]
        _fs_eta(fdat, q, qd, d0, m, P, opk, opl, oH + P * g, SD, o_eta, o_zeta)
        uf = 0.0
        beta = 0.0
        for a in range(4):
            r[a] = 0.0
            rd[a] = 0.0
        for k in range(m):
            ps = fdat[opsi + m * g + k]
            ax = idat[_H + _CI * (d0 + k) + 1]
            r[ax] += ps * q[d0 + k]
            rd[ax] += ps * qd[d0 + k]
            uf -= 0.5 * q[d0 + k] * SD[o_eta + k]
            rd[0] -= qd[d0 + k] * SD[o_eta + k]
            beta += qd[d0 + k] * SD[o_zeta + k]
        r[0] = x + uf
        r[3] = 1.0
        r[4] = x
        for a in range(4):
            acc[a] += W * uf * (r[a] if a > 0 else 2.0 * x + uf)
            acc[6 + a] += W * rd[0] * r[a]
        acc[4] += W * uf * rd[1]
        acc[5] += W * uf * rd[2]
        _fs_own(fdat, m, opsi + m * g, W, r, rd, beta, V, kqv, kqdv, SD, fo)
    _fs_add_moments(B, kP, kPv, V, kmr, acc)


@inline
def _fs_add_moments(B, kP, kPv, V, kmr, acc):
    """The foreshortening parts acc (10,) of _fs_moments added to P, Pv, m_r: acc = sum W times
    (u_f (2 x + u_f), u_f v, u_f w, u_f, u_f vdot, u_f wdot, rho (x + u_f), rho v, rho w, rho)."""
    B[kP, 0, 0] += acc[0]
    for a in range(1, 4):
        B[kP, 0, a] += acc[a]
        B[kP, a, 0] += acc[a]
        B[kPv, a, 0] += acc[6 + a]
    V[kmr, 0] += acc[3]
    B[kPv, 0, 0] += acc[6]
    B[kPv, 0, 1] += acc[4]
    B[kPv, 0, 2] += acc[5]


@inline
def _fs_contract(fdat, d0, m, oA, q, qd, SD, o_M, mm, o_h, t):
    """The contractions of a stiffened link's tensors (packing._fs_tables' tensor form at fdat[oA:]:
    A0, A1 (m, m), B (m, m, m), A4 (m^4)) with delta = q[d0:], deltadot = qd[d0:]:

        Mfs_kl = A4_kilj delta_i delta_j -> SD[o_M + mm k + l],  E_k = A4_kilj delta_i deltadot_l deltadot_j -> SD[o_h + k]
        t = (A0 delta, A1 delta, delta^T B_k delta, deltadot^T B_k delta, deltadot^T B_k deltadot (m each),
             (B_k delta)_l (m, m))
    """
    oA1 = oA + m * m
    oB = oA1 + m * m
    o4 = oB + m * m * m
    for k in range(m):
        for i in range(m):
            di = q[d0 + i]
            for l in range(m):
                for j in range(m):
                    a = fdat[o4 + ((k * m + i) * m + l) * m + j] * di
                    SD[o_M + mm * k + l] += a * q[d0 + j]
                    SD[o_h + k] += a * qd[d0 + l] * qd[d0 + j]
            t[k] += fdat[oA + m * k + i] * di
            t[m + k] += fdat[oA1 + m * k + i] * di
            for l in range(m):
                b = fdat[oB + (k * m + i) * m + l]
                t[2 * m + k] += b * di * q[d0 + l]
                t[3 * m + k] += b * di * qd[d0 + l]
                t[4 * m + k] += b * qd[d0 + i] * qd[d0 + l]
                t[5 * m + m * k + l] += b * q[d0 + i]  # B_k symmetric: (B_k delta)_l


@inline
def _fs_tensor_moments(fdat, idat, d0, m, oA, q, qd, V, kqv, kqdv, SD, fo, acc):
    """_fs_moments' sums from the precomputed tensors (the same sums over the same points, taken
    once: packing._fs_tables), with e0 = A0 delta, e1 = A1 delta, b.. = _fs_contract's, Mfs, E:

        int u_f = -1/2 delta.e0,  int x u_f = -1/2 delta.e1,  int u_f^2 = 1/4 delta^T Mfs delta,
        int rho = -deltadot.e0,  int u_f rho = 1/2 delta^T Mfs deltadot,  int psi_k u_f = -1/2 b_dd,k,
        int psi_k rho = -b_vd,k,  int psi_k beta = b_vv,k,  s_l = (e1 - 1/2 Mfs delta, sum_k delta_k (B_k delta)_l
        by axis, e0)_l,  sd_l = (-Mfs deltadot, sum_k deltadot_k (B_k delta)_l by axis, 0)_l,  hfs = E,
        qa = (-deltadot^T A1 deltadot + 1/2 delta.E, -sum_k delta_k b_vv,k by axis, -deltadot^T A0 deltadot)
    """
    o_s, o_sd, o_z, o_M, o_h, o_qa, o_eta, o_zeta = fo
    mm = (o_sd - o_s) // 4
    t = np.zeros(5 * m + m * m)
    _fs_contract(fdat, d0, m, oA, q, qd, SD, o_M, mm, o_h, t)
    for k in range(m):
        dk = q[d0 + k]
        vk = qd[d0 + k]
        ax = idat[_H + _CI * (d0 + k) + 1]
        Md = 0.0
        Mv = 0.0
        for l in range(m):
            Md += SD[o_M + mm * k + l] * q[d0 + l]
            Mv += SD[o_M + mm * k + l] * qd[d0 + l]
            SD[o_s + 4 * l + ax] += dk * t[5 * m + m * k + l]
            SD[o_sd + 4 * l + ax] += vk * t[5 * m + m * k + l]
        acc[0] += -dk * t[m + k] + 0.25 * dk * Md
        acc[3] -= 0.5 * dk * t[k]
        acc[ax] -= 0.5 * dk * t[2 * m + k]
        acc[3 + ax] -= 0.5 * vk * t[2 * m + k]
        acc[6] += -vk * t[m + k] + 0.5 * dk * Mv
        acc[6 + ax] -= dk * t[3 * m + k]
        acc[9] -= vk * t[k]
        V[kqv + k, 0] -= 0.5 * t[2 * m + k]
        V[kqdv + k, 0] -= t[3 * m + k]
        SD[o_s + 4 * k] += t[m + k] - 0.5 * Md
        SD[o_s + 4 * k + 3] += t[k]
        SD[o_sd + 4 * k] -= Mv
        SD[o_qa] += 0.5 * dk * SD[o_h + k]
        SD[o_qa + ax] -= dk * t[4 * m + k]
        for l in range(m):
            SD[o_qa] -= vk * fdat[oA + m * m + m * k + l] * qd[d0 + l]
            SD[o_qa + 3] -= vk * fdat[oA + m * k + l] * qd[d0 + l]
