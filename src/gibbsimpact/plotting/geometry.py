"""What the configuration drawings show, as points [m]: links split at a guide, prismatic joint
symbols, wall sections, scene extents and the 3D camera. numpy only; every point of a deformed
link comes from dynamics.link_points."""

from __future__ import annotations

import numpy as np

from ..dynamics.kinematics import transforms
from ..dynamics.link_points import body_centers, link_points, points_on_link


_PLANAR_TOL = 1e-9  # m or rad: out-of-plane motion below this counts as planar


# --------------------------------------------------------------------------
# Geometry

def _link_parts(model, q, n_points: int = 41) -> list:
    """Per link (main (m, 3), rear (2, 3) or None) [m].

    A link sliding through a FixedPrismatic guide (Pb, protruding length d) is split at the
    guide: main is its protruding part x = l - d ... l, where it bends, sampled with
    ``n_points`` points; rear is the straight part behind the guide, x = 0 ... l - d (None when
    d = l). Every other link is main only, as link_points samples it.
    """
    q = np.asarray(q, dtype=float)
    T = transforms(model, q)
    out = []
    for i, lk in enumerate(model.chain.links):
        rear = None
        if model.chain.joints[i].spec.guide:
            s = min(max(lk.length - float(q[model.theta_index[i]]), 0.0), lk.length)
            main = points_on_link(model, q, T, i, np.linspace(s, lk.length, n_points))
            if s > 0.0:
                rear = points_on_link(model, q, T, i, np.array([0.0, s]))
        else:
            main = points_on_link(model, q, T, i, np.linspace(0.0, lk.length, n_points))
        out.append((main, rear))
    return out


def _chain_scale(model) -> float:
    """Length that sizes the joint symbols: the sum of the link lengths [m]."""
    return float(sum(lk.length for lk in model.chain.links)) or 1.0


def _box(p, a, b, half_length, half_width) -> np.ndarray:
    """Closed outline (5, 3) of the rectangle centred at p with unit axes a (length) and b (width)."""
    corners = [(1, 1), (-1, 1), (-1, -1), (1, -1), (1, 1)]
    return np.array([p + sa * half_length * a + sb * half_width * b for sa, sb in corners])


def _stop_point(model, q, joint: int) -> np.ndarray:
    """Where prismatic joint ``joint`` (1-based) is drawn (3,) [m]: the guide of a FixedPrismatic
    joint (link i's axis at x = l_i - d_i), the carriage centre O_i of a SlidingPrismatic one."""
    q = np.asarray(q, dtype=float)
    T = transforms(model, q)
    i = joint - 1
    if model.chain.joints[i].spec.guide:
        s = model.chain.links[i].length - float(q[model.theta_index[i]])
        return (T[i] @ np.array([s, 0.0, 0.0, 1.0]))[:3]
    return T[i][:3, 3].copy()


def _prismatic_marks(model, q) -> list:
    """Outlines of the prismatic joints at q: [(kind, joint i (1-based), (m, 3) polyline [m])].

    kind "guide": the FixedPrismatic guide, a sleeve around link i's axis at the host's tip;
    "carriage": the SlidingPrismatic carriage, a box along its chord on the host (length 2 c,
    at least a few per cent of the chain so that a point slider shows); "rail": the straight
    rail on the base of a SlidingPrismatic joint 1, its travel d_min - c ... d_max + c along the
    base x axis, with a tick at each end.
    """
    if not any(j.spec.prismatic for j in model.chain.joints):
        return []
    q = np.asarray(q, dtype=float)
    T = transforms(model, q)
    L = _chain_scale(model)
    out = []
    for i, jt in enumerate(model.chain.joints):
        if jt.spec.guide:
            a, b = T[i][:3, 0], T[i][:3, 1]
            out.append(("guide", i + 1, _box(_stop_point(model, q, i + 1), a, b, 0.03 * L, 0.014 * L)))
        elif jt.spec.carriage:
            g = jt.angle
            # The carriage frame is link i's frame turned back by gamma.
            a = np.cos(g) * T[i][:3, 0] - np.sin(g) * T[i][:3, 1]
            b = np.sin(g) * T[i][:3, 0] + np.cos(g) * T[i][:3, 1]
            out.append(("carriage", i + 1, _box(T[i][:3, 3], a, b, max(jt.half_length, 0.015 * L), 0.012 * L)))
            if i == 0 and model.base_transform is not None:
                T0 = np.asarray(model.base_transform, dtype=float)
                lo, hi = jt.range[0] - jt.half_length, jt.range[1] + jt.half_length
                ends = [(T0 @ np.array([x, 0.0, 0.0, 1.0]))[:3] for x in (lo, hi)]
                out.append(("rail", 1, np.array(ends)))
                for e in ends:
                    out.append(("rail", 1, np.array([e - 0.02 * L * T0[:3, 1], e + 0.02 * L * T0[:3, 1]])))
    return out


