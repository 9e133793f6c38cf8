"""Independent oracle for planar flexible robots with R, Pa and Pb joints (test reference).

What it is
----------
A second derivation of the equations of motion

    M(q) qddot = Q - h(q, qdot) - dV/dq

of the planar chains of ``shared/design/docs/theory.md §8, §4, §7.1, §7.6, §9, §13; docs/design-notes.md, Tests: a fixed
base, revolute (R), sliding-prismatic (Pa, a carriage of half-length c running
along the host) and fixed-prismatic (Pb, the link slides through a guide at the
host's tip) joints, links that are rigid or discretised by Hermite cubic finite
elements (clamped at node 0). It exists to check the package's compiled kernel
and shares **no code** with ``gibbsimpact`` (nothing is imported from it; the
Hermite functions, the Gauss rule and the kinematics are written here).

Method (different from the kernel's 4x4 recursion)
--------------------------------------------------
1. The position map ``p(q, i, x)`` of the material point at abscissa x of link i
   is written directly, in 2-D with angles: a planar frame is (o, theta), a
   planar vector is the complex number o = o_x + i o_y and R(theta) is
   multiplication by exp(i theta); composing a frame with a translation t or a
   rotation a is

       o' = o + exp(i theta) t,      theta' = theta + a,
       p(q, i, x) = o_i + exp(i theta_i) (x + i v_i(x; q))                (10.1)

   with the frames of docs/theory.md §7.1 (see ``PlanarChain._frames``).
   No 4x4 transforms, no twists, no recursion over derivatives: only this map.
2. Everything is evaluated with ``Jet``: a forward-mode number carrying
   (value, first, second) derivatives along one direction s. With
   q(s) = q + s v (so d2q/ds2 = 0):

       d/ds   p(q + s v)|0 = J v,      d2/ds2 p(q + s v)|0 = sum_jk d2p/dq_j dq_k v_j v_k

   Many directions ("lanes") are evaluated at once by giving the derivative
   parts a leading lane axis; the value part has none, so every element
   selection (which Hermite element contains an abscissa) is made on the real
   value, the same for all lanes. Lanes 0..N-1 are the unit vectors e_k
   (J[:, k] = first derivative, dV/dq_k = first derivative of V), lane N is
   qdot (pdot = first derivative, a0 = second derivative).
   Deflections: on links behind R and Pa joints at fixed abscissae (Gauss
   points, the tip) v = Psi(x) delta with the global Hermite basis Psi
   tabulated once (``hermite_basis``; a linear map of the delta jets); at the
   moving abscissae d +- c of a carriage and everywhere on a Pb link the
   element is chosen on the real value and the Hermite cubics are evaluated
   on jets (``PlanarChain._deflection``), so the jets carry d through eta
   and, for Pb, through the element length h = d/n_e.
3. Gibbs-Appell / d'Alembert (formulation section 12, identical to Lagrange):

       M = sum_i int mu J^T J dx,      h = sum_i int mu J^T a0 dx,
       T = 1/2 sum_i int mu |pdot|^2 dx,
       V = - sum_i int mu g . p dx + 1/2 sum_i int_(bending part) EI v''^2 dx,
       qddot = solve(M, Q - h - dV/dq).

   Rotary inertia is ignored (j_z = 0); no damping.
4. Quadrature: 4-point Gauss-Legendre per piece (exact to degree 7). Pieces: the
   element intervals of an R/Pa link (one piece for a rigid link); for a Pb link
   [0, l - d] (rear part, straight) and the moving elements
   [l - d + j d/n_e, l - d + (j+1) d/n_e] (split points from the real value of d;
   the derivatives are taken at fixed material abscissa x, formulation 11
   "Quadrature"). The strain energy of a Pb link is integrated in xi = sigma/d on
   the fixed interval [0, 1] (per element, d sigma = h d eta with h = d/n_e).

Conventions (binding; must match the package)
----------------------------------------------
* q = [j_1 ... j_n, delta_1 (2 n_e1), ..., delta_n]; j_i = theta_i (R) or d_i (Pa, Pb);
  delta_i = (w_1, t_1, ..., w_ne, t_ne) (deflection, slope at nodes 1..n_e).
* Hermite on element e (x in [x_(e-1), x_e], eta = (x - x_(e-1))/h):
  v = H1 w_(e-1) + h H2 t_(e-1) + H3 w_e + h H4 t_e,  w_0 = t_0 = 0.
* T_0 = Trans(b1, b2) Rz(beta);  T_i = T_(i-1) G_i;
  E_(i-1) = Trans(l_(i-1), v_(i-1)(l)) Rz(v'_(i-1)(l)),  E_0 = I.
  R : G_i = E_(i-1) Rz(theta_i)
  Pa: G_i = Trans(d, vbar) Rz(phibar) Rz(gamma),
      vbar = [v_h(d+c) + v_h(d-c)]/2,  phibar = [v_h(d+c) - v_h(d-c)]/(2c)
      (host = link i-1; 0 on the base rail or on a rigid host)
  Pb: G_i = E_(i-1) Rz(gamma) Trans(d - l_i, 0);  sigma = x - (l_i - d):
      v_i = 0 for sigma <= 0, else the Hermite interpolant of delta_i on n_e
      stretching elements of length h = d/n_e (nodes at sigma_j = j d/n_e).
* Joint points: origins of T_1 ... T_n and of T_n E_n (the tip).
"""
from __future__ import annotations

