"""The closest point of every link to every wall: :func:`closest_points`.

x*_wi minimises g_w(p(q, i, x)) over link i's search interval [a_i, b_i] (contact/candidates.py:
search_interval, and what the event loop does with x*). The per-model tables it evaluates
the links with are contact/link_tables.py.

Method of :func:`closest_points` (it runs in every event function call, so it is vectorised
over states, links, walls and samples, with one kernel call for all frames):

1. *Rigid links* (no elastic coordinates): the link is a straight segment A + t (B - A),
   t in [0, 1]. g is linear along it for a plane and concave for a circle or a sphere that
   confines the chain (|P (p - c)| is convex along a line), so the minimum is at an end: the
   smaller of the two end gaps (ties: the proximal end). On an obstacle (g = |P (p - c)| - R,
   convex) the minimum is the projection of the centre, t* = clip(-P (A - c) . P (B - A) /
   |P (B - A)|^2, 0, 1), in closed form (_rigid_obstacle_minima).
2. *Flexible links*: g and g' = dg/ds are sampled at S points evenly spaced on the search
   interval, in the shape coordinate s (s = x, or s = xi = sigma / d on the protruding part
   of a Pb link). The local points r(s) and dr/ds at the samples are one product
   r0 + A qe with a matrix A precomputed per model (qe: q with the Pb slopes times d); a stiffened link's
   samples and refined points are foreshortened (x + u_f, formulation §15: link_tables._foreshortened).
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
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .link_tables import _foreshorten_points, _foreshorten_samples, _foreshortened, _state, _tables

#: Error left in s (relative to the search interval's length) at which the Newton refinement stops.
X_TOL = 1e-12
#: Iteration cap of the refinement (bisection from a bracket of l / 16 to 1e-12 l takes 40).
MAX_ITERATIONS = 60
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


# -- walls ------------------------------------------------------------------------------------

class _WallParams(NamedTuple):
    """Walls as arrays (W, ...): plane flag, normal and n.point; projector diagonal, centre, radius, side
    s (+1: g = R - rho, -1 an obstacle: g = rho - R; +1 for a plane)."""

    plane: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    proj: np.ndarray
    center: np.ndarray
    radius: np.ndarray
    side: np.ndarray


def _wall_params(walls) -> _WallParams:
    W = len(walls)
    plane = np.zeros(W, dtype=bool)
    nv, off, proj, c, R = np.zeros((W, 3)), np.zeros(W), np.zeros((W, 3)), np.zeros((W, 3)), np.zeros(W)
    side = np.ones(W)
    for k, wl in enumerate(walls):
        # The wall kinds as the compiled code takes them (Wall.packed(): 0 plane, 1 circle, 2 sphere).
        kind, p = wl.packed()
        if kind == 0:  # (point, normal)
            plane[k] = True
            proj[k] = 1.0  # g' = n.P p1 with P = I holds for a plane too
            nv[k] = p[3:]
            off[k] = float(np.dot(p[3:], p[:3]))
        else:  # (R, centre): a circle's 2D, a sphere's 3D
            proj[k] = (1.0, 1.0, 0.0) if kind == 1 else 1.0
            c[k, :2 if kind == 1 else 3] = p[1:3 if kind == 1 else 4]
            R[k] = p[0]
            side[k] = p[5]
    return _WallParams(plane, nv, off, proj, c, R, side)


_WALLS: dict = {}


def _walls(walls: tuple) -> _WallParams:
    """_wall_params, cached per tuple of (immutable) walls."""
    try:
        return _WALLS[walls]
    except KeyError:
        if len(_WALLS) > 64:
            _WALLS.clear()
        return _WALLS.setdefault(walls, _wall_params(walls))
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
    # g' = n . p1 with n = -s d / rho; on the axis or at the centre (d = 0) it is 0.
    s = wp.side[k]
    return s * (wp.radius[k] - rho), dp / (-s * np.maximum(rho, 1e-300))


def _normals(wp: _WallParams, k: int, p):
    """Unit normal (..., 3) of wall k at the points p (..., 3): n, or -s P (p - c) / |P (p - c)| (0 on the axis)."""
    if wp.plane[k]:
        nrm = np.empty(p.shape)
        nrm[...] = wp.normal[k]
        return nrm
    m = 2 if wp.proj[k, 2] == 0.0 else 3
    nrm = np.zeros(p.shape)
    d = p[..., :m] - wp.center[k, :m]
    rho = np.hypot(d[..., 0], d[..., 1]) if m == 2 else np.hypot(np.hypot(d[..., 0], d[..., 1]), d[..., 2])
    nrm[..., :m] = d / (-wp.side[k] * np.maximum(rho, 1e-300))[..., None]
    return nrm


def _gap_terms(wp: _WallParams, p, p1=None, p2=None):
    """Gap g, unit normal n and, with p1 = dp/ds (and p2 = d2p/ds2), g' (and g'') along s.

    wp's arrays and p (P, 3) correspond row by row. Plane: g = n.p - n.p0, g' = n.p1,
    g'' = n.p2. Circle, sphere: d = P (p - c), rho = |d|, g = s (R - rho), n = -s d / rho (0 on
    the axis or at the centre), g' = n.P p1, g'' = n.P p2 - s (|P p1|^2 - (n.P p1)^2) / rho.
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
    nrm = dvec / (-wp.side * safe)[:, None]
    g = wp.side * (wp.radius - rho)
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
    g2 = np.einsum("pi,pi->p", nrm, wp.proj * p2) - np.where(plane, 0.0, wp.side * curv)
    return g, nrm, g1, g2


