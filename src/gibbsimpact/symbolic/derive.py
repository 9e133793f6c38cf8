"""Symbolic equations of motion of a chain: model -> M(q) qddot = forcing(q, qdot).

``derive_equations(model, method)`` writes the flight-phase equations of any
chain the numeric kernel models (free-flying or fixed base, assumed-mode or
finite-element links, planar or spatial, rotary inertia) as sympy expressions
in the coordinates q and speeds qdot (symbols named after
``model.coordinate_names``; speeds ``<name>_dot``)::

    M(q) qddot = forcing(q, qdot),     forcing = Q - h(q, qdot) - dV/dq,   Q = 0

    M       (N, N)  [kg, kg m, kg m^2 by block]
    forcing (N, 1)  [N, N m]

Numbers of the model (link moments ``P0, C, D, m_r0, m_psi, M_dd, K, end_t,
end_phi, J_body``, gravity, the fixed-base frame T_0) enter as constants
(binary-exact 17-digit floats, or exact rationals with ``rational=True``).

method="gibbs-appell" (docs/theory.md §6, the moment form of
gibbsimpact.dynamics): the 4x4 recursion, link by link, with G_i the local
transform of the variables s in {theta_i, delta_(i-1)}::

    T_i = T_(i-1) G_i
    A_ij = dT_i/dq_j  = A_(i-1)j G_i  (upstream),  T_(i-1) dG_i/ds  (local)
    Td_i   = Td_(i-1) G_i + T_(i-1) Gd_i,                Gd = sum_s dG/ds sdot
    Tdd0_i = Tdd0_(i-1) G_i + 2 Td_(i-1) Gd_i + T_(i-1) Gdd0_i,
                                                          Gdd0 = sum_st d2G/dsdt sdot tdot

and dS/dqddot = M qddot + h assembled per link from its moments
(P = int mu r r^T, Q_l = int mu r psihat_l^T, Pv = int mu r rdot^T,
Qd_l = int mu rdot psihat_l^T, m_r = int mu r)::

    M_jk += tr(A_j P A_k^T),  M_jl += tr(A_j Q_l T^T),  M_kl += tr(D_kl)
    h_j  += tr(A_j (P Tdd0^T + 2 Pv Td^T)),  h_l += tr(Tdd0 Q_l T^T) + 2 tr(Td Qd_l T^T)
    dV/dq_j -= g~^T A_j m_r,  dV/ddelta_l -= g~^T T m_psi,l,  dV/ddelta += K delta

Rotary inertia (body angular velocity omega = W qdot, body acceleration
alpha = W qddot + alpha0, recursively with R_G the rotation of G and
omega_G = W_G sdot, W_G = vee(R_G^T dR_G/ds))::

    W_i = R_G^T W_(i-1) (+ W_G columns),
    alpha0_i = R_G^T alpha0_(i-1) - omega_G x (R_G^T omega_(i-1)) + sum_st d(W_G)_s/dt tdot sdot
    M += W^T J W,   h += W^T (J alpha0 + omega x J omega)

method="lagrange" (the comparison route): the same transforms T_i, their
time derivatives by symbolic differentiation Td_i = sum_j dT_i/dq_j qdot_j, and::

    T = sum_i [1/2 tr(Td_i P_i Td_i^T) + tr(Td_i Pv_i T_i^T) + 1/2 deltadot_i^T M_dd,i deltadot_i
               + 1/2 omega_i^T J_i omega_i],     omega_i = vee(R_i^T Rd_i)
    V = -g~^T sum_i T_i m_r,i + 1/2 delta^T K delta
    M = d2T/dqdot dqdot,   forcing = dT/dq - (d2T/dqdot dq) qdot - dV/dq

The end rotation Rot(phi), phi = end_phi^T delta [rad], is the exact
Rodrigues rotation R = I + a(s) K + b(s) K^2, K = skew(phi), s = phi.phi,
a = sin(t)/t, b = (1 - cos t)/t^2, t = sqrt(s). a and b (and their
s-derivatives) are the functions ``rodrigues_a<k>(s)``, ``rodrigues_b<k>(s)``
(k-th s-derivative), evaluated numerically with a power series for s < 1, so
they are finite at phi = 0. Where only one component of phi is non-zero (every
planar chain) Rot(phi) is written exactly as the single-axis rotation.

Common-subexpression elimination (sympy.cse) gives the straight-line program
behind ``operation_count``, ``to_python`` and ``numeric``.
"""

from __future__ import annotations

import inspect
import math
import re
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

#: Derivation routes of derive_equations.
METHODS = ("gibbs-appell", "lagrange")

_SERIES_TERMS = 16


# ---------------------------------------------------------------------------
# Rodrigues coefficients a(s), b(s) and their s-derivatives (numeric)
# ---------------------------------------------------------------------------

def rodrigues_coefficient(kind: str, order: int, s: float) -> float:
    """k-th s-derivative of a(s) = sin(t)/t (kind "a") or b(s) = (1 - cos t)/t^2 ("b"), t = sqrt(s).

    Power series for s < 1 (finite at s = 0); otherwise the recurrences
    a^(k+1) = (c^(k) - (2k+1) a^(k)) / (2s), c = cos t, c^(k) = -a^(k-1)/2 (k >= 1),
    b^(k+1) = (a^(k)/2 - (k+1) b^(k)) / s.
    """
    if s < 1.0:
        # a = sum (-1)^n s^n/(2n+1)!, b = sum (-1)^n s^n/(2n+2)!
        off = 1 if kind == "a" else 2
        total = 0.0
        for n in range(order, order + _SERIES_TERMS):
            total += (-1.0) ** n * math.perm(n, order) * s ** (n - order) / math.factorial(2 * n + off)
        return total
    t = math.sqrt(s)
    a = [math.sin(t) / t]
    for k in range(order):
        c = math.cos(t) if k == 0 else -0.5 * a[k - 1]
        a.append((c - (2 * k + 1) * a[k]) / (2 * s))
    if kind == "a":
        return a[order]
    b = (1.0 - math.cos(t)) / s
    for k in range(order):
        b = (0.5 * a[k] - (k + 1) * b) / s
    return b


