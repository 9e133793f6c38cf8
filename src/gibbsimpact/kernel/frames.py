"""Position stage: the chain's frames T_i, their time derivatives and the world twists S_c.

Notation (docs/theory.md §2, §6): link i has the frame T_i (4x4),
material points p(x) = T_i r(x), r(x) = r0(x) + sum_l psihat_l(x) delta_l,
psihat_l = (e_{a_l} psi_l(x), 0) with a_l in {y, z} the bending axis of mode l.
The items are numbered as in the derivation of the kernel package's docstring
(a composite-body recursion in the 4x4 form, O(n^2)).

1. *Twists.* Every coordinate c enters the chain exactly once, through one
   local transform G_c (Trans(X), an axis rotation, or a link end E(delta)).
   Writing B_c for the frame just before G_c, every frame T_i downstream of it
   satisfies T_i = B_c G_c (rest independent of q_c), hence

       dT_i/dq_c = S_c T_i,    S_c = B_c (dG_c/dq_c G_c^-1) B_c^-1      (4x4)

   S_c is a world twist ([[skew(w), v], [0, 0]]), the same for every frame it
   moves. f_c denotes the first frame moved by c (0 .. n; frame n is the tip,
   which carries no mass): theta_i moves frames i.., delta_i moves i+1...
   T_i, Td_i and the qddot-free Tdd0_i come from the forward recursion
   T' = T G, Td' = Td G + T Gd, Tdd0' = Tdd0 G + 2 Td Gd + T Gdd0.

8. *Trees* (formulation §17, docs/theory.md §6.5.1). Link i starts again from its parent's frame
   (_restart) and applies A_p(x_a) (_end_step with the attachment table) and its joint, a constant
   rotation first (_constant_rotation; a weld turns by its fixed angle, with no twist). A parent's
   delta gets one twist per child (the first child's at B[ss + c], the others' at extra entries):
   "downstream" is "in the subtree" (layout._anc).

6. *Prismatic joints* (docs/theory.md §7.1, §7.6). A Pa carriage and a Pb guide are
   local transforms like the others (_pa_step, _pb_step): each coordinate they
   depend on gets its world twist.
7. *Two twists.* Under a Pa carriage on a flexible Pb link, the host's D moves
   frames i-1.. by S_D and frames i.. also by S2_D (the carriage follows the
   stretching deflection): S_D(j) = S_D + [j >= f2] S2_D (assemble.py sums every
   trace over the pieces).
"""

from __future__ import annotations

import math

import numpy as np

from .layout import (_CI, _F_BASE, _H, _LI, BASE_FIXED, BASE_FREE, END_GENERAL, END_RIGID, JOINT_PA, JOINT_PB, JOINT_R,
                     JOINT_WELD, _joint_field, _tree_tables, inline)
from .mat4 import _conjugate, _copy4, _mm, _mm_add, _put_skew, _zero4, rodrigues_directional
from .moments import _fs_tables


# -- forward recursion -----------------------------------------------------------

def _rot_step(B, w, si, axis, th, thd, vel):
    """T <- T Rot_axis(th) for T = B[w] (with Td = B[w+1], Tdd0 = B[w+2] when vel);
    B[si] = the world twist of th."""
    # S = T_prev skew(e_axis) T_prev^-1 = [[skew(w), p x w], [0, 0]],  w = R_prev e_axis
    w0 = B[w, 0, axis]
    w1 = B[w, 1, axis]
    w2 = B[w, 2, axis]
    p0 = B[w, 0, 3]
    p1 = B[w, 1, 3]
    p2 = B[w, 2, 3]
    _put_skew(B, si, w0, w1, w2)
    B[si, 0, 3] = p1 * w2 - p2 * w1
    B[si, 1, 3] = p2 * w0 - p0 * w2
    B[si, 2, 3] = p0 * w1 - p1 * w0
    for j in range(4):
        B[si, 3, j] = 0.0
    # G = Rot_axis(th) turns columns i, j of T (axis and origin stay):
    # X G -> (c x_i + s x_j, -s x_i + c x_j); X G1 -> (-s x_i + c x_j, -c x_i - s x_j); X G2 = -X G on i, j.
    # T' = T G;  Td' = Td G + thd T G1;  Tdd0' = Tdd0 G + 2 thd Td G1 + thd^2 T G2
    i = (axis + 1) % 3
    j = (axis + 2) % 3
    c = math.cos(th)
    s = math.sin(th)
    for r in range(4):
        ti = B[w, r, i]
        tj = B[w, r, j]
        tgi = c * ti + s * tj
        tgj = -s * ti + c * tj
        if vel:
            di = B[w + 1, r, i]
            dj = B[w + 1, r, j]
            ei = B[w + 2, r, i]
            ej = B[w + 2, r, j]
            B[w + 2, r, i] = c * ei + s * ej + 2.0 * thd * (-s * di + c * dj) - thd * thd * tgi
            B[w + 2, r, j] = -s * ei + c * ej + 2.0 * thd * (-c * di - s * dj) - thd * thd * tgj
            B[w + 1, r, i] = c * di + s * dj + thd * (-s * ti + c * tj)
            B[w + 1, r, j] = -s * di + c * dj + thd * (-c * ti - s * tj)
        B[w, r, i] = tgi
        B[w, r, j] = tgj


