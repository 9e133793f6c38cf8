"""method="lagrange" (the comparison route): Lagrange's equations on T and V of the moment form.

The same transforms T_i as the recursion (recursion.py), their
time derivatives by symbolic differentiation Td_i = sum_j dT_i/dq_j qdot_j, and::

    T = sum_i [1/2 tr(Td_i P_i Td_i^T) + tr(Td_i Pv_i T_i^T) + 1/2 deltadot_i^T M_dd,i deltadot_i
               + 1/2 omega_i^T J_i omega_i],     omega_i = vee(R_i^T Rd_i)
    V = -g~^T sum_i T_i m_r,i + 1/2 delta^T K delta
    M = d2T/dqdot dqdot,   forcing = dT/dq - (d2T/dqdot dq) qdot - dV/dq
"""

from __future__ import annotations

import numpy as np

from .recursion import each_link


class _Differentiator:
    """d expr / d x on expression DAGs, memoised so shared subexpressions are differentiated once."""

    def __init__(self, alg, x):
        self.alg, self.x, self.memo = alg, x, {}

    def __call__(self, e):
        r = self.memo.get(e)
        if r is not None:
            return r
        alg = self.alg
        if e.is_Atom:
            r = alg.O if e == self.x else alg.Z
        elif e.is_Add:
            r = alg.add([self(a) for a in e.args])
        elif e.is_Mul:
            args = e.args
            terms = []
            for k, a in enumerate(args):
                da = self(a)
                if da is not alg.Z:
                    terms.append(alg.sp.Mul(*args[:k], da, *args[k + 1:]))
            r = alg.add(terms)
        elif e.is_Pow and e.exp.is_Number:
            db = self(e.base)
            r = alg.Z if db is alg.Z else e.exp * e.base ** (e.exp - 1) * db
        elif isinstance(e, alg.sp.Function) and len(e.args) == 1:
            da = self(e.args[0])
            r = alg.Z if da is alg.Z else alg.mul(e.fdiff(1), da)
        else:
            r = e.diff(self.x)
        self.memo[e] = r
        return r


def mass_matrix_and_forcing(model, alg, q, qd):
    """M (N, N) and forcing (N,) from Lagrange's equations on T and V of the moment form."""
    sp = alg.sp
    N = len(q)
    dq = [_Differentiator(alg, x) for x in q]
    kin, pot = [], []
    gt = alg.cmat(np.append(model.gravity, 0.0))
    for i, rec, ld, idx, d, dd, (P, Q, m_r, Pv, Qd, Mdd) in each_link(model, alg, q, qd, False, False,
                                                                  "lagrange: T and V of link"):
        T = rec.T
        # Td = sum_j dT/dq_j qdot_j by differentiation
        Td = [[alg.add([alg.mul(dq[j](e), qd[j]) for j in range(N)]) for e in row] for row in T]
        half = sp.Rational(1, 2)
        kin.append(alg.mul(half, alg.dot(alg.mm(Td, P), Td)))
        kin.append(alg.dot(alg.mm(Td, Pv), T))
        kin.append(alg.mul(half, alg.add([alg.mul(alg.mul(Mdd[k][l], dd[k]), dd[l])
                                          for k in range(len(d)) for l in range(len(d))])))
        if ld.has_rotary:
            R, Rd = [row[:3] for row in T[:3]], [row[:3] for row in Td[:3]]
            w = alg.vee_skew(alg.mm(alg.T(R), Rd))
            J = alg.cmat(ld.J_body)
            kin.append(alg.mul(half, alg.add([alg.mul(x, y) for x, y in zip(w, alg.mv(J, w))])))
        pot.append(-alg.add([alg.mul(g, x) for g, x in zip(gt, alg.mv(T, m_r))]))
        K = alg.cmat(ld.K)
        pot.append(alg.mul(half, alg.add([alg.mul(alg.mul(K[k][l], d[k]), d[l])
                                          for k in range(len(d)) for l in range(len(d))])))
    Tk, V = alg.add(kin), alg.add(pot)
    dqd = [_Differentiator(alg, x) for x in qd]
    p = [dqd[j](Tk) for j in range(N)]
    M = [[None] * N for _ in range(N)]
    for j in range(N):
        for k in range(j, N):
            M[j][k] = M[k][j] = dqd[k](p[j])
    forcing = []
    for j in range(N):
        alg.tick("lagrange: equation", j + 1, N)
        # d/dt dT/dqdot_j = M_j. qddot + sum_k dp_j/dq_k qdot_k
        dp = alg.add([alg.mul(dq[k](p[j]), qd[k]) for k in range(N)])
        forcing.append(alg.add([dq[j](Tk), -dp, -dq[j](V)]))
    return M, forcing
