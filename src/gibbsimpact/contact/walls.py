"""Walls: gap functions g(p) > 0 inside the admissible region (docs/theory.md §10).

Every wall has ``gap(p)`` and ``normal(p)`` for points p of shape (K, 3) [m]
(``geometry(p, v)``: gap, normal and curvature term from one distance computation);
the unit normal n = grad g / |grad g| points into the admissible region. |grad g| = 1
for all three, so the gap's second time derivative along a point's motion is

    g'' = n . p'' + p'^T H_g p'      (``curvature(p, v)`` = v^T H_g v, resting contact)

A Circle or Sphere confines the chain (``inside=True``, g = R - |d|) or is an obstacle that
keeps it out (``inside=False``, g = |d| - R): the side s = +1 or -1 multiplies g, n and H_g.
``obstacle`` is True for an obstacle (its gap is convex along a straight line, so a rigid
link's closest point to it can lie between the link's ends: contacts.Contacts).
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real

import numpy as np

from .compliant import check_compliance


def _check_restitution(name, e):
    if e is None:
        return None
    if isinstance(e, bool) or not isinstance(e, Real) or not (0.0 <= e <= 1.0):
        raise ValueError(f"{name} restitution={e!r} must be a number in [0, 1] (1 = elastic, 0 = plastic)")
    return float(e)


#: Largest accepted Coulomb coefficient (the same bound as the case files' walls.friction):
#: beyond it the friction cone is a sticking constraint in all but name.
MAX_FRICTION = 100.0


def _check_friction(name, mu):
    if isinstance(mu, bool) or not isinstance(mu, Real) or not np.isfinite(mu) or not 0 <= mu <= MAX_FRICTION:
        raise ValueError(f"{name} friction={mu!r} must be a finite number >= 0 and <= {MAX_FRICTION:g} (Coulomb's "
                         f"coefficient; 0 = frictionless)")
    return float(mu)


def _norm(d: np.ndarray) -> np.ndarray:
    """|d| over the last axis: what np.linalg.norm(d, axis=-1) computes for real d (bit for bit),
    without its overhead (the event layer evaluates sphere gaps tens of thousands of times)."""
    return np.sqrt(np.add.reduce(d * d, axis=-1))


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """sum(a * b) over the last axis (np.sum's value, without its dispatch overhead)."""
    return np.add.reduce(a * b, axis=-1)


def _unit(d: np.ndarray, r: np.ndarray) -> np.ndarray:
    """d / r row by row, (K, m) by (K,); rows with r = 0 give 0 (an undefined direction)."""
    if r.size and r.min() > 0:
        return d / r[..., None]
    return np.divide(d, r[..., None], out=np.zeros_like(d), where=r[..., None] > 0)


def _check_vector(owner, name, v, n):
    a = np.asarray(v, dtype=float) if not isinstance(v, str) else np.array([])
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{owner} {name}={v!r} must be {n} finite numbers (m)")
    return tuple(float(x) for x in a)


def _check_radius(owner, r):
    if isinstance(r, bool) or not isinstance(r, Real) or not np.isfinite(r) or r <= 0:
        raise ValueError(f"{owner} radius={r!r} must be a positive number of metres")
    return float(r)


def _set_compliance(wall, name, stiffness, exponent, damping) -> None:
    """Check and set the compliant law's stiffness, exponent, damping of a (frozen) wall."""
    k, p, d = check_compliance(name, stiffness, exponent, damping)
    for key, value in (("stiffness", k), ("exponent", p), ("damping", d)):
        object.__setattr__(wall, key, value)


def is_compliant(wall) -> bool:
    """Whether the wall resolves contact by the compliant law (a stiffness) rather than Newton's law."""
    return getattr(wall, "stiffness", None) is not None


@dataclass(frozen=True)
class _RoundWall:
    """What Circle and Sphere share: a radius about a centre of 2 or 3 coordinates, checked once, and
    the contact parameters (their fields, in this order; each subclass gives ``center`` its default)."""

    radius: float
    center: tuple
    restitution: float | None = None
    friction: float = 0.0
    inside: bool = True
    stiffness: float | None = None
    exponent: float = 1.5
    damping: str = "flores"

    def __post_init__(self):
        name, dims = type(self).__name__, len(type(self).__dataclass_fields__["center"].default)
        object.__setattr__(self, "radius", _check_radius(name, self.radius))
        object.__setattr__(self, "center", _check_vector(name, "center", self.center, dims))
        object.__setattr__(self, "restitution", _check_restitution(name, self.restitution))
        object.__setattr__(self, "friction", _check_friction(name, self.friction))
        if not isinstance(self.inside, (bool, np.bool_)):
            raise ValueError(f"{name} inside={self.inside!r} must be True (the chain stays inside: a container) "
                             f"or False (the chain stays outside: an obstacle)")
        object.__setattr__(self, "inside", bool(self.inside))
        _set_compliance(self, name, self.stiffness, self.exponent, self.damping)

    @property
    def side(self) -> float:
        """s = +1 inside (g = R - |d|), -1 for an obstacle (g = |d| - R)."""
        return 1.0 if self.inside else -1.0

    @property
    def obstacle(self) -> bool:
        """True when the chain stays outside (inside=False)."""
        return not self.inside

    def parameters(self) -> dict:
        """Its geometry as case files and result files name it (``inside`` only for an obstacle, so that
        the files of containers read as before)."""
        out = {"radius": self.radius, "center": list(self.center)}
        if not self.inside:
            out["inside"] = False
        return out

    flat = False

    def section(self, n_samples: int = 721) -> np.ndarray:
        """Its section with the plane X3 = 0, (n_samples, 2) [m]: a circle of radius r about c_12 sampled
        from angle 0 to 2 pi (r = R for a circle, sqrt(R^2 - c_3^2) for a sphere); (0, 2) when none."""
        r2 = self.radius ** 2 - (self.center[2] ** 2 if len(self.center) == 3 else 0.0)
        if r2 <= 0.0:
            return np.zeros((0, 2))
        s = np.linspace(0.0, 2.0 * np.pi, n_samples)
        return np.asarray(self.center[:2]) + np.sqrt(r2) * np.stack([np.cos(s), np.sin(s)], axis=-1)

    def bounds(self) -> tuple:
        """(lo, hi), (3,) each [m]: its bounding box; a circle (a cylinder along X3) sets none along X3
        (lo = +inf, hi = -inf there, so that np.minimum / np.maximum with it leave a box unchanged)."""
        c = np.zeros(3)
        c[:len(self.center)] = self.center
        r = np.full(3, self.radius)
        lo, hi = c - r, c + r
        if len(self.center) == 2:
            lo[2], hi[2] = np.inf, -np.inf
        return lo, hi

    def in_plane(self, tol: float) -> bool:
        """True when its section with every plane X3 = z of a planar motion is the X1-X2 curve of
        section(): always for a circle, for a sphere centred within tol [m] of X3 = 0."""
        return len(self.center) == 2 or abs(self.center[2]) < tol

    def _describe(self, shape: str, center) -> str:
        where = "" if self.inside else " (obstacle: the chain stays outside)"
        return f"{shape} R={self.radius:g} m centre ({', '.join(f'{c:g}' for c in center)}){where}"

    def normal(self, p: np.ndarray) -> np.ndarray:
        """Unit normal into the free region for p (K, 3) -> (K, 3); zero on the axis (circle) or at the
        centre (sphere), where it is undefined."""
        return self.geometry(p)[1]

    def curvature(self, p: np.ndarray, v: np.ndarray) -> np.ndarray:
        """v^T H_g v (K,) [m/s^2] for points p (K, 3) [m] moving at v (K, 3) [m/s], H_g the Hessian of g."""
        return self.geometry(p, v)[2]


@dataclass(frozen=True)
class Circle(_RoundWall):
    """Circular wall of radius R about centre c in the X1-X2 plane (a cylinder along X3).

    g(p) = s (R - |(p - c)_12|),   n = -s (p - c)_12 / |(p - c)_12|,   s = +1 (inside), -1 (obstacle)

    Parameters
    ----------
    radius : float, R [m]
    center : (float, float), c [m]
    restitution : float or None
        Coefficient of restitution for contacts with this wall; None uses the
        global value given to ``simulate``.
    friction : float >= 0
        Coulomb's coefficient mu on this wall, in impacts (gibbsimpact.friction) and in
        resting contact (gibbsimpact.resting); 0 (default) is frictionless. The same
        parameter exists for every wall type.
    inside : bool
        True (default): the chain stays inside the circle (a container); False: outside it
        (an obstacle: a post, a peg, a cylinder to rest on). The same for Sphere.
    stiffness : float or None
        k [N/m^p] of the compliant (Hunt-Crossley) law F_n = k g_-^p (1 + chi gdot_- / v_0)
        (gibbsimpact.contact.compliant); None (default): Newton's impulse law.
    exponent : float, p of the compliant law (1.5: Hertz); damping : "flores" (default) or
        "lankarani-nikravesh", the relation chi(e). The same three exist for every wall type.
    """

    center: tuple = (0.0, 0.0)
    kind = "circle"

    def gap(self, p: np.ndarray) -> np.ndarray:
        """g(p) for p (K, 3) [m] -> (K,) [m]."""
        d = p[..., :2] - np.asarray(self.center)
        return self.side * (self.radius - np.hypot(d[..., 0], d[..., 1]))

    def geometry(self, p: np.ndarray, v: np.ndarray | None = None):
        """Gap g (K,) [m], unit normal n (K, 3) and curvature term v^T H_g v (K,) [m/s^2] (None
        without v) of points p (K, 3) [m] moving at v (K, 3) [m/s], from one distance computation.

        g = s (R - r), r = |d_12|:  H_g = -s (I_2 - d^ d^T) / r  ->  v^T H_g v = -s (|v_12|^2 - (d^ . v_12)^2) / r
        """
        s = self.side
        d = p[..., :2] - np.asarray(self.center)
        r = np.hypot(d[..., 0], d[..., 1])
        n = np.zeros(p.shape)
        n[..., :2] = -s * _unit(d, r)
        if v is None:
            return s * (self.radius - r), n, None
        vt = v[..., :2]
        dv = _dot(d, vt)
        return s * (self.radius - r), n, -s * (_dot(vt, vt) - dv * dv / (r * r)) / r

    def describe(self) -> str:
        return self._describe("circle", self.center)

    def packed(self) -> tuple:
        """(kind, 6 floats): this wall for the compiled contact terms (kernel.contact_terms); the last is s."""
        return 1, (self.radius, *self.center, 0.0, 0.0, self.side)


@dataclass(frozen=True)
class Sphere(_RoundWall):
    """Spherical wall of radius R about centre c.

    g(p) = s (R - |p - c|),   n = -s (p - c) / |p - c|,   s = +1 (inside), -1 (obstacle)

    restitution, friction, inside, stiffness, exponent, damping : as for Circle.
    """

    center: tuple = (0.0, 0.0, 0.0)
    kind = "sphere"

    def gap(self, p: np.ndarray) -> np.ndarray:
        """g(p) for p (K, 3) [m] -> (K,) [m]."""
        d = p - np.asarray(self.center)
        return self.side * (self.radius - _norm(d))

    def geometry(self, p: np.ndarray, v: np.ndarray | None = None):
        """Gap g (K,) [m], unit normal n (K, 3) and curvature term v^T H_g v (K,) [m/s^2] (None
        without v) of points p (K, 3) [m] moving at v (K, 3) [m/s], from one distance computation.

        g = s (R - |d|):  H_g = -s (I - d^ d^T) / |d|  ->  v^T H_g v = -s (|v|^2 - (d^ . v)^2) / |d|
        """
        s = self.side
        d = p - np.asarray(self.center)
        r = _norm(d)
        n = -s * _unit(d, r)
        if v is None:
            return s * (self.radius - r), n, None
        dv = _dot(d, v)
        return s * (self.radius - r), n, -s * (_dot(v, v) - dv * dv / (r * r)) / r

    def describe(self) -> str:
        return self._describe("sphere", self.center)

    def packed(self) -> tuple:
        """(kind, 6 floats): this wall for the compiled contact terms (kernel.contact_terms); the last is s."""
        return 2, (self.radius, *self.center, 0.0, self.side)


@dataclass(frozen=True)
class Plane:
    """Plane wall through ``point`` with unit ``normal`` pointing into the admissible side.

    g(p) = n . (p - point)

    restitution, friction, stiffness, exponent, damping : as for Circle.
    """

    point: tuple
    normal_vector: tuple = (0.0, 1.0, 0.0)
    restitution: float | None = None
    friction: float = 0.0
    stiffness: float | None = None
    exponent: float = 1.5
    damping: str = "flores"
    kind = "plane"
    obstacle = False
    #: A flat wall: figures clip it as a line or a polygon (the other kinds are drawn from section()).
    flat = True

    def __init__(self, point=(0.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0), restitution=None, friction=0.0,
                 stiffness=None, exponent=1.5, damping="flores"):
        object.__setattr__(self, "point", _check_vector("Plane", "point", point, 3))
        nv = np.array(_check_vector("Plane", "normal", normal, 3))
        nn = np.linalg.norm(nv)
        if nn == 0:
            raise ValueError(f"Plane normal={normal!r} is the zero vector; give the direction into the free side")
        object.__setattr__(self, "normal_vector", tuple(nv / nn))
        object.__setattr__(self, "restitution", _check_restitution("Plane", restitution))
        object.__setattr__(self, "friction", _check_friction("Plane", friction))
        _set_compliance(self, "Plane", stiffness, exponent, damping)

    def gap(self, p: np.ndarray) -> np.ndarray:
        """g(p) for p (K, 3) [m] -> (K,) [m]."""
        return (p - np.asarray(self.point)) @ np.asarray(self.normal_vector)

    def normal(self, p: np.ndarray) -> np.ndarray:
        """Unit normal (constant) broadcast to p's shape (K, 3)."""
        return np.broadcast_to(np.asarray(self.normal_vector), p.shape).copy()

    def curvature(self, p: np.ndarray, v: np.ndarray) -> np.ndarray:
        """v^T H_g v (K,) [m/s^2]: zero, g is linear in p."""
        return np.zeros(np.shape(p)[:-1])

    def geometry(self, p: np.ndarray, v: np.ndarray | None = None):
        """Gap (K,) [m], normal (K, 3) and curvature term (K,) [m/s^2] (zero; None without v), as Circle.geometry."""
        return self.gap(p), self.normal(p), None if v is None else self.curvature(p, v)

    def bounds(self) -> tuple:
        """(lo, hi) (3,) [m]: no bounding box (lo = +inf, hi = -inf: it leaves a box unchanged)."""
        return np.full(3, np.inf), np.full(3, -np.inf)

    def in_plane(self, tol: float) -> bool:
        """True when its normal lies in the X1-X2 plane (within tol): its section is a line there."""
        return abs(self.normal_vector[2]) < tol

    def parameters(self) -> dict:
        """Its geometry as case files and result files name it."""
        return {"point": list(self.point), "normal": list(self.normal_vector)}

    def describe(self) -> str:
        return (f"plane through ({', '.join(f'{c:g}' for c in self.point)}) normal "
                f"({', '.join(f'{c:g}' for c in self.normal_vector)})")

    def packed(self) -> tuple:
        """(kind, 6 floats): this wall for the compiled contact terms (kernel.contact_terms)."""
        return 0, (*self.point, *self.normal_vector)


WALL_TYPES = (Circle, Sphere, Plane)
#: Each wall class by the name case files and result files give it (``type``): the one table of wall kinds.
WALL_KINDS = {cls.kind: cls for cls in WALL_TYPES}

_PACKED: dict = {}


def packed_walls(walls):
    """(kinds (W,) int64, parameters (W, 6)) of the walls for the compiled code (Wall.packed():
    kernel.contact_terms, kernel.event_gaps), cached per walls."""
    key = tuple(walls)
    got = _PACKED.get(key)
    if got is None:
        kinds, pars = zip(*(w.packed() for w in walls)) if walls else ((), ())
        got = (np.array(kinds, dtype=np.int64), np.array(pars, dtype=float).reshape(-1, 6))
        if len(_PACKED) < 64:
            _PACKED[key] = got
    return got


def has_obstacle(walls) -> bool:
    """True when one of ``walls`` is an obstacle (``obstacle``: the chain stays outside it)."""
    return any(getattr(w, "obstacle", False) for w in walls)


def describe(wall) -> str:
    """One-line description of a wall, for messages and summaries."""
    mu = f", friction {wall.friction:g}" if wall.friction else ""
    law = (f", compliant k={wall.stiffness:g} N/m^{wall.exponent:g} ({wall.damping})" if is_compliant(wall)
           else "")
    return wall.describe() + mu + law


def tangent_basis(n: np.ndarray) -> np.ndarray:
    """Two unit tangents (k, 2, 3) orthogonal to the unit normals n (k, 3) and to each other.

    t1 = e3 x n / |e3 x n| (in the X1-X2 plane: the tangent of a planar motion along a
    circle or a plane containing X3), or e1 x n when n is along X3; t2 = n x t1.
    """
    n = np.asarray(n, dtype=float).reshape(-1, 3)
    a = np.where((np.abs(n[:, 2]) < 0.9)[:, None], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    t1 = np.cross(a, n)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return np.stack((t1, np.cross(n, t1)), axis=1)