# Scratch of _end_step, relative to w: _E_V rows t, tdot, phi, phidot; R, dR, d2R; G, Gd, Gdd0;
# L; dR_k; _apply_local's T, Td, Tdd0 (3); u; Rodrigues scratch (3) and _conjugate's (w+19).
_E_V, _E_R, _E_DR, _E_D2R, _E_G, _E_L, _E_DRK, _E_TN, _E_U, _E_S = 3, 4, 5, 6, 7, 10, 11, 12, 15, 16


def _end_step(fdat, idat, link, q, qd, vel, B, w, ss, ends, at=-1):
    """T <- T E(delta) for the end of ``link`` (T, Td, Tdd0 = B[w], B[w+1], B[w+2]);
    B[ss + c] = the world twist of each end coordinate c of the link. With an attachment table
    at fdat[at:] (at >= 0: [x_a, t(x_a) (3 m), phi(x_a) (3 m), H(x_a) (m m, a stiffened link)]),
    A(x_a) of formulation §17 instead: the same transform with x_a, t(x_a), phi(x_a), H(x_a) in the
    place of l, end_t, end_phi, H(l).

    E = [[R(phi), t], [0, 1]], t = l e_x + end_t^T delta, phi = end_phi^T delta;
    Ed = [[dR[phidot], tdot], [0, 0]], Edd0 = [[d2R[phidot, phidot], 0], [0, 0]];
    local twist of delta_k: dE_k E^-1 = [[dR_k R^T, t_k - dR_k R^T t], [0, 0]].
    A stiffened link (formulation §15) adds u_f(l) = -1/2 delta^T H(l) delta to t along e_x, so
    t_k gains -(H(l) delta)_k e_x, tdot -(delta^T H(l) deltadot) e_x, Edd0's translation
    -(deltadot^T H(l) deltadot) e_x.
    ends: None in the variant for chains whose link ends are all rigid (see kernel).
    """
    base = _H + _CI * idat[1] + _LI * link
    m = idat[base]
    d0 = idat[base + 1]
    off = idat[base + 3]
    kind = idat[base + 4]
    l = fdat[off + 20]
    if at >= 0:
        l = fdat[at]
        kind = END_RIGID if m == 0 else END_GENERAL  # t(x_a), phi(x_a) need not vanish
    if ends is None or kind == END_RIGID:
        # E = Trans(l e_x): the origin column gains l times the x column.
        for r in range(4):
            B[w, r, 3] += l * B[w, r, 0]
            if vel:
                B[w + 1, r, 3] += l * B[w + 1, r, 0]
                B[w + 2, r, 3] += l * B[w + 2, r, 0]
        return
    o_t = off + 21 + 2 * m + 2 * m * m
    o_phi = o_t + 3 * m
    oHl = -1
    if idat[base + 6] >= 0:
        oHl = _fs_tables(fdat, idat[base + 6], m)[8]
    if at >= 0:
        o_t = at + 1
        o_phi = o_t + 3 * m
        if oHl >= 0:
            oHl = o_phi + 3 * m
    _end_transform(fdat, q, qd, B, w, l, m, d0, o_t, o_phi, oHl)
    _end_twists(fdat, q, B, w, ss + d0, m, d0, o_t, o_phi, oHl)
    _apply_local(B, w, w + _E_G, vel, w + _E_TN)


