"""4x4 helpers on the kernel's matrix stack, skew matrices and the Rodrigues formula."""

from __future__ import annotations

import math

import numpy as np


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
