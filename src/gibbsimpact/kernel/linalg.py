"""Solve stage: Cholesky factor and solves, and the least-squares symmetric and SVD solves."""

from __future__ import annotations

import math

import numpy as np


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