@inline
def _end_transform(fdat, q, qd, B, w, l, m, d0, o_t, o_phi, oHl):
    """E, Ed, Edd0 of a link end into B[w + _E_G .. w + _E_G + 2] (_end_step), from its m
    coordinates delta = q[d0:d0 + m] and their rates (end_t, end_phi at fdat[o_t], fdat[o_phi]):

        t = l e_x + end_t^T delta,  tdot = end_t^T deltadot,  phi = end_phi^T delta,
        phidot = end_phi^T deltadot;  E = [[R(phi), t]],  Ed = [[dR[phidot], tdot]],
        Edd0 = [[d2R[phidot, phidot], 0]]   (rodrigues_directional)
    plus, for a stiffened link (H(l) (m, m) at fdat[oHl:], oHl >= 0), u_f(l) = -1/2 delta^T H delta
    in t, -delta^T H deltadot in tdot and -deltadot^T H deltadot in Edd0's translation (along e_x).
    """
    kv = w + _E_V
    kG = w + _E_G
    for k in range(kv, w + _E_U + 1):
        _zero4(B, k)
    B[kv, 0, 0] = l
    for k in range(m):
        dk = q[d0 + k]
        vk = qd[d0 + k]
        for a in range(3):
            B[kv, 0, a] += fdat[o_t + 3 * k + a] * dk
            B[kv, 1, a] += fdat[o_t + 3 * k + a] * vk
            B[kv, 2, a] += fdat[o_phi + 3 * k + a] * dk
            B[kv, 3, a] += fdat[o_phi + 3 * k + a] * vk
    beta = 0.0
    if oHl >= 0:
        for k in range(m):
            for j in range(m):
                H = fdat[oHl + m * k + j]
                B[kv, 0, 0] -= 0.5 * H * q[d0 + k] * q[d0 + j]
                B[kv, 1, 0] -= H * q[d0 + k] * qd[d0 + j]
                beta += H * qd[d0 + k] * qd[d0 + j]
    B[kG, 3, 3] = 1.0
    rodrigues_directional(B, kv, 2, 3, 3, w + _E_R, w + _E_DR, w + _E_D2R, w + _E_S)
    if oHl >= 0:
        B[kG + 2, 0, 3] = -beta
    for a in range(3):
        B[kG, a, 3] = B[kv, 0, a]
        B[kG + 1, a, 3] = B[kv, 1, a]
        for b in range(3):
            B[kG, a, b] = B[w + _E_R, a, b]
            B[kG + 1, a, b] = B[w + _E_DR, a, b]
            B[kG + 2, a, b] = B[w + _E_D2R, a, b]


@inline
def _end_twists(fdat, q, B, w, s0, m, d0, o_t, o_phi, oHl):
    """World twists B[s0 + k] of the m end coordinates delta_k of a link (_end_step), from the
    frame before E (B[w]) and E's t, phi (rows 0, 2 of B[w + _E_V]):

        L_k = dE_k E^-1 = [[dR_k R^T, t_k - dR_k R^T t], [0, 0]],  S_k = T L_k T^-1
        (dR_k = dR[end_phi_k] at phi, t_k = end_t_k - [oHl >= 0] (H(l) delta)_k e_x (a stiffened
        link, _end_transform); S_k = 0 where both are zero)
    """
    kv = w + _E_V
    kR = w + _E_R
    kL = w + _E_L
    kdRk = w + _E_DRK
    ku = w + _E_U
    ks = w + _E_S
    for k in range(m):
        eta = 0.0
        if oHl >= 0:
            for j in range(m):
                eta += fdat[oHl + m * k + j] * q[d0 + j]
        zero = eta == 0.0
        for a in range(3):
            B[ku, 0, a] = fdat[o_phi + 3 * k + a]
            if fdat[o_phi + 3 * k + a] != 0.0 or fdat[o_t + 3 * k + a] != 0.0:
                zero = False
        if zero:
            _zero4(B, s0 + k)  # an interior FE node: E does not depend on it
            continue
        # phi and u side by side in the scratch slot ks + 3 (rows 0, 1)
        for a in range(3):
            B[ks + 3, 0, a] = B[kv, 2, a]
            B[ks + 3, 1, a] = B[ku, 0, a]
        rodrigues_directional(B, ks + 3, 0, 1, 1, kR, kdRk, w + _E_D2R, ks)
        # L = [[dR_k R^T, t_k - dR_k R^T t], [0, 0]]
        for a in range(3):
            for b in range(3):
                s = 0.0
                for c in range(3):
                    s += B[kdRk, a, c] * B[kR, b, c]
                B[kL, a, b] = s
        for a in range(3):
            s = fdat[o_t + 3 * k + a] - (eta if a == 0 else 0.0)
            for b in range(3):
                s -= B[kL, a, b] * B[kv, 0, b]
            B[kL, a, 3] = s
        _conjugate(B, w, kL, s0 + k, ks + 3)


def _apply_local(B, w, kG, vel, kTn):
    """T <- T G for the local transform G = B[kG] with Gd = B[kG+1], Gdd0 = B[kG+2]
    (T, Td, Tdd0 = B[w], B[w+1], B[w+2]; B[kTn .. kTn+2] scratch):
    T' = T G;  Td' = Td G + T Gd;  Tdd0' = Tdd0 G + 2 Td Gd + T Gdd0."""
    kGd = kG + 1
    kGdd = kG + 2
    kTdn = kTn + 1
    kTddn = kTn + 2
    _mm(B, w, kG, kTn)
    if vel:
        _mm(B, w + 1, kG, kTdn)
        _mm_add(B, w, kGd, 1.0, kTdn)
        _mm(B, w + 2, kG, kTddn)
        _mm_add(B, w + 1, kGd, 2.0, kTddn)
        _mm_add(B, w, kGdd, 1.0, kTddn)
        _copy4(B, kTdn, w + 1)
        _copy4(B, kTddn, w + 2)
    _copy4(B, kTn, w)


