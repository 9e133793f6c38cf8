"""The compiled kernel: kinematics, Gibbs-Appell dynamics, energies, momentum.

One source, compiled with numba (``njit``, explicit signatures, on-disk
cache). With ``NUMBA_DISABLE_JIT=1`` the same functions run as plain Python
(slow; the tests use it to check the compiled code against itself). The
public wrappers are in ``kinematics.py`` and ``dynamics.py``.

Derivation: a composite-body recursion in the 4x4 form (O(n^2))
--------------------------------------------------------------------------

Notation (docs/theory.md §2, §6): link i has the frame T_i (4x4),
material points p(x) = T_i r(x), r(x) = r0(x) + sum_l psihat_l(x) delta_l,
psihat_l = (e_{a_l} psi_l(x), 0) with a_l in {y, z} the bending axis of mode l.

1. *Twists.* Every coordinate c enters the chain exactly once, through one
   local transform G_c (Trans(X), an axis rotation, or a link end E(delta)).
   Writing B_c for the frame just before G_c, every frame T_i downstream of it
   satisfies T_i = B_c G_c (rest independent of q_c), hence

       dT_i/dq_c = S_c T_i,    S_c = B_c (dG_c/dq_c G_c^-1) B_c^-1      (4x4)

   S_c is a world twist ([[skew(w), v], [0, 0]]), the same for every frame it
   moves. f_c denotes the first frame moved by c (0 .. n; frame n is the tip,
   which carries no mass): theta_i moves frames i.., delta_i moves i+1...

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

   T_i, Td_i and the qddot-free Tdd0_i come from the forward recursion
   T' = T G, Td' = Td G + T Gd, Tdd0' = Tdd0 G + 2 Td Gd + T Gdd0.

4. *Potential.* V = -g~ . sum_i T_i m_r,i + 1/2 delta^T K delta, so

       dV_c = -g~ . (S_c mu^c_{f_c}) + [own] (-c1_c g~ . e_c + (K delta)_c)
       mu_i = T_i m_r,i,  mu^c_j = sum_{i >= j} mu_i,  c1_l = int mu psi_l.

5. *Rotary inertia* J = l diag(j_x, j_y, j_z) about the link frame enters as the
   pseudo-inertia Sigma = tr(J)/2 I - J added to P_i[:3, :3]: a body with
   second moment Sigma has angular momentum J omega and Gibbs function
   1/2 alpha.J alpha + alpha.(omega x J omega), the term of docs/theory.md §6 (Gibbs-Appell of a rigid body is linear in its pseudo-inertia).

6. *Prismatic joints* (docs/theory.md §7.1, §7.6). A Pa carriage and a Pb guide are
   local transforms like the others (_pa_step, _pb_step): each coordinate they
   depend on gets its world twist. A Pb link's d also deforms the link's own
   material (chi = dv/dd at fixed x): d is then an *own* coordinate of that link
   (o_d = i, shape chi, velocity coefficient ddot) as well as a twist coordinate
   (f_d = i), and for every pair

       M_ab = tr(S_a Pi^c_max(f_a, f_b) S_b^T) + [o_b >= 0, f_a <= o_b] e_b.(S_a y_b)
              + [o_a >= 0, f_b <= o_a] e_a.(S_b y_a) + [o_a = o_b] int mu phi_a phi_b

   (for modes f = o + 1, so this is item 2). The Pb link's moments depend on d
   and come from an exact Gauss rule per call (_pb_moments), with the
   convective acceleration r0dd = e_y a0 adding int mu r a0 to F and
   int mu phi_l a0 to the own part of h.
7. *Two twists.* Under a Pa carriage on a flexible Pb link, the host's D moves
   frames i-1.. by S_D and frames i.. also by S2_D (the carriage follows the
   stretching deflection): S_D(j) = S_D + [j >= f2] S2_D, and every trace above
   is summed over the pieces, each with the composite of its later start frame.

Kinetic energy per link: 1/2 tr(Td P Td^T) + tr(Td Pv T^T) + 1/2 int mu vdot^2.

Data layout (``pack``): one float64 and one int64 array per model, so that a
call passes few arguments (numba's dispatch cost grows with their number).
"""

from __future__ import annotations

import functools
import math
import os
import sys
import threading
import time

import numpy as np

# -- data layout --------------------------------------------------------------
# idat: [n, N, base kind, X, prismatic (0/1), general ends (0/1), 0, 0] + per coordinate (N rows of _CI ints)
#       (X: extra contact points, the tips of host links whose child joint is prismatic)
#       + per link (n rows of _LI ints)
_H = 8
_CI = 6  # kind, axis, first frame, own link (-1), local index, first frame of a second twist (-1)
_LI = 6  # m, first delta index in q, joint variable index in q, offset in fdat, end kind, joint kind
KIND_TRANSLATION, KIND_ROTATION, KIND_MODE, KIND_PA, KIND_PB = 0, 1, 2, 3, 4
END_RIGID, END_GENERAL = 0, 2  # a link end fixed to its frame, or moved by its modes
JOINT_R, JOINT_PA, JOINT_PB = 0, 1, 2
BASE_FIXED, BASE_FREE, BASE_PLANAR = 0, 1, 2
# fdat: base T0 (16), g~ (4), then per link: P0+Sigma (16), m_r0 (4), length,
#       cx (m), c1 (m), Mpsi (m*m), K (m*m), end_t (3m), end_phi (3m),
#       gamma, c, n_e, mu, EI (_F_JOINT values: the joint and the constants of a Pb link),
#       and for a Pb link its unit-interval tables (_pb_moments): xi (G), w (G),
#       N (G m), N' (G m), N'' (G m), Kunit (m m), a (m), G = 4 n_e Gauss points.
_F_BASE, _F_G, _F_LINKS = 0, 16, 20
_F_JOINT = 5
_GAUSS = 4  # Gauss-Legendre points per (stretching) element: exact for degree <= 7


# -- small 4x4 helpers ----------------------------------------------------------------
# Every 4x4 matrix of a kernel call lives in one array B (k, 4, 4) and is named by
# its index k: passing or slicing arrays costs a reference count per array in
# numba (~25 ns), more than a 4x4 product; an index costs nothing.

def _mm(B, a, b, o):
    """B[o] = B[a] @ B[b] (o differs from a and b)."""
    for i in range(4):
        for j in range(4):
            s = 0.0
            for k in range(4):
                s += B[a, i, k] * B[b, k, j]
            B[o, i, j] = s


def _mm_add(B, a, b, alpha, o):
    """B[o] += alpha B[a] @ B[b]."""
    for i in range(4):
        for j in range(4):
            s = 0.0
            for k in range(4):
                s += B[a, i, k] * B[b, k, j]
            B[o, i, j] += alpha * s


def _mmt(B, a, b, o):
    """B[o] = B[a] @ B[b]^T."""
    for i in range(4):
        for j in range(4):
            s = 0.0
            for k in range(4):
                s += B[a, i, k] * B[b, j, k]
            B[o, i, j] = s


def _copy4(B, src, dst):
    """B[dst] = B[src]."""
    for i in range(4):
        for j in range(4):
            B[dst, i, j] = B[src, i, j]


def _zero4(B, o):
    for i in range(4):
        for j in range(4):
            B[o, i, j] = 0.0


