"""Independent symbolic derivation of a free-flying flexible chain (test oracle).

This module re-derives, from ``shared/design/docs/theory.md §1, §2, §3, §6 and
with *no code shared with gibbsimpact*, the equations of motion

    M(q) qddot = forcing(q, qdot)

of a free-flying chain of Euler-Bernoulli links, by a different route than the
package's recursive 4x4 Gibbs-Appell algorithm:

* kinematics with ``sympy.physics.mechanics`` frames and points
  (``ReferenceFrame.orient_axis`` for every rotation, ``Vector.dt`` for every
  velocity);
* the kinetic energy of each link written in closed form through its *modal
  integrals* (``int mu``, ``int mu x``, ``int mu x^2``, ``int mu psi_k``,
  ``int mu x psi_k``, ``int mu psi_k psi_l``) which are computed here with
  mpmath at 40 digits from mode shapes whose frequency roots and normalisation
  are also computed here;
* Kane's equations via ``KanesMethod`` (default; each link's continuum is
  replaced by dynamically equivalent particles from an LDL^T factorisation of
  its modal Gram matrix, see ``derive``), or Lagrange's equations of the second
  kind via ``LagrangesMethod`` on L = T - V (``method="lagrange"``, slower; the
  two routes agree to ~1e-15 on the three test chains);
* ``lambdify(..., cse=True)`` so that tests can evaluate at random states.

Conventions (binding, docs/theory.md §1-§3):

    q = [X1, X2, X3, th_m1, th_0, th_1, ..., th_n, delta_1_1 .. delta_n_mn]
    T_1 = Trans(X) Rx(th_m1) Ry(th_0) Rz(th_1)
    T_i = T_(i-1) E_(i-1) Rz(th_i),  E_j = Trans(l_j + u, v(l_j), w(l_j)) Rot(phi_j)
    phi_j = (0, -w'(l_j), v'(l_j))
    p(x) = T_i (x + u(x), v(x), w(x), 1)^T,  v = sum psi_k delta_k (y-modes), w (z-modes)
    T = sum_i 1/2 int mu |p_dot|^2 dx + 1/2 omega_i^T J_i omega_i   (omega_i of T_i, in T_i)
    J_i = l_i diag(j_x, j_y, j_z)
    V = - sum_i int mu g.p dx + 1/2 sum_i delta_i^T K_i delta_i
    K_kl = int EI_z psi_k'' psi_l'' (y-modes), int EI_y psi_k'' psi_l'' (z-modes)

Hermite cubic finite-element links (docs/theory.md §4, §4.4): a RefLink with
``elements = n_e > 0`` has, per direction in ``element_directions``, the 2 n_e
global Hermite functions psi_k of sec. 9.1 as its assumed modes, coordinates
(w_1, t_1, ..., w_ne, t_ne) per direction, the direction sets in the order given.
Their integrals are computed exactly here (sympy polynomials per element,
rational arithmetic on the exact binary values of l, mu, EI; ``fe_integrals_exact``).

Only uniform links (constant mu, EI) and no axial/torsion modes are supported;
``Rot(phi)`` is supported when at most one of v'(l), w'(l) is generically
non-zero on a link that has a successor (then it is the exact single-axis
rotation Rz(v'(l)) or Ry(-w'(l))).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import mpmath as mp
import numpy as np
import sympy as sp
from sympy.physics.mechanics import (
    KanesMethod,
    LagrangesMethod,
    Particle,
    Point,
    ReferenceFrame,
    RigidBody,
    dynamicsymbols,
    inertia,
)

MP_DPS = 40

# --------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class RefMode:
    """One assumed mode: boundary condition, bending direction, mode number."""

    bc: str  # "clamped-clamped" | "clamped-free"
    direction: str  # "y" (v, bending with EI_z) | "z" (w, bending with EI_y)
    number: int = 1


@dataclass(frozen=True)
class RefLink:
    """One uniform link. EI_y bends along z (w), EI_z bends along y (v).

    ``elements = n_e > 0``: Hermite cubic finite elements (docs/theory.md §4.1, §4.4) instead of ``modes``; 2 n_e coordinates (w_1, t_1, ..., w_ne, t_ne) per
    direction in ``element_directions`` (in that order; "y" uses EI_z, "z" EI_y).
    A link with a successor may have only one of the two directions (Rot(phi)).
    """

    length: float
    mu: float
    EI_y: float
    EI_z: float
    modes: tuple = ()
    rotary_inertia: tuple = (0.0, 0.0, 0.0)  # (j_x, j_y, j_z) per unit length, kg m
    elements: int = 0  # n_e > 0: Hermite cubic finite elements instead of modes
    element_directions: tuple = ("y",)  # direction sets of the elements, in coordinate order

    def __post_init__(self):
        if self.elements and self.modes:
            raise ValueError("a RefLink has either modes or elements, not both")
        if self.elements < 0 or any(d not in ("y", "z") for d in self.element_directions):
            raise ValueError("elements >= 0, element_directions from 'y', 'z'")
        if self.elements and len(set(self.element_directions)) != len(self.element_directions):
            raise ValueError("repeated element direction")

    @property
    def directions(self) -> tuple:
        """Bending direction ("y" or "z") of every elastic coordinate, in order."""
        if self.elements:
            return tuple(d for d in self.element_directions for _ in range(2 * self.elements))
        return tuple(m.direction for m in self.modes)

    @property
    def n_coords(self) -> int:
        return len(self.directions)


# --------------------------------------------------------------------------
# Mode shapes (mpmath, independent of the package)
# --------------------------------------------------------------------------


def _freq_eq(bc):
    # clamped-clamped: cos(bl) cosh(bl) = 1 ; clamped-free: cos(bl) cosh(bl) = -1
    if bc == "clamped-clamped":
        return lambda b: mp.cos(b) * mp.cosh(b) - 1, lambda k: (k + mp.mpf(1) / 2) * mp.pi
    if bc == "clamped-free":
        return lambda b: mp.cos(b) * mp.cosh(b) + 1, lambda k: (k - mp.mpf(1) / 2) * mp.pi
    raise ValueError(f"unsupported boundary condition {bc!r}")


@lru_cache(maxsize=None)
def beta_l(bc: str, number: int):
    """k-th positive root beta*l of the frequency equation (mpmath, MP_DPS digits)."""
    with mp.workdps(MP_DPS):
        f, guess = _freq_eq(bc)
        # f grows like cosh; divide by cosh to get a well-scaled function
        g = lambda b: f(b) / mp.cosh(b)  # noqa: E731
        return mp.findroot(g, guess(number))


class ModeShape:
    """psi(x) = C [cosh bx - cos bx - sigma (sinh bx - sin bx)], max|psi| = 1."""

    def __init__(self, bc: str, number: int, length: float):
        self.bc, self.number = bc, number
        with mp.workdps(MP_DPS):
            self.l = mp.mpf(length)
            bl = beta_l(bc, number)
            self.beta = bl / self.l
            if bc == "clamped-clamped":
                self.sigma = (mp.cosh(bl) - mp.cos(bl)) / (mp.sinh(bl) - mp.sin(bl))
            else:
                self.sigma = (mp.cosh(bl) + mp.cos(bl)) / (mp.sinh(bl) + mp.sin(bl))
            self.C = mp.mpf(1)
            # locate max |psi| on [0, l]: dense scan, then refine on psi' = 0
            xs = [self.l * i / 4000 for i in range(4001)]
            vals = [abs(self.psi(x)) for x in xs]
            imax = max(range(len(xs)), key=lambda i: vals[i])
            if 0 < imax < len(xs) - 1:
                xm = mp.findroot(lambda x: self.dpsi(x), xs[imax])
            else:
                xm = xs[imax]
            pm = self.psi(xm)
            self.x_max = xm
            self.C = 1 / pm  # |psi(xm)| = 1 and psi(xm) > 0

    def psi(self, x):
        b = self.beta
        return self.C * (mp.cosh(b * x) - mp.cos(b * x) - self.sigma * (mp.sinh(b * x) - mp.sin(b * x)))

    def dpsi(self, x):
        b = self.beta
        return self.C * b * (mp.sinh(b * x) + mp.sin(b * x) - self.sigma * (mp.cosh(b * x) - mp.cos(b * x)))

    def ddpsi(self, x):
        b = self.beta
        return self.C * b**2 * (mp.cosh(b * x) + mp.cos(b * x) - self.sigma * (mp.sinh(b * x) + mp.sin(b * x)))


# --------------------------------------------------------------------------
# Hermite cubic finite elements (sympy, exact rational arithmetic)
# --------------------------------------------------------------------------

_X = sp.Symbol("x")
_ETA = sp.Symbol("eta")
# local Hermite cubics of docs/theory.md §4.1
HERMITE = (
    1 - 3 * _ETA**2 + 2 * _ETA**3,  # H1
    _ETA - 2 * _ETA**2 + _ETA**3,  # H2
    3 * _ETA**2 - 2 * _ETA**3,  # H3
    -_ETA**2 + _ETA**3,  # H4
)


class HermiteBasis:
    """Global Hermite basis psi_1 .. psi_(2 n_e) on [0, l] (docs/theory.md §4.1).

    Node 0 is clamped and removed; psi_(2j-1) (deflection w_j) is H3 on element j
    and H1 on element j+1, psi_(2j) (slope t_j) is h H4 on element j and h H2 on
    element j+1.  ``pieces[k][e]`` is psi_(k+1) on element e+1 as an exact sympy
    polynomial in the global abscissa x (rational coefficients; l is the exact
    binary value of the float).
    """

    def __init__(self, length, n_e: int):
        if n_e < 1:
            raise ValueError("n_e >= 1")
        self.n_e = n_e
        self.l = sp.Rational(length)
        self.h = h = self.l / n_e
        self.nodes = [j * h for j in range(n_e + 1)]
        m = 2 * n_e
        self.pieces = [[sp.S.Zero] * n_e for _ in range(m)]
        for e in range(1, n_e + 1):  # element e spans [x_(e-1), x_e]
            sub = {_ETA: (_X - self.nodes[e - 1]) / h}
            H1, H2, H3, H4 = (sp.expand(Hf.xreplace(sub)) for Hf in HERMITE)
            if e >= 2:  # left node e-1 is free: w_(e-1) -> H1, t_(e-1) -> h H2
                self.pieces[2 * (e - 1) - 2][e - 1] = H1
                self.pieces[2 * (e - 1) - 1][e - 1] = sp.expand(h * H2)
            self.pieces[2 * e - 2][e - 1] = H3  # w_e
            self.pieces[2 * e - 1][e - 1] = sp.expand(h * H4)  # t_e

    @property
    def m(self) -> int:
        return 2 * self.n_e

    def element_integral(self, f) -> sp.Expr:
        """sum_e int_(x_(e-1))^(x_e) f(e) dx, f(e) a polynomial in x (exact)."""
        total = sp.S.Zero
        for e in range(self.n_e):
            F = sp.Poly(f(e), _X, domain=sp.QQ).integrate()
            total += F.eval(self.nodes[e + 1]) - F.eval(self.nodes[e])
        return total

    def value(self, k: int, x, derivative: int = 0) -> sp.Expr:
        """psi_(k+1)^(derivative)(x), exact (at an interior node the right-hand
        element's piece; the pieces agree there up to the first derivative)."""
        x = sp.Rational(x) if not isinstance(x, sp.Basic) else x
        e = min(int(sp.floor(x / self.h)), self.n_e - 1) if x > 0 else 0
        return sp.diff(self.pieces[k][e], _X, derivative).subs(_X, x)


@lru_cache(maxsize=None)
def fe_integrals_exact(length, mu, EI, n_e: int) -> dict:
    """Exact (rational) integrals of the Hermite basis of one uniform link.

    Returns sympy matrices: s_k = int mu psi_k, t_k = int mu x psi_k,
    S_kl = int mu psi_k psi_l, K_kl = int EI psi_k'' psi_l'', and
    end_value_k = psi_k(l), end_slope_k = psi_k'(l); plus the basis.
    """
    B = HermiteBasis(length, n_e)
    m = B.m
    mu_r, EI_r = sp.Rational(mu), sp.Rational(EI)
    P = B.pieces
    s = sp.Matrix([mu_r * B.element_integral(lambda e, k=k: P[k][e]) for k in range(m)])
    t = sp.Matrix([mu_r * B.element_integral(lambda e, k=k: _X * P[k][e]) for k in range(m)])
    S = sp.zeros(m, m)
    K = sp.zeros(m, m)
    for a in range(m):
        for b in range(a, m):
            S[a, b] = S[b, a] = mu_r * B.element_integral(lambda e: P[a][e] * P[b][e])
            K[a, b] = K[b, a] = EI_r * B.element_integral(
                lambda e: sp.diff(P[a][e], _X, 2) * sp.diff(P[b][e], _X, 2))
    end_value = sp.Matrix([B.value(k, B.l) for k in range(m)])
    end_slope = sp.Matrix([B.value(k, B.l, 1) for k in range(m)])
    return dict(s=s, t=t, S=S, K=K, end_value=end_value, end_slope=end_slope, basis=B)


def _fe_modal_integrals(link) -> "ModalIntegrals":
    """Per-coordinate integrals of an FE link: the direction sets share one basis."""
    dirs = link.directions
    m = len(dirs)
    ne2 = 2 * link.elements
    loc = [a % ne2 for a in range(m)]  # index of the Hermite function of coordinate a
    ex = {d: fe_integrals_exact(link.length, link.mu, link.EI_z if d == "y" else link.EI_y, link.elements)
          for d in link.element_directions}
    e0 = ex[link.element_directions[0]]  # s, t, S, end values do not depend on EI
    f = lambda v: float(v)  # noqa: E731
    s = np.array([f(e0["s"][loc[a]]) for a in range(m)])
    t = np.array([f(e0["t"][loc[a]]) for a in range(m)])
    S = np.array([[f(e0["S"][loc[a], loc[b]]) for b in range(m)] for a in range(m)])
    K = np.array([[f(ex[dirs[a]]["K"][loc[a], loc[b]]) if dirs[a] == dirs[b] else 0.0
                   for b in range(m)] for a in range(m)])
    l, mu = sp.Rational(link.length), sp.Rational(link.mu)
    return ModalIntegrals(
        m0=f(mu * l), m1=f(mu * l**2 / 2), m2=f(mu * l**3 / 3),
        s=s, t=t, S=S, K=K,
        end_value=np.array([f(e0["end_value"][loc[a]]) for a in range(m)]),
        end_slope=np.array([f(e0["end_slope"][loc[a]]) for a in range(m)]),
        shapes=[e0["basis"]], shape_ids=tuple(("hermite", k) for k in loc), exact=ex,
    )


@dataclass
class ModalIntegrals:
    """Exact (40-digit) modal integrals of one uniform link."""

    m0: float  # int mu dx
    m1: float  # int mu x dx
    m2: float  # int mu x^2 dx
    s: np.ndarray  # s_k = int mu psi_k dx
    t: np.ndarray  # t_k = int mu x psi_k dx
    S: np.ndarray  # S_kl = int mu psi_k psi_l dx
    K: np.ndarray  # K_kl = int EI psi_k'' psi_l'' dx (EI_z for y, EI_y for z; 0 across)
    end_value: np.ndarray  # psi_k(l)
    end_slope: np.ndarray  # psi_k'(l)
    shapes: list = field(default_factory=list)  # ModeShape per mode; [HermiteBasis] for FE
    # coordinates with equal ids have the same shape function psi (e.g. a y- and a
    # z-coordinate of one Hermite function): the Kane route merges them
    shape_ids: tuple = ()
    exact: dict | None = None  # FE: fe_integrals_exact(...) per direction


def _quad(f, l):
    return mp.quad(f, [0, l / 4, l / 2, 3 * l / 4, l])


@lru_cache(maxsize=None)
def modal_integrals(link: RefLink) -> ModalIntegrals:
    """Modal integrals of one link (cached; treat the result as read-only)."""
    if link.elements:
        return _fe_modal_integrals(link)
    with mp.workdps(MP_DPS):
        l = mp.mpf(link.length)
        mu = mp.mpf(link.mu)
        shapes = [ModeShape(m.bc, m.number, link.length) for m in link.modes]
        m = len(shapes)
        s = np.zeros(m)
        t = np.zeros(m)
        S = np.zeros((m, m))
        K = np.zeros((m, m))
        for a, pa in enumerate(shapes):
            s[a] = float(mu * _quad(pa.psi, l))
            t[a] = float(mu * _quad(lambda x: x * pa.psi(x), l))
            for b, pb in enumerate(shapes):
                S[a, b] = float(mu * _quad(lambda x: pa.psi(x) * pb.psi(x), l))
                da, db = link.modes[a].direction, link.modes[b].direction
                if da == db:
                    EI = mp.mpf(link.EI_z if da == "y" else link.EI_y)
                    K[a, b] = float(EI * _quad(lambda x: pa.ddpsi(x) * pb.ddpsi(x), l))
        end_value = np.array([float(p.psi(l)) for p in shapes])
        end_slope = np.array([float(p.dpsi(l)) for p in shapes])
        # clamped-clamped: psi(l) = psi'(l) = 0 exactly
        for a, mode in enumerate(link.modes):
            if mode.bc == "clamped-clamped":
                end_value[a] = 0.0
                end_slope[a] = 0.0
        return ModalIntegrals(
            m0=float(mu * l),
            m1=float(mu * l**2 / 2),
            m2=float(mu * l**3 / 3),
            s=s, t=t, S=S, K=K,
            end_value=end_value, end_slope=end_slope, shapes=shapes,
            shape_ids=tuple((m.bc, m.number) for m in link.modes),
        )


# --------------------------------------------------------------------------
# Symbolic model
# --------------------------------------------------------------------------


def _mat3(v, frame):
    return v.to_matrix(frame)


def ldl(A):
    """A = L D L^T with unit lower-triangular L (mpmath, MP_DPS digits)."""
    with mp.workdps(MP_DPS):
        A = mp.matrix(A.tolist())
        n = A.rows
        L = mp.eye(n)
        D = [mp.mpf(0)] * n
        for j in range(n):
            D[j] = A[j, j] - sum(L[j, k] ** 2 * D[k] for k in range(j))
            for i in range(j + 1, n):
                L[i, j] = (A[i, j] - sum(L[i, k] * L[j, k] * D[k] for k in range(j))) / D[j]
        return np.array([[float(L[i, j]) for j in range(n)] for i in range(n)]), np.array([float(d) for d in D])


def moment_matrix(mi: ModalIntegrals) -> np.ndarray:
    """Gram matrix of the functions (1, x, psi_1..psi_m) weighted by mu.

    int mu |p_dot|^2 dx = V^T G V  with  p_dot(x) = A0 + x A1 + sum_k psi_k(x) B_k,
    V = (A0, A1, B_1, ..., B_m).
    """
    m = len(mi.s)
    G = np.zeros((m + 2, m + 2))
    G[0, 0], G[0, 1], G[1, 1] = mi.m0, mi.m1, mi.m2
    G[1, 0] = mi.m1
    G[0, 2:] = G[2:, 0] = mi.s
    G[1, 2:] = G[2:, 1] = mi.t
    G[2:, 2:] = mi.S
    return G


@dataclass
class ReferenceModel:
    """Lambdified oracle. All callables take 1-D numpy arrays of length N."""

    links: tuple
    gravity: tuple
    coordinate_names: list
    n_dof: int
    _M: object
    _F: object
    _T: object
    _V: object
    _tip: object

    def mass_matrix(self, q):
        """M(q), shape (N, N)."""
        return np.asarray(self._M(*np.asarray(q, float)), dtype=float)

    def forcing(self, q, qdot):
        """Right-hand side of M qddot = forcing, shape (N,)."""
        args = np.concatenate([np.asarray(q, float), np.asarray(qdot, float)])
        return np.asarray(self._F(*args), dtype=float).reshape(-1)

    def forward_dynamics(self, q, qdot):
        """qddot = M^-1 forcing, shape (N,)."""
        return np.linalg.solve(self.mass_matrix(q), self.forcing(q, qdot))

    def kinetic_energy(self, q, qdot):
        """T from the modal-integral quadratic form (not from M), J."""
        args = np.concatenate([np.asarray(q, float), np.asarray(qdot, float)])
        return float(self._T(*args))

    def potential_energy(self, q):
        """V = gravity + strain, J."""
        return float(self._V(*np.asarray(q, float)))

    def energy(self, q, qdot):
        return self.kinetic_energy(q, qdot) + self.potential_energy(q)

    def joint_points(self, q):
        """O_1 .. O_(n+1) in the inertial frame, shape (n+1, 3)."""
        return np.asarray(self._tip(*np.asarray(q, float)), dtype=float).reshape(-1, 3)


def derive(links, gravity=(0.0, -9.81, 0.0), *, method="kane"):
    """Derive the chain symbolically; return (symbolic dict, ReferenceModel).

    Kinetic energy of link i, with p_dot(x) = A0 + x A1 + sum_k psi_k(x) B_k,
    A0 = d/dt O_i, A1 = d/dt e_x(i), B_k = d/dt(delta_k e_dir(k)):

      T_i = 1/2 V^T G V + 1/2 omega_i^T J_i omega_i,   V = (A0, A1, B_1..B_m),
      G = [[m0, m1, s^T], [m1, m2, t^T], [s, t, S]]         (moment_matrix)
      V_i = -g . (m0 O_i + R_i (m1 e_x + sum_k s_k delta_k e_dir(k)))
            + 1/2 delta^T K delta

    method="lagrange": LagrangesMethod on L = sum_i (T_i - V_i).

    method="kane": G = L D L^T (unit lower L).  Then V^T G V = sum_j D_j |W_j|^2
    with W_j = sum_a L_aj V_a = d/dt P_j, P_j = sum_a L_aj (O_i, e_x, delta_k e_k)_a.
    So the continuum is dynamically equivalent to m+2 particles of mass D_j at
    the (kinematic) positions P_j.  (Coordinates with the same shape function,
    e.g. the y- and z-coordinates of one Hermite function, are first merged into
    one term psi (B_k + B_k'): one particle per distinct function, so that G is
    regular.)  L_a0 = G_a0 / m0, so P_0 is the centre of mass and D_0 = m0;
    the other P_j are not material points.  Since int mu p dx = m0 P_0, gravity
    is the single load m0 g on P_0.  The link-frame rotary
    inertia is a massless RigidBody with inertia dyadic J_i in frame T_i.
    The strain force -K delta is added to the forcing by hand.
    KanesMethod with u = qdot then gives M udot = forcing.
    """
    if method not in ("kane", "lagrange"):
        raise ValueError("method must be 'kane' or 'lagrange'")
    links = tuple(links)
    n = len(links)
    ints = [modal_integrals(lk) for lk in links]

    X = dynamicsymbols("X1:4")
    th = dynamicsymbols("th_m1 th_0") + [dynamicsymbols(f"th_{i}") for i in range(1, n + 1)]
    deltas = []
    names = ["X1", "X2", "X3", "th_m1", "th_0"] + [f"th_{i}" for i in range(1, n + 1)]
    for i, lk in enumerate(links, start=1):
        di = [dynamicsymbols(f"delta_{i}_{k}") for k in range(1, lk.n_coords + 1)]
        deltas.append(di)
        names += [f"delta_{i}_{k}" for k in range(1, lk.n_coords + 1)]
    q = list(X) + list(th) + [d for di in deltas for d in di]
    t = dynamicsymbols._t
    qd = [qi.diff(t) for qi in q]

    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    # T_1 = Trans(X) Rx(th_m1) Ry(th_0) Rz(th_1): successive body-axis rotations
    Fa = ReferenceFrame("Fa")
    Fa.orient_axis(N, N.x, th[0])
    Fb = ReferenceFrame("Fb")
    Fb.orient_axis(Fa, Fa.y, th[1])
    frame = ReferenceFrame("L1")
    frame.orient_axis(Fb, Fb.z, th[2])
    origin = O.locatenew("O1", X[0] * N.x + X[1] * N.y + X[2] * N.z)

    gvec = gravity[0] * N.x + gravity[1] * N.y + gravity[2] * N.z
    T_total = sp.S.Zero
    V_total = sp.S.Zero
    strain = [sp.S.Zero] * len(q)  # dV_strain/dq
    joint_pts = []
    frames = []
    bodies, loads = [], []
    for i, (lk, mi, di) in enumerate(zip(links, ints, deltas), start=1):
        frames.append(frame)
        joint_pts.append(origin)
        dirs = [frame.y if d == "y" else frame.z for d in lk.directions]
        rpos = origin.pos_from(O)
        G = moment_matrix(mi)

        # --- kinetic energy as the modal-integral quadratic form -------------
        A0 = rpos.dt(N)  # velocity of O_i
        A1 = frame.x.dt(N)  # omega x e_x
        B = [(dk * ek).dt(N) for dk, ek in zip(di, dirs)]
        vel = [_mat3(v, frame) for v in [A0, A1] + B]  # components in the link frame
        Ti = sp.S.Zero
        for a in range(len(vel)):
            for b in range(len(vel)):
                if G[a, b] != 0.0:
                    Ti += G[a, b] * vel[a].dot(vel[b])
        Ti = Ti / 2
        w = _mat3(frame.ang_vel_in(N), frame)
        J = [lk.length * j for j in lk.rotary_inertia]
        Ti += sp.Rational(1, 2) * sum(J[c] * w[c] ** 2 for c in range(3))
        T_total += Ti

        # --- potential ------------------------------------------------------
        first_moment = mi.m0 * rpos + mi.m1 * frame.x
        for k in range(len(di)):
            first_moment += mi.s[k] * di[k] * dirs[k]
        V_total += -gvec.dot(first_moment)
        off = q.index(di[0]) if di else 0
        for k in range(len(di)):
            for kk in range(len(di)):
                if mi.K[k, kk] != 0.0:
                    V_total += sp.Rational(1, 2) * mi.K[k, kk] * di[k] * di[kk]
                    strain[off + k] += mi.K[k, kk] * di[kk]

        # --- equivalent particles and rotary body (Kane route) ---------------
        if method == "kane":
            # coordinates sharing one shape function psi (a y- and a z-coordinate of
            # the same Hermite function or mode shape) enter p_dot as psi (B_k + B_k'):
            # merge them, so that the Gram matrix of distinct functions is regular
            groups = {}
            for k, sid in enumerate(mi.shape_ids):
                groups.setdefault(sid, []).append(k)
            members = list(groups.values())
            keep = [0, 1] + [2 + g[0] for g in members]
            Lc, D = ldl(G[np.ix_(keep, keep)])
            pos = [rpos, frame.x] + [
                sum((di[k] * dirs[k] for k in g), sp.S.Zero * N.x) for g in members
            ]
            for j in range(len(pos)):
                Pj = sum((Lc[a, j] * pos[a] for a in range(len(pos)) if Lc[a, j] != 0.0), sp.S.Zero * N.x)
                pt = O.locatenew(f"P{i}_{j}", Pj)
                pt.set_vel(N, Pj.dt(N))
                bodies.append(Particle(f"m{i}_{j}", pt, D[j]))
                if j == 0 and any(gravity):
                    # -g . int mu p dx = -g . (m0 P_0): gravity acts on the centre of mass only
                    loads.append((pt, D[0] * gvec))
            if any(J):
                # massless body: the mass centre is irrelevant; O has zero velocity
                bodies.append(RigidBody(f"R{i}", O, frame, 0, (inertia(frame, *J), O)))

        # tip of link i: E_i = Trans(l + u, v(l), w(l)) Rot(0, -w'(l), v'(l))
        vl = sum((mi.end_value[k] * di[k] for k, d in enumerate(lk.directions) if d == "y"), sp.S.Zero)
        wl = sum((mi.end_value[k] * di[k] for k, d in enumerate(lk.directions) if d == "z"), sp.S.Zero)
        vsl = sum((mi.end_slope[k] * di[k] for k, d in enumerate(lk.directions) if d == "y"), sp.S.Zero)
        wsl = sum((mi.end_slope[k] * di[k] for k, d in enumerate(lk.directions) if d == "z"), sp.S.Zero)
        tip = origin.locatenew(f"O{i + 1}", lk.length * frame.x + vl * frame.y + wl * frame.z)
        if i < n:
            if vsl != 0 and wsl != 0:
                raise NotImplementedError("Rot(phi) with both v'(l) and w'(l) non-zero")
            Fe = ReferenceFrame(f"E{i}")
            if wsl != 0:
                Fe.orient_axis(frame, frame.y, -wsl)  # Rot(0, -w'(l), 0) = Ry(-w'(l))
            else:
                Fe.orient_axis(frame, frame.z, vsl)  # Rot(0, 0, v'(l)) = Rz(v'(l))
            nxt = ReferenceFrame(f"L{i + 1}")
            nxt.orient_axis(Fe, Fe.z, th[2 + i])  # Rz(th_(i+1))
            frame = nxt
        origin = tip
    joint_pts.append(origin)

    qs = sp.symbols(f"q0:{len(q)}")
    us = sp.symbols(f"u0:{len(q)}")
    rep_q = dict(zip(q, qs))

    if method == "lagrange":
        lm = LagrangesMethod(sp.Matrix([T_total - V_total]), q, frame=N)
        lm.form_lagranges_equations()
        Msym, Fsym = lm.mass_matrix, lm.forcing
        rep_d = dict(zip(qd, us))
    else:
        u = dynamicsymbols(f"u0:{len(q)}")
        kd = [qd[r] - u[r] for r in range(len(q))]
        km = KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
        km.kanes_equations(bodies, loads)
        Msym = km.mass_matrix
        # M udot = forcing_inertia_gravity - dV_strain/dq
        Fsym = km.forcing - sp.Matrix(strain)
        rep_d = dict(zip(u, us))
        rep_d.update(dict(zip(qd, us)))

    def plain(expr):
        return expr.xreplace(rep_d).xreplace(rep_q)

    Mp = plain(Msym)
    Fp = plain(Fsym)
    Tp = plain(sp.Matrix([T_total]))[0]
    Vp = plain(sp.Matrix([V_total]))[0]
    tips = sp.Matrix([[plain(P.pos_from(O).dot(e)) for e in (N.x, N.y, N.z)] for P in joint_pts])
    model = ReferenceModel(
        links=links, gravity=tuple(gravity), coordinate_names=names, n_dof=len(q),
        _M=sp.lambdify(qs, Mp, modules="numpy", cse=True),
        _F=sp.lambdify(qs + us, Fp, modules="numpy", cse=True),
        _T=sp.lambdify(qs + us, Tp, modules="numpy", cse=True),
        _V=sp.lambdify(qs, Vp, modules="numpy", cse=True),
        _tip=sp.lambdify(qs, tips, modules="numpy", cse=True),
    )
    sym = dict(q=q, qd=qd, T=T_total, V=V_total, M=Msym, forcing=Fsym, integrals=ints, frames=frames)
    return sym, model


_CACHE: dict = {}


def reference_model(links, gravity=(0.0, -9.81, 0.0), method="kane") -> ReferenceModel:
    """Cached ``derive(...)[1]``; links must be a tuple of RefLink."""
    key = (tuple(links), tuple(gravity), method)
    if key not in _CACHE:
        _CACHE[key] = derive(links, gravity, method=method)[1]
    return _CACHE[key]
