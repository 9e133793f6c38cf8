"""Walls: gap functions g(p) > 0 inside the admissible region (docs/theory.md §10).

Every wall has ``gap(p)`` and ``normal(p)`` for points p of shape (K, 3) [m]
(``geometry(p, v)``: gap, normal and curvature term from one distance computation);
the unit normal n = grad g / |grad g| points into the admissible region. |grad g| = 1
for all three, so the gap's second time derivative along a point's motion is

    g'' = n . p'' + p'^T H_g p'      (``curvature(p, v)`` = v^T H_g v, resting contact)
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


class _RoundWall:
    """What Circle and Sphere share: a radius about a centre of 2 or 3 coordinates, checked once."""

    def __post_init__(self):
        name, dims = type(self).__name__, len(type(self).__dataclass_fields__["center"].default)
        object.__setattr__(self, "radius", _check_radius(name, self.radius))
        object.__setattr__(self, "center", _check_vector(name, "center", self.center, dims))
        object.__setattr__(self, "restitution", _check_restitution(name, self.restitution))
        object.__setattr__(self, "friction", _check_friction(name, self.friction))
        _set_compliance(self, name, self.stiffness, self.exponent, self.damping)

    def parameters(self) -> dict:
        """Its geometry as case files and result files name it."""
        return {"radius": self.radius, "center": list(self.center)}

    def normal(self, p: np.ndarray) -> np.ndarray:
        """Unit inward normal for p (K, 3) -> (K, 3); zero on the axis (circle) or at the centre (sphere),
        R away from the wall, where it is undefined."""
        return self.geometry(p)[1]

    def curvature(self, p: np.ndarray, v: np.ndarray) -> np.ndarray:
        """v^T H_g v (K,) [m/s^2] for points p (K, 3) [m] moving at v (K, 3) [m/s], H_g the Hessian of g."""
        return self.geometry(p, v)[2]


@dataclass(frozen=True)
class Circle(_RoundWall):
    """Circular wall of radius R about centre c in the X1-X2 plane (a cylinder along X3).

    g(p) = R - |(p - c)_12|,   n = -(p - c)_12 / |(p - c)_12|

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
    stiffness : float or None
        k [N/m^p] of the compliant (Hunt-Crossley) law F_n = k g_-^p (1 + chi gdot_- / v_0)
        (gibbsimpact.contact.compliant); None (default): Newton's impulse law.
    exponent : float, p of the compliant law (1.5: Hertz); damping : "flores" (default) or
        "lankarani-nikravesh", the relation chi(e). The same three exist for every wall type.
    """

    radius: float
    center: tuple = (0.0, 0.0)
    restitution: float | None = None
    friction: float = 0.0
    stiffness: float | None = None
    exponent: float = 1.5
    damping: str = "flores"
    kind = "circle"


    def gap(self, p: np.ndarray) -> np.ndarray:
        """g(p) for p (K, 3) [m] -> (K,) [m]."""
        d = p[..., :2] - np.asarray(self.center)
        return self.radius - np.hypot(d[..., 0], d[..., 1])

    def geometry(self, p: np.ndarray, v: np.ndarray | None = None):
        """Gap g (K,) [m], unit normal n (K, 3) and curvature term v^T H_g v (K,) [m/s^2] (None
        without v) of points p (K, 3) [m] moving at v (K, 3) [m/s], from one distance computation.

        g = R - r, r = |d_12|:  H_g = -(I_2 - d^ d^T) / r  ->  v^T H_g v = -(|v_12|^2 - (d^ . v_12)^2) / r
        """
        d = p[..., :2] - np.asarray(self.center)
        r = np.hypot(d[..., 0], d[..., 1])
        n = np.zeros(p.shape)
        n[..., :2] = -_unit(d, r)
        if v is None:
            return self.radius - r, n, None
        vt = v[..., :2]
        dv = _dot(d, vt)
        return self.radius - r, n, -(_dot(vt, vt) - dv * dv / (r * r)) / r

    def describe(self) -> str:
        return f"circle R={self.radius:g} m centre ({self.center[0]:g}, {self.center[1]:g})"

    def packed(self) -> tuple:
        """(kind, 6 floats): this wall for the compiled contact terms (kernel.contact_terms)."""
        return 1, (self.radius, *self.center, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Sphere(_RoundWall):
    """Spherical wall of radius R about centre c.

    g(p) = R - |p - c|,   n = -(p - c) / |p - c|

    restitution, friction, stiffness, exponent, damping : as for Circle.
    """

    radius: float
    center: tuple = (0.0, 0.0, 0.0)
    restitution: float | None = None
    friction: float = 0.0
    stiffness: float | None = None
    exponent: float = 1.5
    damping: str = "flores"
    kind = "sphere"


    def gap(self, p: np.ndarray) -> np.ndarray:
        """g(p) for p (K, 3) [m] -> (K,) [m]."""
        d = p - np.asarray(self.center)
        return self.radius - _norm(d)

    def geometry(self, p: np.ndarray, v: np.ndarray | None = None):
        """Gap g (K,) [m], unit normal n (K, 3) and curvature term v^T H_g v (K,) [m/s^2] (None
        without v) of points p (K, 3) [m] moving at v (K, 3) [m/s], from one distance computation.

        g = R - |d|:  H_g = -(I - d^ d^T) / |d|  ->  v^T H_g v = -(|v|^2 - (d^ . v)^2) / |d|
        """
        d = p - np.asarray(self.center)
        r = _norm(d)
        n = -_unit(d, r)
        if v is None:
            return self.radius - r, n, None
        dv = _dot(d, v)
        return self.radius - r, n, -(_dot(v, v) - dv * dv / (r * r)) / r

    def describe(self) -> str:
        return f"sphere R={self.radius:g} m centre ({', '.join(f'{c:g}' for c in self.center)})"

    def packed(self) -> tuple:
        """(kind, 6 floats): this wall for the compiled contact terms (kernel.contact_terms)."""
        return 2, (self.radius, *self.center, 0.0, 0.0)


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
