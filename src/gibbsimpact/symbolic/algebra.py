"""The shared algebra of both derivation routes: Rodrigues coefficients and dense 4x4 algebra on sympy.

The end rotation Rot(phi), phi = end_phi^T delta [rad], is the exact
Rodrigues rotation R = I + a(s) K + b(s) K^2, K = skew(phi), s = phi.phi,
a = sin(t)/t, b = (1 - cos t)/t^2, t = sqrt(s). a and b (and their
s-derivatives) are the functions ``rodrigues_a<k>(s)``, ``rodrigues_b<k>(s)``
(k-th s-derivative), evaluated numerically with a power series for s < 1, so
they are finite at phi = 0. Where only one component of phi is non-zero (every
planar chain) Rot(phi) is written exactly as the single-axis rotation.
"""

from __future__ import annotations

import math

import numpy as np

SERIES_TERMS = 16

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
        for n in range(order, order + SERIES_TERMS):
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


def rodrigues_function(kind: str, order: int):
    """The sympy function rodrigues_<kind><order>(s) (created once, derivative -> order + 1)."""
    key = (kind, order)
    if key in _ROD_CACHE:
        return _ROD_CACHE[key]
    import sympy as sp

    off = 1 if kind == "a" else 2

    def fdiff(self, argindex=1):
        return rodrigues_function(kind, order + 1)(self.args[0])

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

class Algebra:
    """Dense algebra on nested lists of sympy expressions that skips exact zeros and ones.

    Matrices are lists of rows; model numbers enter through const / cmat (17-digit
    Floats, or exact Rationals when ``rational``); ``progress`` is None or
    callable(stage: str, done: int, total: int), called by tick.
    """

    def __init__(self, sp, rational: bool, progress=None):
        self.sp = sp
        self.Z, self.O, self.two = sp.S.Zero, sp.S.One, sp.Integer(2)
        self.rational = rational
        self.progress = progress

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


def rot4(alg, axis: int, angle):
    """Rotation about the coordinate axis (4, 4), exact cos/sin of angle."""
    sp = alg.sp
    c, s = sp.cos(angle), sp.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = alg.eye(4)
    R[i][i] = R[j][j] = c
    R[i][j], R[j][i] = -s, s
    return R
