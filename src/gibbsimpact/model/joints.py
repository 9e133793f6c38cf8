"""The joints of a chain (docs/theory.md §7): Revolute (R), SlidingPrismatic (Pa), FixedPrismatic
(Pb) and Weld (W, no coordinate; formulation §17), and the FixedBase a chain may stand on instead of flying freely (docs/theory.md §8).

Each is a frozen dataclass, validated once when it is built; ``kind`` ('R', 'Pa', 'Pb', 'W') names
its row of JOINT_KINDS, the one table of what each kind of joint is (has it a coordinate, is it
prismatic, ...): the rest of the package asks that table (``JOINT_KINDS[kind].prismatic``, or
``joint.spec.prismatic``) instead of testing the kind's string.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real

import numpy as np

from ..kernel.layout import JOINT_PA, JOINT_PB, JOINT_R, JOINT_WELD


@dataclass(frozen=True)
class JointKind:
    """The properties of one kind of joint (a row of JOINT_KINDS).

    Attributes
    ----------
    code : 'R', 'Pa', 'Pb' or 'W': the joints' ``kind`` and the case file's [links.joint] type
    name : the class that builds it (gi.Revolute, ...)
    has_coordinate : False for a weld (no joint variable in q; formulation §17)
    turns : its coordinate is an angle theta_i [rad] about the joint's axis (R)
    prismatic : True when its coordinate is a length d_i [m] along a line (Pa, Pb), False when the
        joint sits at its host's tip (or at_m) and at most turns (R, W)
    carriage : a carriage fixed to the link slides along the host (Pa, docs/theory.md §7.3)
    guide : the link slides through a guide at the host's tip (Pb, docs/theory.md §7.4)
    symbol, unit : joint i's coordinate is named f"{symbol}_{i}", in ``unit`` ('theta', 'rad' or
        'd', 'm'; '' for a weld)
    kernel_code : the kernel's integer code of the kind (kernel.layout JOINT_*)
    summary : one line saying what it is (case-file help, messages)
    """

    code: str
    name: str
    has_coordinate: bool
    turns: bool
    prismatic: bool
    carriage: bool
    guide: bool
    symbol: str
    unit: str
    kernel_code: int
    summary: str

    def coordinate_name(self, i: int) -> str:
        """The name of joint i's coordinate in q ('theta_2', 'd_3'); '' for a weld."""
        return f"{self.symbol}_{i}" if self.has_coordinate else ""


#: The one table of joint kinds, by code (Joint.kind).
JOINT_KINDS = {k.code: k for k in (
    JointKind("R", "Revolute", True, True, False, False, False, "theta", "rad", JOINT_R,
              "revolute: the link turns by theta_i at the host's tip"),
    JointKind("Pa", "SlidingPrismatic", True, False, True, True, False, "d", "m", JOINT_PA,
              "sliding prismatic: a carriage fixed to the link runs along the host, d_i"),
    JointKind("Pb", "FixedPrismatic", True, False, True, False, True, "d", "m", JOINT_PB,
              "fixed prismatic: the link slides through a guide at the host's tip, d_i"),
    JointKind("W", "Weld", False, False, False, False, False, "", "", JOINT_WELD,
              "weld: the link is clamped to its host at the fixed angle, no coordinate"),
)}


def _rotation(name: str, value):
    """``value`` as a proper rotation matrix (3, 3) (a tuple of rows), or None; a ValueError names
    the argument ``name``."""
    if value is None:
        return None
    R = np.asarray(value, dtype=float) if not isinstance(value, str) else np.zeros(0)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R @ R.T, np.eye(3), atol=1e-12) \
            or np.linalg.det(R) <= 0:
        raise ValueError(f"{name}={value!r} must be a proper rotation matrix (3, 3): R R^T = I to 1e-12 "
                         "and det R = +1 (e.g. scipy.spatial.transform.Rotation.from_euler('x', 90, degrees=True)"
                         ".as_matrix())")
    return tuple(tuple(float(v) for v in row) for row in R)


class _Joint:
    """What every joint class has: ``spec``, the row of JOINT_KINDS of its ``kind``."""

    __slots__ = ()

    @property
    def spec(self) -> JointKind:
        return JOINT_KINDS[self.kind]


@dataclass(frozen=True)
class Revolute(_Joint):
    """A revolute joint: link i turns by theta_i [rad] about the z axis at the host's tip (docs/theory.md §7.2).

    J_i = Rot(R) Rz(theta_i) (formulation §17): G_i = E_(i-1) J_i, or A_p(x_a) J_i in a tree; on a
    fixed base E_0 = I (the motor sits at the base origin).

    Parameters
    ----------
    axis_rotation : (3, 3) array_like or None
        R, a constant rotation applied before Rz(theta) that orients the joint axis: link i turns
        about R e_z of the parent's frame (a 3D leg's hip axis). None: the identity (R e_z = e_z).
    """

    axis_rotation: tuple | None = None
    kind = "R"

    def __post_init__(self):
        object.__setattr__(self, "axis_rotation", _rotation("Revolute axis_rotation", self.axis_rotation))


@dataclass(frozen=True)
class Weld(_Joint):
    """A welded joint: link i is clamped to its parent at a fixed angle, with no coordinate
    (formulation §17): J_i = Rot(R) Rz(angle).

    Parameters
    ----------
    angle : float
        gamma [rad], link i's axis turned about the parent's z axis (after R).
    rotation : (3, 3) array_like or None
        R, a constant rotation (3D); None: the identity.
    """

    angle: float = 0.0
    rotation: tuple | None = None
    kind = "W"

    def __post_init__(self):
        object.__setattr__(self, "angle", _joint_angle("Weld", self.angle))
        object.__setattr__(self, "rotation", _rotation("Weld rotation", self.rotation))