def _hermite_at(ne, length, x, out):
    """The (up to) four global Hermite functions of an n_e-element link that are non-zero at
    abscissa x [m] (docs/theory.md §4.1): out[r] = (local index k, psi_k, psi_k', psi_k'')
    for r = 0..3 (k = -1 for the clamped node's two). The element is the one containing x
    (the left one at a node: psi and psi' are continuous there, psi'' takes its left value)."""
    h = length / ne
    e = int(math.ceil(x / h))
    if e < 1:
        e = 1
    if e > ne:
        e = ne
    t = (x - (e - 1) * h) / h
    t2 = t * t
    t3 = t2 * t
    # H1, h H2, H3, h H4 and their x-derivatives (d/dx = (1/h) d/dt)
    out[0, 1] = 1.0 - 3.0 * t2 + 2.0 * t3
    out[1, 1] = h * (t - 2.0 * t2 + t3)
    out[2, 1] = 3.0 * t2 - 2.0 * t3
    out[3, 1] = h * (-t2 + t3)
    out[0, 2] = (-6.0 * t + 6.0 * t2) / h
    out[1, 2] = 1.0 - 4.0 * t + 3.0 * t2
    out[2, 2] = (6.0 * t - 6.0 * t2) / h
    out[3, 2] = -2.0 * t + 3.0 * t2
    out[0, 3] = (-6.0 + 12.0 * t) / (h * h)
    out[1, 3] = (-4.0 + 6.0 * t) / h
    out[2, 3] = (6.0 - 12.0 * t) / (h * h)
    out[3, 3] = (-2.0 + 6.0 * t) / h
    out[0, 0] = 2.0 * (e - 2)
    out[1, 0] = 2.0 * (e - 2) + 1.0
    out[2, 0] = 2.0 * (e - 1)
    out[3, 0] = 2.0 * (e - 1) + 1.0


def _host_shapes(fdat, idat, link, q, x, out):
    """The (up to) four host functions of link ``link`` non-zero at host abscissa x [m]:
    out[r] = (local index k, psi_k, d/dx, d2/dx2, d/dD, d2/dD2, d2/dxdD), r = 0..3.

    An FE host (docs/theory.md §4.1): psi_k(x), D-derivatives zero. A Pb host with
    protruding length D (10.3): psi_k = Phi_k(sigma; D) = D^a_k N_k(xi), sigma = x - (l - D),
    xi = sigma / D, and at fixed x (11, 12 item 2):
      d/dx = D^(a-1) N',  d2/dx2 = D^(a-2) N'',  d/dD = rho = D^(a-1) F,  F = a N + (1 - xi) N',
      d2/dD2 = D^(a-2) [(a - 1) F + (1 - xi) F'],  d2/dxdD = D^(a-2) F',  F' = (a - 1) N' + (1 - xi) N''.
    """
    N = idat[1]
    hb = _H + _CI * N + _LI * link
    hoff = idat[hb + 3]
    ne = int(_joint_field(fdat, idat, link, 2))
    hl = fdat[hoff + 20]
    if idat[hb + 5] != JOINT_PB:
        _hermite_at(ne, hl, x, out)
        for r in range(4):
            for c in range(4, 7):
                out[r, c] = 0.0
        return
    D = q[idat[hb + 2]]
    xi = (x - (hl - D)) / D
    _hermite_at(ne, 1.0, xi, out)
    for r in range(4):
        a = float(int(out[r, 0]) % 2)  # local index even: a deflection dof (a = 0), odd: a slope dof (a = 1)
        Nv = out[r, 1]
        N1 = out[r, 2]
        N2 = out[r, 3]
        pa = D if a == 1.0 else 1.0
        F = a * Nv + (1.0 - xi) * N1
        F1 = (a - 1.0) * N1 + (1.0 - xi) * N2
        out[r, 1] = pa * Nv
        out[r, 2] = pa / D * N1
        out[r, 3] = pa / (D * D) * N2
        out[r, 4] = pa / D * F
        out[r, 5] = pa / (D * D) * ((a - 1.0) * F + (1.0 - xi) * F1)
        out[r, 6] = pa / (D * D) * F1


# Scratch of _pa_step, relative to w: G, Gd, Gdd0 (3); L; _apply_local's T, Td, Tdd0 (3);
# _conjugate's.
_PA_G, _PA_L, _PA_TN, _PA_S = 3, 6, 7, 10