import math

import numpy as np

# --------------------------------------------------------------------------
# Forward-mode jets: (value, first, second derivative) along one direction s
# --------------------------------------------------------------------------


class Jet:
    """f(s) to second order at s = 0: value ``v`` = f, ``D[0]`` = f', ``D[1]`` = f''.

    ``v`` has shape () or (P,) (P: quadrature points); ``D`` has shape (2, L, 1)
    or (2, L, P): a lane axis L, each lane one direction s. Values may be
    complex (a planar point x + i y). Arithmetic with plain numbers / numpy
    arrays treats them as constants. The rules (product rule to 2nd order):

        (a b)'  = a' b + a b'            (a b)'' = a'' b + 2 a' b' + a b''
        (a/b)'  = (a' - c b')/b          (a/b)'' = (a'' - 2 c' b' - c b'')/b,   c = a/b
    """

    __slots__ = ("v", "D")
    __array_ufunc__ = None  # numpy array (op) Jet -> Jet.__rop__

    def __init__(self, v, D):
        self.v, self.D = v, D

    d1 = property(lambda self: self.D[0], doc="first derivative (L, 1|P)")
    d2 = property(lambda self: self.D[1], doc="second derivative (L, 1|P)")

    def __add__(self, o):
        if isinstance(o, Jet):
            return Jet(self.v + o.v, self.D + o.D)
        return Jet(self.v + o, self.D)

    __radd__ = __add__

    def __neg__(self):
        return Jet(-self.v, -self.D)

    def __sub__(self, o):
        if isinstance(o, Jet):
            return Jet(self.v - o.v, self.D - o.D)
        return Jet(self.v - o, self.D)

    def __rsub__(self, o):
        return Jet(o - self.v, -self.D)

    def __mul__(self, o):
        if isinstance(o, Jet):
            D = self.D * o.v + self.v * o.D      # [a'b + ab', a''b + ab'']
            t = self.D[0] * o.D[0]
            t *= 2.0
            D[1] += t                            # + 2 a'b'
            return Jet(self.v * o.v, D)
        return Jet(self.v * o, self.D * o)

    __rmul__ = __mul__

    def __truediv__(self, o):
        if isinstance(o, Jet):
            c = self.v / o.v
            c1 = (self.D[0] - c * o.D[0]) / o.v
            c2 = (self.D[1] - 2.0 * c1 * o.D[0] - c * o.D[1]) / o.v
            return Jet(c, np.stack([c1, c2]))
        return Jet(self.v / o, self.D / o)

    def __rtruediv__(self, o):
        # o / b with o constant: c = o/b, c' = -c b'/b, c'' = (-2 c' b' - c b'')/b
        c = o / self.v
        c1 = -c * self.D[0] / self.v
        c2 = (-2.0 * c1 * self.D[0] - c * self.D[1]) / self.v
        return Jet(c, np.stack([c1, c2]))

    def __pow__(self, n):
        # (a^n)' = n a^(n-1) a',  (a^n)'' = n (n-1) a^(n-2) a'^2 + n a^(n-1) a''
        if not isinstance(n, (int, np.integer)) or n < 0:
            raise TypeError("Jet supports non-negative integer powers only")
        n = int(n)
        if n == 0:
            return Jet(np.ones_like(self.v), 0.0 * self.D)
        if n == 1:
            return self
        a = self.v
        an2 = a ** (n - 2)
        an1 = an2 * a
        return Jet(an1 * a, np.stack([n * an1 * self.D[0], n * (n - 1) * an2 * self.D[0] ** 2 + n * an1 * self.D[1]]))

    @property
    def real(self):
        return Jet(np.real(self.v), np.real(self.D))

    def linear(self, B):
        """The linear map f -> B f over the point axis: B (P, m) or (m,) (a row) with constant entries."""
        if B.ndim == 1:
            return Jet(B @ self.v, (self.D @ B)[..., None])
        return Jet(B @ self.v, self.D @ B.T)

    def take(self, idx):
        """Select entries along the point axis (idx: int or int array) -> Jet."""
        v = self.v[idx]
        D = self.D[:, :, idx]
        if np.ndim(idx) == 0:
            D = D[..., None]
        return Jet(v, D)

    def integrate(self, weights):
        """sum_p weights_p f_p over the point axis -> scalar Jet (quadrature)."""
        P = np.size(weights)
        v = np.broadcast_to(self.v, (P,))
        D = np.broadcast_to(self.D, self.D.shape[:2] + (P,))
        return Jet(v @ weights, (D @ weights)[..., None])