def _scene_points(model, q, n_points: int = 41) -> np.ndarray:
    """Every point a configuration drawing shows (links, prismatic joint symbols, attached bodies), (m, 3) [m]."""
    pts = [link_points(model, q, n_points).reshape(-1, 3), body_centers(model, q)[0]] + \
        [P for _, _, P in _prismatic_marks(model, q)]
    return np.concatenate(pts)


def is_planar(result) -> bool:
    """True when the chain stays in the X1-X2 plane (X3, theta_-1, theta_0, z-modes ~ 0, and no re-chart of the
    free base: its angles are then measured from another orientation) and every wall has a curve as its section
    with that plane."""
    model = result.model
    if getattr(result, "base_chart", None) is not None:
        return False
    # Only the spatial free base has X3, theta_-1, theta_0 (a planar one has X1, X2 only).
    idx = [2, 3, 4] if model.chain.base == "free" else []
    idx += [k for k, d in enumerate(model.bending_directions) if d == "z"]
    planar = np.all(np.abs(result.q[:, idx]) < _PLANAR_TOL) and np.all(np.abs(result.qdot[:, idx]) < _PLANAR_TOL)
    return bool(planar) and all(w.in_plane(_PLANAR_TOL) for w in result.walls)


def _clip_polygon(poly: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """The part of a convex polygon (m, d) where normal . p >= offset (Sutherland-Hodgman, one plane)."""
    if len(poly) == 0:
        return poly
    s = poly @ normal - offset
    out = []
    for k in range(len(poly)):
        a, b, sa, sb = poly[k - 1], poly[k], s[k - 1], s[k]
        if sb >= 0:
            if sa < 0:
                out.append(a + (b - a) * (sa / (sa - sb)))
            out.append(b)
        elif sa >= 0:
            out.append(a + (b - a) * (sa / (sa - sb)))
    return np.array(out).reshape(-1, poly.shape[1])


def _wall_curves_2d(walls, extent, n_samples: int = 721) -> list:
    """[(wall index, (m, 2) polyline)]: each wall's section with the X1-X2 plane, clipped to the
    view box and to the free side of every other wall (NaN rows break a polyline).

    A flat wall (a plane) is a straight segment: the box and the other flat walls clip it exactly
    (so two planes meet in a V, not an X); the others are their sampled section(), masked.
    """
    x0, x1, y0, y1 = extent
    tol = 1e-9 * max(x1 - x0, y1 - y0)
    box = [(np.array([1.0, 0.0]), x0), (np.array([-1.0, 0.0]), -x1),
           (np.array([0.0, 1.0]), y0), (np.array([0.0, -1.0]), -y1)]
    out = []
    for k, w in enumerate(walls):
        if w.flat:
            n3, p3 = np.asarray(w.normal_vector), np.asarray(w.point)
            n = n3[:2] / np.linalg.norm(n3[:2])
            # Points with n12 . p12 = n . point (the section at X3 = 0), along the tangent.
            c = (n3 @ p3) / np.linalg.norm(n3[:2]) * n
            t = np.array([-n[1], n[0]])
            big = 4.0 * max(x1 - x0, y1 - y0) + 4.0 * np.linalg.norm(c - [0.5 * (x0 + x1), 0.5 * (y0 + y1)])
            s_lo, s_hi = -big, big
            cuts = box + [(np.asarray(o.normal_vector)[:2], np.asarray(o.normal_vector) @ np.asarray(o.point))
                          for i, o in enumerate(walls) if i != k and o.flat]
            for a, b in cuts:
                # a . (c + s t) >= b
                at, rhs = a @ t, b - a @ c
                if abs(at) < 1e-14:
                    if rhs > tol:
                        s_lo, s_hi = 1.0, 0.0
                    continue
                if at > 0:
                    s_lo = max(s_lo, rhs / at)
                else:
                    s_hi = min(s_hi, rhs / at)
            if s_hi <= s_lo:
                continue
            s = np.linspace(s_lo, s_hi, n_samples)
            seg = c + s[:, None] * t
        else:
            seg = w.section(n_samples)
        P = np.column_stack([seg, np.zeros(len(seg))])
        # Planes clipped a plane's segment exactly; the rest are sampled.
        ok = np.ones(len(seg), dtype=bool)
        for i, o in enumerate(walls):
            if i != k and not (w.flat and o.flat):
                ok &= o.gap(P) >= -tol
        seg = seg.copy()
        seg[~ok] = np.nan
        if np.any(ok):
            out.append((k, seg))
    return out


def _plane_polygon_3d(walls, k: int, lo, hi) -> np.ndarray:
    """Plane wall k inside the box [lo, hi] (3,) and on the free side of every other plane: (m, 3)."""
    w = walls[k]
    n, p = np.asarray(w.normal_vector), np.asarray(w.point)
    a = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    mid = 0.5 * (lo + hi)
    c = mid - ((mid - p) @ n) * n
    size = 2.0 * np.linalg.norm(hi - lo)
    poly = np.array([c + size * (sa * a + sb * b) for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    for d in range(3):
        e = np.eye(3)[d]
        poly = _clip_polygon(poly, e, lo[d])
        poly = _clip_polygon(poly, -e, -hi[d])
    for i, o in enumerate(walls):
        if i != k and o.flat:
            no = np.asarray(o.normal_vector)
            poly = _clip_polygon(poly, no, no @ np.asarray(o.point))
    return poly


def _scene_extent_2d(result, points):
    """(xmin, xmax, ymin, ymax) covering the bounded walls (Wall.bounds), or the chain when only planes bound it."""
    lo, hi = points[..., :2].reshape(-1, 2).min(0), points[..., :2].reshape(-1, 2).max(0)
    curved = [w for w in result.walls if not w.flat]
    for w in curved:
        b_lo, b_hi = w.bounds()
        lo, hi = np.minimum(lo, b_lo[:2]), np.maximum(hi, b_hi[:2])
    span = max(hi - lo)
    pad = 0.08 * span if curved else 0.25 * max(span, 1e-3)
    mid = 0.5 * (lo + hi)
    half = 0.5 * span + pad
    return mid[0] - half, mid[0] + half, mid[1] - half, mid[1] + half


def _to3(p):
    """Inertial (X1, X2, X3) -> plot axes (X3, X1, X2): right-handed with X2 vertical."""
    p = np.asarray(p)
    return p[..., 2], p[..., 0], p[..., 1]


def _scene_extent_3d(result, points):
    lo, hi = points.reshape(-1, 3).min(0), points.reshape(-1, 3).max(0)
    curved = any(not w.flat for w in result.walls)
    for w in result.walls:
        b_lo, b_hi = w.bounds()    # a plane: none; a circle: none along X3
        lo, hi = np.minimum(lo, b_lo), np.maximum(hi, b_hi)
    span = max(hi - lo)
    half = 0.5 * span * (1.05 if curved else 1.4) + 1e-3
    mid = 0.5 * (lo + hi)
    return mid - half, mid + half


def camera(points) -> tuple[float, float]:
    """(elev, azim) [deg] of the 3D view along the direction of least spread of ``points`` (..., 3) [m].

    The eigenvector of the smallest eigenvalue of the points' covariance, taken from
    above (elevation >= 0) and kept between 10 and 75 degrees of elevation so that the
    vertical X2 stays readable; (18, -60) when no direction spreads clearly less
    (smallest eigenvalue above 0.6 of the middle one).
    """
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) < 3:
        return 18.0, -60.0
    lam, vec = np.linalg.eigh(np.cov(P.T))
    if not lam[1] > 0 or lam[0] > 0.6 * lam[1]:
        return 18.0, -60.0
    x, y, z = _to3(vec[:, 0])
    if z < 0:
        x, y, z = -x, -y, -z
    elev = np.degrees(np.arcsin(np.clip(z, -1.0, 1.0)))
    azim = np.degrees(np.arctan2(y, x)) if np.hypot(x, y) > 1e-9 else -60.0
    return float(np.clip(elev, 10.0, 75.0)), float(azim)


def _run_camera(result, extra=None):
    """The camera of a run's 3D figures: along the direction of least joint motion."""
    P = result.joint_positions().reshape(-1, 3)
    return camera(P if extra is None else np.concatenate([P, extra.reshape(-1, 3)]))