# -- the search -------------------------------------------------------------------------------

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
    W, n, N = len(walls), tab.n, tab.N
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
    p0, g, g1 = _sample_gaps(tab, wp, st, K, W)
    best_s, best_g, best_p = _end_minima(tab, p0, g, K, W)
    if tab.flex_links.size:
        _interior_minima(tab, wp, st, p0, g, g1, refine_below, best_s, best_g, best_p)
    if tab.flex_links.size < n and (wp.side < 0.0).any():
        _rigid_obstacle_minima(tab, wp, p0, best_s, best_g, best_p)
    x = _abscissa(tab, st, best_s)
    _foreshorten(model, wp, st, qs, x, best_g, best_p)
    best_n = np.empty((K, W, n, 3))
    for k in range(W):
        best_n[:, k] = _normals(wp, k, best_p[:, k])
    out = ClosestPoints(x, best_g, best_n)
    return out if qa.ndim == 2 else ClosestPoints(*(a[0] for a in out))


def _foreshorten(model, wp: _WallParams, st, qs, x, best_g, best_p):
    """Closest points of stiffened links on their foreshortened centreline (formulation §15), in place:
    x (K, W, n) [m], best_g (K, W, n) [m], best_p (K, W, n, 3) [m].

    The search above already runs on r = (x + u_f, v, w); from its x* (an end included) a Newton
    iteration on g'(x) = 0 (steps only where g'' > 0, x kept in [0, l]; u_f' = -1/2 (v'^2 + w'^2),
    u_f'' = -(v' v'' + w' w'')) until the step is below X_TOL l gives the point and gap of the closest
    material point of the foreshortened link (those the impact's Jacobian, material_jacobian, uses).
    """
    for i in [i for i, lk in enumerate(model.chain.links) if lk.stiffened]:
        for k, q in enumerate(qs):
            x[k, :, i], best_p[k, :, i], best_g[k, :, i] = _foreshortened_minimum(model, wp, q, i, x[k, :, i], st.R[k, i],
                                                                                st.o[k, i])