_ROD_CACHE: dict = {}


def _rodrigues_function(kind: str, order: int):
    """The sympy function rodrigues_<kind><order>(s) (created once, derivative -> order + 1)."""
    key = (kind, order)
    if key in _ROD_CACHE:
        return _ROD_CACHE[key]
    import sympy as sp

    off = 1 if kind == "a" else 2

    def fdiff(self, argindex=1):
        return _rodrigues_function(kind, order + 1)(self.args[0])

    @classmethod
    def eval(cls, s):
        if s.is_zero:
            # value of the series at s = 0: (-1)^k k! / (2k + off)!
            return sp.Integer(-1) ** order * sp.factorial(order) / sp.factorial(2 * order + off)
        return None

    def _eval_evalf(self, prec):
        s = self.args[0].evalf(prec)
        if s.is_Number:
            return sp.Float(rodrigues_coefficient(kind, order, float(s)), prec)
        return None

    def _latex(self, printer):
        primes = "'" * order if order <= 3 else f"^{{({order})}}"
        return f"{kind}{primes}\\left({printer._print(self.args[0])}\\right)"

    cls = type(f"rodrigues_{kind}{order}", (sp.Function,),
               dict(nargs=1, fdiff=fdiff, eval=eval, _eval_evalf=_eval_evalf, _latex=_latex))
    _ROD_CACHE[key] = cls
    return cls


# ---------------------------------------------------------------------------
# Small dense algebra on lists of sympy expressions, skipping zeros and ones
# ---------------------------------------------------------------------------

class _Algebra:
    def __init__(self, sp, rational: bool):
        self.sp = sp
        self.Z, self.O, self.two = sp.S.Zero, sp.S.One, sp.Integer(2)
        self.rational = rational
        self.progress = None  # callable(stage, done, total) or None

    def tick(self, stage: str, done: int, total: int):
        if self.progress is not None:
            self.progress(stage, done, total)

    def const(self, v):
        if isinstance(v, self.sp.Basic):  # a parametric model's named constant or parameter expression
            return v
        v = float(v)
        if v == 0.0:
            return self.Z
        if v.is_integer() and abs(v) < 2.0**53:
            return self.sp.Integer(int(v))
        return self.sp.Rational(v) if self.rational else self.sp.Float(v, 17)

    def cmat(self, a):
        a = np.asarray(a)
        if a.dtype != object:
            a = a.astype(float)
        if a.ndim == 1:
            return [self.const(v) for v in a]
        return [self.cmat(r) for r in a]

    def mul(self, a, b):
        Z, O = self.Z, self.O
        if a is Z or b is Z:
            return Z
        if a is O:
            return b
        if b is O:
            return a
        return a * b

    def add(self, terms):
        terms = [t for t in terms if t is not self.Z]
        if not terms:
            return self.Z
        if len(terms) == 1:
            return terms[0]
        return self.sp.Add(*terms)

    def mm(self, A, B):
        """A B for nested lists (r, n) x (n, c)."""
        Bt = list(zip(*B))
        return [[self.add([self.mul(a, b) for a, b in zip(row, col)]) for col in Bt] for row in A]

    def mv(self, A, v):
        return [self.add([self.mul(a, b) for a, b in zip(row, v)]) for row in A]

    def T(self, A):
        return [list(c) for c in zip(*A)]

    def madd(self, *mats):
        return [[self.add(list(es)) for es in zip(*rows)] for rows in zip(*mats)]

    def scale(self, c, A):
        return [[self.mul(c, a) for a in row] for row in A]

    def dot(self, A, B):
        """sum_ab A_ab B_ab (= tr(A B^T))."""
        return self.add([self.mul(a, b) for ra, rb in zip(A, B) for a, b in zip(ra, rb)])

    def is_zero(self, A):
        return all(a is self.Z for row in A for a in row)

    def zeros(self, r, c):
        return [[self.Z] * c for _ in range(r)]

    def eye(self, n):
        return [[self.O if i == j else self.Z for j in range(n)] for i in range(n)]

    def diff(self, A, x):
        return [[a.diff(x) if a.has(x) else self.Z for a in row] for row in A]

    def cross(self, u, v):
        return [self.add([self.mul(u[1], v[2]), -self.mul(u[2], v[1])]),
                self.add([self.mul(u[2], v[0]), -self.mul(u[0], v[2])]),
                self.add([self.mul(u[0], v[1]), -self.mul(u[1], v[0])])]

    def vee_skew(self, S):
        h = self.sp.Rational(1, 2)
        return [self.mul(h, self.add([S[2][1], -S[1][2]])), self.mul(h, self.add([S[0][2], -S[2][0]])),
                self.mul(h, self.add([S[1][0], -S[0][1]]))]


def _rot4(alg, axis: int, angle):
    """Rotation about the coordinate axis (4, 4), exact cos/sin of angle."""
    sp = alg.sp
    c, s = sp.cos(angle), sp.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = alg.eye(4)
    R[i][i] = R[j][j] = c
    R[i][j], R[j][i] = -s, s
    return R