def _conjugate(B, t, l, o, tl):
    """B[o] = B[t] B[l] B[t]^-1 for a homogeneous transform B[t] and a twist B[l] (last row 0).

    T L = [[R w, R v], [0, 0]],  T^-1 = [[R^T, -R^T p], [0, 1]]; B[tl] is scratch.
    """
    _mm(B, t, l, tl)
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += B[tl, i, k] * B[t, j, k]
            B[o, i, j] = s
    for i in range(3):
        s = B[tl, i, 3]
        for j in range(3):
            s -= B[o, i, j] * B[t, j, 3]
        B[o, i, 3] = s
    for j in range(4):
        B[o, 3, j] = 0.0


# -- Rodrigues --------------------------------------------------------------------
_SERIES = 14
_SERIES_A = np.array([(-1.0) ** k / np.prod(np.arange(1, 2 * k + 2, dtype=float)) for k in range(_SERIES)])
_SERIES_B = np.array([(-1.0) ** k / np.prod(np.arange(1, 2 * k + 3, dtype=float)) for k in range(_SERIES)])


def rodrigues_coefficients(s):
    """a = sin t / t, b = (1 - cos t)/t^2 (t = sqrt s) and their s-derivatives.

    Returns (a, a_s, a_ss, b, b_s, b_ss). A power series for s < 1 (no 0/0),
    closed forms with a_s = (cos t - a)/(2s), b_s = (a - 2b)/(2s),
    a_ss = (-a/2 - 3 a_s)/(2s), b_ss = (a_s - 4 b_s)/(2s) otherwise.
    """
    if s < 1.0:
        # 14 terms of the alternating series; s < 1, so they converge to round-off.
        a = 0.0
        a1 = 0.0
        a2 = 0.0
        b = 0.0
        b1 = 0.0
        b2 = 0.0
        p = 1.0
        for k in range(_SERIES):
            a += _SERIES_A[k] * p
            b += _SERIES_B[k] * p
            if k + 1 < _SERIES:
                a1 += (k + 1) * _SERIES_A[k + 1] * p
                b1 += (k + 1) * _SERIES_B[k + 1] * p
            if k + 2 < _SERIES:
                a2 += (k + 2) * (k + 1) * _SERIES_A[k + 2] * p
                b2 += (k + 2) * (k + 1) * _SERIES_B[k + 2] * p
            p *= s
        return a, a1, a2, b, b1, b2
    t = math.sqrt(s)
    a = math.sin(t) / t
    b = (1.0 - math.cos(t)) / s
    a_s = (math.cos(t) - a) / (2.0 * s)
    b_s = (a - 2.0 * b) / (2.0 * s)
    a_ss = (-0.5 * a - 3.0 * a_s) / (2.0 * s)
    b_ss = (a_s - 4.0 * b_s) / (2.0 * s)
    return a, a_s, a_ss, b, b_s, b_ss


def _skew3(B, kv, row, o):
    """B[o][:3, :3] = skew(B[kv, row, :3])."""
    _put_skew(B, o, B[kv, row, 0], B[kv, row, 1], B[kv, row, 2])


def _put_skew(B, o, v0, v1, v2):
    """B[o][:3, :3] = skew(v)."""
    B[o, 0, 0] = 0.0
    B[o, 0, 1] = -v2
    B[o, 0, 2] = v1
    B[o, 1, 0] = v2
    B[o, 1, 1] = 0.0
    B[o, 1, 2] = -v0
    B[o, 2, 0] = -v1
    B[o, 2, 1] = v0
    B[o, 2, 2] = 0.0


def rodrigues_directional(B, kv, rphi, ru, rw, kR, kdR, kd2R, ks):
    """R(phi), dR[u] and d2R[w, w] into the upper-left 3x3 of B[kR], B[kdR], B[kd2R].

    phi, u, w are the rows rphi, ru, rw of B[kv] (first three entries); B[ks],
    B[ks+1], B[ks+2] are scratch. R = I + a K + b K^2, K = skew(phi); with
    s = phi.phi, Ku = skew(u), s' = 2 phi.u, s'' = 2 u.u (along u):
      dR[u]    = a_s s' K + a Ku + b_s s' K^2 + b (Ku K + K Ku)
      d2R[u,u] = (a_ss s'^2 + a_s s'') K + 2 a_s s' Ku + (b_ss s'^2 + b_s s'') K^2
                 + 2 b_s s' (Ku K + K Ku) + 2 b Ku^2
    """
    p0 = B[kv, rphi, 0]
    p1 = B[kv, rphi, 1]
    p2 = B[kv, rphi, 2]
    a, a_s, a_ss, b, b_s, b_ss = rodrigues_coefficients(p0 * p0 + p1 * p1 + p2 * p2)
    kK = ks
    kK2 = ks + 1
    kKv = ks + 2
    _skew3(B, kv, rphi, kK)
    for i in range(3):
        for j in range(3):
            t = 0.0
            for k in range(3):
                t += B[kK, i, k] * B[kK, k, j]
            B[kK2, i, j] = t
    for i in range(3):
        for j in range(3):
            B[kR, i, j] = a * B[kK, i, j] + b * B[kK2, i, j]
        B[kR, i, i] += 1.0
    for which in range(2):
        row = ru if which == 0 else rw
        _skew3(B, kv, row, kKv)
        v0 = B[kv, row, 0]
        v1 = B[kv, row, 1]
        v2 = B[kv, row, 2]
        s1 = 2.0 * (p0 * v0 + p1 * v1 + p2 * v2)
        s2 = 2.0 * (v0 * v0 + v1 * v1 + v2 * v2)
        for i in range(3):
            for j in range(3):
                sym = 0.0
                vv = 0.0
                for k in range(3):
                    sym += B[kKv, i, k] * B[kK, k, j] + B[kK, i, k] * B[kKv, k, j]
                    vv += B[kKv, i, k] * B[kKv, k, j]
                if which == 0:
                    B[kdR, i, j] = (a_s * s1 * B[kK, i, j] + a * B[kKv, i, j] + b_s * s1 * B[kK2, i, j]
                                    + b * sym)
                else:
                    B[kd2R, i, j] = ((a_ss * s1 * s1 + a_s * s2) * B[kK, i, j] + 2.0 * a_s * s1 * B[kKv, i, j]
                                     + (b_ss * s1 * s1 + b_s * s2) * B[kK2, i, j] + 2.0 * b_s * s1 * sym
                                     + 2.0 * b * vv)


# -- forward recursion -----------------------------------------------------------
# Work slots relative to w (the running frame): w T, w+1 Td, w+2 Tdd0, then the
# scratch of _end_step (w+3 .. w+19) and of the link moments (w+20 .. w+23).
_W_SIZE = 24


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