def _foreshortened_minimum(model, wp, q, i: int, xs, R, o, newton=True, bounds=None, slopes=False, curve=None):
    """x (P,), p (P, 3), g (P,) [m] (slopes: and g', g'' (P,), the curve at x): _foreshorten's minima of stiffened link
    i's gap to walls wp (row by row) from xs (P,) [m] in bounds (lo, hi) [m] (default [0, l]), fixed where newton (P,)
    is False; R (3, 3), o (3,): link frame at q; curve: the curve at xs if known (one evaluation per distinct x)."""
    length, xs = model.chain.links[i].length, np.array(xs, dtype=float)
    lo, hi = (0.0, length) if bounds is None else bounds
    curve = _foreshortened_curve(model, q, i, xs, R, o) if curve is None else curve
    for _ in range(MAX_ITERATIONS if np.any(newton) else 0):
        g, _, g1, g2 = _gap_terms(wp, *curve)
        step = np.where((g2 > 0.0) & newton, -g1 / np.where(g2 > 0.0, g2, 1.0), 0.0)
        new = np.clip(xs + step, lo, hi)
        done = np.abs(new - xs).max() <= X_TOL * length
        if np.any(new != xs):
            xs, curve = new, _foreshortened_curve(model, q, i, new, R, o)
        if done:
            break
    g, _, g1, g2 = _gap_terms(wp, *curve)
    return (xs, curve[0], g, g1, g2, curve) if slopes else (xs, curve[0], g)


def _foreshortened_curve(model, q, i, xs, R, o):
    """World p, dp/dx, d2p/dx2 (W, 3) of stiffened link i at abscissae xs (W,) [m]: r = (x + u_f, v, w)
    in the link frame (R (3, 3), origin o (3,))."""
    from ..model.shapes import link_deflection, link_foreshortening

    (v, w), (v1, w1), (v2, w2) = (link_deflection(model, q, i, xs, d) for d in range(3))
    r = np.stack([xs + link_foreshortening(model, q, i, xs)[0], v, w], axis=1)
    r1 = np.stack([1.0 - 0.5 * (v1 * v1 + w1 * w1), v1, w1], axis=1)
    r2 = np.stack([-(v1 * v2 + w1 * w2), v2, w2], axis=1)
    return r @ R.T + o, r1 @ R.T, r2 @ R.T


def _sample_gaps(tab, wp: _WallParams, st, K: int, W: int):
    """Step 2's samples: world points p0 (K, n, S, 3) [m], gaps g and g' = dg/ds (K, W, n, S) of every wall."""
    n, S, N = tab.n, tab.S, tab.N
    # Samples: local r and dr/ds (K, 2, n, S, 3) = r0 + A qe, world p, dp/ds; g, g' (K, W, n, S).
    r = tab.r0 + (tab.A @ st.qe.reshape(K, N + 1).T).T.reshape(K, 2, n, S, 3)
    _foreshorten_samples(tab, st.qe.reshape(K, N + 1), r)
    p = np.matmul(r, st.R.swapaxes(-1, -2)[:, None])
    p0, p1 = p[:, 0], p[:, 1]
    p0 += st.o[:, :, None, :]
    terms = [_sample_terms(wp, k, p0, p1) for k in range(W)]
    if W == 1:
        g, g1 = terms[0][0][:, None], terms[0][1][:, None]
    else:
        g, g1 = np.stack([t[0] for t in terms], axis=1), np.stack([t[1] for t in terms], axis=1)
    return p0, g, g1


def _end_minima(tab, p0, g, K: int, W: int):
    """The lower end of every link: s (K, W, n), its gap (K, W, n) [m] and point (K, W, n, 3) [m]."""
    # The ends of every link (the only candidates of a rigid link: closed form; ties: the proximal end).
    far = g[..., -1] < g[..., 0]
    best_s = far * tab.Lc
    best_g = np.minimum(g[..., 0], g[..., -1])
    kk, ll = tab.grid_index(K, W)
    best_p = p0[kk, ll, far * (tab.S - 1)]
    return best_s, best_g, best_p