def _pa_step(fdat, idat, link, q, qd, vel, B, w, ss):
    """T <- T G for the carriage of joint ``link`` (docs/theory.md §7.3, §7.6);
    the world twists of d_i and of every host coordinate into B[ss + c] (and, on a
    flexible Pb host with protruding length D = d_(i-1), D's second twist into B[ss + N + D's index]).

    G = Trans(d, vbar) Rz(phibar + gamma), vbar = sum b_k delta_k, phibar = sum a_k delta_k,
    b_k = [psi_k(d + c) + psi_k(d - c)] / 2,  a_k = [psi_k(d + c) - psi_k(d - c)] / (2 c)
    (delta: the host's coordinates; zero on the base rail and on a rigid host; psi_k depends
    on D too on a Pb host, _host_shapes). On a stiffened host the x of t is d + ubar, ubar the mean
    of the foreshortening u_f(d +- c) (formulation §15, _carriage_foreshortening): t_d and t_k gain
    ubar_d, ubar_k along x, tdot ubardot, Gdd0's translation ubar0dd. With theta = phibar + gamma, t = (d, vbar, 0),
    Z = skew(e_z) and subscripts for partial derivatives (u = d, D):
      local twist of q_c:  L_c = dG/dq_c G^-1 = [[Z theta_c, t_c - theta_c Z t], [0, 0]]
        d: theta_d = phibar_d, t_d = (1, vbar_d, 0);  D: theta_D = phibar_D, t_D = (0, vbar_D, 0);
        delta_k: theta_k = a_k, t_k = (0, b_k, 0)
      Gd   = [[R' thetadot, tdot], [0, 0]],  thetadot = sum_u phibar_u udot + sum a_k deltadot_k,
             tdot = (ddot, sum_u vbar_u udot + sum b_k deltadot_k, 0)
      Gdd0 = [[R'' thetadot^2 + R' theta0dd, (0, vbar0dd, 0)], [0, 0]],
             theta0dd = sum_uv phibar_uv udot vdot + 2 sum_u udot sum a_k,u deltadot_k (vbar0dd alike)
    """
    N = idat[1]
    jd = idat[_H + _CI * N + _LI * link + 2]
    gamma = _joint_field(fdat, idat, link, 0)
    c = _joint_field(fdat, idat, link, 1)
    d = q[jd]
    dd = qd[jd]
    # sums over the host coordinates: S[0] = vbar-type (b), S[1] = phibar-type (a); columns:
    # 0 value, 1 _d, 2 _dd, 3 _D, 4 _DD, 5 _dD, then with deltadot: 6 value, 7 _d, 8 _D
    S = np.zeros((2, 9))
    ab = np.zeros((2, 4, 7))
    mh, h0, jD, Ddot = _host_sums(fdat, idat, link, q, qd, d, c, B, ss, S, ab)
    vb = S[0, 0]
    # a stiffened host's foreshortening (formulation §15): U = (ubar, ubar_d, ubardot, ubar0dd), ubk = ubar_k
    U = np.zeros(4)
    ubk = np.zeros(mh)
    if mh > 0 and idat[_H + _CI * N + _LI * (link - 1) + 6] >= 0:
        _carriage_foreshortening(fdat, idat, link - 1, q, qd, d, c, dd, h0, mh, ab, U, ubk)
    dx = d + U[0]
    # first and qddot-free second time derivatives of theta and vbar
    thd = S[1, 1] * dd + S[1, 3] * Ddot + S[1, 6]
    vbd = S[0, 1] * dd + S[0, 3] * Ddot + S[0, 6]
    th0dd = (S[1, 2] * dd * dd + 2.0 * S[1, 5] * dd * Ddot + S[1, 4] * Ddot * Ddot
             + 2.0 * dd * S[1, 7] + 2.0 * Ddot * S[1, 8])
    vb0dd = (S[0, 2] * dd * dd + 2.0 * S[0, 5] * dd * Ddot + S[0, 4] * Ddot * Ddot
             + 2.0 * dd * S[0, 7] + 2.0 * Ddot * S[0, 8])
    _pa_transform(B, w + _PA_G, S[1, 0] + gamma, dx, dd + U[2], vb, thd, vbd, th0dd, vb0dd, vel)
    B[w + _PA_G + 2, 0, 3] = U[3]
    # Twists, from the frame before G: L = [[Z theta_q, t_q - theta_q Z t], [0, 0]], Z t = (-vbar, d + ubar, 0)
    _carriage_twist(B, w, ss + jd, S[1, 1], 1.0 + U[1] + S[1, 1] * vb, S[0, 1] - S[1, 1] * dx)
    if jD >= 0:
        _carriage_twist(B, w, ss + N + jD, S[1, 3], S[1, 3] * vb, S[0, 3] - S[1, 3] * dx)
    _host_twists(B, w, ss + h0, mh, ab, c, vb, dx, ubk)
    _apply_local(B, w, w + _PA_G, vel, w + _PA_TN)