def _end_step(fdat, idat, link, q, qd, vel, B, w, ss, ends):
    """T <- T E(delta) for the end of ``link`` (T, Td, Tdd0 = B[w], B[w+1], B[w+2]);
    B[ss + c] = the world twist of each end coordinate c of the link.

    E = [[R(phi), t], [0, 1]], t = l e_x + end_t^T delta, phi = end_phi^T delta;
    Ed = [[dR[phidot], tdot], [0, 0]], Edd0 = [[d2R[phidot, phidot], 0], [0, 0]];
    local twist of delta_k: dE_k E^-1 = [[dR_k R^T, t_k - dR_k R^T t], [0, 0]].
    ends: None in the variant for chains whose link ends are all rigid (see kernel).
    """
    N = idat[1]
    base = _H + _CI * N + _LI * link
    m = idat[base]
    d0 = idat[base + 1]
    off = idat[base + 3]
    kind = idat[base + 4]
    l = fdat[off + 20]
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
    kv = w + 3     # rows: t, tdot, phi, phidot
    kR = w + 4
    kdR = w + 5
    kd2R = w + 6
    kG = w + 7
    kGd = w + 8
    kGdd = w + 9
    kL = w + 10
    kdRk = w + 11
    kTn = w + 12   # w+12 .. w+14: T, Td, Tdd0 scratch of _apply_local
    kTddn = w + 14
    ku = w + 15    # row 0: u
    ks = w + 16    # w+16 .. w+18: Rodrigues scratch; w+19: _conjugate scratch
    for k in range(kv, kTddn + 2):
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
    B[kG, 3, 3] = 1.0
    rodrigues_directional(B, kv, 2, 3, 3, kR, kdR, kd2R, ks)
    for a in range(3):
        B[kG, a, 3] = B[kv, 0, a]
        B[kGd, a, 3] = B[kv, 1, a]
        for b in range(3):
            B[kG, a, b] = B[kR, a, b]
            B[kGd, a, b] = B[kdR, a, b]
            B[kGdd, a, b] = B[kd2R, a, b]
    # Twists of the link's own end coordinates, from the frame before E.
    for k in range(m):
        zero = True
        for a in range(3):
            B[ku, 0, a] = fdat[o_phi + 3 * k + a]
            if fdat[o_phi + 3 * k + a] != 0.0 or fdat[o_t + 3 * k + a] != 0.0:
                zero = False
        if zero:
            _zero4(B, ss + d0 + k)  # an interior FE node: E does not depend on it
            continue
        # phi and u side by side in the scratch slot ks + 3 (rows 0, 1)
        for a in range(3):
            B[ks + 3, 0, a] = B[kv, 2, a]
            B[ks + 3, 1, a] = B[ku, 0, a]
        rodrigues_directional(B, ks + 3, 0, 1, 1, kR, kdRk, kd2R, ks)
        # L = [[dR_k R^T, t_k - dR_k R^T t], [0, 0]]
        for a in range(3):
            for b in range(3):
                s = 0.0
                for c in range(3):
                    s += B[kdRk, a, c] * B[kR, b, c]
                B[kL, a, b] = s
        for a in range(3):
            s = fdat[o_t + 3 * k + a]
            for b in range(3):
                s -= B[kL, a, b] * B[kv, 0, b]
            B[kL, a, 3] = s
        _conjugate(B, w, kL, ss + d0 + k, ks + 3)
    _apply_local(B, w, kG, vel, kTn)


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


def _joint_field(fdat, idat, link, k):
    """Entry k of link ``link``'s _F_JOINT values: 0 gamma [rad], 1 c [m], 2 n_e, 3 mu [kg/m], 4 EI [N m^2]."""
    base = _H + _CI * idat[1] + _LI * link
    m = idat[base]
    return fdat[idat[base + 3] + 21 + 8 * m + 2 * m * m + k]


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