def _interior_minima(tab, wp: _WallParams, st, p0, g, g1, refine_below: float, best_s, best_g, best_p):
    """Where a flexible link has an interior minimum lower than its ends' beyond round-off, it replaces
    best_s, best_g (K, W, n) and best_p (K, W, n, 3) (in place); p0, g, g1 are _sample_gaps'."""
    W, n = g.shape[1], tab.n
    fl = tab.flex_links
    # Interior minima: g' changes sign from - to + between samples k and k + 1.
    g1f = g1 if fl.size == n else g1[:, :, fl]
    ks, ws, ls, js = np.nonzero((g1f[..., :-1] < 0.0) & (g1f[..., 1:] >= 0.0))
    gf = g if fl.size == n else g[:, :, fl]
    hidden = _hidden_brackets(tab, wp, st, gf, g1f)
    lo = hi = np.full(ks.size, np.nan)
    if hidden is not None:
        n_old = ks.size
        ks, ws, ls, js = (np.concatenate((u, v)) for u, v in zip((ks, ws, ls, js), hidden[:4]))
        order = np.lexsort((js, ls, ws, ks))  # np.nonzero's order: the keys of a pair stay together
        ks, ws, ls, js = ks[order], ws[order], ls[order], js[order]
        lo, hi = (np.concatenate((np.full(n_old, np.nan), e))[order] for e in hidden[4:])
    if refine_below < np.inf and ks.size:
        ks, ws, ls, js, lo, hi = _keep_coarse(tab, p0, g, refine_below, (ks, ws, ls, js, lo, hi), best_s, best_g,
                                              best_p)
    if not ks.size:
        return
    links = fl[ls]
    s_new, gs, ps = _refine(tab, wp, st, ks, ws, links, js, g[ks, ws, links, js], g[ks, ws, links, js + 1],
                            g1[ks, ws, links, js], g1[ks, ws, links, js + 1], (lo, hi))
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


def _rigid_obstacle_minima(tab, wp: _WallParams, p0, best_s, best_g, best_p):
    """Step 1 on obstacles: the closest point of every rigid link's segment A + t (B - A) (its first
    and last samples in p0 (K, n, S, 3) [m]) to every obstacle, in closed form,

        t* = clip(-P (A - c) . P (B - A) / |P (B - A)|^2, 0, 1),   g = |P (A + t* (B - A) - c)| - R,

    replaces best_s, best_g (K, W, n) and best_p (K, W, n, 3) (in place) where it is lower than the
    ends' beyond round-off (as _interior_minima; ties: the end)."""
    rigid = np.flatnonzero(~tab.flexible)
    A, B = p0[:, rigid, 0], p0[:, rigid, -1]                        # (K, r, 3)
    tie = _TIE * (1.0 + np.abs(p0).max())
    for k in np.flatnonzero(wp.side < 0.0):
        P, c = wp.proj[k], wp.center[k]
        d, e = P * (A - c), P * (B - A)
        ee = np.einsum("kri,kri->kr", e, e)
        t = np.clip(-np.einsum("kri,kri->kr", d, e) / np.where(ee > 0.0, ee, 1.0), 0.0, 1.0)
        dt = d + t[..., None] * e
        gt = np.sqrt(np.einsum("kri,kri->kr", dt, dt)) - wp.radius[k]
        better = gt < best_g[:, k, rigid] - tie
        kk, rr = np.nonzero(better)
        ll = rigid[rr]
        best_s[kk, k, ll] = t[kk, rr] * tab.Lc[ll]
        best_g[kk, k, ll] = gt[kk, rr]
        best_p[kk, k, ll] = A[kk, rr] + t[kk, rr, None] * (B[kk, rr] - A[kk, rr])