@inline
def _host_sums(fdat, idat, link, q, qd, d, c, B, ss, S, ab):
    """The host sums of the carriage of joint ``link`` at d [m] with half-length c [m] (_pa_step):

        S[0, :] = sums of b_k-type terms,  S[1, :] = sums of a_k-type terms (_pa_step's columns),
        b_k = [psi_k(d + c) + psi_k(d - c)] / 2,  a_k = [psi_k(d + c) - psi_k(d - c)] / (2 c)

    ab[side] (4, 7): _host_shapes at d + c (side 0) and d - c (side 1). Zeroes the twists of the
    host's mh coordinates (B[ss + h0 + k]). Returns (mh, h0, jD, Ddot): the host's number of
    coordinates and the first one's index, its protruding length's index (-1 unless a flexible
    Pb host) and rate Ddot [m/s].
    """
    N = idat[1]
    mh = 0
    h0 = 0
    jD = -1
    Ddot = 0.0
    if link > 0:
        hb = _H + _CI * N + _LI * (link - 1)
        mh = idat[hb]
        h0 = idat[hb + 1]
        if idat[hb + 5] == JOINT_PB and mh > 0:
            jD = idat[hb + 2]
            Ddot = qd[jD]
        for k in range(mh):
            _zero4(B, ss + h0 + k)
    if mh > 0:
        # the four host functions non-zero at d + c (side 0) and at d - c (side 1)
        _host_shapes(fdat, idat, link - 1, q, d + c, ab[0])
        _host_shapes(fdat, idat, link - 1, q, d - c, ab[1])
        for side in range(2):
            sg = 1.0 if side == 0 else -1.0
            for r in range(4):
                k = int(ab[side, r, 0])
                if k < 0:
                    continue
                x = q[h0 + k]
                y = qd[h0 + k]
                for col in range(6):
                    S[0, col] += 0.5 * ab[side, r, 1 + col] * x
                    S[1, col] += sg * ab[side, r, 1 + col] * x / (2.0 * c)
                S[0, 6] += 0.5 * ab[side, r, 1] * y
                S[1, 6] += sg * ab[side, r, 1] * y / (2.0 * c)
                S[0, 7] += 0.5 * ab[side, r, 2] * y
                S[1, 7] += sg * ab[side, r, 2] * y / (2.0 * c)
                S[0, 8] += 0.5 * ab[side, r, 4] * y
                S[1, 8] += sg * ab[side, r, 4] * y / (2.0 * c)
    return mh, h0, jD, Ddot


# 3-point Gauss-Legendre on [0, 1]: exact for the degree-4 products psi_k' psi_l' of one Hermite element
_G3_T = (0.5 - 0.5 * math.sqrt(0.6), 0.5, 0.5 + 0.5 * math.sqrt(0.6))
_G3_W = (5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0)


@inline
def _carriage_foreshortening(fdat, idat, host, q, qd, d, c, dd, h0, mh, ab, U, ubk):
    """The foreshortening of a carriage at d [m] (half-length c [m], rate dd [m/s]) on a stiffened
    finite-element host (formulation §15): its x in the host frame is d + ubar,

        ubar = [u_f(d + c) + u_f(d - c)] / 2,  u_f(x) = -1/2 delta^T H(x) delta = -1/2 int_0^x v'^2,
        ubar_k = -[(H(d + c) delta)_k + (H(d - c) delta)_k] / 2,   ubar_d = -[v'(d + c)^2 + v'(d - c)^2] / 4,
        ubardot = ubar_d ddot + sum_k ubar_k deltadot_k,
        ubar0dd = sum_x [-v' v'' ddot^2 - 2 ddot v' vdot' - deltadot^T H deltadot](x) / 2   (x = d +- c)

    (H'(x) = psi' psi'^T, so d/dd of u_f(x) is -1/2 v'(x)^2). Into U = (ubar, ubar_d, ubardot,
    ubar0dd) (4) and ubk = ubar_k (mh, host coordinates from q[h0]); ab[side] = _host_shapes at
    d + c (side 0) and d - c (side 1). The integrals run over the host's elements with an exact
    3-point Gauss rule, so the model stays the exact holonomic system.
    """
    N = idat[1]
    ne = int(_joint_field(fdat, idat, host, 2))
    hl = fdat[idat[_H + _CI * N + _LI * host + 3] + 20]
    h = hl / ne
    sh = np.zeros((4, 4))
    for side in range(2):
        x = d + c if side == 0 else d - c
        v1 = 0.0
        v2 = 0.0
        vd1 = 0.0
        for r in range(4):
            k = int(ab[side, r, 0])
            if k >= 0:
                v1 += ab[side, r, 2] * q[h0 + k]
                v2 += ab[side, r, 3] * q[h0 + k]
                vd1 += ab[side, r, 2] * qd[h0 + k]
        A = 0.0  # int_0^x v'^2
        Z = 0.0  # int_0^x vdot'^2
        e = 0
        while e < ne and e * h < x:
            L = min(h, x - e * h)
            for g in range(3):
                _hermite_at(ne, hl, e * h + _G3_T[g] * L, sh)
                p1 = 0.0
                pd1 = 0.0
                for r in range(4):
                    k = int(sh[r, 0])
                    if k >= 0:
                        p1 += sh[r, 2] * q[h0 + k]
                        pd1 += sh[r, 2] * qd[h0 + k]
                W = _G3_W[g] * L
                A += W * p1 * p1
                Z += W * pd1 * pd1
                for r in range(4):
                    k = int(sh[r, 0])
                    if k >= 0:
                        ubk[k] -= 0.5 * W * sh[r, 2] * p1
            e += 1
        U[0] -= 0.25 * A
        U[1] -= 0.25 * v1 * v1
        U[3] += 0.5 * (-v1 * v2 * dd * dd - 2.0 * dd * v1 * vd1 - Z)
    U[2] = U[1] * dd
    for k in range(mh):
        U[2] += ubk[k] * qd[h0 + k]