def _end_transform(alg, ld, d):
    """E(delta) (4, 4) and its rotation kind: None (translation), ('axis', a, angle) or ('general',).

    E = Trans(l e_1 + end_t^T delta) Rot(end_phi^T delta).
    """
    G = alg.cmat(ld.E0)
    et = alg.cmat(ld.end_t)
    for a in range(3):
        G[a][3] = alg.add([G[a][3]] + [alg.mul(et[k][a], d[k]) for k in range(len(d))])
    ep = alg.cmat(ld.end_phi)
    phi = [alg.add([alg.mul(ep[k][a], d[k]) for k in range(len(d))]) for a in range(3)]
    nz = [a for a in range(3) if phi[a] is not alg.Z]
    if not nz:
        return G, None
    if len(nz) == 1:
        # phi = angle e_a: Rot(phi) is the exact rotation about axis a
        R = _rot4(alg, nz[0], phi[nz[0]])
        kind = ("axis", nz[0], phi[nz[0]])
    else:
        s = alg.add([alg.mul(p, p) for p in phi])
        a_s, b_s = _rodrigues_function("a", 0)(s), _rodrigues_function("b", 0)(s)
        K = [[alg.Z, -phi[2], phi[1]], [phi[2], alg.Z, -phi[0]], [-phi[1], phi[0], alg.Z]]
        K2 = alg.mm(K, K)
        R = alg.madd(alg.eye(3), alg.scale(a_s, K), alg.scale(b_s, K2))
        R = [row + [alg.Z] for row in R] + [[alg.Z, alg.Z, alg.Z, alg.O]]
        kind = ("general",)
    return alg.mm(G, R), kind


class _Recursion:
    """State of the 4x4 recursion along the chain (docs/theory.md §6).

    T (4, 4); A: dict q-index -> dT/dq_j (4, 4) (nonzero ones only); Td, Tdd0 (4, 4);
    with rotary: W dict q-index -> (3,) body angular-velocity column, alpha0 (3,).
    """

    def __init__(self, alg, q, qd, velocities: bool, rotary: bool):
        self.alg, self.q, self.qd = alg, q, qd
        self.vel, self.rotary = velocities, rotary
        self.T = alg.eye(4)
        self.A = {}
        self.Td = alg.zeros(4, 4)
        self.Tdd0 = alg.zeros(4, 4)
        self.W = {}
        self.alpha0 = [alg.Z] * 3

    def step(self, G, local, kind):
        """T <- T G with G depending on the q-indices ``local``; kind: rotation of G (see _end_transform)."""
        alg, q, qd = self.alg, self.q, self.qd
        dG = {s: alg.diff(G, q[s]) for s in local}
        A = {j: alg.mm(Aj, G) for j, Aj in self.A.items()}
        for s in local:
            A[s] = alg.mm(self.T, dG[s])
        A = {j: Aj for j, Aj in A.items() if not alg.is_zero(Aj)}
        if self.vel:
            Gd = alg.madd(*[alg.scale(qd[s], dG[s]) for s in local]) if local else alg.zeros(4, 4)
            terms = [alg.scale(alg.mul(qd[s], qd[t]), alg.diff(dG[s], q[t])) for s in local for t in local]
            Gdd0 = alg.madd(*terms) if terms else alg.zeros(4, 4)
            Td = alg.madd(alg.mm(self.Td, G), alg.mm(self.T, Gd))
            Tdd0 = alg.madd(alg.mm(self.Tdd0, G), alg.scale(alg.two, alg.mm(self.Td, Gd)), alg.mm(self.T, Gdd0))
            self.Td, self.Tdd0 = Td, Tdd0
        if self.rotary and kind is not None:
            self._rotate(G, dG, local, kind)
        self.T = alg.mm(self.T, G)
        self.A = A

    def _rotate(self, G, dG, local, kind):
        alg, qd = self.alg, self.qd
        R = [row[:3] for row in G[:3]]
        Rt = alg.T(R)
        if kind[0] == "axis":
            # R_G = Rot_a(angle), angle linear in the local q: W_G,s = e_a d(angle)/dq_s, constant
            WG = {s: [kind[2].diff(self.q[s]) if c == kind[1] else alg.Z for c in range(3)] for s in local}
            wGd0 = [alg.Z] * 3
        else:
            WG = {s: alg.vee_skew(alg.mm(Rt, [row[:3] for row in dG[s][:3]])) for s in local}
            wGd0 = [alg.add([alg.mul(alg.mul(qd[s], qd[t]), WG[s][c].diff(self.q[t]))
                             for s in local for t in local]) for c in range(3)]
        w_prev = [alg.add([alg.mul(Wj[c], qd[j]) for j, Wj in self.W.items()]) for c in range(3)]
        wG = [alg.add([alg.mul(WG[s][c], qd[s]) for s in local]) for c in range(3)]
        Rw = alg.mv(Rt, w_prev)
        # alpha0_i = R_G^T alpha0 - omega_G x (R_G^T omega) + d(W_G)/dt sdot
        self.alpha0 = [alg.add([x, -y, z]) for x, y, z in zip(alg.mv(Rt, self.alpha0), alg.cross(wG, Rw), wGd0)]
        W = {j: alg.mv(Rt, Wj) for j, Wj in self.W.items()}
        for s in local:
            W[s] = [alg.add([a, b]) for a, b in zip(W.get(s, [alg.Z] * 3), WG[s])]
        self.W = {j: Wj for j, Wj in W.items() if any(w is not alg.Z for w in Wj)}

    def omega(self):
        alg = self.alg
        return [alg.add([alg.mul(Wj[c], self.qd[j]) for j, Wj in self.W.items()]) for c in range(3)]