def _keep_coarse(tab, p0, g, refine_below: float, brackets, best_s, best_g, best_p):
    """refine_below: a flexible pair whose lowest sample gap exceeds it takes that sample as its minimum
    (written into best_s, best_g, best_p); returns the brackets (ks, ws, ls, js, sub) of the other pairs
    (lo, hi: the ends of a bracket of _hidden_brackets, NaN for a sample bracket)."""
    ks, ws, ls, js, lo, hi = brackets
    fl = tab.flex_links
    gf = g if fl.size == tab.n else g[:, :, fl]
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
        ks, ws, ls, js, lo, hi = ks[fine], ws[fine], ls[fine], js[fine], lo[fine], hi[fine]
    return ks, ws, ls, js, lo, hi


def _abscissa(tab, st, s):
    """Material abscissa x [m] (K, W, n) of the shape coordinate s (K, W, n): x = offset + scale s."""
    if tab.has_pb:   # x = offset + scale s, exactly l at the far end
        return np.where(s == tab.Lc, tab.length, st.offset[:, None] + st.scale[:, None] * s)
    return s   # s = x (and s = l exactly at the far end)


def _hidden_brackets(tab, wp: _WallParams, st, g, g1):
    """Interior minima that the signs of the sampled g' miss: (ks, ws, ls, js, lo, hi) or None.

    g, g1 : (K, W, F, S) samples of the F flexible links (_sample_gaps). On the sample interval
    [s_j, s_(j+1)] of length h, t in [0, 1], the cubic Hermite interpolant G of (g, g') has

        h G'(t) = a t^2 + b t + c,  a = 3 (m0 + m1) - 6 dg,  b = 6 dg - 4 m0 - 2 m1,  c = m0,

    m0 = h g'(s_j), m1 = h g'(s_(j+1)), dg = g(s_(j+1)) - g(s_j). Where g' has one sign at both
    samples, G still has an interior minimum when G' changes sign twice: m0, m1 >= 0 with a > 0,
    or m0, m1 < 0 with a < 0, the vertex -b / (2 a) in (0, 1) and b^2 > 4 a c; its minimum is at
    t_m = (-b + sqrt(b^2 - 4 a c)) / (2 a) (G'' = 2 a t + b > 0 there). Typically a dip that grows
    out of a link's end resting on a wall (issue 25 item 5): the link turns about the end, g'(0)
    is still > 0 while the curvature near the end already pulls the span below the end. The
    exact g' at 8 probes, t = 1/8 .. 7/8 and t_m, then gives the first bracket where g' goes from
    < 0 to >= 0 among (0, probes, 1); an interval without one is dropped. (``lo``, ``hi``: that
    bracket's ends.) For Hermite elements on a plane with the nodes as samples the cubic is
    exact, so no minimum is missed there; for modes the test sees every dip the cubic resolves.
    """
    fl = tab.flex_links
    h = (tab.Lc[fl] / (tab.S - 1))[:, None]                        # (F, 1) [m or shape units]
    m0, m1 = h * g1[..., :-1], h * g1[..., 1:]
    dg = g[..., 1:] - g[..., :-1]
    a = 3.0 * (m0 + m1) - 6.0 * dg
    b = 6.0 * dg - 4.0 * m0 - 2.0 * m1
    disc = b * b - 4.0 * a * m0
    up = (m0 >= 0.0) & (m1 >= 0.0) & (a > 0.0)
    down = (m0 < 0.0) & (m1 < 0.0) & (a < 0.0)
    vertex = -b / np.where(a != 0.0, 2.0 * a, 1.0)
    ks, ws, ls, js = np.nonzero((up | down) & (disc > 0.0) & (vertex > 0.0) & (vertex < 1.0))
    if not ks.size:
        return None
    aa, bb, dd = a[ks, ws, ls, js], b[ks, ws, ls, js], disc[ks, ws, ls, js]
    links, P = fl[ls], ks.size
    t_m = np.clip((-bb + np.sqrt(dd)) / (2.0 * aa), 0.0, 1.0)
    t = np.sort(np.concatenate((np.broadcast_to(np.arange(1, 8) / 8.0, (P, 7)), t_m[:, None]), axis=1), axis=1)
    s0, hh = tab.s_grid[links, js], h[ls, 0]
    probes = s0[:, None] + t * hh[:, None]                          # (P, 8)
    rep = lambda v: np.repeat(v, 8)  # noqa: E731
    slope = _slopes(tab, wp, st, rep(ks), rep(ws), rep(links), rep(js), probes.ravel()).reshape(P, 8)
    V = np.concatenate((m0[ks, ws, ls, js, None], slope, m1[ks, ws, ls, js, None]), axis=1)   # (P, 10)
    S = np.concatenate((s0[:, None], probes, tab.s_grid[links, js + 1][:, None]), axis=1)
    fall = (V[:, :-1] < 0.0) & (V[:, 1:] >= 0.0)
    keep = fall.any(axis=1)
    if not keep.any():
        return None
    i = np.argmax(fall, axis=1)[keep]
    rows = np.flatnonzero(keep)
    return ks[keep], ws[keep], ls[keep], js[keep], S[rows, i], S[rows, i + 1]