def _pa_step(fdat, idat, link, q, qd, vel, B, w, ss):
    """T <- T G for the carriage of joint ``link`` (docs/theory.md §7.3, §7.6);
    the world twists of d_i and of every host coordinate into B[ss + c] (and, on a
    flexible Pb host with protruding length D = d_(i-1), D's second twist into B[ss + N + D's index]).

    G = Trans(d, vbar) Rz(phibar + gamma), vbar = sum b_k delta_k, phibar = sum a_k delta_k,
    b_k = [psi_k(d + c) + psi_k(d - c)] / 2,  a_k = [psi_k(d + c) - psi_k(d - c)] / (2 c)
    (delta: the host's coordinates; zero on the base rail and on a rigid host; psi_k depends
    on D too on a Pb host, _host_shapes). With theta = phibar + gamma, t = (d, vbar, 0),
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
    kG = w + 3
    kL = w + 6
    kTn = w + 7
    ks = w + 10
    # sums over the host coordinates: S[0] = vbar-type (b), S[1] = phibar-type (a); columns:
    # 0 value, 1 _d, 2 _dd, 3 _D, 4 _DD, 5 _dD, then with deltadot: 6 value, 7 _d, 8 _D
    S = np.zeros((2, 9))
    mh = 0
    h0 = 0
    jD = -1
    Ddot = 0.0
    ab = np.zeros((2, 4, 7))
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
    vb = S[0, 0]
    th = S[1, 0] + gamma
    ct = math.cos(th)
    st = math.sin(th)
    # first and qddot-free second time derivatives of theta and vbar
    thd = S[1, 1] * dd + S[1, 3] * Ddot + S[1, 6]
    vbd = S[0, 1] * dd + S[0, 3] * Ddot + S[0, 6]
    th0dd = (S[1, 2] * dd * dd + 2.0 * S[1, 5] * dd * Ddot + S[1, 4] * Ddot * Ddot
             + 2.0 * dd * S[1, 7] + 2.0 * Ddot * S[1, 8])
    vb0dd = (S[0, 2] * dd * dd + 2.0 * S[0, 5] * dd * Ddot + S[0, 4] * Ddot * Ddot
             + 2.0 * dd * S[0, 7] + 2.0 * Ddot * S[0, 8])
    for k in range(kG, kG + 3):
        _zero4(B, k)
    # G, Gd, Gdd0 (R' = [[-s, -c], [c, -s]], R'' = -R in the x-y block)
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
    # Twists, from the frame before G: L = [[Z theta_q, t_q - theta_q Z t], [0, 0]], Z t = (-vbar, d, 0)
    _zero4(B, kL)
    B[kL, 0, 1] = -S[1, 1]
    B[kL, 1, 0] = S[1, 1]
    B[kL, 0, 3] = 1.0 + S[1, 1] * vb
    B[kL, 1, 3] = S[0, 1] - S[1, 1] * d
    _conjugate(B, w, kL, ss + jd, ks)
    if jD >= 0:
        _zero4(B, kL)
        B[kL, 0, 1] = -S[1, 3]
        B[kL, 1, 0] = S[1, 3]
        B[kL, 0, 3] = S[1, 3] * vb
        B[kL, 1, 3] = S[0, 3] - S[1, 3] * d
        _conjugate(B, w, kL, ss + N + jD, ks)
    if mh > 0:
        for k in range(mh):
            ak = 0.0
            bk = 0.0
            hit = False
            for side in range(2):
                sg = 1.0 if side == 0 else -1.0
                for r in range(4):
                    if int(ab[side, r, 0]) == k:
                        ak += sg * ab[side, r, 1] / (2.0 * c)
                        bk += 0.5 * ab[side, r, 1]
                        hit = True
            if not hit:
                continue
            _zero4(B, kL)
            B[kL, 0, 1] = -ak
            B[kL, 1, 0] = ak
            B[kL, 0, 3] = ak * vb
            B[kL, 1, 3] = bk - ak * d
            _conjugate(B, w, kL, ss + h0 + k, ks)
    _apply_local(B, w, kG, vel, kTn)


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


def chain_frames(fdat, idat, q, qd, vel, B, ts, tds, tdds, ss, w, pris, ends):
    """Frames of the n links and of the tip into B[ts + i], i = 0 .. n (and their
    time derivatives into B[tds + i], B[tdds + i] when vel); twists into B[ss + c].

    B[w .. w + _W_SIZE) is work space. pris, ends: the variant (see kernel's compilation notes).
    """
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
    for i in range(n):
        base = _H + _CI * N + _LI * i
        th = idat[base + 2]
        jk = idat[base + 5]
        # R and Pb joints sit at the host's tip: the host's end E_(i-1) first (docs/theory.md §7.1).
        if i > 0 and jk != JOINT_PA:
            _end_step(fdat, idat, i - 1, q, qd, vel, B, w, ss, ends)
        if pris is None or jk == JOINT_R:
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


# -- per-link moments ---------------------------------------------------------------

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


def _mmax(idat):
    n = idat[0]
    N = idat[1]
    mmax = 0
    for i in range(n):
        mmax = max(mmax, idat[_H + _CI * N + _LI * i])
    return mmax


# -- dynamics -------------------------------------------------------------------------

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


def _cholesky_solve(M, b):
    """Solve M x = b by Cholesky (M is kept). Returns (x, status, dmin, dmax).

    status 0: solved; 1: not positive definite; 2: pivots spread beyond 1e7
    (dmin, dmax: smallest and largest diagonal entry of the factor).
    """
    L, status, dmin, dmax = _cholesky_factor(M)
    if status == 1:
        return np.zeros(b.shape[0]), 1, 0.0, dmax
    return _cholesky_apply(L, b), status, dmin, dmax


def _cholesky_factor(M):
    """L with M = L L^T (lower triangular), status (0; 1 not positive definite; 2 pivots spread
    beyond 1e7), the smallest and largest pivot."""
    N = M.shape[0]
    L = np.zeros((N, N))
    dmin = math.inf
    dmax = 0.0
    for j in range(N):
        s = M[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if s <= 0.0:  # (a NaN state gives NaN pivots and a NaN x: the integrator rejects it)
            return L, 1, 0.0, dmax
        d = math.sqrt(s)
        L[j, j] = d
        dmin = min(dmin, d)
        dmax = max(dmax, d)
        for i in range(j + 1, N):
            s = M[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    return L, (2 if dmin < 1e-7 * dmax else 0), dmin, dmax


def _cholesky_apply(L, b):
    """x with L L^T x = b: forward, then backward substitution."""
    N = b.shape[0]
    x = np.zeros(N)
    for i in range(N):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(N - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, N):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]
    return x


def _link_observables(fdat, idat, q, qd, B, ts, tds, w, V, out, SD, pris):
    """out (12,): kinetic, gravity, strain energy [J]; linear momentum L [kg m/s];
    angular momentum about the origin H0 [kg m^2/s]; first moment sum T m_r [kg m].

    Frames in B[ts + i], B[tds + i]; B[w + 20 .. w + 23], V (2 mmax + 4, 4) and SD are scratch.
    E_k = sum 1/2 tr(Td P Td^T) + tr(Td Pv T^T) + 1/2 deltadot^T M_dd deltadot,
    V_g = -g~ . sum T m_r,  V_s = 1/2 delta^T K delta,
    L = sum (Td m_r + T m_rdot),  H0 = sum vee(X),  X = T P Td^T + T Pv T^T = int mu p pdot^T.
    """
    n = idat[0]
    N = idat[1]
    mmax = _mmax(idat)
    kP = w + 20
    kPv = w + 21
    kX = w + 22
    kA = w + 23
    MR = 0
    MRD = 1
    QV = 2
    QDV = 3 + mmax
    SDS = _sd_stride(mmax)
    for a in range(12):
        out[a] = 0.0
    for i in range(n):
        base = _H + _CI * N + _LI * i
        m = idat[base]
        d0 = idat[base + 1]
        off = idat[base + 3]
        ms, src, o_cx = _link_body(fdat, idat, i, q, qd, B, kP, kPv, V, MR, QV, QDV, SD, i * SDS, pris)
        T = ts + i
        Td = tds + i
        # Kinetic energy: 1/2 tr(Td P Td^T) + tr(Td Pv T^T) here, the modal part below.
        for a in range(4):
            for b in range(4):
                x = 0.0
                z = 0.0
                for c in range(4):
                    x += B[Td, a, c] * B[kP, c, b]
                    z += B[Td, a, c] * B[kPv, c, b]
                out[0] += 0.5 * x * B[Td, a, b] + z * B[T, a, b]
        o_K = off + 21 + 2 * m + m * m
        for a in range(4):
            V[MRD, a] = 0.0
        for l in range(ms):
            al, dl, vl = _own(idat, i, q, qd, l)
            out[0] += 0.5 * vl * V[QDV + l, al]
            V[MRD, al] += vl * src[o_cx + ms + l]
        if pris is not None and idat[base + 5] == JOINT_PB:
            out[2] += SD[i * SDS + 3 * ms + ms * ms + 4 + m + 1]
        else:
            for l in range(m):
                for k in range(m):
                    out[2] += 0.5 * q[d0 + l] * fdat[o_K + m * l + k] * q[d0 + k]
        for a in range(3):
            s = 0.0
            p = 0.0
            for b in range(4):
                s += B[Td, a, b] * V[MR, b] + B[T, a, b] * V[MRD, b]
                p += B[T, a, b] * V[MR, b]
            out[3 + a] += s
            out[9 + a] += p
            out[1] -= fdat[_F_G + a] * p
        # X = T P Td^T + (T Pv) T^T
        _mm(B, T, kP, kA)
        _mmt(B, kA, Td, kX)
        _mm(B, T, kPv, kA)
        for a in range(3):
            for b in range(3):
                s = 0.0
                for c in range(4):
                    s += B[kA, a, c] * B[T, b, c]
                B[kX, a, b] += s
        out[6] += B[kX, 1, 2] - B[kX, 2, 1]
        out[7] += B[kX, 2, 0] - B[kX, 0, 2]
        out[8] += B[kX, 0, 1] - B[kX, 1, 0]


# Bits of ``job`` in ``kernel``.
JOB_M, JOB_H, JOB_SOLVE, JOB_ENERGY, JOB_MOMENTUM, JOB_POINTS, JOB_JACOBIANS, JOB_FRAMES = 1, 2, 4, 8, 16, 32, 64, 128
#: q̈ only: alone, the whole output is q̈ (N,) (forward_dynamics returns it as it is; a slice of
#: a larger output costs ~0.3 us a call). Its status is the return value.
JOB_QDDOT = 256


# Sections of ``kernel``'s output, in order (``layout`` gives their offsets).
SECTIONS = ("status", "ydot", "M", "h", "dV", "energy", "momentum", "points", "jacobians", "frames")
_S_STATUS, _S_YDOT, _S_M, _S_H, _S_DV, _S_EN, _S_MO, _S_PTS, _S_JAC, _S_FR = range(10)


def layout(n, N, K, job, npts):
    """Start offsets (11,) of the sections of ``kernel``'s output (SECTIONS), then its length;
    npts contact points (n + 1 frame origins and the extra tips)."""
    hv = (job & JOB_H) != 0
    off = np.zeros(11, dtype=np.int64)
    # status: always but for JOB_QDDOT alone; ydot: (qdot, qddot) with JOB_SOLVE, else qddot with JOB_QDDOT
    off[_S_STATUS + 1] = 0 if job == JOB_QDDOT else 3
    off[_S_YDOT + 1] = 2 * N if job & JOB_SOLVE else (N if job & JOB_QDDOT else 0)
    off[_S_M + 1] = N * N if job & JOB_M else 0
    off[_S_H + 1] = N if hv else 0
    off[_S_DV + 1] = N if hv else 0
    off[_S_EN + 1] = 3 * K if job & JOB_ENERGY else 0
    off[_S_MO + 1] = 9 * K if job & JOB_MOMENTUM else 0
    off[_S_PTS + 1] = 3 * npts * K if job & JOB_POINTS else 0
    off[_S_JAC + 1] = 3 * npts * N * K if job & JOB_JACOBIANS else 0
    off[_S_FR + 1] = 48 * (n + 1) * K if job & JOB_FRAMES else 0
    for i in range(10):  # sizes -> offsets
        off[i + 1] += off[i]
    return off


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


def _extra_points(fdat, idat, q, B, ts, ss, out, o_pts, o_jac, job, npts, k):
    """The tips of host links h whose child joint is prismatic (contact points n + 1 ..):
    p = T_h (l_h e_x + sum end_t_k delta_k, 1),  dp/dq_c = (S_c p)[:3] for f_c <= h,
    R_h end_t_k for h's own delta_k (docs/theory.md §7.1: E_h is not on the chain's path)."""
    n = idat[0]
    N = idat[1]
    x = n + 1
    for i in range(1, n):
        if idat[_H + _CI * N + _LI * i + 5] == JOINT_R:
            continue
        h = i - 1
        hb = _H + _CI * N + _LI * h
        m = idat[hb]
        d0 = idat[hb + 1]
        off = idat[hb + 3]
        o_t = off + 21 + 2 * m + 2 * m * m
        t0 = fdat[off + 20]
        t1 = 0.0
        t2 = 0.0
        for c in range(m):
            t0 += fdat[o_t + 3 * c] * q[d0 + c]
            t1 += fdat[o_t + 3 * c + 1] * q[d0 + c]
            t2 += fdat[o_t + 3 * c + 2] * q[d0 + c]
        p0 = B[ts + h, 0, 0] * t0 + B[ts + h, 0, 1] * t1 + B[ts + h, 0, 2] * t2 + B[ts + h, 0, 3]
        p1 = B[ts + h, 1, 0] * t0 + B[ts + h, 1, 1] * t1 + B[ts + h, 1, 2] * t2 + B[ts + h, 1, 3]
        p2 = B[ts + h, 2, 0] * t0 + B[ts + h, 2, 1] * t1 + B[ts + h, 2, 2] * t2 + B[ts + h, 2, 3]
        if job & JOB_POINTS:
            o = o_pts + 3 * (npts * k + x)
            out[o] = p0
            out[o + 1] = p1
            out[o + 2] = p2
        if job & JOB_JACOBIANS:
            o = o_jac + 3 * N * (npts * k + x)
            for c in range(N):
                if idat[_H + _CI * c + 2] <= h:
                    for a in range(3):
                        out[o + N * a + c] = (B[ss + c, a, 3] + B[ss + c, a, 0] * p0 + B[ss + c, a, 1] * p1
                                              + B[ss + c, a, 2] * p2)
            for c in range(m):
                for a in range(3):
                    s = 0.0
                    for b in range(3):
                        s += B[ts + h, a, b] * fdat[o_t + 3 * c + b]
                    out[o + N * a + d0 + c] = s
        x += 1


#: Wall kinds of contact_terms (walls.py: Plane, Circle, Sphere; Wall.packed()).
WALL_PLANE, WALL_CIRCLE, WALL_SPHERE = 0, 1, 2


def contact_layout(N, k):
    """Offsets (12,) of contact_terms' output sections W, M^-1 W, G, c, g, v, n, pd, a0, lambda,
    qddot for N coordinates and k pairs, and its size (after the status entry at 0)."""
    o = np.zeros(12, dtype=np.int64)
    sizes = (N * k, N * k, k * k, k, k, k, 3 * k, 3 * k, 3 * k, k, N)
    o[0] = 1
    for i in range(11):
        o[i + 1] = o[i] + sizes[i]
    return o


def _wall_gap(wk, wp, w, p0, p1, p2):
    """Gap g [m] of the point (p0, p1, p2) [m] on wall w of the packed walls (wk, wp: contact_terms),
    with d = p - c (its X1-X2 part for a circle; 0 for a plane) and r = |d| [m]:

        g = n_w . (p - p_w) (plane),   g = R - |d| (circle, sphere)
    """
    kind = wk[w]
    if kind == WALL_PLANE:
        return (p0 - wp[w, 0]) * wp[w, 3] + (p1 - wp[w, 1]) * wp[w, 4] + (p2 - wp[w, 2]) * wp[w, 5], 0.0, 0.0, 0.0, 0.0
    d0 = p0 - wp[w, 1]
    d1 = p1 - wp[w, 2]
    if kind == WALL_CIRCLE:
        r = math.hypot(d0, d1)
        return wp[w, 0] - r, d0, d1, 0.0, r
    d2 = p2 - wp[w, 3]
    r = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    return wp[w, 0] - r, d0, d1, d2, r


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
                if _skip_pair(wk[w], wp[w, 0], res[o + a], res[o + b], E[k, f], E[k, F + f], refine, pts,
                              3 * (P * k + a), 3 * (P * k + b)):
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
    oM = off[_S_M]
    oP = off[_S_PTS]
    oJ = off[_S_JAC]
    oF = off[_S_FR]
    o = contact_layout(N, k)
    oW = o[0]
    oMW = o[1]
    oG = o[2]
    oc = o[3]
    og = o[4]
    ov = o[5]
    on = o[6]
    opd = o[7]
    oa0 = o[8]
    olam = o[9]
    oqdd = o[10]
    res = np.zeros(o[11])
    for a in range(k):
        w = pairs[a, 0]
        j = pairs[a, 1]
        kind = wk[w]
        p0 = out[oP + 3 * j]
        p1 = out[oP + 3 * j + 1]
        p2 = out[oP + 3 * j + 2]
        gap, d0, d1, d2, dist = _wall_gap(wk, wp, w, p0, p1, p2)
        res[og + a] = gap
        if vel:
            for r in range(3):
                s = 0.0
                for c in range(N):
                    s += out[oJ + (3 * j + r) * N + c] * qd[c]
                res[opd + 3 * a + r] = s
                # Tddot0 of frame j, row r, column 3 (frames section: T, Td, Tdd0 per frame).
                res[oa0 + 3 * a + r] = out[oF + 48 * j + 32 + 4 * r + 3]
        v0 = res[opd + 3 * a]
        v1 = res[opd + 3 * a + 1]
        v2 = res[opd + 3 * a + 2]
        n0 = 0.0
        n1 = 0.0
        n2 = 0.0
        curv = 0.0
        if kind == WALL_PLANE:
            n0 = wp[w, 3]
            n1 = wp[w, 4]
            n2 = wp[w, 5]
        else:
            vz = v2 if kind == WALL_SPHERE else 0.0
            if dist > 0.0:
                n0 = -(d0 / dist)
                n1 = -(d1 / dist)
                n2 = -(d2 / dist)
                dv = d0 * v0 + d1 * v1 + d2 * vz
                curv = -((v0 * v0 + v1 * v1 + vz * vz) - dv * dv / (dist * dist)) / dist
        res[on + 3 * a] = n0
        res[on + 3 * a + 1] = n1
        res[on + 3 * a + 2] = n2
        if vel:
            res[oc + a] = (n0 * res[oa0 + 3 * a] + n1 * res[oa0 + 3 * a + 1] + n2 * res[oa0 + 3 * a + 2]) + curv
            res[ov + a] = n0 * v0 + n1 * v1 + n2 * v2
        for c in range(N):
            res[oW + c * k + a] = (out[oJ + 3 * j * N + c] * n0 + out[oJ + (3 * j + 1) * N + c] * n1
                                   + out[oJ + (3 * j + 2) * N + c] * n2)
    # M^-1 W: one Cholesky factor, k solves.
    M = np.zeros((N, N))
    for i in range(N):
        for c in range(N):
            M[i, c] = out[oM + N * i + c]
    L, status, dmin, dmax = _cholesky_factor(M)
    if status == 1:
        res[0] = 1.0
        return res
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
            res[oG + a * k + b] = 0.5 * (s1 + s2)
            res[oG + b * k + a] = 0.5 * (s1 + s2)
    if vel == 2:
        # Equation (3): G lambda = -(W^T qdd_free + c), qddot = qdd_free + M^-1 W lambda.
        oy = off[_S_YDOT] + N
        G = np.empty((k, k))
        rhs = np.empty(k)
        for a in range(k):
            s1 = res[oc + a]
            for c in range(N):
                s1 += res[oW + c * k + a] * out[oy + c]
            rhs[a] = -s1
            for b in range(k):
                G[a, b] = res[oG + a * k + b]
        lam = _sym_solve(G, rhs)
        for a in range(k):
            res[olam + a] = lam[a]
        for c in range(N):
            s1 = out[oy + c]
            for a in range(k):
                s1 += res[oMW + c * k + a] * lam[a]
            res[oqdd + c] = s1
    return res


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
    for a in range(k):
        for i in range(N):
            C[i, a] = W[i, a]
            B[i, a] = W[i, a]
        cc[a] = c[a]
    col = k
    for a in range(k):
        if not mu[a] > 0.0:
            continue
        n0 = nrm[a, 0]
        n1 = nrm[a, 1]
        n2 = nrm[a, 2]
        if stick[a] == 0:
            # (7): the slip direction, smooth through v_t = 0.
            vn = pd[a, 0] * n0 + pd[a, 1] * n1 + pd[a, 2] * n2
            s0 = pd[a, 0] - vn * n0 + v_tol * sdir[a, 0]
            s1 = pd[a, 1] - vn * n1 + v_tol * sdir[a, 1]
            s2 = pd[a, 2] - vn * n2 + v_tol * sdir[a, 2]
            sn = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
            s_hat[a, 0] = s0 / sn
            s_hat[a, 1] = s1 / sn
            s_hat[a, 2] = s2 / sn
            for i in range(N):
                B[i, a] -= (J[a, 0, i] * s_hat[a, 0] + J[a, 1, i] * s_hat[a, 1] + J[a, 2, i] * s_hat[a, 2]) * mu[a]
            continue
        # A sticking pair: t1 = e x n / |e x n|, t2 = n x t1.
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
        for r in range(2):
            for i in range(N):
                w = J[a, 0, i] * T[a, r, 0] + J[a, 1, i] * T[a, r, 1] + J[a, 2, i] * T[a, r, 2]
                C[i, col] = w
                B[i, col] = w
            cc[col] = T[a, r, 0] * a0[a, 0] + T[a, r, 1] * a0[a, 1] + T[a, r, 2] * a0[a, 2]
            col += 1
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
    return res


def _svd_solve(A, b):
    """x with A x = b for a square A (m, m): lstsq's solution (rcond = 1e-10), the least-squares
    solution of smallest |x| with singular values below 1e-10 of the largest cut:

        x = sum over sigma_j > 1e-10 max sigma of v_j (u_j . b) / sigma_j

    The SVD by one-sided Jacobi rotations (Hestenes): orthogonalise the columns of U = A V
    pairwise until every pair's cosine is below 1e-15; then sigma_j = |U_j|, u_j = U_j / sigma_j.
    """
    m = b.shape[0]
    U = np.empty((m, m))
    V = np.zeros((m, m))
    for i in range(m):
        V[i, i] = 1.0
        for j in range(m):
            U[i, j] = A[i, j]
    for _ in range(100):
        rotated = False
        for p in range(m):
            for q in range(p + 1, m):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for i in range(m):
                    alpha += U[i, p] * U[i, p]
                    beta += U[i, q] * U[i, q]
                    gamma += U[i, p] * U[i, q]
                if gamma == 0.0 or not abs(gamma) > 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                # The rotation (c, s) that makes columns p, q orthogonal: t = tan, the smaller root
                # of t^2 + 2 zeta t - 1 = 0, zeta = (beta - alpha) / (2 gamma).
                zeta = (beta - alpha) / (2.0 * gamma)
                t = 1.0 / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                if zeta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(1.0 + t * t)
                s = c * t
                for i in range(m):
                    up = U[i, p]
                    uq = U[i, q]
                    U[i, p] = c * up - s * uq
                    U[i, q] = s * up + c * uq
                    vp = V[i, p]
                    vq = V[i, q]
                    V[i, p] = c * vp - s * vq
                    V[i, q] = s * vp + c * vq
        if not rotated:
            break
    sig = np.zeros(m)
    big = 0.0
    for j in range(m):
        s2 = 0.0
        for i in range(m):
            s2 += U[i, j] * U[i, j]
        sig[j] = math.sqrt(s2)
        big = max(big, sig[j])
    x = np.zeros(m)
    for j in range(m):
        if sig[j] > 1e-10 * big:
            ub = 0.0
            for i in range(m):
                ub += U[i, j] * b[i]
            f = ub / (sig[j] * sig[j])  # (u_j . b) / sigma_j with u_j = U_j / sigma_j
            for i in range(m):
                x[i] += V[i, j] * f
    return x


def sym_solve(G, b):
    """_sym_solve as an entry point of its own (resting.py's projections)."""
    return _sym_solve(G, b)


def _sym_solve(G, b):
    """x with G x = b for a symmetric G (k, k): the least-squares solution of smallest |x| with
    eigenvalues below 1e-10 of the largest in magnitude cut (lstsq's rcond = 1e-10: for a
    symmetric matrix the singular values are |eigenvalues|, the singular vectors its eigenvectors):

        x = sum over |l_i| > 1e-10 max|l| of v_i (v_i . b) / l_i

    Eigenpairs by cyclic Jacobi rotations (k is the number of contacts: small), until the
    off-diagonal part is below eps^2 of the matrix (Frobenius).
    """
    k = b.shape[0]
    A = np.empty((k, k))
    V = np.zeros((k, k))
    total = 0.0
    for i in range(k):
        V[i, i] = 1.0
        for j in range(k):
            A[i, j] = G[i, j]
            total += G[i, j] * G[i, j]
    for _ in range(100):
        off = 0.0
        for p in range(k):
            for q in range(p + 1, k):
                off += A[p, q] * A[p, q]
        if off <= 1e-32 * total:
            break
        for p in range(k):
            for q in range(p + 1, k):
                apq = A[p, q]
                if apq == 0.0:
                    continue
                # The rotation (c, s) that zeroes A[p, q]: t = tan, the smaller root of
                # t^2 + 2 theta t - 1 = 0, theta = (A_qq - A_pp) / (2 A_pq).
                theta = (A[q, q] - A[p, p]) / (2.0 * apq)
                t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for r in range(k):  # A <- A R (columns p, q)
                    arp = A[r, p]
                    arq = A[r, q]
                    A[r, p] = c * arp - s * arq
                    A[r, q] = s * arp + c * arq
                for r in range(k):  # A <- R^T A (rows p, q)
                    apr = A[p, r]
                    aqr = A[q, r]
                    A[p, r] = c * apr - s * aqr
                    A[q, r] = s * apr + c * aqr
                A[p, q] = 0.0
                A[q, p] = 0.0
                for r in range(k):  # V <- V R
                    vrp = V[r, p]
                    vrq = V[r, q]
                    V[r, p] = c * vrp - s * vrq
                    V[r, q] = s * vrp + c * vrq
    big = 0.0
    for i in range(k):
        big = max(big, abs(A[i, i]))
    x = np.zeros(k)
    for i in range(k):
        lam = A[i, i]
        if abs(lam) > 1e-10 * big:
            vb = 0.0
            for r in range(k):
                vb += V[r, i] * b[r]
            for r in range(k):
                x[r] += V[r, i] * (vb / lam)
    return x


# -- compilation ----------------------------------------------------------------------
# The entry point called from Python gets explicit signatures (C-contiguous
# float64 / int64 arrays): each compiled once, then frozen (no silent recompiles
# for other types). Every entry point is linked and optimised with all the code it
# calls, so fewer entry points compile faster. Helpers are compiled for the types
# their callers use; called from Python they run uncompiled.
#
# Three variants of the one source, told apart by the types of the last two
# arguments (pris, ends), each None or an int64 (1): ``pris`` None for chains
# whose joints are all revolute, ``ends`` None for chains whose link ends are all
# rigid (rigid links, clamped-clamped modes: E = Trans(l e_x)). ``x is None`` is
# known while numba compiles, so it removes the prismatic branches (_pa_step,
# _pb_step, _pb_moments, _extra_points, the second twists) and the moving-end
# path (Rodrigues: rodrigues_directional, _conjugate, _apply_local) before they
# are typed: the published chains compile neither. Each variant compiles on its
# first use.
_HELPERS = ("_mm", "_copy4", "_zero4", "_mm_add", "_mmt", "_conjugate", "_put_skew", "_skew3",
            "rodrigues_coefficients", "rodrigues_directional", "_rot_step", "_end_step", "_apply_local",
            "_joint_field", "_hermite_at", "_host_shapes", "_pa_step", "_pb_step", "_pb_moments", "chain_frames",
            "_sd_stride", "_own", "_link_body", "_tr_sps", "_e_sy", "_extra_points", "_mmax", "assemble", "_cholesky_solve",
            "_cholesky_factor", "_cholesky_apply", "_link_observables", "layout", "contact_layout", "_sym_solve", "_wall_gap", "_skip_pair", "_svd_solve")
#: Helpers called from more than one function, compiled as their own dispatchers.
_SHARED = ("chain_frames",)
_A1, _A2, _I1 = "float64[::1]", "float64[:, ::1]", "int64[::1]"
#: The states and forces the entry point only reads: typed read-only, so that a read-only array
#: (e.g. Case.q0) is taken as it is, and a writable one converts to it at no cost (~0.02 us).
_R1 = "Array(float64, 1, 'C', readonly=True)"
#: The variants (pris, ends): the values of the entry point's last two arguments.
RIGID_ENDS, REVOLUTE, PRISMATIC = (None, None), (None, 1), (1, 1)
_VARIANT_NAME = {RIGID_ENDS: "revolute joints and rigid link ends", REVOLUTE: "revolute joints",
                 PRISMATIC: "prismatic joints"}
_VARIANT_COST = {RIGID_ENDS: "about 15-20 s", REVOLUTE: "about 20-25 s", PRISMATIC: "about 30 s"}
_ENTRY_SIG = f"float64({_A1}, {_I1}, {_R1}, {_R1}, {_R1}, int64, {{}}, {{}}, {_A1})"
#: Entry points apart from the kernel, compiled on first use: their signatures ...
_LAZY = {"contact_terms": f"{_A1}({_A1}, {_I1}, {_A1}, int64[:, ::1], {_I1}, {_A2}, int64)",
         "sym_solve": f"{_A1}({_A2}, {_A1})",
         "event_gaps": f"{_A1}({_A1}, int64, {_I1}, {_A2}, {_A2}, int64[:, ::1], float64)",
         "friction_solve": f"{_A1}({_A2}, {_A2}, float64[:, :, ::1], {_A2}, {_A2}, {_A2}, {_A1}, {_A1}, {_A1}, "
                           f"{_I1}, {_A2}, float64)"}
#: ... in groups compiled together (a contact phase needs both of its entries), with what the
#: notice calls them and when they are needed.
_LAZY_GROUP = {"contact_terms": "resting", "sym_solve": "resting", "friction_solve": "friction",
               "event_gaps": "events"}
_LAZY_NOTICE = {"resting": ("the resting-contact code", "first contact phase"),
                "friction": ("the frictional resting-contact code", "first contact phase with friction"),
                "events": ("the wall-gap code", "first run with walls")}


def _signature_args(v) -> tuple:
    """numba type names of the last two arguments of variant v."""
    return tuple("none" if x is None else "int64" for x in v)
_state = {"ready": set(), "cached": None, "seconds": {}, "kernel": None, "jitted": False, "lazy": {}}
_PY_KERNEL = kernel  # the plain-Python entry point (the global is replaced by the compiled one)
_lock = threading.Lock()
NOTICE_AFTER_S = 1.0


def variant(idat) -> tuple:
    """The kernel variant for a packed model: PRISMATIC if any joint is prismatic, else
    REVOLUTE if some link end moves with its modes, else RIGID_ENDS."""
    return PRISMATIC if idat[4] else (REVOLUTE if idat[5] else RIGID_ENDS)


def _jit_helpers():
    """Replace this module's helpers and entry point by numba dispatchers (nothing compiled yet)."""
    g = globals()
    try:
        import numba
        import numba.extending
    except ImportError:  # pragma: no cover - numba is a dependency
        import warnings

        warnings.warn("numba is not installed: gibbsimpact's kernel runs as plain Python (about 1000x "
                      "slower); install it with 'pip install numba'", RuntimeWarning, stacklevel=4)
        _state["cached"] = False
        return
    cached = True

    def jit(f):
        nonlocal cached
        kw = dict(cache=cached, nogil=True)
        try:
            return numba.njit(**kw)(f)
        except RuntimeError as exc:  # read-only install and no user cache directory
            if "cannot cache" not in str(exc):
                raise
            cached = False
            return numba.njit(nogil=True)(f)

    for name in _HELPERS:
        if name in _SHARED:
            # Called from several functions: one dispatcher compiles it once per variant (an
            # overload would be typed and lowered again for every caller).
            g[name] = jit(g[name])
            continue
        # Compiled inside the entry points that call them (no wrapper, no separate finalisation).
        numba.extending.register_jitable(g[name])
    g["kernel"] = jit(g["kernel"])
    for name in _LAZY:  # their own dispatchers: compiled on first use (lazy)
        g[name] = jit(g[name])
    _state["cached"] = cached


def _compile_variant(v):
    """Compile (or load from numba's cache) the entry point's signature of variant ``v``."""
    if not _state["jitted"]:
        _jit_helpers()
        _state["jitted"] = True
    d = globals()["kernel"]
    if not hasattr(d, "disable_compile"):  # no numba
        return
    d.disable_compile(False)
    try:
        d.compile(_ENTRY_SIG.format(*_signature_args(v)))
    finally:
        d.disable_compile()


def compiled(v=PRISMATIC):
    """The entry point ``kernel`` with variant ``v`` compiled (or loaded) on first use.

    Call it as ``compiled(v)(fdat, idat, qs, qds, Q, job, *v, out)``, v = variant(idat), with
    out = ``output(idat, K, job)``; or let ``run`` do both.
    """
    f = _state["kernel"]
    if f is None or v not in _state["ready"]:
        ensure_compiled(v)
        f = _state["kernel"] = globals()["kernel"]
    return f


@functools.lru_cache(maxsize=256)
def _output_size(n, N, K, job, npts) -> int:
    return int(layout(n, N, K, job, npts)[10])


def output(idat, K, job) -> np.ndarray:
    """An (uninitialised) output array of ``kernel`` for K states of the packed model idat and
    the JOB_* bits ``job``: layout(n, N, K, job, n + 1 + X)[10] float64 entries."""
    return np.empty(_output_size(int(idat[0]), int(idat[1]), int(K), int(job), int(idat[0] + 1 + idat[3])))


def run(v, fdat, idat, qs, qds, Q, job) -> np.ndarray:
    """The output of variant v of ``kernel`` (compiled on first use) for the K = qs.size / N
    states qs, qds (K N,), forces Q (N,) and the JOB_* bits ``job``, in a new array
    (``layout``). The arguments must have the entry point's types (``as_vector``)."""
    out = output(idat, qs.shape[0] // idat[1], job)
    if compiled(v)(fdat, idat, qs, qds, Q, job, v[0], v[1], out) < 0.0:  # pragma: no cover - sized above
        raise RuntimeError(f"kernel output of {out.size} entries does not fit its layout")
    return out


def lazy(name):
    """The entry point ``name`` of _LAZY (contact_terms, sym_solve, event_gaps), compiled (or
    loaded from numba's cache) on first use.

    They have their own dispatchers, so that a run that needs none of them (no walls, no
    resting contact) never compiles them; the first request compiles its group of
    _LAZY_GROUP (resting: ~3-6 s of CPU; events: ~1-2 s), with one notice on stderr when that
    takes more than NOTICE_AFTER_S. Call with contiguous arrays of the signature's types
    (resting.py, contacts.py).
    """
    f = _state["lazy"].get(name)
    if f is not None:
        return f
    with _lock:
        if name not in _state["lazy"]:
            if not _state["jitted"]:
                _jit_helpers()
                _state["jitted"] = True
            t0 = time.perf_counter()
            shown = []
            group = _LAZY_GROUP[name]
            what, when = _LAZY_NOTICE[group]

            def notice():
                shown.append(True)
                print(f"gibbsimpact: compiling {what} ({when}; a few seconds of CPU) ...", file=sys.stderr,
                      flush=True)

            timer = None if jit_disabled() else threading.Timer(NOTICE_AFTER_S, notice)
            if timer is not None:
                timer.daemon = True
                timer.start()
            try:
                for entry, sig in _LAZY.items():
                    if _LAZY_GROUP[entry] != group:
                        continue
                    d = globals()[entry]
                    if hasattr(d, "disable_compile"):
                        d.compile(sig)
                        d.disable_compile()
                    _state["lazy"][entry] = d
            finally:
                if timer is not None:
                    timer.cancel()
            if shown:
                print(f"gibbsimpact: {what} ready in {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    return _state["lazy"][name]


def _cache_is_warm(v):
    """True if numba's on-disk cache holds a valid entry of variant ``v`` (False: a
    compile is coming; None: cannot tell)."""
    try:
        import numba

        probe = numba.njit(cache=True)(_PY_KERNEL)
        # The index is keyed by the source file's stamp: a stale one loads as empty.
        index = probe._cache._cache_file._load_index()
        # Keys: (signature text as compiled, codegen's magic tuple, ...).
        want = _ENTRY_SIG.format(*_signature_args(v)).replace(" ", "")
        return any(str(key[0]).replace(" ", "") == want for key in index)
    except Exception:  # no cache location, numba internals changed, JIT disabled ...
        return None


def ensure_compiled(v=PRISMATIC):
    """Compile variant ``v`` (RIGID_ENDS, REVOLUTE, PRISMATIC) of the kernel on first use (or
    load it from numba's cache); cheap afterwards.

    A one-line notice goes to stderr before a compile (15-30 s of CPU, _VARIANT_COST);
    loading from the cache (~0.5 s) is silent. If the cache state cannot be read, the
    notice appears once compiling has taken NOTICE_AFTER_S.
    """
    if v in _state["ready"]:
        return
    with _lock:
        if v in _state["ready"]:
            return
        t0 = time.perf_counter()
        shown = []
        what = _VARIANT_NAME[v]
        cost = _VARIANT_COST[v]

        def notice():
            shown.append(True)
            print(f"gibbsimpact: compiling the dynamics kernel for {what} (first use; {cost} of CPU) ...",
                  file=sys.stderr, flush=True)

        warm = None if jit_disabled() else _cache_is_warm(v)
        timer = None
        if warm is False:
            notice()
        elif warm is None and not jit_disabled():
            timer = threading.Timer(NOTICE_AFTER_S, notice)
            timer.daemon = True
            timer.start()
        try:
            _compile_variant(v)
        finally:
            if timer is not None:
                timer.cancel()
        _state["seconds"][v] = time.perf_counter() - t0
        _state["ready"].add(v)
        if shown:
            where = (" and cached for later runs" if _state["cached"] else
                     " (not cached: no writable cache directory; set NUMBA_CACHE_DIR to one)")
            print(f"gibbsimpact: kernel ready in {_state['seconds'][v]:.1f} s{where}", file=sys.stderr,
                  flush=True)


def jit_disabled() -> bool:
    """True when numba runs the kernel as plain Python (NUMBA_DISABLE_JIT=1)."""
    return os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")