def _link_frames(model, alg, q, qd, velocities, rotary):
    """Yield (i, recursion state at T_i) for i = 0 .. n-1 (state valid only during the yield)."""
    rec = _Recursion(alg, q, qd, velocities, rotary)
    theta = model.theta_index
    if model.free_base:
        G = alg.eye(4)
        for a in range(3):
            G[a][3] = q[a]
        rec.step(G, [0, 1, 2], None)
        rec.step(_rot4(alg, 0, q[3]), [3], ("axis", 0, q[3]))
        rec.step(_rot4(alg, 1, q[4]), [4], ("axis", 1, q[4]))
    else:
        rec.T = alg.cmat(model.base_transform)  # constant: no derivatives, zero angular velocity
    rec.step(_rot4(alg, 2, q[theta[0]]), [theta[0]], ("axis", 2, q[theta[0]]))
    n = model.n_links
    for i in range(n):
        yield i, rec
        if i + 1 < n:
            ld = model.link_data[i]
            idx = [int(k) for k in model.delta_index[i]]
            if ld.end_is_rigid:
                rec.step(alg.cmat(ld.E0), [], None)
            else:
                E, kind = _end_transform(alg, ld, [q[k] for k in idx])
                rec.step(E, idx, kind)
            rec.step(_rot4(alg, 2, q[theta[i + 1]]), [theta[i + 1]], ("axis", 2, q[theta[i + 1]]))


def _link_moments(alg, ld, d, dd):
    """P (4,4), Q_l (m,4,4), m_r (4,), Pv (4,4), Qd_l (m,4,4), M_dd (m,m) as expressions."""
    m = len(d)
    P0, C, D = alg.cmat(ld.P0), [alg.cmat(c) for c in ld.C], [[alg.cmat(x) for x in row] for row in ld.D]
    Q = [alg.madd(C[l], *[alg.scale(d[k], D[k][l]) for k in range(m)]) for l in range(m)]
    # P = P0 + sum_k d_k (C_k + C_k^T) + sum_kl d_k d_l D_kl
    P = alg.madd(P0, *[alg.scale(d[k], alg.madd(C[k], alg.T(C[k]))) for k in range(m)],
                 *[alg.scale(alg.mul(d[k], d[l]), D[k][l]) for k in range(m) for l in range(m)])
    m_r = [alg.add([alg.const(ld.m_r0[a])] + [alg.mul(alg.const(ld.m_psi[k][a]), d[k]) for k in range(m)])
           for a in range(4)]
    Pv = alg.madd(*[alg.scale(dd[l], Q[l]) for l in range(m)]) if m else alg.zeros(4, 4)
    Qd = [alg.madd(*[alg.scale(dd[k], D[k][l]) for k in range(m)]) for l in range(m)]
    return P, Q, m_r, Pv, Qd, alg.cmat(ld.M_dd)


def _links(model, alg, q, qd, velocities, rotary, stage):
    """Per link: (i, recursion state, link data, its delta indices, delta, deltadot, _link_moments(...))."""
    for i, rec in _link_frames(model, alg, q, qd, velocities, rotary):
        alg.tick(stage, i + 1, model.n_links)
        ld = model.link_data[i]
        idx = [int(k) for k in model.delta_index[i]]
        d, dd = [q[k] for k in idx], [qd[k] for k in idx]
        yield i, rec, ld, idx, d, dd, _link_moments(alg, ld, d, dd)


