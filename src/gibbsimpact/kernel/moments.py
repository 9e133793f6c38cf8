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

from .layout import _CI, _F_JOINT, _GAUSS, _H, _LI, JOINT_PB


def _sd_stride(mmax):
    """Per-link stride of the per-call shape data SD of Pb links (_pb_moments)."""
    ms = mmax + 1
    return 2 * ms + ms * ms + 4 + ms + mmax + 2


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
    N = idat[1]
    base = _H + _CI * N + _LI * link
    m = idat[base]
    d0 = idat[base + 1]
    jd = idat[base + 2]
    off = idat[base + 3]
    ms = m + 1
    o_c1 = o + ms
    o_M = o_c1 + ms
    o_qa = o_M + ms * ms
    o_ha = o_qa + 4
    o_K = o_ha + ms
    o_dK = o_K + m
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
    oxi = ox + _F_JOINT
    ow = oxi + G
    oN = ow + G
    oN1 = oN + G * m
    oN2 = oN1 + G * m
    oKu = oN2 + G * m
    oa = oKu + m * m
    d = q[jd]
    dd = qd[jd]
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
    """Body moments of ``link`` at delta, deltadot; returns (ms, src, o_cx): the number of own
    shapes and where their moments cx, c1, Mpsi live (fdat, or SD[so:] for a Pb link).

    B[kP] = P = P0 + Cd^T + sum_l delta_l Q_l (rotary pseudo-inertia included),
    V[kmr] = m_r, V[kqv + l] = q_l = c0_l + sum_k delta_k Mpsi_kl e_{a_k}, c0_l = (cx_l, 0, 0, c1_l),
    V[kqdv + l] = sum_k deltadot_k Mpsi_kl e_{a_k}, B[kPv] = Pv = sum_l deltadot_l q_l e_{a_l}^T
    (over the own shapes; a Pb link adds chi with velocity coefficient ddot, _pb_moments).
    """
    N = idat[1]
    base = _H + _CI * N + _LI * link
    m = idat[base]
    off = idat[base + 3]
    if pris is not None and idat[base + 5] == JOINT_PB:
        _pb_moments(fdat, idat, link, q, qd, SD, so)
        src = SD
        o_cx = so
        ms = m + 1
    else:
        src = fdat
        o_cx = off + 21
        ms = m
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
    return ms, src, o_cx