@dataclass(frozen=True)
class FixedBase:
    """A fixed base: joint 1 sits at the constant frame T_0 = Trans(b1, b2, b3) Rz(beta) (docs/theory.md §8).

    Parameters
    ----------
    position : (b1, b2) or (b1, b2, b3) [m]
    angle : beta [rad], the base x axis measured from X1 about X3
    """

    position: tuple = (0.0, 0.0)
    angle: float = 0.0

    def __post_init__(self):
        p = np.asarray(self.position, dtype=float) if not isinstance(self.position, str) else np.array([])
        if p.shape not in ((2,), (3,)) or not np.all(np.isfinite(p)):
            raise ValueError(f"FixedBase position={self.position!r} must be 2 or 3 finite numbers (m)")
        object.__setattr__(self, "position", tuple(float(v) for v in np.pad(p, (0, 3 - p.size))))
        a = self.angle
        if isinstance(a, bool) or not isinstance(a, Real) or not np.isfinite(a):
            raise ValueError(f"FixedBase angle={a!r} must be a finite number of radians")
        object.__setattr__(self, "angle", float(a))

    @property
    def transform(self) -> np.ndarray:
        """T_0 (4, 4)."""
        c, s = np.cos(self.angle), np.sin(self.angle)
        T = np.eye(4)
        T[:2, :2] = [[c, -s], [s, c]]
        T[:3, 3] = self.position
        return T


def _joint_range(kind: str, value) -> tuple[float, float]:
    if value is None:
        raise ValueError(f"{kind} needs range=(d_min, d_max) in metres: the joint's travel (joint limits "
                         "are events of the simulation)")
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{kind} range={value!r} must be a pair (d_min, d_max) in metres") from None
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo >= hi:
        raise ValueError(f"{kind} range={value!r} must be finite with d_min < d_max (metres)")
    return lo, hi


def _joint_angle(kind: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, Real) or not np.isfinite(value):
        raise ValueError(f"{kind} angle={value!r} must be a finite number of radians")
    return float(value)


@dataclass(frozen=True)
class SlidingPrismatic(_Joint):
    """Pa: a carriage fixed to link i slides along the host link i-1 (docs/theory.md §7.3).

    The carriage has half-length c and rides on the host's centreline with two
    contact points at host abscissae d - c and d + c; its frame sits at the
    midpoint of their chord, x axis along the chord, and link i is clamped to
    it at the fixed angle gamma:

        G_i = Trans(d, vbar(d)) Rz(phibar(d)) Rz(gamma)
        vbar = [v(d + c) + v(d - c)] / 2,   phibar = [v(d + c) - v(d - c)] / (2 c)

    On the base (joint 1) the host is a straight rigid rail along the base x axis.

    Parameters
    ----------
    angle : float
        gamma [rad], link i's axis relative to the carriage.
    half_length : float
        c [m] >= 0; must be > 0 on a finite-element host (a point slider makes
        M jump at every element node and breaks energy conservation).
    range : (float, float)
        (d_min, d_max) [m], the carriage centre's travel; on a host link
        c <= d_min < d_max <= l_host - c.
    """

    angle: float = 0.0
    half_length: float = 0.0
    range: tuple | None = None
    kind = "Pa"

    def __post_init__(self):
        object.__setattr__(self, "angle", _joint_angle("SlidingPrismatic", self.angle))
        c = self.half_length
        if isinstance(c, bool) or not isinstance(c, Real) or not np.isfinite(c) or c < 0:
            raise ValueError(f"SlidingPrismatic half_length={c!r} must be a number >= 0 (metres)")
        object.__setattr__(self, "half_length", float(c))
        object.__setattr__(self, "range", _joint_range("SlidingPrismatic", self.range))


@dataclass(frozen=True)
class FixedPrismatic(_Joint):
    """Pb: link i slides through a guide fixed at the host's tip (docs/theory.md §7.4).

    The guide sits at the host's deflected tip, along its tangent turned by
    gamma; link i's frame is at its rear end:

        G_i = E_(i-1) Rz(gamma) Trans(d - l_i, 0)

    d is the protruding length (guide to link i's tip). Only the protruding part
    bends (stretching Hermite elements of length d / n_e); the part behind the
    guide is straight but keeps its mass. On the base (joint 1) the guide is at
    the base origin.

    Parameters
    ----------
    angle : float
        gamma [rad], the guide axis relative to the host's tip tangent.
    range : (float, float)
        (d_min, d_max) [m] with 0 < d_min < d_max <= l_i.
    """

    angle: float = 0.0
    range: tuple | None = None
    kind = "Pb"

    def __post_init__(self):
        object.__setattr__(self, "angle", _joint_angle("FixedPrismatic", self.angle))
        lo, hi = _joint_range("FixedPrismatic", self.range)
        if lo <= 0:
            raise ValueError(f"FixedPrismatic range={self.range!r}: d_min must be > 0 (the protruding "
                             "length; the link's stiffness grows like 1/d^3 as d -> 0)")
        object.__setattr__(self, "range", (lo, hi))


#: Joint types a chain accepts.
JOINT_TYPES = (Revolute, SlidingPrismatic, FixedPrismatic, Weld)