def _gibbs_appell(model, alg, q, qd):
    """M (N, N) and forcing (N,) as nested lists of expressions."""
    N = len(q)
    Mt = [[[] for _ in range(N)] for _ in range(N)]  # upper-triangle term lists
    ht = [[] for _ in range(N)]
    gt = alg.cmat(np.append(model.gravity, 0.0))
    rotary = any(ld.has_rotary for ld in model.link_data)

    def addM(j, k, term):
        if term is not alg.Z:
            Mt[min(j, k)][max(j, k)].append(term)

    for i, rec, ld, idx, d, dd, (P, Q, m_r, Pv, Qd, Mdd) in _links(model, alg, q, qd, True, rotary,
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


def _lagrange(model, alg, q, qd):
    """M (N, N) and forcing (N,) from Lagrange's equations on T and V of the moment form."""
    sp = alg.sp
    N = len(q)
    dq = [_Differentiator(alg, x) for x in q]
    kin, pot = [], []
    gt = alg.cmat(np.append(model.gravity, 0.0))
    for i, rec, ld, idx, d, dd, (P, Q, m_r, Pv, Qd, Mdd) in _links(model, alg, q, qd, False, False,
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


class _ParametricLink:
    """The LinkData arrays of one uniform link as expressions of its parameters (object arrays).

    With l, mu, EI and the length exponent a_k of each shape function (0 for
    a mode or an element deflection function, 1 for an element slope function,
    whose values are lengths), every moment is a parameter monomial times a
    dimensionless named constant:

        int mu psi_k = mu l^(1+a_k) c_k          int mu x psi_k = mu l^(2+a_k) cx_k
        int mu psi_k psi_l = mu l^(1+a_k+a_l) d_kl    K_kl = EI l^(a_k+a_l-3) kappa_kl
        psi_k(l) = l^(a_k) e_k                   psi_k'(l) = l^(a_k-1) s_k
        P0 = mu [[l^3/3, l^2/2], [l^2/2, l]] (x and 1 entries),  J = l diag(j_x, j_y, j_z)
    """

    def __init__(self, sp, link, ld, i: int, values: dict):
        if callable(link.mass_per_length) or any(callable(e) for e in link.EI):
            raise ValueError(f"derive_equations symbols=True needs uniform links; link {i} has a callable "
                             "mass_per_length or EI")
        self.end_is_rigid, self.has_rotary, self.directions = ld.end_is_rigid, ld.has_rotary, ld.directions
        l_v, mu_v = link.length, link.mass_per_length
        l, mu = self._par(sp, values, f"l_{i}", l_v), self._par(sp, values, f"mu_{i}", mu_v)
        EI = {"y": (f"EIz_{i}", link.EI_z), "z": (f"EIy_{i}", link.EI_y)}  # y-bending resists with EI_z
        m = len(ld.directions)
        a = np.array([(k % 2) if link.elements else 0 for k in range(m)])  # element slopes: odd 0-based k
        obj = lambda shape: np.full(shape, sp.S.Zero, dtype=object)  # noqa: E731
        self.P0, self.m_r0, self.E0 = obj((4, 4)), obj(4), obj((4, 4))
        self.P0[0, 0], self.P0[0, 3] = mu * l**3 / 3, mu * l**2 / 2
        self.P0[3, 0], self.P0[3, 3] = mu * l**2 / 2, mu * l
        self.m_r0[0], self.m_r0[3] = mu * l**2 / 2, mu * l
        for k in range(4):
            self.E0[k, k] = sp.S.One
        self.E0[0, 3] = l

        self.C, self.D, self.m_psi = obj((m, 4, 4)), obj((m, m, 4, 4)), obj((m, 4))
        self.K, self.M_dd, self.end_t, self.end_phi = obj((m, m)), obj((m, m)), obj((m, 3)), obj((m, 3))
        for k in range(m):
            ak = int(a[k])
            ax = 1 if ld.directions[k] == "y" else 2
            c1 = self._const(sp, values, f"c_{i}_{k + 1}", ld.C[k, 3, ax] / (mu_v * l_v ** (1 + ak)))
            cx = self._const(sp, values, f"cx_{i}_{k + 1}", ld.C[k, 0, ax] / (mu_v * l_v ** (2 + ak)))
            self.C[k, 3, ax] = mu * l ** (1 + ak) * c1
            self.C[k, 0, ax] = mu * l ** (2 + ak) * cx
            self.m_psi[k, ax] = mu * l ** (1 + ak) * c1
            for j in range(m):
                aj = int(a[j])
                axj = 1 if ld.directions[j] == "y" else 2
                lo, hi = min(k, j), max(k, j)
                dv = ld.D[k, j, ax, axj]
                dk = self._const(sp, values, f"d_{i}_{lo + 1}_{hi + 1}", dv / (mu_v * l_v ** (1 + ak + aj)))
                self.D[k, j, ax, axj] = mu * l ** (1 + ak + aj) * dk
                if ax == axj:
                    self.M_dd[k, j] = self.D[k, j, ax, axj]
                if ld.directions[k] == ld.directions[j] and ld.K[k, j] != 0.0:
                    nm, ei_v = EI[ld.directions[k]]
                    ei = self._par(sp, values, nm, ei_v)
                    kk = self._const(sp, values, f"kappa_{i}_{lo + 1}_{hi + 1}", ld.K[k, j] / (ei_v * l_v ** (ak + aj - 3)))
                    self.K[k, j] = ei * l ** (ak + aj - 3) * kk
            e = self._const(sp, values, f"e_{i}_{k + 1}", ld.end_t[k, ax] / l_v ** ak)
            self.end_t[k, ax] = l ** ak * e
            rot = 2 if ld.directions[k] == "y" else 1
            sv = self._const(sp, values, f"s_{i}_{k + 1}", ld.end_phi[k, rot] / l_v ** (ak - 1))
            self.end_phi[k, rot] = l ** (ak - 1) * sv
        self.J_body = obj((3, 3))
        for r, (nm, jv) in enumerate(zip(("jx", "jy", "jz"), link.rotary_inertia)):
            if jv != 0.0:
                self.J_body[r, r] = l * self._par(sp, values, f"{nm}_{i}", jv)

    @staticmethod
    def _par(sp, values, name, v):
        x = sp.Symbol(name, positive=True)
        values[x] = float(v)
        return x

    @staticmethod
    def _const(sp, values, name, v):
        if v == 0.0:
            return sp.S.Zero
        x = sp.Symbol(name, real=True)
        values[x] = float(v)
        return x


class _ParametricModel:
    """A Model whose link data and gravity are expressions of named parameters (attributes else delegated)."""

    def __init__(self, sp, model, values: dict):
        self._model = model
        self.link_data = tuple(_ParametricLink(sp, lk, ld, i, values)
                               for i, (lk, ld) in enumerate(zip(model.chain.links, model.link_data), start=1))
        g = np.full(3, sp.S.Zero, dtype=object)
        for a, gv in enumerate(model.gravity):
            if gv != 0.0:
                g[a] = sp.Symbol(f"g_{a + 1}", real=True)
                values[g[a]] = float(gv)
        self.gravity = g

    def __getattr__(self, name):
        return getattr(self._model, name)


def derive_equations(model, method: str = "gibbs-appell", *, rational: bool = False,
                     symbols=False, progress=None) -> "Equations":
    """Symbolic equations of motion M(q) qddot = forcing(q, qdot) of ``model`` (Q = 0).

    Parameters
    ----------
    model : gibbsimpact.Model
    method : "gibbs-appell" (the recursive 4x4 moment form, docs/theory.md §6)
        or "lagrange" (Lagrange's equations on T and V of the same moment form).
    rational : bool
        Model numbers as exact rationals of their binary values instead of floats.
    symbols : bool or sequence of str
        Parametric equations (uniform links only). True: each link's length ``l_i``,
        mass per length ``mu_i``, stiffnesses ``EIz_i`` / ``EIy_i``, rotary inertias
        ``jx_i`` ..., and gravity ``g_1 .. g_3`` stay symbols; a sequence of those
        names keeps only them symbolic (the other parameters become numbers). The
        dimensionless modal integrals are named constants (``c_i_k``, ``cx_i_k``,
        ``d_i_k_l``, ``kappa_i_k_l``, ``e_i_k``, ``s_i_k``, see _ParametricLink).
        ``eqs.constants`` lists every value; numeric() and to_python() substitute them.
    progress : None, True (a line on stderr that counts links / equations), or a
        callable(stage: str, done: int, total: int)

    Returns
    -------
    Equations
        ``coordinates``, ``speeds`` (N,) symbols, ``mass_matrix`` (N, N),
        ``forcing`` (N, 1), ``derivation_seconds``; ``operation_count()``,
        ``to_latex(path)``, ``to_python(path)``, ``numeric()``.
    """
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"derive_equations method={method!r} is not supported; choose one of "
                         + ", ".join(repr(m) for m in METHODS))
    from ..model.model import Model

    if not isinstance(model, Model):
        raise ValueError(f"derive_equations model={model!r} must be a gibbsimpact.Model")
    if model.chain.base == "planar" or any(k != "R" for k in model.joint_kinds):
        # The symbolic recursion builds revolute joints behind a spatial free or a fixed base only.
        raise NotImplementedError(
            "derive_equations: prismatic joints and the planar floating base are not derived symbolically yet "
            f"(this model has joints {'-'.join(model.joint_kinds)}, base {model.chain.base!r}); the numeric "
            "kernel simulates them, and tests/reference/planar_oracle.py is an independent derivation")
    import sympy as sp
    from sympy.core.parameters import distribute

    t0 = time.perf_counter()
    names = model.coordinate_names
    q = [sp.Symbol(nm, real=True) for nm in names]
    qd = [sp.Symbol(nm + "_dot", real=True) for nm in names]
    alg = _Algebra(sp, rational)
    if progress is True:
        def progress(stage, done, total):
            end = "\n" if done == total else ""
            print(f"\rderiving ({stage} {done}/{total})", end=end, file=sys.stderr, flush=True)
    alg.progress = progress or None
    constants: dict = {}
    source = _ParametricModel(sp, model, constants) if symbols else model
    with distribute(False):  # keep c*(a + b) unexpanded: shared subexpressions stay shared
        M, forcing = (_gibbs_appell if method == "gibbs-appell" else _lagrange)(source, alg, q, qd)
    M, forcing = sp.ImmutableMatrix(M), sp.ImmutableMatrix(forcing)
    if symbols and symbols is not True:
        keep = {str(x) for x in ([symbols] if isinstance(symbols, str) else symbols)}
        params = {str(k): k for k in constants if re.fullmatch(r"(l|mu|EI[yz]|j[xyz])_\d+|g_\d", str(k))}
        unknown = sorted(keep - set(params))
        if unknown:
            raise ValueError(f"derive_equations symbols={tuple(sorted(keep))!r}: {', '.join(unknown)} not parameters "
                             f"of this model; choose from {', '.join(params)}")
        fixed = {k: sp.Float(constants.pop(k), 17) for name, k in params.items() if name not in keep}
        M, forcing = M.xreplace(fixed), forcing.xreplace(fixed)
    eqs = Equations(model, method, tuple(q), tuple(qd), M, forcing, time.perf_counter() - t0)
    eqs.constants = constants
    return eqs


# ---------------------------------------------------------------------------
# The result object
# ---------------------------------------------------------------------------

class OperationCount(NamedTuple):
    """Operations of the CSE'd program: an Add of k terms is k-1 adds, a Mul of k factors k-1 muls
    (a factor -1 is free), x**k with integer k is |k|-1 muls (+1 for a division);
    sin, cos, sqrt, rodrigues_* are functions."""

    adds: int
    muls: int
    functions: int

    @property
    def total(self) -> int:
        return self.adds + self.muls + self.functions


def _count(exprs, sp):
    adds = muls = funcs = 0
    seen = set()
    stack = list(exprs)
    while stack:
        e = stack.pop()
        if e.is_Atom or e in seen:
            continue
        seen.add(e)
        if e.is_Add:
            adds += len(e.args) - 1
        elif e.is_Mul:
            muls += len([a for a in e.args if a is not sp.S.NegativeOne]) - 1
        elif e.is_Pow:
            x = e.exp
            if x.is_Integer:
                muls += max(abs(int(x)) - 1, 0) + (1 if x < 0 else 0)
            else:
                funcs += 1
        else:
            funcs += 1
        stack.extend(e.args)
    return OperationCount(adds, muls, funcs)


def _latex_name(name: str, dot: bool = False) -> str:
    base, _, rest = name.partition("_")
    if not rest and base[:1] == "X":
        base, rest = "X", base[1:]
    head = {"theta": r"\theta", "delta": r"\delta"}.get(base, base)
    if dot:
        head = rf"\dot{{{head}}}"
    return f"{head}_{{{rest.replace('_', ',')}}}" if rest else head


class NumericEquations:
    """Compiled M(q) and forcing(q, qdot); unpacks as ``mass_matrix, forcing = eqs.numeric()``.

    ``mass_matrix(q)`` (N, N), ``forcing(q, qdot)`` (N,), ``mass_matrix_and_forcing(q, qdot)``
    (both, sharing subexpressions), ``forward_dynamics(q, qdot)`` qddot (N,).
    """

    def __init__(self, namespace):
        self.mass_matrix = namespace["mass_matrix"]
        self.forcing = namespace["forcing"]
        self.mass_matrix_and_forcing = namespace["mass_matrix_and_forcing"]
        self.forward_dynamics = namespace["forward_dynamics"]

    def __iter__(self):
        return iter((self.mass_matrix, self.forcing))


class Equations:
    """M(q) qddot = forcing(q, qdot) as sympy expressions (see derive_equations).

    Attributes
    ----------
    method : str
    coordinates, speeds : tuple of N sympy Symbols (``<name>``, ``<name>_dot``)
    mass_matrix : sympy ImmutableMatrix (N, N) [kg, kg m, kg m^2]
    forcing : sympy ImmutableMatrix (N, 1) [N, N m], Q - h - dV/dq with Q = 0
    derivation_seconds : float, wall time of the derivation
    """

    def __init__(self, model, method, coordinates, speeds, mass_matrix, forcing, seconds):
        self.coordinate_names = model.coordinate_names
        self.method = method
        self.coordinates = coordinates
        self.speeds = speeds
        self.mass_matrix = mass_matrix
        self.forcing = forcing
        self.derivation_seconds = seconds
        self._cse = None
        self._source = None
        self.cse_seconds = None
        self.constants = {}  # symbol -> value of a parametric derivation (symbols=True)
        self._model = model
        self._evaluated_copy = None

    def evaluated(self) -> "Equations":
        """These equations with every named constant replaced by its value (self when there are none)."""
        if not self.constants:
            return self
        if self._evaluated_copy is None:
            import sympy as sp

            sub = {k: sp.Float(v, 17) for k, v in self.constants.items()}
            self._evaluated_copy = Equations(self._model, self.method, self.coordinates, self.speeds,
                                             self.mass_matrix.xreplace(sub), self.forcing.xreplace(sub),
                                             self.derivation_seconds)
        return self._evaluated_copy

    def __repr__(self):
        return f"Equations(method={self.method!r}, N={len(self.coordinates)})"

    # -- common subexpressions ------------------------------------------------
    def cse(self):
        """(replacements [(x_k, expr)], upper-triangle M entries [((j, k), expr)], forcing entries [expr]).

        Computed once, over M's upper triangle and the forcing together.
        """
        if self._cse is None:
            import sympy as sp

            t0 = time.perf_counter()
            N = len(self.coordinates)
            keys = [(j, k) for j in range(N) for k in range(j, N) if self.mass_matrix[j, k] != 0]
            exprs = [self.mass_matrix[j, k] for j, k in keys] + list(self.forcing)
            # tree_cse: the repeated-subexpression pass of sympy.cse without its opt_cse pre-pass, which
            # is slower here and returned wrong sums on the Lagrange expressions (sympy 1.14).
            from sympy.simplify.cse_main import tree_cse

            repl, red = tree_cse(exprs, sp.numbered_symbols("x"), {}, "none")
            self._cse = (repl, list(zip(keys, red[:len(keys)])), red[len(keys):])
            self.cse_seconds = time.perf_counter() - t0
        return self._cse

    def operation_count(self) -> OperationCount:
        """(adds, muls, functions) to evaluate M and forcing after common-subexpression elimination."""
        import sympy as sp

        if self.constants:
            return self.evaluated().operation_count()
        repl, Mred, fred = self.cse()
        return _count([e for _, e in repl] + [e for _, e in Mred] + list(fred), sp)

    # -- writers ----------------------------------------------------------------
    def to_latex(self, path) -> Path:
        """Write a LaTeX document with M(q) qddot = forcing: auxiliary quantities x_k, then M_jk, f_j."""
        import sympy as sp

        names = {c: _latex_name(nm) for c, nm in zip(self.coordinates, self.coordinate_names)}
        names.update({c: _latex_name(nm, dot=True) for c, nm in zip(self.speeds, self.coordinate_names)})
        repl, Mred, fred = self.cse()
        names.update({x: f"x_{{{x.name[1:]}}}" for x, _ in repl})

        def tex(e):
            return sp.latex(e, symbol_names=names)

        N = len(self.coordinates)
        lines = [
            r"\documentclass{article}", r"\usepackage{amsmath}", r"\allowdisplaybreaks", r"\begin{document}",
            rf"\section*{{Equations of motion ({self.method})}}",
            r"$M(q)\,\ddot q = f(q, \dot q)$ with $q = (" + ", ".join(names[c] for c in self.coordinates)
            + rf")$, $N = {N}$. $M$ is symmetric; entries not listed are zero.",
        ]

        def block(title, rows):
            lines.append(rf"\subsection*{{{title}}}")
            if not rows:
                lines.append("None.")
                return
            lines.append(r"\begin{align*}")
            lines.append(" \\\\\n".join(f"{lhs} &= {rhs}" for lhs, rhs in rows))
            lines.append(r"\end{align*}")

        block("Auxiliary quantities", [(names[x], tex(e)) for x, e in repl])
        block("Mass matrix", [(f"M_{{{j + 1},{k + 1}}}", tex(e)) for (j, k), e in Mred])
        block("Forcing", [(f"f_{{{j + 1}}}", tex(e)) for j, e in enumerate(fred)])
        if self.constants:
            block("Parameters and named constants", [(tex(k), f"{v:.17g}") for k, v in self.constants.items()])
        lines.append(r"\end{document}")
        path = Path(path)
        path.write_text("\n".join(lines) + "\n")
        return path

    def python_source(self) -> str:
        """Source of a standalone module (math and numpy only) computing M and the forcing."""
        if self.constants:
            return self.evaluated().python_source()
        if self._source is None:
            self._source = _python_source(self)
        return self._source

    def to_python(self, path) -> Path:
        """Write ``python_source()`` to ``path``: mass_matrix(q), forcing(q, qdot),
        mass_matrix_and_forcing(q, qdot), forward_dynamics(q, qdot)."""
        path = Path(path)
        path.write_text(self.python_source())
        return path

    def numeric(self) -> NumericEquations:
        """Compile the generated module in memory: callables of q (N,), qdot (N,) returning numpy arrays."""
        ns: dict = {"__name__": "gibbsimpact_equations"}
        exec(compile(self.python_source(), "<gibbsimpact.symbolic>", "exec"), ns)
        return NumericEquations(ns)


# The generated module is standalone: it carries rodrigues_coefficient's own source.
_HELPERS = "\n" + inspect.getsource(rodrigues_coefficient).replace(
    "def rodrigues_coefficient(", "def _rodrigues(").replace("_SERIES_TERMS", str(_SERIES_TERMS))


class _PythonPrinter:
    """Python source of a CSE'd expression (math for scalars); linear in the expression size."""

    _FUNCS = {"sin": "math.sin", "cos": "math.cos", "tan": "math.tan", "exp": "math.exp", "log": "math.log"}

    def __init__(self, sp, names):
        self.sp, self.names = sp, names

    def __call__(self, e):
        sp = self.sp
        if e.is_Symbol:
            return self.names.get(e, e.name)
        if e.is_Integer:
            return f"{int(e)}.0" if abs(int(e)) < 2**53 else repr(float(e))
        if e.is_Rational:
            return f"({e.p}/{e.q})"
        if e.is_Float:
            return repr(float(e))
        if e.is_Add:
            out = []
            for k, a in enumerate(e.args):
                if a.is_Mul and a.args[0].is_Number and a.args[0] < 0:
                    out.append((" - " if k else "-") + self(-a))
                elif a.is_Number and a < 0:
                    out.append((" - " if k else "-") + self(-a))
                else:
                    out.append((" + " if k else "") + self(a))
            return "(" + "".join(out) + ")"
        if e.is_Mul:
            num, den = [], []
            for a in e.args:
                if a.is_Pow and a.exp.is_Integer and a.exp < 0:
                    den.append(self(a.base) if a.exp == -1 else self(a.base ** -a.exp))
                elif a is sp.S.NegativeOne:
                    num.insert(0, "-1.0")
                else:
                    num.append(self(a))
            text = "*".join(num) if num else "1.0"
            if den:
                text = f"{text}/({'*'.join(den)})"
            return "(" + text + ")"
        if e.is_Pow:
            b, x = self(e.base), e.exp
            if x == 2:
                return f"({b}*{b})"
            if x == -1:
                return f"(1.0/{b})"
            if x == sp.S.Half:
                return f"math.sqrt({b})"
            return f"({b}**{self(x)})"
        if isinstance(e, sp.Function) and len(e.args) == 1:
            name = type(e).__name__
            return f"{self._FUNCS.get(name, name)}({self(e.args[0])})"
        raise NotImplementedError(f"no Python translation for {type(e).__name__}: {e}")


def _python_source(eqs: Equations) -> str:
    import sympy as sp

    repl, Mred, fred = eqs.cse()
    N = len(eqs.coordinates)
    names = {c: f"q_{k}" for k, c in enumerate(eqs.coordinates)}
    names.update({c: f"qd_{k}" for k, c in enumerate(eqs.speeds)})
    code = _PythonPrinter(sp, names)

    deps = {x: e.free_symbols for x, e in repl}
    funcs = set()
    for _, e in repl:
        funcs |= {type(f).__name__ for f in e.atoms(sp.Function) if type(f).__name__.startswith("rodrigues_")}

    def needed(outputs):
        need = set().union(*[e.free_symbols for e in outputs]) if outputs else set()
        for x, _ in reversed(repl):
            if x in need:
                need |= deps[x]
        return [(x, e) for x, e in repl if x in need]

    def body(outputs, with_qdot):
        out = ["    q = np.asarray(q, dtype=float).tolist()"]
        if N:
            out.append("    " + ", ".join(f"q_{k}" for k in range(N)) + (", = q" if N == 1 else " = q"))
        if with_qdot:
            out.append("    qdot = np.asarray(qdot, dtype=float).tolist()")
            out.append("    " + ", ".join(f"qd_{k}" for k in range(N)) + (", = qdot" if N == 1 else " = qdot"))
        for x, e in needed(outputs):
            out.append(f"    {x} = {code(e)}")
        return out

    def mass_lines():
        out, ent = [], {}
        for (j, k), e in Mred:
            out.append(f"    m_{j}_{k} = {code(e)}")
            ent[(j, k)] = ent[(k, j)] = f"m_{j}_{k}"
        rows = ", ".join("[" + ", ".join(ent.get((j, k), "0.0") for k in range(N)) + "]" for j in range(N))
        out.append(f"    M = np.array([{rows}])")
        return out

    def forcing_lines():
        return [f"    f = np.array([{', '.join(code(e) for e in fred)}], dtype=float)"]

    Mexprs, fexprs = [e for _, e in Mred], list(fred)
    src = [
        '"""M(q) qddot = forcing(q, qdot) of a gibbsimpact chain, generated by gibbsimpact.symbolic',
        f"(method={eqs.method!r}, N = {N}). Needs only math and numpy.",
        "",
        "q = [" + ", ".join(eqs.coordinate_names) + "]  [m, rad, m]; qdot the same order.",
        "mass_matrix(q) (N, N) [kg, kg m, kg m^2]; forcing(q, qdot) (N,) [N, N m] = -h - dV/dq.",
        '"""',
        "",
        "import math",
        "",
        "import numpy as np",
        "",
        f"N = {N}",
        f"COORDINATES = {tuple(eqs.coordinate_names)!r}",
        f"METHOD = {eqs.method!r}",
        _HELPERS,
    ]
    for name in sorted(funcs):
        kind, order = name[len("rodrigues_")], int(name[len("rodrigues_") + 1:])
        src += [f"def {name}(s):", f"    return _rodrigues({kind!r}, {order}, s)", "", ""]
    src += ["def mass_matrix(q):", '    """M(q), shape (N, N)."""'] + body(Mexprs, False) + mass_lines()
    src += ["    return M", "", ""]
    src += ["def forcing(q, qdot):", '    """forcing(q, qdot) = -h - dV/dq, shape (N,)."""']
    src += body(fexprs, True) + forcing_lines() + ["    return f", "", ""]
    src += ["def mass_matrix_and_forcing(q, qdot):", '    """(M (N, N), forcing (N,)) sharing subexpressions."""']
    src += body(Mexprs + fexprs, True) + mass_lines() + forcing_lines() + ["    return M, f", "", ""]
    src += ["def forward_dynamics(q, qdot):", '    """qddot (N,) from M qddot = forcing."""',
            "    M, f = mass_matrix_and_forcing(q, qdot)", "    return np.linalg.solve(M, f)", ""]
    return "\n".join(src)