@inline
def _pa_transform(B, kG, th, d, dd, vb, thd, vbd, th0dd, vb0dd, vel):
    """The carriage's G, Gd, Gdd0 into B[kG], B[kG+1], B[kG+2] (_pa_step), theta = th [rad]:

        G = [[Rz(theta), (d, vbar, 0)]],  Gd = [[R' thetadot, (ddot, vbardot, 0)]],
        Gdd0 = [[R'' thetadot^2 + R' theta0dd, (0, vbar0dd, 0)]]
        (R' = [[-s, -c], [c, -s]], R'' = -R in the x-y block)
    """
    ct = math.cos(th)
    st = math.sin(th)
    for k in range(kG, kG + 3):
        _zero4(B, k)
    B[kG, 0, 0] = ct
    B[kG, 0, 1] = -st
    B[kG, 1, 0] = st
    B[kG, 1, 1] = ct
    B[kG, 2, 2] = 1.0
    B[kG, 3, 3] = 1.0
    B[kG, 0, 3] = d
    B[kG, 1, 3] = vb
    if vel:
        B[kG + 1, 0, 0] = -st * thd
        B[kG + 1, 0, 1] = -ct * thd
        B[kG + 1, 1, 0] = ct * thd
        B[kG + 1, 1, 1] = -st * thd
        B[kG + 1, 0, 3] = dd
        B[kG + 1, 1, 3] = vbd
        B[kG + 2, 0, 0] = -ct * thd * thd - st * th0dd
        B[kG + 2, 0, 1] = st * thd * thd - ct * th0dd
        B[kG + 2, 1, 0] = -st * thd * thd + ct * th0dd
        B[kG + 2, 1, 1] = -ct * thd * thd - st * th0dd
        B[kG + 2, 1, 3] = vb0dd


def _carriage_twist(B, w, o, th_q, lx, ly):
    """B[o] = T L T^-1 (T = B[w], the frame before the carriage) for the local twist

        L = [[Z theta_q, (lx, ly, 0)], [0, 0]],  (lx, ly) = (t_q - theta_q Z t)[:2]  (_pa_step)
    """
    kL = w + _PA_L
    _zero4(B, kL)
    B[kL, 0, 1] = -th_q
    B[kL, 1, 0] = th_q
    B[kL, 0, 3] = lx
    B[kL, 1, 3] = ly
    _conjugate(B, w, kL, o, w + _PA_S)


@inline
def _host_twists(B, w, s0, mh, ab, c, vb, d, ubk):
    """World twists B[s0 + k] of the host coordinates delta_k that move the carriage (_pa_step):
    theta_k = a_k, t_k = (ubar_k, b_k, 0), so L_k = [[Z a_k, (ubar_k + a_k vbar, b_k - a_k d, 0)], [0, 0]]
    (d: the carriage's x in the host frame [m], d + ubar on a stiffened host; ubk[k] = ubar_k [m], zero
    on a linear one)."""
    for k in range(mh):
        ak = 0.0
        bk = 0.0
        hit = ubk[k] != 0.0
        for side in range(2):
            sg = 1.0 if side == 0 else -1.0
            for r in range(4):
                if int(ab[side, r, 0]) == k:
                    ak += sg * ab[side, r, 1] / (2.0 * c)
                    bk += 0.5 * ab[side, r, 1]
                    hit = True
        if not hit:
            continue
        _carriage_twist(B, w, s0 + k, ak, ak * vb + ubk[k], bk - ak * d)


def _pb_step(fdat, idat, link, q, qd, vel, B, w, ss):
    """T <- T Rz(gamma) Trans(d - l, 0) for the guide of joint ``link`` (docs/theory.md §7.4);
    the world twist of d into B[ss + d]: a translation along the guide axis,
    S_d = [[0, x-axis of T Rz(gamma)], [0, 0]].
    Td' = Td + ddot x-column in the origin, Tdd0' = Tdd0 + 2 ddot Td's x-column (G constant in the rotation)."""
    N = idat[1]
    base = _H + _CI * N + _LI * link
    jd = idat[base + 2]
    gamma = _joint_field(fdat, idat, link, 0)
    l = fdat[idat[base + 3] + 20]
    _rot_step(B, w, w + 3, 2, gamma, 0.0, vel)
    _zero4(B, ss + jd)
    for a in range(3):
        B[ss + jd, a, 3] = B[w, a, 0]
    a = q[jd] - l
    dd = qd[jd]
    for r in range(4):
        B[w, r, 3] += a * B[w, r, 0]
        if vel:
            B[w + 2, r, 3] += a * B[w + 2, r, 0] + 2.0 * dd * B[w + 1, r, 0]
            B[w + 1, r, 3] += a * B[w + 1, r, 0] + dd * B[w, r, 0]


