"""Material points of the links as contact candidates: the closest point of every link to every wall.

The points themselves, p(q, i, x) = (T_i(q) r_i(x))[:3] with r_i(x) = (x, v_i(x), w_i(x), 1),
their Jacobian and acceleration term are gibbsimpact.dynamics.link_points (material_points,
material_jacobian; re-exported here). For a link behind a FixedPrismatic (Pb) guide, v depends
on the protruding length d as well: v = sum_k d^(a_k) N_k(xi) delta_k on the protruding part
sigma = x - (l - d) in [0, d], xi = sigma / d, and v = 0 behind the guide (docs/theory.md §7.4).

Functions, all pure f(model, q, ...):

* :func:`closest_points` -- for every wall w and link i, the material point of link i with
  the smallest gap g_w(p(x)): x* (W, n), gap (W, n), normal (W, n, 3);
* :func:`search_interval`, :func:`end_joints`, :func:`interior` -- what the event loop needs
  to use x* as one more contact candidate without counting a joint twice.

Search interval. x* minimises g_w(p(x)) over [a_i, b_i] = [0, l_i]; for a Pb link over the
protruding part [l_i - d_i, l_i] (the part behind the guide is straight along the guide
axis, so its gap is linear (plane) or concave (circle, sphere) along it: its minimum is at
an end, the rear end O_i or the guide, which are candidates already).

Method of :func:`closest_points` (it runs in every event function call, so it is vectorised
over states, links, walls and samples, with one kernel call for all frames):

1. *Rigid links* (no elastic coordinates): the link is a straight segment. g is linear along
   it for a plane and concave for a circle or a sphere (|P (p - c)| is convex along a line),
   so the minimum is at an end: the smaller of the two end gaps (ties: the proximal end).
   Nothing else is done for them.
2. *Flexible links*: g and g' = dg/ds are sampled at S points evenly spaced on the search
   interval, in the shape coordinate s (s = x, or s = xi = sigma / d on the protruding part
   of a Pb link). The local points r(s) and dr/ds at the samples are one product
   r0 + A qe with a matrix A precomputed per model (qe: q with the Pb slopes times d).
   Sampling rule: S = max_i S_i with S_i = max(17, ceil(8 beta_max l / pi) + 1) for assumed
   modes (at least 8 samples per half-wavelength pi / beta of the shortest mode) and
   S_i = max(17, 8 n_e + 1) for n_e Hermite elements (8 per element); S - 1 is then rounded
   up to a multiple of every n_e when that at most doubles it, so that the nodes are samples.
   Candidates: both ends, and every bracket [s_j, s_(j+1)] where g' goes from < 0 to >= 0
   (an interior local minimum; all of them, not only the lowest sample's, so that two dips
   of a link nearly as close to the wall are both found). In each bracket: start at the
   minimum of the cubic Hermite interpolant of (g, g') at its ends (exact for a Hermite link
   and a plane: g is a cubic on an element), then a safeguarded Newton iteration on g' = 0
   (Newton steps with g'' > 0 inside the bracket, else bisection) with exact p, p', p''
   (world coefficients times the basis (1, s, e^(beta s), e^(-beta s), cos, sin) of the modes,
   or (1, eta, eta^2, eta^3) of the element), until the error left after the step is below
   1e-12 of the interval (usually 2 evaluations for modes, 1 for elements on a plane); the
   result follows from the last evaluation by Taylor (error O(step^3)). An interior minimum
   replaces the ends when its gap is lower by more than 64 eps (1 + max|p|). The sampling
   assumes no interior minimum hides between two samples with g' of one sign at both, which
   the 8-samples rule makes a matter of dips shallower than ~h^2 max|g''|.
3. *Cost* (numpy on small arrays: the number of calls counts, not the array sizes): one
   kernel call and ~40 numpy calls when no link has an interior minimum, about twice that
   per Newton iteration group otherwise. Two ways to pay less in an event loop: K states in
   one call (q of shape (K, N), e.g. the dense samples of a step), and ``refine_below``
   (pairs whose sampled minimum is farther than that from the wall keep the best sample:
   the sign of the gap is still exact).

Contact candidate rule (for the event loop). The ends of the search interval are joint
candidates already (:func:`end_joints` gives their index in
``kinematics.joint_positions``). A link candidate (w, i) is *interior* when x* is farther
than ``end_tol`` (default 1e-6 l_i) from both ends of [a_i, b_i] (:func:`interior`). Dedupe:

* event functions: one per (wall, flexible link), g*_wi(q) = gap[w, i] (continuous in q,
  never above the gaps of the link's end joints); rigid links need none (their minimum is
  a joint);
* impact stage: a link candidate enters the impulse problem only when it is interior;
  otherwise its end joint (end_joints) stands for it. The joint's gap exceeds g* by at most
  1/2 max|g''| end_tol^2 (about 5e-13 m for |g''| = 1 /m, l = 1 m), far below the contact band
  2 contact_tol, so the joint is in the band whenever the link point is. (end_joints -1: the
  guide of a Pb link on the base, a fixed point with J = 0, which needs no candidate.)
* an interior candidate enters with its own row n^T J(x*) (material_jacobian); its
  identity is (wall, link), not x*, which moves along the link from one event call to the
  next.
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np

from .. import kernel as _k
from ..dynamics.kinematics import as_vector
# Re-exported: the points' own module is gibbsimpact.dynamics.link_points; gibbsimpact.linkpoints
# (this module's earlier name) has always offered them.
from ..dynamics.link_points import material_jacobian, material_points
from ..model.modes import _normalisation, _sigma_terms, frequency_root
from .walls import Circle, Plane, Sphere

__all__ = ["ClosestPoints", "closest_points", "end_joints", "interior", "material_jacobian", "material_points",
           "search_interval"]

#: Error left in s (relative to the search interval's length) at which the Newton refinement stops.
X_TOL = 1e-12
#: Iteration cap of the refinement (bisection from a bracket of l / 16 to 1e-12 l takes 40).
MAX_ITERATIONS = 60
#: Default end tolerance of :func:`interior`, relative to the link length.
END_TOL = 1e-6
_MIN_SAMPLES = 17
#: Relative margin by which an interior minimum must beat the ends' gaps (round-off of g).
_TIE = 64.0 * np.finfo(float).eps


class ClosestPoints(NamedTuple):
    """Closest material points of every (wall, link) pair.

    x : (W, n) material abscissa x* [m] of the point of link i closest to wall w
    gap : (W, n) its gap g_w(p(x*)) [m]
    normal : (W, n, 3) the wall's unit normal at p(x*) (into the admissible region)
    """

    x: np.ndarray
    gap: np.ndarray
    normal: np.ndarray


# -- model tables (built once per model) -----------------------------------------------------

class _Tables:
    """Per-model shape data for the vectorised evaluation of link deflections.

    Every deflection value is a stencil: v (resp. w) at shape coordinate s of link i is
    sum_k wt_k(s) qe[ix_k], qe = (q with the slope coordinates of Pb links times d, 0),
    the last entry a zero slot for padding. Modal links: wt = psi_k (all modes, the other
    direction's weights 0); Hermite links: the 4 local functions of the element holding s.
    """

    def __init__(self, model):
        n, N = model.n_links, model.n_dof
        links, kinds = model.chain.links, model.joint_kinds
        self.n, self.N = n, N
        self.length = np.array([lk.length for lk in links])
        self.pb = np.array([k == "Pb" for k in kinds])
        self.d_index = np.array([model.theta_index[i] if self.pb[i] else 0 for i in range(n)], dtype=int)
        self.modal = np.array([bool(lk.modes) for lk in links])
        self.fe = np.array([lk.elements > 0 for lk in links])
        self.flexible = self.modal | self.fe
        # Shape coordinate: s = x on [0, l]; s = xi on [0, 1] for a Pb link.
        self.Lc = np.where(self.pb, 1.0, self.length)
        width = max([4] + [len(lk.modes) for lk in links])
        self.width = width
        # Modal coefficients: psi^(k)(s) = beta^k [ca e^(beta s) + (-1)^k cb e^(-beta s) + cc cos^(k) + cs sin^(k)].
        shp = (n, width)
        self.beta, self.ca, self.cb, self.cc, self.cs = (np.zeros(shp) for _ in range(5))
        self.dmask = np.zeros((n, 2, width))   # direction of each mode: slot 0 = v (y), 1 = w (z)
        self.midx = np.full((n, 2, width), N)  # q index of each mode
        # Hermite links: h on the shape coordinate, n_e, q index of (deflection, slope) at node j per direction.
        self.ne = np.array([max(lk.elements, 1) for lk in links])
        self.h = self.Lc / self.ne
        self.node_q = np.full((n, int(self.ne.max()) + 1, 2, 2), N)
        self.pb_slopes = []                    # (q index of each slope coordinate, index of d) of Pb links
        for i, lk in enumerate(links):
            idx = model.delta_index[i]
            if lk.modes:
                for k, md in enumerate(lk.modes):
                    z = frequency_root(md.kind, int(md.number))
                    beta = z / lk.length
                    C = _normalisation(md.kind, int(md.number), float(lk.length))
                    if md.kind == "pinned-pinned":
                        a, b, c, s = 0.0, 0.0, 0.0, C
                    else:
                        sigma, one_minus, one_plus = _sigma_terms(md.kind, z)
                        a, b, c, s = 0.5 * C * one_minus, 0.5 * C * one_plus, -C, C * sigma
                    self.beta[i, k], self.ca[i, k], self.cb[i, k], self.cc[i, k], self.cs[i, k] = beta, a, b, c, s
                    slot = 0 if md.direction == "y" else 1
                    self.dmask[i, slot, k] = 1.0
                    self.midx[i, :, k] = idx[k]
            elif lk.elements:
                ne = lk.elements
                for set_k, direction in enumerate(lk.element_directions):
                    slot = 0 if direction == "y" else 1
                    base = idx[2 * ne * set_k:2 * ne * (set_k + 1)]
                    self.node_q[i, 1:ne + 1, slot, 0] = base[0::2]
                    self.node_q[i, 1:ne + 1, slot, 1] = base[1::2]
                if self.pb[i]:
                    self.pb_slopes.append((idx[1::2], model.theta_index[i]))
        # Sample grid on [0, Lc] and its stencils.
        S = 2
        for i, lk in enumerate(links):
            if lk.modes:
                bl = max(frequency_root(md.kind, int(md.number)) for md in lk.modes)
                S = max(S, _MIN_SAMPLES, int(np.ceil(8.0 * bl / np.pi)) + 1)
            elif lk.elements:
                S = max(S, _MIN_SAMPLES, 8 * lk.elements + 1)
        # Element nodes on the grid when that at most doubles S: S - 1 a multiple of every n_e.
        lcm = int(np.lcm.reduce([lk.elements for lk in links if lk.elements] or [1]))
        if lcm <= S - 1:
            S = -(-(S - 1) // lcm) * lcm + 1
        self.S = S
        u = np.linspace(0.0, 1.0, S)
        self.s_grid = self.Lc[:, None] * u[None, :]
        self.s_grid[:, -1] = self.Lc  # the far end exactly
        # Local samples r(s) and dr/ds of every link, linear in qe: r = r0 + A qe, rows (order, link, sample,
        # component) [docs/theory.md §7.2: x = s, or x = l + (s - 1) d on a Pb link; v, w from the stencils].
        L = np.repeat(np.arange(n), S)
        wt, ix = _stencils(self, L, self.s_grid.ravel(), 2)
        r0 = np.zeros((2, n, S, 3))
        A = np.zeros((2, n, S, 3, N + 1))
        for i in range(n):
            if self.pb[i]:
                r0[0, i, :, 0] = self.length[i]
                A[0, i, :, 0, self.d_index[i]] = self.s_grid[i] - 1.0
                A[1, i, :, 0, self.d_index[i]] = 1.0
            else:
                r0[0, i, :, 0] = self.s_grid[i]
                r0[1, i, :, 0] = 1.0
        wt = wt.reshape(2, n, S, 2, width)
        ix = ix.reshape(n, S, 2, width)
        for o in range(2):
            for c in range(2):
                np.add.at(A[o, :, :, 1 + c], (np.arange(n)[:, None, None], np.arange(S)[None, :, None], ix[:, :, c]),
                          wt[o, :, :, c])
        A = A.reshape(-1, N + 1)
        if A.size > 200_000:  # long Hermite links: a sparse matrix (each row has at most 4 entries)
            from scipy.sparse import csr_matrix

            A = csr_matrix(A)
        self.r0, self.A = r0, A
        self.flex_links = np.flatnonzero(self.flexible)
        self.has_pb = bool(self.pb.any())
        self.offset1, self.scale1 = np.zeros((1, n)), np.ones((1, n))   # x = offset + scale s, no Pb link
        # Assumed-mode basis for the refinement (_ModalBasis): F = (1, s, E_j, 1/E_j, cos_j, sin_j),
        # E_j = e^(beta_j s); template (n, 3 orders, 2 (v, w), nb, width) times the modal coordinates.
        nb = 2 + 4 * width
        tm = np.zeros((n, 3, 2, nb, width))
        j = np.arange(width)
        for i in range(n):
            bt, ca, cb, cc, cs = self.beta[i], self.ca[i], self.cb[i], self.cc[i], self.cs[i]
            for slot in range(2):
                dm = self.dmask[i, slot]
                # psi = ca E + cb /E + cc cos + cs sin; psi' = beta (ca E - cb /E - cc sin + cs cos);
                # psi'' = beta^2 (ca E + cb /E - cc cos - cs sin)
                for k, (fa, fb, fc, fs) in enumerate(((ca, cb, cc, cs), (bt * ca, -bt * cb, bt * cs, -bt * cc),
                                                      (bt**2 * ca, bt**2 * cb, -bt**2 * cc, -bt**2 * cs))):
                    tm[i, k, slot, 2 + j, j] = fa * dm
                    tm[i, k, slot, 2 + width + j, j] = fb * dm
                    tm[i, k, slot, 2 + 2 * width + j, j] = fc * dm
                    tm[i, k, slot, 2 + 3 * width + j, j] = fs * dm
        self.modal_template = tm
        # Hermite elements (_HermiteBasis): v, v', v'' on an element as powers of eta from its dofs
        # (w_(e-1), t_(e-1), w_e, t_e): (H1, h H2, H3, h H4) = (1, eta, eta^2, eta^3) @ H0 (elements.py);
        # d/ds = (1/h) d/deta. Template (n, 3 orders, 4 powers, 4 dofs).
        H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [-3.0, -2.0, 3.0, -1.0], [2.0, 1.0, -2.0, 1.0]])
        D = np.diag([1.0, 2.0, 3.0], 1)   # d/deta on power coefficients: c -> (c1, 2 c2, 3 c3, 0)
        self.hermite_template = np.zeros((n, 3, 4, 4))
        for i in range(n):
            if self.fe[i]:
                hi_ = self.h[i]
                H0 = H * np.array([1.0, hi_, 1.0, hi_])
                self.hermite_template[i] = (H0, D @ H0 / hi_, D @ D @ H0 / hi_**2)
        self.samples_per_element = np.where(self.fe & ((S - 1) % self.ne == 0), (S - 1) // self.ne, 0)
        self.modal_x = np.zeros((3, nb))
        self.modal_x[0, 1] = 1.0   # x = s
        self.modal_x[1, 0] = 1.0   # dx/ds = 1
        self.qdot1 = np.zeros(N)
        job = _k.JOB_FRAMES
        self.frames_offset = int(_k.layout(n, N, 1, job, model.n_joints)[_k.SECTIONS.index("frames")])


    def grid_index(self, K, W):
        """Index arrays (K, 1, 1), (1, 1, n) that pick (state, link) for every (state, wall, link)."""
        key = (K, W)
        try:
            return self._grid_index[key]
        except AttributeError:
            self._grid_index = {}
        except KeyError:
            pass
        if len(self._grid_index) > 16:
            self._grid_index.clear()
        out = self._grid_index[key] = (np.arange(K)[:, None, None], np.arange(self.n)[None, None, :])
        return out


_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _tables(model) -> _Tables:
    try:
        return _TABLES[model]
    except KeyError:
        t = _TABLES[model] = _Tables(model)
        return t


def _hermite_local(eta, h, orders):
    """(orders, 4, P): H1, h H2, H3, h H4 at eta (P,) and their s-derivatives, h (P,) (elements.py)."""
    e = eta
    e2 = e * e
    e3 = e2 * e
    out = np.empty((orders, 4, e.size))
    out[0] = (1 - 3 * e2 + 2 * e3, h * (e - 2 * e2 + e3), 3 * e2 - 2 * e3, h * (e3 - e2))
    if orders > 1:
        out[1] = ((-6 * e + 6 * e2) / h, 1 - 4 * e + 3 * e2, (6 * e - 6 * e2) / h, -2 * e + 3 * e2)
    if orders > 2:
        h2 = h * h
        out[2] = ((-6 + 12 * e) / h2, (-4 + 6 * e) / h, (6 - 12 * e) / h2, (-2 + 6 * e) / h)
    return out


def _stencils(tab: _Tables, L, s, orders):
    """Weights (orders, P, 2, width) and qe indices (P, 2, width) of v, w and their s-derivatives.

    L (P,) link of each point, s (P,) its shape coordinate; orders 1 .. 3 (value, first, second).
    """
    P, width = s.size, tab.width
    wt = np.zeros((orders, P, 2, width))
    ix = np.full((P, 2, width), tab.N)
    m = tab.modal[L]
    if m.any():
        Lm = L[m]
        beta = tab.beta[Lm]
        bs = beta * s[m, None]
        ep = tab.ca[Lm] * np.exp(bs)
        em = tab.cb[Lm] * np.exp(-bs)
        co, si = np.cos(bs), np.sin(bs)
        cc, cs = tab.cc[Lm], tab.cs[Lm]
        dm = tab.dmask[Lm]
        psi = [ep + em + cc * co + cs * si]
        if orders > 1:
            psi.append(beta * (ep - em - cc * si + cs * co))
        if orders > 2:
            psi.append(beta * beta * (ep + em - cc * co - cs * si))
        for o in range(orders):
            wt[o, m] = psi[o][:, None, :] * dm
        ix[m] = tab.midx[Lm]
    f = tab.fe[L]
    if f.any():
        Lf = L[f]
        sf = s[f]
        h, ne = tab.h[Lf], tab.ne[Lf]
        # Element holding s (1-based); at a node the element to its left (elements.hermite_shape).
        e = np.clip(np.ceil(sf / h).astype(int), 1, ne)
        H = _hermite_local((sf - (e - 1) * h) / h, h, orders)  # (orders, 4, Pf)
        wt[:, f, :, :4] = np.transpose(H, (0, 2, 1))[:, :, None, :]
        left, right = tab.node_q[Lf, e - 1], tab.node_q[Lf, e]   # (Pf, 2 slots, 2 (w, t))
        ix[f, :, :2] = left
        ix[f, :, 2:4] = right
    return wt, ix


class _State(NamedTuple):
    """What the evaluation of material points needs from K states: R (K, n, 3, 3), o (K, n, 3),
    qe (K (N + 1),) flat, offset and scale (K, n) of x = offset + scale s."""

    R: np.ndarray
    o: np.ndarray
    qe: np.ndarray
    offset: np.ndarray
    scale: np.ndarray


def _state(model, tab: _Tables, qs) -> _State:
    """Frames of the K states qs (K, N) from one kernel call, and the effective coordinates.

    qe: q with the slope coordinates of Pb links times d (so that v = sum_k N_k(xi) qe_k,
    docs/theory.md §7.4) and a zero slot at index N for the stencils' padding.
    """
    K, N, n = qs.shape[0], tab.N, tab.n
    job = _k.JOB_FRAMES
    fdat, idat, zeros, v = model.kernel_data
    # One kernel call (kernel.run, no run_kernel checks: as_vector gives the entry point the array
    # type it was compiled for, and the frames section's offset is cached for K = 1).
    if K == 1:
        out = _k.run(v, fdat, idat, as_vector(qs), tab.qdot1, zeros, job)
        o0 = tab.frames_offset
    else:
        out = _k.run(v, fdat, idat, as_vector(qs), np.zeros(K * N), zeros, job)
        o0 = int(_k.layout(n, N, K, job, model.n_joints)[_k.SECTIONS.index("frames")])
    T = out[o0:o0 + 48 * (n + 1) * K].reshape(K, n + 1, 3, 4, 4)[:, :n, 0]
    qe = np.concatenate((qs, np.zeros((K, 1))), axis=1)
    if not tab.has_pb:
        if K == 1:
            return _State(T[..., :3, :3], T[..., :3, 3], qe.reshape(-1), tab.offset1, tab.scale1)
        return _State(T[..., :3, :3], T[..., :3, 3], qe.reshape(-1), np.zeros((K, n)), np.ones((K, n)))
    for slopes, jd in tab.pb_slopes:
        qe[:, slopes] *= qs[:, jd, None]
    d = qs[:, tab.d_index]
    offset = np.where(tab.pb, tab.length - d, 0.0)
    scale = np.where(tab.pb, d, 1.0)
    return _State(T[..., :3, :3], T[..., :3, 3], qe.reshape(-1), offset, scale)


# -- walls ------------------------------------------------------------------------------------

class _WallParams(NamedTuple):
    """Walls as arrays (W, ...): plane flag, normal and n.point; projector diagonal, centre, radius."""

    plane: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    proj: np.ndarray
    center: np.ndarray
    radius: np.ndarray


def _wall_params(walls) -> _WallParams:
    W = len(walls)
    plane = np.zeros(W, dtype=bool)
    nv, off, proj, c, R = np.zeros((W, 3)), np.zeros(W), np.zeros((W, 3)), np.zeros((W, 3)), np.zeros(W)
    for k, wl in enumerate(walls):
        if isinstance(wl, Plane):
            plane[k] = True
            proj[k] = 1.0  # g' = n.P p1 with P = I holds for a plane too
            nv[k] = wl.normal_vector
            off[k] = float(np.dot(wl.normal_vector, wl.point))
        elif isinstance(wl, Circle):
            proj[k] = (1.0, 1.0, 0.0)
            c[k, :2] = wl.center
            R[k] = wl.radius
        elif isinstance(wl, Sphere):
            proj[k] = 1.0
            c[k] = wl.center
            R[k] = wl.radius
        else:
            raise TypeError(f"walls[{k}]={wl!r} is not a gibbsimpact Plane, Circle or Sphere")
    return _WallParams(plane, nv, off, proj, c, R)


_WALLS: dict = {}


def _walls(walls: tuple) -> _WallParams:
    """_wall_params, cached per tuple of (immutable) walls."""
    try:
        return _WALLS[walls]
    except KeyError:
        if len(_WALLS) > 64:
            _WALLS.clear()
        wp = _WALLS[walls] = _wall_params(walls)
        return wp
    except TypeError:  # an unhashable entry: not a wall of this package (_wall_params says so)
        return _wall_params(walls)


def _sample_terms(wp: _WallParams, k: int, p, p1):
    """g and g' = dg/ds of wall k at the points p (..., 3) moving along s at p1 (..., 3).

    Written with elementwise operations only (the cheapest numpy calls on small arrays).
    """
    if wp.plane[k]:
        nv = wp.normal[k]
        return p @ nv - wp.offset[k], p1 @ nv
    c = wp.center[k]
    d0, d1 = p[..., 0] - c[0], p[..., 1] - c[1]
    dp = d0 * p1[..., 0] + d1 * p1[..., 1]
    if wp.proj[k, 2] == 0.0:
        rho = np.hypot(d0, d1)
    else:
        d2 = p[..., 2] - c[2]
        rho = np.hypot(np.hypot(d0, d1), d2)
        dp += d2 * p1[..., 2]
    # g' = n . p1 with n = -d / rho; on the axis or at the centre (d = 0) it is 0.
    return wp.radius[k] - rho, dp / -np.maximum(rho, 1e-300)


def _normals(wp: _WallParams, k: int, p):
    """Unit normal (..., 3) of wall k at the points p (..., 3): n, or -P (p - c) / |P (p - c)| (0 on the axis)."""
    if wp.plane[k]:
        nrm = np.empty(p.shape)
        nrm[...] = wp.normal[k]
        return nrm
    m = 2 if wp.proj[k, 2] == 0.0 else 3
    nrm = np.zeros(p.shape)
    d = p[..., :m] - wp.center[k, :m]
    rho = np.hypot(d[..., 0], d[..., 1]) if m == 2 else np.hypot(np.hypot(d[..., 0], d[..., 1]), d[..., 2])
    nrm[..., :m] = d / -np.maximum(rho, 1e-300)[..., None]
    return nrm


def _gap_terms(wp: _WallParams, p, p1=None, p2=None):
    """Gap g, unit normal n and, with p1 = dp/ds (and p2 = d2p/ds2), g' (and g'') along s.

    wp's arrays and p (P, 3) correspond row by row. Plane: g = n.p - n.p0, g' = n.p1,
    g'' = n.p2. Circle, sphere: d = P (p - c), rho = |d|, g = R - rho, n = -d / rho (0 on
    the axis or at the centre), g' = n.P p1, g'' = n.P p2 - (|P p1|^2 - (n.P p1)^2) / rho.
    """
    plane = wp.plane
    if plane.all():
        nrm = wp.normal
        g = np.einsum("pi,pi->p", nrm, p) - wp.offset
        if p1 is None:
            return g, nrm
        if p2 is None:
            return g, nrm, np.einsum("pi,pi->p", nrm, p1)
        return g, nrm, np.einsum("pi,pi->p", nrm, p1), np.einsum("pi,pi->p", nrm, p2)
    dvec = wp.proj * (p - wp.center)
    rho = np.sqrt(np.einsum("pi,pi->p", dvec, dvec))
    safe = np.where(rho > 0.0, rho, 1.0)
    nrm = dvec / -safe[:, None]
    g = wp.radius - rho
    if plane.any():
        nrm = np.where(plane[:, None], wp.normal, nrm)
        g = np.where(plane, np.einsum("pi,pi->p", wp.normal, p) - wp.offset, g)
    if p1 is None:
        return g, nrm
    pp1 = wp.proj * p1
    g1 = np.einsum("pi,pi->p", nrm, pp1)
    if p2 is None:
        return g, nrm, g1
    curv = (np.einsum("pi,pi->p", pp1, pp1) - g1 * g1) / safe
    g2 = np.einsum("pi,pi->p", nrm, wp.proj * p2) - np.where(plane, 0.0, curv)
    return g, nrm, g1, g2


# -- public functions -----------------------------------------------------------------------

def search_interval(model, q) -> tuple[np.ndarray, np.ndarray]:
    """Ends (a, b) [m] of the interval searched by closest_points: [0, l_i], or the protruding
    part [l_i - d_i, l_i] of a Pb link. q (N,) gives (n,) each, q (K, N) gives (K, n)."""
    tab = _tables(model)
    q = np.asarray(q, dtype=float)
    a = np.where(tab.pb, tab.length - q[..., tab.d_index], 0.0)
    return a, np.broadcast_to(tab.length, a.shape).copy()


def end_joints(model) -> np.ndarray:
    """Index (n, 2) in ``kinematics.joint_positions`` of the contact point at each end of every
    link's search interval (a_i, b_i); -1 where there is none (the guide of a Pb link on the base).

    a: link i's frame origin O_(i+1) (i), or for a Pb link the host's tip (the guide).
    b: the frame origin of the next link behind a revolute joint (i + 1), the chain's tip (n),
    or the extra "tip of link i" point when the next joint is prismatic.
    """
    n = model.n_links
    kinds = model.joint_kinds
    extra, k = {}, n + 1
    for j in range(1, n):
        if kinds[j] != "R":
            extra[j] = k          # the tip of link j - 1 (host of joint j)
            k += 1
    out = np.empty((n, 2), dtype=int)
    for i in range(n):
        out[i, 0] = (extra[i] if i > 0 else -1) if kinds[i] == "Pb" else i
        out[i, 1] = n if i == n - 1 else (i + 1 if kinds[i + 1] == "R" else extra[i + 1])
    return out


def interior(model, q, x, end_tol: float = END_TOL) -> np.ndarray:
    """True where x* [m] (closest_points(...).x: (W, n), or (K, W, n) for q (K, N)) is farther
    than end_tol l_i from both ends of link i's search interval: an interior contact
    candidate (module docstring, dedupe rule)."""
    a, b = search_interval(model, q)
    if a.ndim == 2:
        a, b = a[:, None], b[:, None]
    tol = end_tol * _tables(model).length
    x = np.asarray(x, dtype=float)
    return (x - a > tol) & (b - x > tol)


def closest_points(model, q, walls, refine_below: float = np.inf) -> ClosestPoints:
    """For every wall w and link i, the material point of link i with the smallest gap.

    x*_wi = argmin over x in [a_i, b_i] of g_w(p(q, i, x)) (module docstring: the method,
    the sampling rule and the closed form of rigid links).

    Parameters
    ----------
    model : Model
    q : (N,) coordinates, or (K, N) for K states at once (one kernel call, one pass)
    walls : sequence of W Plane, Circle, Sphere
    refine_below : float [m], default inf (every pair exact). A flexible link whose lowest
        sample gap exceeds it is not refined: x* and the gap are those of its best sample,
        an upper bound of the minimum within h^2/8 max|g''| of it (h the sample spacing), so
        the gap's sign is exact whenever refine_below exceeds that bound -- all an event
        function needs away from contact, at the cost of the sampling alone.

    Returns
    -------
    ClosestPoints(x (W, n) [m], gap (W, n) [m], normal (W, n, 3)); with q (K, N) each gets a
    leading axis K.
    """
    tab = _tables(model)
    walls = tuple(walls)
    W, n, S, N = len(walls), tab.n, tab.S, tab.N
    qa = np.asarray(q, dtype=float)
    if qa.shape[-1:] != (N,) or qa.ndim not in (1, 2):
        raise ValueError(f"q has shape {qa.shape}; this model needs (N,) or (K, N), N = {N} "
                         f"({', '.join(model.coordinate_names)})")
    qs = qa.reshape(-1, N)
    K = qs.shape[0]
    if W == 0:
        out = ClosestPoints(np.zeros((K, 0, n)), np.zeros((K, 0, n)), np.zeros((K, 0, n, 3)))
        return out if qa.ndim == 2 else ClosestPoints(*(a[0] for a in out))
    wp = _walls(walls)
    st = _state(model, tab, qs)

    # Samples: local r and dr/ds (K, 2, n, S, 3) = r0 + A qe, world p, dp/ds; g, g' (K, W, n, S).
    r = tab.r0 + (tab.A @ st.qe.reshape(K, N + 1).T).T.reshape(K, 2, n, S, 3)
    p = np.matmul(r, st.R.swapaxes(-1, -2)[:, None])
    p0, p1 = p[:, 0], p[:, 1]
    p0 += st.o[:, :, None, :]
    terms = [_sample_terms(wp, k, p0, p1) for k in range(W)]
    if W == 1:
        g, g1 = terms[0][0][:, None], terms[0][1][:, None]
    else:
        g, g1 = np.stack([t[0] for t in terms], axis=1), np.stack([t[1] for t in terms], axis=1)

    # The ends of every link (the only candidates of a rigid link: closed form; ties: the proximal end).
    far = g[..., -1] < g[..., 0]
    best_s = far * tab.Lc
    best_g = np.minimum(g[..., 0], g[..., -1])
    kk, ll = tab.grid_index(K, W)
    best_p = p0[kk, ll, far * (S - 1)]
    fl = tab.flex_links
    if fl.size:
        # Interior minima: g' changes sign from - to + between samples k and k + 1.
        g1f = g1 if fl.size == n else g1[:, :, fl]
        ks, ws, ls, js = np.nonzero((g1f[..., :-1] < 0.0) & (g1f[..., 1:] >= 0.0))
        if refine_below < np.inf and ks.size:
            gf = g if fl.size == n else g[:, :, fl]
            kmin = np.argmin(gf, axis=-1)
            gmin = np.take_along_axis(gf, kmin[..., None], -1)[..., 0]
            coarse = gmin > refine_below
            if coarse.any():
                kc, wc, lc = np.nonzero(coarse)
                jc, lk = kmin[kc, wc, lc], fl[lc]
                best_s[kc, wc, lk] = tab.s_grid[lk, jc]
                best_g[kc, wc, lk] = gmin[kc, wc, lc]
                best_p[kc, wc, lk] = p0[kc, lk, jc]
                fine = ~coarse[ks, ws, ls]
                ks, ws, ls, js = ks[fine], ws[fine], ls[fine], js[fine]
        if ks.size:
            links = fl[ls]
            s_new, gs, ps = _refine(tab, wp, st, ks, ws, links, js, g[ks, ws, links, js], g[ks, ws, links, js + 1],
                                    g1[ks, ws, links, js], g1[ks, ws, links, js + 1])
            # The lowest interior minimum of each pair (np.nonzero sorts the keys); it beats the
            # ends only beyond round-off.
            key = (ks * W + ws) * n + links
            if key.size > 1 and np.any(key[1:] == key[:-1]):
                order = np.lexsort((gs, key))
                first = np.ones(order.size, dtype=bool)
                first[1:] = key[order[1:]] != key[order[:-1]]
                win = order[first]
                kv, wv, lv = ks[win], ws[win], links[win]
            else:
                win, kv, wv, lv = slice(None), ks, ws, links
            better = gs[win] < best_g[kv, wv, lv] - _TIE * (1.0 + np.abs(p0).max())
            if not better.all():
                win = np.arange(ks.size)[win][better]
                kv, wv, lv = kv[better], wv[better], lv[better]
            best_s[kv, wv, lv] = s_new[win]
            best_g[kv, wv, lv] = gs[win]
            best_p[kv, wv, lv] = ps[win]
    best_n = np.empty((K, W, n, 3))
    for k in range(W):
        best_n[:, k] = _normals(wp, k, best_p[:, k])
    if tab.has_pb:   # x = offset + scale s, exactly l at the far end
        x = np.where(best_s == tab.Lc, tab.length, st.offset[:, None] + st.scale[:, None] * best_s)
    else:
        x = best_s   # s = x (and s = l exactly at the far end)
    if qa.ndim == 1:
        return ClosestPoints(x[0], best_g[0], best_n[0])
    return ClosestPoints(x, best_g, best_n)


def _refine(tab, wp, st, ks, ws, links, js, ga, gb, g1a, g1b):
    """Minima of g(s) in the brackets [s_j, s_(j+1)] where g'(s_j) < 0 <= g'(s_(j+1)) (P seeds).

    Returns s (P,), g (P,) [m] and p (P, 3) [m] at the minima. Start: the minimum of the cubic
    Hermite interpolant of (g, g') at the bracket's ends (exact for a Hermite-element link
    and a plane: g is then a cubic in s on one element). Then a safeguarded Newton iteration
    on g'(s) = 0 (_newton), per group of links with the same basis functions.
    """
    Lc = tab.Lc[links]
    h = Lc / (tab.S - 1)
    lo = js * h
    hi = lo + h
    last = js == tab.S - 2
    hi[last] = Lc[last]
    # Cubic Hermite interpolant on t in [0, 1]: h G'(t) = a t^2 + b t + c, c < 0 <= a + b + c;
    # its root with G'' >= 0 is t = 2 c / (-b - sqrt(b^2 - 4 a c)) (the denominator is < 0).
    dg = gb - ga
    a = 3.0 * h * (g1a + g1b) - 6.0 * dg
    b = 6.0 * dg - h * (4.0 * g1a + 2.0 * g1b)
    c = h * g1a
    den = -b - np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    t = np.clip(2.0 * c / np.minimum(den, -1e-300), 0.0, 1.0)
    s = lo + t * (hi - lo)
    wpp = _WallParams(*(arr[ws] for arr in wp))
    modal = tab.modal[links]
    tol = X_TOL * Lc
    if modal.all() or not modal.any():
        return _group(tab, st, ks, links, js, modal.all(), wpp, lo, hi, s, tol)
    out_s, out_g, out_p = np.empty_like(s), np.empty_like(s), np.empty((s.size, 3))
    for sel, is_modal in ((modal, True), (~modal, False)):
        sub = _WallParams(*(arr[sel] for arr in wpp))
        out_s[sel], out_g[sel], out_p[sel] = _group(tab, st, ks[sel], links[sel], js[sel], is_modal, sub, lo[sel],
                                                    hi[sel], s[sel], tol[sel])
    return out_s, out_g, out_p


def _group(tab, st, ks, links, js, modal, wpp, lo, hi, s, tol):
    """_newton for seeds whose links share one kind of basis (assumed modes, or Hermite elements)."""
    basis = _ModalBasis(tab, st, ks, links) if modal else _HermiteBasis(tab, st, ks, links, js, lo, hi, s, wpp)
    return _newton(basis, wpp, lo, hi, s, tol)


class _ModalBasis:
    """p, dp/ds, d2p/ds2 of assumed-mode link points as C @ F(s) (world frame, P points).

    F = (1, s, e^(beta_j s), e^(-beta_j s), cos beta_j s, sin beta_j s) (j = 1 .. width), the
    coefficients C (P, 3 orders x 3 components, 2 + 4 width) hold T_i, the modal coordinates
    and the mode constants (modes.py: psi = C[(1 - sigma)/2 e^(beta x) + (1 + sigma)/2 e^(-beta x)
    - cos + sigma sin]; _Tables.modal_template).
    """

    def __init__(self, tab, st, ks, links):
        qv = st.qe[tab.midx[links, 0] + (ks * (tab.N + 1))[:, None]]           # (P, width)
        local = np.einsum("pksbj,pj->pksb", tab.modal_template[links], qv)    # (P, 3 orders, 2, nb)
        self.beta = tab.beta[links]
        self.C = _world(st, ks, links, local, tab.modal_x)

    def points(self, s):
        """(P, 3 orders, 3): p, dp/ds, d2p/ds2 at s (P,)."""
        bs = self.beta * s[:, None]
        e = np.exp(bs)
        F = np.concatenate((np.ones((s.size, 1)), s[:, None], e, 1.0 / e, np.cos(bs), np.sin(bs)), axis=1)
        return (self.C @ F[:, :, None]).reshape(s.size, 3, 3)

    def compress(self, keep):
        self.beta, self.C = self.beta[keep], self.C[keep]


class _HermiteBasis:
    """The same for Hermite-element links (and Pb links): on the element [s_(e-1), s_(e-1) + h]
    holding the bracket, F = (1, eta, eta^2, eta^3), eta = (s - s_(e-1)) / h, so C @ F is the
    cubic of that element (coefficients: _Tables.hermite_template). When the sample grid
    does not contain the nodes, a bracket that straddles a node is first cut there, on the
    side where g' changes sign (g' is continuous at a node: v is C1)."""

    _POWERS = np.arange(4.0)

    def __init__(self, tab, st, ks, links, js, lo, hi, s, wpp):
        self.tab, self.st, self.ks, self.links = tab, st, ks, links
        per = tab.samples_per_element[links]
        if per.all():
            self._build(js // per + 1)     # the nodes are samples: the bracket is inside element e
            return
        h, ne = tab.h[links], tab.ne[links]
        e_lo = np.minimum(np.floor(lo / h).astype(int) + 1, ne)     # element right of lo
        e_hi = np.clip(np.ceil(hi / h).astype(int), 1, ne)            # element left of hi
        cut = e_hi > e_lo
        if cut.any():
            # g' at the node s_n = e_lo h from the left element; keep the half where g' changes sign.
            self._build(e_lo)
            node = e_lo * h
            p = self.points(node)
            g1n = _gap_terms(wpp, p[:, 0], p[:, 1])[2]
            right = cut & (g1n < 0.0)
            lo[right] = node[right]
            hi[cut & ~right] = node[cut & ~right]
            np.clip(s, lo, hi, out=s)
            e_lo = np.where(right, e_lo + 1, e_lo)
        self._build(e_lo)

    def _build(self, e):
        """World coefficients C (P, 9, 4) of the elements e (P,) (1-based)."""
        tab, st, ks, links = self.tab, self.st, self.ks, self.links
        h = self.h = tab.h[links]
        self.s0 = (e - 1) * h
        off = (ks * (tab.N + 1))[:, None, None]
        dofs = np.concatenate((st.qe[tab.node_q[links, e - 1] + off], st.qe[tab.node_q[links, e] + off]), axis=2)
        local = np.zeros((links.size, 3, 3, 4))
        local[:, :, 1:] = np.einsum("pkbj,pdj->pkdb", tab.hermite_template[links], dofs)
        sc = st.scale[ks, links]
        local[:, 0, 0, 0] = st.offset[ks, links] + sc * self.s0     # x = offset + scale (s0 + h eta)
        local[:, 0, 0, 1] = sc * h
        local[:, 1, 0, 0] = sc
        self.C = _world(st, ks, links, local, None)

    def points(self, s):
        """(P, 3 orders, 3): p, dp/ds, d2p/ds2 at s (P,)."""
        F = ((s - self.s0) / self.h)[:, None] ** self._POWERS
        return (self.C @ F[:, :, None]).reshape(s.size, 3, 3)

    def compress(self, keep):
        self.s0, self.h, self.C = self.s0[keep], self.h[keep], self.C[keep]


def _world(st, ks, links, local, modal_x):
    """World coefficients (P, 9, nb) from local ones (P, 3 orders, 3 or 2 rows, nb): C = R local (+ o),
    rows (order, component)."""
    if modal_x is not None:
        # Assumed-mode links are ordinary (x = s): rows v, w given, x row = (0, 1, 0 ...) / (1, 0 ...).
        full = np.zeros(local.shape[:2] + (3,) + local.shape[3:])
        full[:, :, 1:] = local
        full[:, :, 0] = modal_x
        local = full
    C = np.einsum("pij,pkjb->pkib", st.R[ks, links], local)
    C[:, 0, :, 0] += st.o[ks, links]
    return C.reshape(links.size, 9, -1)


def _newton(basis, wpp, lo, hi, s, tol):
    """Safeguarded Newton on g'(s) = 0 for the points of ``basis``.

    A Newton step is taken when g'' > 0 and it stays in [lo, hi], a bisection otherwise; the
    bracket keeps g' < 0 at lo and g' >= 0 at hi. A point is done when the error left after
    its Newton step ds, estimated as |ds| (first step, or after a bisection) or
    |ds|^3 / ds_prev^2 (quadratic convergence, the constant from the last two steps), or its
    bracket, is below tol. The result at s = s_e + ds comes from the last evaluation at s_e by
    Taylor (p, g to O(ds^3): far below round-off). Returns s, g, p (P,), (P,), (P, 3).
    """
    P = s.size
    out_s, out_g, out_p = np.empty(P), np.empty(P), np.empty((P, 3))
    idx = np.arange(P)
    prev = np.full(P, 1e-300)
    for _ in range(MAX_ITERATIONS):
        p = basis.points(s)
        g, g1, g2 = _gap_derivatives(wpp, p)
        neg = g1 < 0.0
        np.copyto(lo, s, where=neg)
        np.copyto(hi, s, where=~neg)
        ds = -g1 / np.maximum(g2, 1e-300)
        s_new = s + ds
        take = (g2 > 0.0) & (s_new >= lo) & (s_new <= hi)
        np.copyto(ds, 0.5 * (lo + hi) - s, where=~take)      # otherwise bisect
        step = np.abs(ds)
        left = step * np.minimum(1.0, step / prev) ** 2     # error left after the step
        done = (take & (left <= tol)) | (hi - lo <= tol) | (g1 == 0.0)
        prev = step * take + 1e-300
        if done.any():
            d = np.where(take, ds, hi - s)[done]   # a bracket below tol ends at hi (g' >= 0; hi = s if g' = 0)
            i = idx[done]
            out_s[i] = s[done] + d
            out_g[i] = g[done] + d * (g1[done] + 0.5 * d * g2[done])
            out_p[i] = p[done, 0] + d[:, None] * (p[done, 1] + 0.5 * d[:, None] * p[done, 2])
            keep = ~done
            if not keep.any():
                return out_s, out_g, out_p
            idx, s, ds, prev, lo, hi, tol = idx[keep], s[keep], ds[keep], prev[keep], lo[keep], hi[keep], tol[keep]
            wpp = _WallParams(*(arr[keep] for arr in wpp))
            basis.compress(keep)
        s = s + ds
    p = basis.points(s)[:, 0]
    out_s[idx], out_p[idx] = s, p
    out_g[idx] = _gap_terms(wpp, p)[0]
    return out_s, out_g, out_p


def _gap_derivatives(wp: _WallParams, p):
    """g, g' and g'' (P,) each along s from p (P, 3 orders, 3) = (p, dp/ds, d2p/ds2), row by row with wp."""
    plane = wp.plane
    if plane.all():
        G = (p @ wp.normal[:, :, None])[:, :, 0]               # n . (p, p', p'')
        return G[:, 0] - wp.offset, G[:, 1], G[:, 2]
    if plane.any():
        g, _, g1, g2 = _gap_terms(wp, p[:, 0], p[:, 1], p[:, 2])
        return g, g1, g2
    # g = R - rho, n = -d / rho, g' = n.P p', g'' = n.P p'' - (|P p'|^2 - g'^2) / rho (_gap_terms).
    d = (p[:, 0] - wp.center) * wp.proj
    rho = np.maximum(np.hypot(np.hypot(d[:, 0], d[:, 1]), d[:, 2]), 1e-300)
    pp = p[:, 1:] * wp.proj[:, None, :]                            # P p', P p''
    G = (pp @ d[:, :, None])[:, :, 0] / -rho[:, None]              # n.P p', n.P p''
    q1 = pp[:, 0]
    q1q1 = (q1[:, None, :] @ q1[:, :, None])[:, 0, 0]
    return wp.radius - rho, G[:, 0], G[:, 1] - (q1q1 - G[:, 0] * G[:, 0]) / rho