def jsin(a):
    """sin of a real Jet: (sin a)' = cos a a',  (sin a)'' = -sin a a'^2 + cos a a''."""
    s, c = np.sin(a.v), np.cos(a.v)
    return Jet(s, np.stack([c * a.D[0], c * a.D[1] - s * a.D[0] ** 2]))


def jcos(a):
    """cos of a real Jet: (cos a)' = -sin a a',  (cos a)'' = -cos a a'^2 - sin a a''."""
    s, c = np.sin(a.v), np.cos(a.v)
    return Jet(c, np.stack([-s * a.D[0], -s * a.D[1] - c * a.D[0] ** 2]))


def jcis(a):
    """exp(i a) = cos a + i sin a of a real Jet (a planar rotation by the angle a as a complex number):
    (e^(ia))' = i a' e^(ia),  (e^(ia))'' = (i a'' - a'^2) e^(ia)."""
    E = np.exp(1j * a.v)
    return Jet(E, np.stack([1j * E * a.D[0], E * (1j * a.D[1] - a.D[0] ** 2)]))


def constant(value, lanes):
    """A constant scalar Jet with ``lanes`` zero derivative lanes."""
    return Jet(value, np.zeros((2, lanes, 1)))


# --------------------------------------------------------------------------
# Hermite cubics and the 4-point Gauss-Legendre rule (written here, not imported)
# --------------------------------------------------------------------------

# H1 = 1 - 3e^2 + 2e^3, H2 = e - 2e^2 + e^3, H3 = 3e^2 - 2e^3, H4 = -e^2 + e^3 (work on floats and Jets)
def hermite(e):
    e2 = e * e
    e3 = e2 * e
    return (1.0 - 3.0 * e2 + 2.0 * e3, e - 2.0 * e2 + e3, 3.0 * e2 - 2.0 * e3, e3 - e2)


def hermite_d1(e):
    """dH/deta: -6e + 6e^2, 1 - 4e + 3e^2, 6e - 6e^2, -2e + 3e^2."""
    e2 = e * e
    return (6.0 * e2 - 6.0 * e, 1.0 - 4.0 * e + 3.0 * e2, 6.0 * e - 6.0 * e2, 3.0 * e2 - 2.0 * e)


def hermite_d2(e):
    """d2H/deta2: -6 + 12e, -4 + 6e, 6 - 12e, -2 + 6e."""
    return (12.0 * e - 6.0, 6.0 * e - 4.0, 6.0 - 12.0 * e, 6.0 * e - 2.0)


# Gauss-Legendre, 4 points on [-1, 1]: t = +-sqrt(3/7 -+ 2/7 sqrt(6/5)), w = (18 +- sqrt(30))/36.
_A = math.sqrt(3.0 / 7.0 - 2.0 / 7.0 * math.sqrt(6.0 / 5.0))
_B = math.sqrt(3.0 / 7.0 + 2.0 / 7.0 * math.sqrt(6.0 / 5.0))
_WA = (18.0 + math.sqrt(30.0)) / 36.0
_WB = (18.0 - math.sqrt(30.0)) / 36.0
GAUSS_T = np.array([-_B, -_A, _A, _B])
GAUSS_W = np.array([_WB, _WA, _WA, _WB])


