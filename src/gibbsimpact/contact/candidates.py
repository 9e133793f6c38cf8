"""Material points of the links as contact candidates: the closest point of every link to every wall.

The points themselves, p(q, i, x) = (T_i(q) r_i(x))[:3] with r_i(x) = (x, v_i(x), w_i(x), 1),
their Jacobian and acceleration term are gibbsimpact.dynamics.link_points (material_points,
material_jacobian; re-exported here). For a link behind a FixedPrismatic (Pb) guide, v depends
on the protruding length d as well: v = sum_k d^(a_k) N_k(xi) delta_k on the protruding part
sigma = x - (l - d) in [0, d], xi = sigma / d, and v = 0 behind the guide (docs/theory.md §7.4).

Functions, all pure f(model, q, ...):

* :func:`closest_points` -- for every wall w and link i, the material point of link i with
  the smallest gap g_w(p(x)): x* (W, n), gap (W, n), normal (W, n, 3) (the search is
  contact/closest_points.py, on the per-model tables of contact/link_tables.py; re-exported
  here);
* :func:`search_interval`, :func:`end_joints`, :func:`interior` -- what the event loop needs
  to use x* as one more contact candidate without counting a joint twice;
* :func:`body_candidates` -- the attached rigid bodies whose centre is a contact candidate of its
  own (docs/theory.md §6.8).

Search interval. x* minimises g_w(p(x)) over [a_i, b_i] = [0, l_i]; for a Pb link over the
protruding part [l_i - d_i, l_i] (the part behind the guide is straight along the guide
axis, so its gap is linear (plane) or concave (circle, sphere confining the chain) along it:
its minimum is at an end, the rear end O_i or the guide, which are candidates already; on an
obstacle, whose gap is convex along a line, that part is not searched: docs/theory.md §10.3).

Contact candidate rule (for the event loop). The ends of the search interval are joint
candidates already (:func:`end_joints` gives their index in
``kinematics.joint_positions``). A link candidate (w, i) is *interior* when x* is farther
than ``end_tol`` (default 1e-6 l_i) from both ends of [a_i, b_i] (:func:`interior`). Dedupe:

* event functions: one per (wall, flexible link), g*_wi(q) = gap[w, i] (continuous in q,
  never above the gaps of the link's end joints); rigid links need none (their minimum is
  a joint) unless a wall is an obstacle (simulation.contacts.link_columns);
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

import numpy as np

# Re-exported: the points' own module is gibbsimpact.dynamics.link_points; gibbsimpact.linkpoints
# (this module's earlier name) has always offered them.
from ..dynamics.link_points import material_jacobian, material_points
from .closest_points import ClosestPoints, closest_points
from .link_tables import _tables

__all__ = ["ClosestPoints", "body_candidates", "closest_points", "end_joints", "interior", "material_jacobian",
           "material_points", "search_interval"]

#: Default end tolerance of :func:`interior`, relative to the link length.
END_TOL = 1e-6


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
    kinds = model.joint_specs
    if not model.chain.serial:  # a tree (no prismatic joints): link i's frame origin and its tip point
        return np.array([(i, t) for i, t in enumerate(model.tip_points)], dtype=int).reshape(n, 2)
    extra, k = {}, n + 1
    for j in range(1, n):
        if kinds[j].prismatic:
            extra[j] = k          # the tip of link j - 1 (host of joint j)
            k += 1
    out = np.empty((n, 2), dtype=int)
    for i in range(n):
        out[i, 0] = (extra[i] if i > 0 else -1) if kinds[i].guide else i
        out[i, 1] = n if i == n - 1 else (extra[i + 1] if kinds[i + 1].prismatic else i + 1)
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


def body_candidates(model) -> tuple:
    """The attached rigid bodies whose centre is a contact candidate: (i, body) pairs, link by link.

    A body with a centre offset c != 0 holds its centre off the link's centreline, where no joint or
    link point is: its centre is a point candidate of its own (a point, no radius; docs/theory.md
    §6.8). A body with c = 0 sits on the centreline, which the joints and link points cover already
    (a payload at the tip is the tip point).
    """
    return tuple((i, b) for i, lk in enumerate(model.chain.links) for b in lk.bodies if any(b.center))