def _restart(fdat, B, w, ts, tds, tdds, p):
    """The running frame T, Td, Tdd0 (B[w], B[w+1], B[w+2]) := frame p's (B[ts + p], ...), or the
    fixed base's T_0 (fdat) at rest when p < 0: a link whose parent is not the link before it."""
    if p < 0:
        _zero4(B, w + 1)
        _zero4(B, w + 2)
        for a in range(4):
            for b in range(4):
                B[w, a, b] = fdat[_F_BASE + 4 * a + b]
        return
    _copy4(B, ts + p, w)
    _copy4(B, tds + p, w + 1)
    _copy4(B, tdds + p, w + 2)


def _constant_rotation(fdat, o, B, w, vel):
    """T <- T Rot(R) for a joint's constant rotation R (3, 3) at fdat[o:] (row-major), applied
    before its Rz (formulation §17): T, Td, Tdd0 (B[w], B[w+1], B[w+2]) each times R (R constant)."""
    for k in range(w, w + (3 if vel else 1)):
        for r in range(4):
            x0 = B[k, r, 0]
            x1 = B[k, r, 1]
            x2 = B[k, r, 2]
            for b in range(3):
                B[k, r, b] = x0 * fdat[o + b] + x1 * fdat[o + 3 + b] + x2 * fdat[o + 6 + b]


def chain_frames(fdat, idat, q, qd, vel, B, ws, pris, ends):
    """Position stage: the frames of the n links and of the tip into B[ts + i], i = 0 .. n (and
    their time derivatives into B[tds + i], B[tdds + i] when vel); the world twists into B[ss + c].

    ts, tds, tdds, ss and the work space B[w .. w + _W_SIZE) from work_slots ws (layout.py).
    pris, ends: the variant (compile.py).
    """
    ts, tds, tdds, ss, w, PS, PVS, PIC, FC, XS, MR, MRD, QV, QDV, MUC, YY, EE = ws
    n = idat[0]
    N = idat[1]
    _zero4(B, w + 1)
    _zero4(B, w + 2)
    for a in range(4):
        for b in range(4):
            B[w, a, b] = fdat[_F_BASE + 4 * a + b]
    if idat[2] != BASE_FIXED:
        # Trans(X): twists e_a in the origin column; then Rx(theta_-1), Ry(theta_0) (spatial base).
        nx = 3 if idat[2] == BASE_FREE else 2
        for a in range(nx):
            B[w, a, 3] = q[a]
            if vel:
                B[w + 1, a, 3] = qd[a]
            _zero4(B, ss + a)
            B[ss + a, a, 3] = 1.0
        if idat[2] == BASE_FREE:
            for c in range(3, 5):
                _rot_step(B, w, ss + c, idat[_H + _CI * c + 1], q[c], qd[c], vel)
    tt = _tree_tables(idat)
    for i in range(n):
        base = _H + _CI * N + _LI * i
        th = idat[base + 2]
        jk = idat[base + 5]
        p = idat[tt + i]
        if i > 0 and p != i - 1:  # a tree (formulation §17): start again from the parent's frame
            _restart(fdat, B, w, ts, tds, tdds, p)
        # R and Pb joints sit at the host's tip, or at x_a on the parent: the host's E_p or A_p(x_a)
        # first (docs/theory.md §7.1, formulation §17).
        if p >= 0 and jk != JOINT_PA:
            _end_step(fdat, idat, p, q, qd, vel, B, w, ss + idat[base + 9], ends, idat[base + 8])
        if idat[base + 7] >= 0:
            _constant_rotation(fdat, idat[base + 7], B, w, vel)
        if jk == JOINT_WELD:
            _rot_step(B, w, w + 3, 2, _joint_field(fdat, idat, i, 0), 0.0, vel)
        elif pris is None or jk == JOINT_R:
            _rot_step(B, w, ss + th, idat[_H + _CI * th + 1], q[th], qd[th], vel)
        elif jk == JOINT_PA:
            _pa_step(fdat, idat, i, q, qd, vel, B, w, ss)
        else:
            _pb_step(fdat, idat, i, q, qd, vel, B, w, ss)
        _copy4(B, w, ts + i)
        if vel:
            _copy4(B, w + 1, tds + i)
            _copy4(B, w + 2, tdds + i)
    if n > 0:
        _end_step(fdat, idat, n - 1, q, qd, vel, B, w, ss, ends)
    _copy4(B, w, ts + n)
    if vel:
        _copy4(B, w + 1, tds + n)
        _copy4(B, w + 2, tdds + n)