def _slopes(tab, wp, st, ks, ws, links, js, s):
    """The exact g' = dg/ds (P,) at s (P,) on the sample intervals js of links (P,) (one basis per kind)."""
    out = np.empty(s.size)
    modal = tab.modal[links]
    for sel, is_modal in ((modal, True), (~modal, False)):
        if not sel.any():
            continue
        wpp = _WallParams(*(arr[ws[sel]] for arr in wp))
        lo = tab.s_grid[links[sel], js[sel]]
        hi = tab.s_grid[links[sel], js[sel] + 1]
        ss = s[sel].copy()
        args = (tab, st, ks[sel], links[sel])
        basis = _ModalBasis(*args) if is_modal else _HermiteBasis(*args, js[sel], lo, hi, ss, wpp)
        out[sel] = _gap_derivatives(wpp, _foreshortened(basis, *args).points(s[sel]))[1]
    return out


def _refine(tab, wp, st, ks, ws, links, js, ga, gb, g1a, g1b, bounds=None):
    """Minima of g(s) in the brackets [s_j, s_(j+1)] where g'(s_j) < 0 <= g'(s_(j+1)) (P seeds);
    bounds : None, or (lo, hi) (P,) each: NaN, or a bracket of _hidden_brackets inside that
    interval (g'(lo) < 0 <= g'(hi)), whose Newton iteration starts at its middle.

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
    if bounds is not None and not np.isnan(bounds[0]).all():
        inner = ~np.isnan(bounds[0])
        lo[inner], hi[inner] = bounds[0][inner], bounds[1][inner]
        s[inner] = 0.5 * (lo[inner] + hi[inner])
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
    return _newton(_foreshortened(basis, tab, st, ks, links), wpp, lo, hi, s, tol)


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
            p = _foreshorten_points(tab, st, ks, links, node, self.points(node))   # the true g' of a stiffened link
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
    # g = s (R - rho), n = -s d / rho, g' = n.P p', g'' = n.P p'' - s (|P p'|^2 - g'^2) / rho (_gap_terms).
    d = (p[:, 0] - wp.center) * wp.proj
    s = wp.side
    rho = np.maximum(np.hypot(np.hypot(d[:, 0], d[:, 1]), d[:, 2]), 1e-300)
    pp = p[:, 1:] * wp.proj[:, None, :]                            # P p', P p''
    G = (pp @ d[:, :, None])[:, :, 0] / (-s * rho)[:, None]        # n.P p', n.P p''
    q1 = pp[:, 0]
    q1q1 = (q1[:, None, :] @ q1[:, :, None])[:, 0, 0]
    return s * (wp.radius - rho), G[:, 0], G[:, 1] - s * (q1q1 - G[:, 0] * G[:, 0]) / rho