def gauss_pieces(breaks):
    """Nodes and weights of the 4-point rule on each piece [breaks[j], breaks[j+1]] (zero-length pieces dropped)."""
    b = np.asarray(breaks, dtype=float)
    a, c = b[:-1], b[1:]
    keep = c > a
    a, c = a[keep], c[keep]
    x = (0.5 * (a + c)[:, None] + 0.5 * (c - a)[:, None] * GAUSS_T[None, :]).ravel()
    w = (0.5 * (c - a)[:, None] * GAUSS_W[None, :]).ravel()
    return x, w


def hermite_basis(ne, l, x, deriv=0):
    """The global Hermite basis of formulation 9.1 at fixed abscissae x (P,): psi_k^(deriv)(x), shape (P, 2 n_e).

    Columns (w_1, t_1, ..., w_ne, t_ne); on element e (nodes e-1, e): psi = H1, h H2 for node e-1 and
    H3, h H4 for node e; d/dx = (1/h) d/deta. Node 0 (clamped) is dropped.
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    h = l / ne
    e = np.clip(np.floor(x / h), 0, ne - 1).astype(int)
    eta = x / h - e
    H = (hermite, hermite_d1, hermite_d2)[deriv](eta)
    scale = h ** -deriv
    F = np.zeros((x.size, 2 * ne + 2))
    r = np.arange(x.size)
    F[r, 2 * e] = H[0] * scale
    F[r, 2 * e + 1] = h * H[1] * scale
    F[r, 2 * e + 2] = H[2] * scale
    F[r, 2 * e + 3] = h * H[3] * scale
    return F[:, 2:]


# --------------------------------------------------------------------------
# The chain
# --------------------------------------------------------------------------

JOINT_TYPES = ("R", "Pa", "Pb")


def link(joint="R", l=1.0, mu=1.0, EI=1.0, n_e=0, gamma=0.0, c=0.0):
    """Plain description of joint i + link i (a dict)."""
    if joint not in JOINT_TYPES:
        raise ValueError(f"joint {joint!r} must be one of {JOINT_TYPES}")
    return dict(joint=joint, l=float(l), mu=float(mu), EI=float(EI), n_e=int(n_e), gamma=float(gamma), c=float(c))


class PlanarChain:
    """A planar chain on a fixed base: ``links`` is a list of dicts (see ``link``).

    Parameters
    ----------
    links : list of dict with keys joint ("R" | "Pa" | "Pb"), l, mu, EI, n_e, gamma, c
    base : (b1, b2, beta)
    gravity : (gx, gy)
    """

    def __init__(self, links, base=(0.0, 0.0, 0.0), gravity=(0.0, -9.81)):
        self.links = [dict(link(**lk)) for lk in links]
        for i, lk in enumerate(self.links):
            if lk["joint"] == "Pa" and i > 0 and self.links[i - 1]["n_e"] > 0 and lk["c"] <= 0:
                raise ValueError(f"joint {i + 1}: a Pa carriage on an FE host needs c > 0")
        self.base = tuple(float(b) for b in base)
        self.gravity = tuple(float(g) for g in gravity[:2])
        n = len(self.links)
        self.n = n
        names = [("theta_" if lk["joint"] == "R" else "d_") + str(i + 1) for i, lk in enumerate(self.links)]
        self.delta_index = []
        k = n
        for i, lk in enumerate(self.links):
            m = 2 * lk["n_e"]
            self.delta_index.append(np.arange(k, k + m))
            names += [f"delta_{i + 1}_{j}" for j in range(1, m + 1)]
            k += m
        self.coordinate_names = tuple(names)
        self.n_dof = k
        # Links behind R or Pa joints have fixed shape functions: their Gauss points, the basis there
        # (v, v''), and at the tip (v, v') are computed once; v = Psi delta is then a linear map.
        self._fixed = []
        for i, lk in enumerate(self.links):
            if lk["joint"] == "Pb" or lk["n_e"] == 0:
                self._fixed.append(None)
                continue
            ne, l = lk["n_e"], lk["l"]
            x, w = gauss_pieces(np.linspace(0.0, l, ne + 1))
            self._fixed.append(dict(x=x, w=w, B0=hermite_basis(ne, l, x, 0), B2=hermite_basis(ne, l, x, 2),
                                    end0=hermite_basis(ne, l, l, 0)[0], end1=hermite_basis(ne, l, l, 1)[0]))

    # -- coordinates as jets -------------------------------------------------
    def _jets(self, q, V):
        """Jets of the coordinates along the lanes V (L, N): q_k(s) = q_k + s V[:, k] (so q_k'' = 0).

        Returns the joint variables (scalar Jets) and, per FE link, the node values with node 0
        clamped, W = (0, w_1 .. w_ne), S = (0, t_1 .. t_ne), as Jets over the node axis.
        """
        L = V.shape[0]
        joint = [Jet(float(q[i]), np.stack([V[:, i:i + 1], np.zeros((L, 1))])) for i in range(self.n)]
        nodes = []
        for i, lk in enumerate(self.links):
            ne = lk["n_e"]
            if ne == 0:
                nodes.append(None)
                continue
            idx = self.delta_index[i]
            pair = []
            for sel in (idx[0::2], idx[1::2]):
                D = np.zeros((2, L, ne + 1))
                D[0, :, 1:] = V[:, sel]
                pair.append(Jet(np.concatenate([[0.0], q[sel]]), D))
            D = np.zeros((2, L, 2 * ne))
            D[0] = V[:, idx]
            pair.append(Jet(q[idx].copy(), D))   # delta_i itself, for the fixed-basis links
            nodes.append(tuple(pair))
        return joint, nodes

    # -- deflection of link i at abscissa X ----------------------------------
    def _deflection(self, i, X, joint, nodes, lanes, derivs=1):
        """v_i(X) and (derivs >= 1) v_i'(X) = dv/dx, Jets; X a float, float array or Jet.

        R/Pa link: s = X, element length h = l/n_e (fixed).
        Pb link:   s = sigma = X - (l - d), h = d/n_e (moving nodes); v = 0 for sigma <= 0.
        Element e (0-based, between nodes e and e+1) chosen on the real value of s; eta = s/h - e;
            v  = H1(eta) W_e + h H2(eta) S_e + H3(eta) W_(e+1) + h H4(eta) S_(e+1)
            v' = [H1' W_e + H3' W_(e+1)]/h + H2' S_e + H4' S_(e+1)
        """
        lk = self.links[i]
        ne = lk["n_e"]
        if ne == 0:
            z = constant(0.0, lanes)
            return (z, z) if derivs else (z,)
        W, S, _ = nodes[i]
        if lk["joint"] == "Pb":
            d = joint[i]
            s = X - (lk["l"] - d)
            h = d * (1.0 / ne)
            sv = s.v
            hv = d.v / ne
        else:
            s = X
            h = lk["l"] / ne
            sv = s.v if isinstance(s, Jet) else np.asarray(s, dtype=float)
            hv = h
        e = np.clip(np.floor(sv / hv), 0, ne - 1).astype(int)
        if np.ndim(e) == 0:
            e = int(e)
        eta = s / h - e
        W0, W1, S0, S1 = W.take(e), W.take(e + 1), S.take(e), S.take(e + 1)
        H1, H2, H3, H4 = hermite(eta)
        out = [H1 * W0 + H3 * W1 + h * (H2 * S0 + H4 * S1)]
        if derivs:
            G1, G2, G3, G4 = hermite_d1(eta)
            out.append((G1 * W0 + G3 * W1) / h + G2 * S0 + G4 * S1)
        if lk["joint"] == "Pb":
            mask = (np.asarray(sv) > 0.0).astype(float)  # rear part behind the guide: straight, v = 0
            out = [o * mask for o in out]
        return tuple(out)

    # -- planar frames (o, theta, E): origin o = o_x + i o_y, angle theta, E = exp(i theta) ------
    @staticmethod
    def _trans(F, t):
        """F . Trans(t_x, t_y), t = t_x + i t_y:  o' = o + R(theta) t = o + E t."""
        o, th, E = F
        return (o + E * t, th, E)

    @staticmethod
    def _rot(F, a):
        """F . Rz(a):  theta' = theta + a."""
        o, th, _ = F
        th = th + a
        return (o, th, jcis(th))

    def _end(self, F, i, joint, nodes, lanes):
        """F . E_i = F . Trans(l_i, v_i(l_i)) Rz(v_i'(l_i))."""
        lk = self.links[i]
        if lk["n_e"] == 0:
            return self._trans(F, lk["l"])
        if self._fixed[i] is not None:
            delta = nodes[i][2]
            v, vp = delta.linear(self._fixed[i]["end0"]), delta.linear(self._fixed[i]["end1"])
        else:
            v, vp = self._deflection(i, lk["l"], joint, nodes, lanes)
        return self._rot(self._trans(F, 1j * v + lk["l"]), vp)

    def _frames(self, joint, nodes, lanes):
        """Frames T_1 .. T_n and the tip frame T_n E_n, each (o, theta, E) of Jets."""
        b1, b2, beta = self.base
        F = self._rot((constant(complex(b1, b2), lanes), constant(0.0, lanes), None), beta)   # T_0
        frames = []
        for i, lk in enumerate(self.links):
            typ = lk["joint"]
            if typ == "R":
                # G_i = E_(i-1) Rz(theta_i)
                if i > 0:
                    F = self._end(F, i - 1, joint, nodes, lanes)
                F = self._rot(F, joint[i])
            elif typ == "Pa":
                # G_i = Trans(d, vbar) Rz(phibar + gamma); vbar, phibar from the host's v(d +- c)
                d, c = joint[i], lk["c"]
                if i > 0 and self.links[i - 1]["n_e"] > 0:
                    vp, = self._deflection(i - 1, d + c, joint, nodes, lanes, derivs=0)
                    vm, = self._deflection(i - 1, d - c, joint, nodes, lanes, derivs=0)
                    vbar = (vp + vm) * 0.5
                    phibar = (vp - vm) * (0.5 / c)
                    F = self._rot(self._trans(F, d + 1j * vbar), phibar + lk["gamma"])
                else:
                    # base rail or rigid host: vbar = phibar = 0
                    F = self._rot(self._trans(F, d * (1.0 + 0j)), lk["gamma"])
            else:
                # G_i = E_(i-1) Rz(gamma) Trans(d - l_i, 0)
                if i > 0:
                    F = self._end(F, i - 1, joint, nodes, lanes)
                F = self._rot(F, lk["gamma"])
                F = self._trans(F, (joint[i] - lk["l"]) * (1.0 + 0j))
            frames.append(F)
        frames.append(self._end(F, self.n - 1, joint, nodes, lanes))
        return frames

    # -- quadrature pieces -------------------------------------------------------
    def _pieces(self, i, q):
        """Gauss nodes/weights on [0, l_i] split at the element nodes or (Pb) at l - d and the moving nodes."""
        lk = self.links[i]
        l, ne = lk["l"], max(lk["n_e"], 1)
        if lk["joint"] == "Pb":
            d = float(q[i])
            breaks = [0.0] + [l - d + j * d / ne for j in range(ne)] + [l]
        else:
            breaks = np.linspace(0.0, l, ne + 1)
        return gauss_pieces(breaks)

    # -- strain energy ------------------------------------------------------------
    def _strain(self, i, joint, nodes, lanes):
        """1/2 int EI v''^2 over the bending part, per element in eta (dx = h deta), a Jet.

        h^2 v'' = H1'' w_(e-1) + h H2'' t_(e-1) + H3'' w_e + h H4'' t_e,  h = l/n_e or (Pb) d/n_e:
        1/2 EI int v''^2 dx = 1/2 EI / h^3 sum_e int_0^1 (h^2 v'')^2 deta.
        """
        lk = self.links[i]
        ne = lk["n_e"]
        if ne == 0:
            return constant(0.0, lanes)
        W, S, delta = nodes[i]
        if self._fixed[i] is not None:
            f = self._fixed[i]
            c = delta.linear(f["B2"])          # v'' at the Gauss points
            return (c * c).integrate(f["w"]) * (0.5 * lk["EI"])
        h = joint[i] * (1.0 / ne) if lk["joint"] == "Pb" else lk["l"] / ne
        eta = np.tile(0.5 * (GAUSS_T + 1.0), ne)
        wq = np.tile(0.5 * GAUSS_W, ne)
        e = np.repeat(np.arange(ne), 4)
        K1, K2, K3, K4 = hermite_d2(eta)
        c = K1 * W.take(e) + K3 * W.take(e + 1) + h * (K2 * S.take(e) + K4 * S.take(e + 1))
        return (c * c).integrate(wq) * (0.5 * lk["EI"]) / (h * h * h)

    # -- everything at one state -----------------------------------------------
    def evaluate(self, q, qdot=None):
        """M, h, dV/dq, T, V_gravity, V_strain at (q, qdot) in one vectorised pass (a dict).

        Lanes 0..N-1: e_k -> J[:, k] = (dp/ds)_k, dV/dq_k = (dV/ds)_k; lane N: qdot -> pdot, a0.
        With p = p_x + i p_y complex:  J_k . J_l = Re(J_k conj(J_l)),  g . p = Re(conj(g) p).
        """
        q = np.asarray(q, dtype=float)
        N = self.n_dof
        if q.shape != (N,):
            raise ValueError(f"q has shape {q.shape}, expected ({N},)")
        qd = np.zeros(N) if qdot is None else np.asarray(qdot, dtype=float)
        V = np.vstack([np.eye(N), qd[None, :]])
        L = N + 1
        joint, nodes = self._jets(q, V)
        frames = self._frames(joint, nodes, L)
        gc = complex(*self.gravity).conjugate()
        M = np.zeros((N, N))
        h = np.zeros(N)
        T = 0.0
        Vg = constant(0.0, L)
        Vs = constant(0.0, L)
        for i, lk in enumerate(self.links):
            o, _, E = frames[i]
            if self._fixed[i] is not None:
                x, w = self._fixed[i]["x"], self._fixed[i]["w"]
                v = nodes[i][2].linear(self._fixed[i]["B0"])
            else:
                x, w = self._pieces(i, q)
                v, = self._deflection(i, x, joint, nodes, L, derivs=0)
            P = x.size
            p = o + E * (1j * v + x)                          # p = o + R(theta) (x, v)
            mw = lk["mu"] * w
            D = np.broadcast_to(p.D, (2, L, P))
            J = D[0, :N]                                      # (N, P) complex: dp/dq_k
            pdot = D[0, N]
            a0 = D[1, N]
            M += np.real((J * mw) @ J.conj().T)               # int mu J^T J
            h += np.real(J.conj() @ (mw * a0))                # int mu J^T a0
            T += 0.5 * float(mw @ np.abs(pdot) ** 2)          # 1/2 int mu |pdot|^2
            Vg = Vg - (p * gc).real.integrate(mw)             # -int mu g.p
            Vs = Vs + self._strain(i, joint, nodes, L)        # 1/2 int EI v''^2
        dV = (Vg.D[0] + Vs.D[0])[:N, 0]
        Vg_v, Vs_v = float(Vg.v), float(Vs.v)
        return dict(M=M, h=h, dV=dV, kinetic=T, gravity=Vg_v, strain=Vs_v, total=T + Vg_v + Vs_v)

    # -- the package-like API -------------------------------------------------------
    def mass_matrix(self, q):
        return self.evaluate(q)["M"]

    def bias_forces(self, q, qdot):
        return self.evaluate(q, qdot)["h"]

    def potential_forces(self, q):
        return self.evaluate(q)["dV"]

    def forward_dynamics(self, q, qdot, Q=None):
        """qddot = solve(M, Q - h - dV/dq)."""
        r = self.evaluate(q, qdot)
        rhs = -r["h"] - r["dV"] + (0.0 if Q is None else np.asarray(Q, dtype=float))
        return np.linalg.solve(r["M"], rhs)

    def energy(self, q, qdot):
        """(kinetic, gravity, strain, total) [J] as a dict."""
        r = self.evaluate(q, qdot)
        return {k: r[k] for k in ("kinetic", "gravity", "strain", "total")}

    def joint_positions(self, q):
        """Contact points, shape (n+1+X, 3), z = 0: the origins of T_1 .. T_n and of the tip
        T_n E_n, then the tip T_(i-1) E_(i-1) of every host link i-1 whose child joint i >= 2
        is prismatic (the package's definition of its contact points)."""
        q = np.asarray(q, dtype=float)
        joint, nodes = self._jets(q, np.zeros((1, self.n_dof)))
        frames = self._frames(joint, nodes, 1)
        for i, lk in enumerate(self.links):
            if i > 0 and lk["joint"] != "R":
                frames.append(self._end(frames[i - 1], i - 1, joint, nodes, 1))
        o = np.array([complex(F[0].v) for F in frames])
        return np.stack([o.real, o.imag, np.zeros_like(o.real)], axis=1)

    def rhs(self, t, y, Q=None):
        """First-order ODE y = [q, qdot] -> [qdot, qddot] (for solve_ivp)."""
        N = self.n_dof
        return np.concatenate([y[N:], self.forward_dynamics(y[:N], y[N:], Q)])
