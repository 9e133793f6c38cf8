"""method="gibbs-appell": M and forcing assembled link by link from the recursion and the link moments.

dS/dqddot = M qddot + h assembled per link from its moments
(P = int mu r r^T, Q_l = int mu r psihat_l^T, Pv = int mu r rdot^T,
Qd_l = int mu rdot psihat_l^T, m_r = int mu r)::

    M_jk += tr(A_j P A_k^T),  M_jl += tr(A_j Q_l T^T),  M_kl += tr(D_kl)
    h_j  += tr(A_j (P Tdd0^T + 2 Pv Td^T)),  h_l += tr(Tdd0 Q_l T^T) + 2 tr(Td Qd_l T^T)
    dV/dq_j -= g~^T A_j m_r,  dV/ddelta_l -= g~^T T m_psi,l,  dV/ddelta += K delta

With rotary inertia (body angular velocity omega = W qdot, body acceleration
alpha = W qddot + alpha0, see recursion.py)::

    M += W^T J W,   h += W^T (J alpha0 + omega x J omega)
"""

from __future__ import annotations

import numpy as np

from .recursion import each_link


def mass_matrix_and_forcing(model, alg, q, qd):
    """M (N, N) and forcing (N,) as nested lists of expressions."""
    N = len(q)
    Mt = [[[] for _ in range(N)] for _ in range(N)]  # upper-triangle term lists
    ht = [[] for _ in range(N)]
    gt = alg.cmat(np.append(model.gravity, 0.0))
    rotary = any(ld.has_rotary for ld in model.link_data)

    def addM(j, k, term):
        if term is not alg.Z:
            Mt[min(j, k)][max(j, k)].append(term)

    for i, rec, ld, idx, d, dd, (P, Q, m_r, Pv, Qd, Mdd) in each_link(model, alg, q, qd, True, rotary,
                                                                  "gibbs-appell: link"):
        T, Td, Tdd0, A = rec.T, rec.Td, rec.Tdd0, rec.A
        keys = sorted(A)
        # M_jk += tr(A_j P A_k^T)
        AP = {j: alg.mm(A[j], P) for j in keys}
        for a, j in enumerate(keys):
            for k in keys[a:]:
                addM(j, k, alg.dot(AP[j], A[k]))
        # M_jl += tr(A_j Q_l T^T) = sum_ab A_j,ab (T Q_l^T)_ab;  M_kl += tr(D_kl)
        F = [alg.mm(T, alg.T(Ql)) for Ql in Q]
        for l, ql in enumerate(idx):
            for j in keys:
                addM(j, ql, alg.dot(A[j], F[l]))
            for k, qk in enumerate(idx):
                if qk <= ql:
                    addM(qk, ql, Mdd[k][l])
        # h_j += tr(A_j (P Tdd0^T + 2 Pv Td^T)) = sum_ab A_j,ab (Tdd0 P^T + 2 Td Pv^T)_ab
        H = alg.madd(alg.mm(Tdd0, alg.T(P)), alg.scale(alg.two, alg.mm(Td, alg.T(Pv))))
        for j in keys:
            ht[j].append(alg.dot(A[j], H))
        # h_l += tr(Tdd0 Q_l T^T) + 2 tr(Td Qd_l T^T)
        for l, ql in enumerate(idx):
            ht[ql].append(alg.dot(F[l], Tdd0))
            ht[ql].append(alg.mul(alg.two, alg.dot(alg.mm(T, alg.T(Qd[l])), Td)))
        # dV/dq_j = -g~^T A_j m_r;  dV/ddelta_l = -g~^T T m_psi,l;  + K delta
        for j in keys:
            ht[j].append(-alg.add([alg.mul(g, x) for g, x in zip(gt, alg.mv(A[j], m_r))]))
        mpsi = alg.cmat(ld.m_psi)
        K = alg.cmat(ld.K)
        for l, ql in enumerate(idx):
            ht[ql].append(-alg.add([alg.mul(g, x) for g, x in zip(gt, alg.mv(T, mpsi[l]))]))
            ht[ql].append(alg.add([alg.mul(K[l][k], d[k]) for k in range(len(d))]))
        if ld.has_rotary:
            # M += W^T J W;  h += W^T (J alpha0 + omega x J omega)
            J = alg.cmat(ld.J_body)
            W = rec.W
            JW = {j: alg.mv(J, W[j]) for j in W}
            wkeys = sorted(W)
            for a, j in enumerate(wkeys):
                for k in wkeys[a:]:
                    addM(j, k, alg.add([alg.mul(x, y) for x, y in zip(W[j], JW[k])]))
            w = rec.omega()
            rhs = [alg.add([x, y]) for x, y in zip(alg.mv(J, rec.alpha0), alg.cross(w, alg.mv(J, w)))]
            for j in wkeys:
                ht[j].append(alg.add([alg.mul(x, y) for x, y in zip(W[j], rhs)]))
    M = [[alg.add(Mt[min(j, k)][max(j, k)]) for k in range(N)] for j in range(N)]
    forcing = [-alg.add(t) for t in ht]
    return M, forcing
