"""The immutable model: links, chain, coordinates and precomputed modal integrals.

Everything that depends only on the model (modal integrals, stiffness
matrices, end values of the mode shapes) is computed once here, so the
dynamics kernel (:mod:`gibbsimpact.dynamics`) only does q-dependent work.

Coordinates (docs/theory.md §1), in this order::

    q = [X1, X2, X3, theta_-1, theta_0, theta_1 ... theta_n,
         delta_1,1 ... delta_1,m1, ..., delta_n,1 ... delta_n,mn]
"""

from __future__ import annotations

import functools
from math import isfinite

from dataclasses import dataclass
from numbers import Real
from typing import Callable, Sequence

import numpy as np

from ..kernel import compiled, output, variant
from .elements import MAX_ELEMENTS, element_quadrature, hermite_shape
from .modes import MODE_DIRECTIONS, Mode, shape
from .packing import pack

#: Axis index in the link frame of each mode direction.
_AXIS = {"y": 1, "z": 2}

#: Default composite Gauss-Legendre rule for the modal integrals:
#: (panels, points per panel). tests/test_quadrature.py shows the error on M
#: is < 1e-12 relative for modes 1-4 with it.
DEFAULT_QUADRATURE = (16, 16)


def _positive_scalar_or_callable(name: str, value):
    if callable(value):
        return value
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ValueError(f"{name}={value!r} must be a positive number or a callable of x [m]")
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name}={value!r} must be positive and finite")
    return float(value)


@dataclass(frozen=True)
class Link:
    """One flexible link: an Euler-Bernoulli beam with assumed modes or Hermite finite elements.

    Parameters
    ----------
    length : float
        l [m], > 0.
    mass_per_length : float or callable
        mu [kg/m], > 0; a callable ``mu(x)`` of an array of abscissae for a
        non-uniform link.
    EI : float, (float, float) or callable
        Bending stiffness [N m^2]. A scalar is used for both directions; a pair
        is ``(EI_y, EI_z)``: ``EI_z`` resists the y-deflection v (in-plane),
        ``EI_y`` the z-deflection w. Callables of x are allowed in each place.
    modes : sequence of Mode
        Assumed modes; empty (and ``elements=0``) for a rigid link.
    elements : int
        n_e >= 1 Hermite cubic finite elements (docs/theory.md §4), clamped
        at the link frame: 2 n_e elastic coordinates per bending direction,
        (deflection [m], slope [rad]) at nodes 1 .. n_e. 0: none. Exclusive with ``modes``.
    element_directions : tuple of "y", "z"
        Bending directions discretised by the elements: ("y",) in-plane only
        (default), ("y", "z") for a spatial chain (the z set uses EI_y).
    damping : float
        zeta >= 0, structural damping ratio of the link's first elastic mode:
        stiffness-proportional damping Q = -beta K delta_dot with beta = 2 zeta / omega_1
        (gibbsimpact.forces). 0 (default): undamped. Needs modes or elements.
    rotary_inertia : (float, float, float)
        ``(j_x, j_y, j_z)`` [kg m]: rotary inertia of the cross-section per unit
        length about the link-frame axes. The link frame then carries
        ``J = l diag(j_x, j_y, j_z)`` [kg m^2] (docs/theory.md §6).
    """

    length: float
    mass_per_length: float | Callable = 1.0
    EI: float | tuple | Callable = 1.0
    modes: tuple = ()
    rotary_inertia: tuple = (0.0, 0.0, 0.0)
    elements: int = 0
    element_directions: tuple = ("y",)
    damping: float = 0.0

    def __post_init__(self):
        if isinstance(self.length, bool) or not isinstance(self.length, Real) or not np.isfinite(self.length) or self.length <= 0:
            raise ValueError(f"Link length={self.length!r} must be a positive number of metres")
        object.__setattr__(self, "length", float(self.length))
        object.__setattr__(
            self, "mass_per_length", _positive_scalar_or_callable("Link mass_per_length", self.mass_per_length)
        )
        ei = self.EI
        if isinstance(ei, (tuple, list, np.ndarray)):
            if len(ei) != 2:
                raise ValueError(f"Link EI={ei!r} must be a scalar or a pair (EI_y, EI_z) in N m^2")
            ei = tuple(_positive_scalar_or_callable(f"Link EI[{k}]", v) for k, v in enumerate(ei))
        else:
            e = _positive_scalar_or_callable("Link EI", ei)
            ei = (e, e)
        object.__setattr__(self, "EI", ei)
        modes = self.modes
        if isinstance(modes, Mode):
            modes = (modes,)
        try:
            modes = tuple(modes)
        except TypeError:
            raise ValueError(f"Link modes={self.modes!r} must be a list of gibbsimpact.Mode") from None
        for k, m in enumerate(modes):
            if not isinstance(m, Mode):
                raise ValueError(f"Link modes[{k}]={m!r} is not a gibbsimpact.Mode; build it as Mode('clamped-clamped', 'y')")
        if len(set(modes)) != len(modes):
            raise ValueError(f"Link modes={modes!r} lists the same mode twice: its mass matrix would be singular")
        object.__setattr__(self, "modes", modes)
        ne = self.elements
        if isinstance(ne, bool) or not isinstance(ne, (int, np.integer)) or not 0 <= ne <= MAX_ELEMENTS:
            raise ValueError(f"Link elements={ne!r} must be an integer in [0, {MAX_ELEMENTS}] (0: no finite elements)")
        object.__setattr__(self, "elements", int(ne))
        if ne and modes:
            raise ValueError(
                f"Link elements={ne} and modes={modes!r} both given; a link is discretised either by "
                "assumed modes or by finite elements: drop one"
            )
        dirs = (self.element_directions,) if isinstance(self.element_directions, str) else self.element_directions
        try:
            dirs = tuple(dirs)
        except TypeError:
            dirs = None
        if not dirs or any(d not in MODE_DIRECTIONS for d in dirs) or len(set(dirs)) != len(dirs):
            raise ValueError(
                f"Link element_directions={self.element_directions!r} must be ('y',), ('z',) or ('y', 'z'): "
                "'y' is in-plane bending v, 'z' out-of-plane bending w"
            )
        object.__setattr__(self, "element_directions", dirs)
        z = self.damping
        if isinstance(z, bool) or not isinstance(z, Real) or not np.isfinite(z) or not 0.0 <= z <= 10.0:
            raise ValueError(f"Link damping={z!r} must be a damping ratio in [0, 10] (e.g. 0.02 for 2 %)")
        if z > 0 and not (modes or ne):
            raise ValueError(f"Link damping={z!r} needs elastic coordinates: give the link modes or elements")
        object.__setattr__(self, "damping", float(z))
        j = np.asarray(self.rotary_inertia, dtype=float) if not isinstance(self.rotary_inertia, str) else None
        if j is None or j.shape != (3,) or not np.all(np.isfinite(j)) or np.any(j < 0):
            raise ValueError(
                f"Link rotary_inertia={self.rotary_inertia!r} must be three non-negative numbers (j_x, j_y, j_z) in kg m"
            )
        object.__setattr__(self, "rotary_inertia", tuple(float(v) for v in j))

    @property
    def EI_y(self):
        """Stiffness against the z-deflection w [N m^2]."""
        return self.EI[0]

    @property
    def EI_z(self):
        """Stiffness against the y-deflection v [N m^2]."""
        return self.EI[1]


@dataclass(frozen=True)
class Revolute:
    """A revolute joint: link i turns by theta_i [rad] about the z axis at the host's tip (docs/theory.md §7.2).

    G_i = E_(i-1) Rz(theta_i); on a fixed base E_0 = I (the motor sits at the base origin).
    """

    kind = "R"


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
class SlidingPrismatic:
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
class FixedPrismatic:
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
JOINT_TYPES = (Revolute, SlidingPrismatic, FixedPrismatic)


@dataclass(frozen=True)
class Chain:
    """A serial chain of links on a free-flying or a fixed base.

    Free base (``base="free"``, the default): joint O_1 (proximal end of link 1)
    flies freely; two massless virtual links of zero length and link 1's joint
    give three rotations ``Rx(theta_-1) Ry(theta_0) Rz(theta_1)``; every further
    link adds a revolute joint about its own z axis.

    Fixed base (``base=gi.FixedBase(position, angle)``): joint 1 sits at the
    base frame T_0; no base coordinates.

    Planar floating base (``base="planar"``): coordinates X1, X2 translate the
    base frame in the X1-X2 plane; joint 1 must be revolute (theta_1 is the
    floating orientation).

    Joints (docs/theory.md §7.1): gi.Revolute() (theta_i [rad]),
    gi.SlidingPrismatic (Pa, a carriage on the host link, d_i [m]) and
    gi.FixedPrismatic (Pb, the link slides through a guide at the host's tip,
    d_i = protruding length [m]). Prismatic joints make the chain planar: a
    fixed or a planar floating base, in-plane bending only.

    Parameters
    ----------
    links : sequence of Link (n >= 1)
    joints : sequence of n joints, or None for all revolute
    base : "free" (spatial floating base), "planar" or FixedBase
    """

    links: tuple
    joints: tuple | None = None
    base: object = "free"

    def __post_init__(self):
        links = self.links
        if isinstance(links, Link):
            links = (links,)
        try:
            links = tuple(links)
        except TypeError:
            raise ValueError(f"Chain links={self.links!r} must be a list of gibbsimpact.Link") from None
        if not links:
            raise ValueError("Chain links=[] is empty; give at least one gibbsimpact.Link")
        for k, lk in enumerate(links):
            if not isinstance(lk, Link):
                raise ValueError(f"Chain links[{k}]={lk!r} is not a gibbsimpact.Link")
        object.__setattr__(self, "links", links)
        joints = self.joints
        if joints is None:
            joints = tuple(Revolute() for _ in links)
        try:
            joints = tuple(joints)
        except TypeError:
            raise ValueError(f"Chain joints={self.joints!r} must be a list of joints, one per link") from None
        if len(joints) != len(links):
            raise ValueError(f"Chain joints has {len(joints)} entries for {len(links)} links; give one joint per link")
        for k, jt in enumerate(joints):
            if not isinstance(jt, JOINT_TYPES):
                raise ValueError(
                    f"Chain joints[{k}]={jt!r} is not a joint; use gi.Revolute(), gi.SlidingPrismatic(...) "
                    "or gi.FixedPrismatic(...)")
        object.__setattr__(self, "joints", joints)
        if not (self.base in ("free", "planar") or isinstance(self.base, FixedBase)):
            raise ValueError(f"Chain base={self.base!r} must be 'free', 'planar' or "
                             "gi.FixedBase(position=(b1, b2), angle=beta)")
        _check_joints(links, joints, self.base)

    @property
    def n_links(self) -> int:
        return len(self.links)

    @property
    def free_base(self) -> bool:
        """True for a floating base, spatial ('free') or planar ('planar')."""
        return isinstance(self.base, str)

    @property
    def planar(self) -> bool:
        """True when the chain moves in the X1-X2 plane only (docs/theory.md §8):
        a planar free base, or any prismatic joint."""
        return self.base == "planar" or any(j.kind != "R" for j in self.joints)


def _check_joints(links, joints, base):
    """The rules of docs/theory.md §8, §7.3, §7.4 for prismatic joints."""
    prismatic = [k for k, j in enumerate(joints) if j.kind != "R"]
    if base == "planar" and joints[0].kind != "R":
        raise ValueError(f"Chain joints[0] (joint 1)={joints[0]!r}: on a planar free base (base='planar') joint 1 "
                         "must be gi.Revolute(); its theta_1 is the floating orientation")
    if not prismatic and base != "planar":
        return
    if base == "free":
        raise ValueError(
            f"Chain joints[{prismatic[0]}] (joint {prismatic[0] + 1})={joints[prismatic[0]]!r}: prismatic joints are planar "
            "(docs/theory.md §8); use base='planar' for a floating chain or gi.FixedBase(...)")
    for k, lk in enumerate(links):
        if lk.elements and lk.element_directions != ("y",) or any(md.direction != "y" for md in lk.modes):
            raise ValueError(f"Chain links[{k}] (link {k + 1}) bends out of plane; a planar chain (prismatic joints or "
                             "base='planar') allows in-plane bending only: element_directions=('y',), y-modes")
    for k in prismatic:
        jt = joints[k]
        lo, hi = jt.range
        if jt.kind == "Pb":
            lk = links[k]
            if lk.modes:
                raise ValueError(
                    f"Chain links[{k}] (link {k + 1}) slides through a FixedPrismatic guide and has assumed modes; a Pb link "
                    "is discretised by stretching finite elements: give it elements=n_e (or none: rigid)")
            if callable(lk.mass_per_length) or any(callable(e) for e in lk.EI):
                raise ValueError(f"Chain links[{k}] (link {k + 1}) slides through a FixedPrismatic guide: its mass_per_length "
                                 "and EI must be constants (a prismatic member has one cross-section)")
            if hi > lk.length + 1e-12:
                raise ValueError(f"Chain joints[{k}] (joint {k + 1}) FixedPrismatic range={jt.range!r}: d_max must be <= the "
                                 f"link's length {lk.length:g} m (d is the protruding length)")
            continue
        if k == 0:
            continue  # a rigid rail on the base: any range, c irrelevant
        host = links[k - 1]
        c = jt.half_length
        if host.modes:
            raise ValueError(
                f"Chain joints[{k}] (joint {k + 1}) SlidingPrismatic on links[{k - 1}] (link {k}), which has assumed modes: a carriage "
                "host must be a finite-element link (elements=n_e) or rigid")
        if host.elements and c <= 0:
            raise ValueError(
                f"Chain joints[{k}] (joint {k + 1}) SlidingPrismatic half_length={c!r} on a finite-element host: give c > 0. "
                "A point slider follows the host's slope v'(d), whose derivative v'' jumps at every element "
                "node, so M(q) would jump there and energy would not be conserved (docs/theory.md §7.3)")
        if lo < c - 1e-12 or hi > host.length - c + 1e-12:
            raise ValueError(
                f"Chain joints[{k}] (joint {k + 1}) SlidingPrismatic range={jt.range!r}: the carriage must stay on the host, "
                f"c <= d_min < d_max <= l_host - c = {host.length - c:g} m (c = {c:g} m)")


def _as_function(v):
    return v if callable(v) else (lambda x, c=v: np.full_like(np.asarray(x, dtype=float), c))


def gauss_legendre(length: float, panels: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss-Legendre nodes and weights on [0, length].

    Returns
    -------
    x, w : ndarray, shape (panels*points,)
    """
    t, wt = np.polynomial.legendre.leggauss(points)
    h = length / panels
    a = np.arange(panels)[:, None] * h
    x = (a + 0.5 * h * (t[None, :] + 1.0)).ravel()
    w = np.tile(0.5 * h * wt, panels)
    return x, w


@dataclass(frozen=True, eq=False)
class LinkData:
    """Model-only quantities of one link, all in the link frame.

    With ``r0(x) = (x, 0, 0, 1)`` and ``psihat_k(x) = (e_dir psi_k(x), 0)``
    (4-vectors), mu the mass per length:

    * ``P0 = int mu r0 r0^T dx`` (4, 4) [kg m^2 / kg m / kg]
    * ``C[k] = int mu r0 psihat_k^T dx`` (m, 4, 4)
    * ``D[k, l] = int mu psihat_k psihat_l^T dx`` (m, m, 4, 4)
    * ``m_r0 = int mu r0 dx`` (4,), ``m_psi[k] = int mu psihat_k dx`` (m, 4)
    * ``M_dd[k, l] = trace D[k, l]`` (m, m) [kg]: the modal mass block
    * ``K[k, l] = int EI psi_k'' psi_l'' dx`` (m, m) [N/m]
    * ``end_t[k]``: tip displacement per unit delta_k (3,); ``end_phi[k]``:
      tip rotation vector per unit delta_k (3,) = (0, -w', v') at x = l.
    * ``J_body = l diag(j_x, j_y, j_z)`` (3, 3) [kg m^2]
    * ``E0 = Trans(l, 0, 0)`` (4, 4): the end transform of the undeformed link
    """

    length: float
    mass: float
    P0: np.ndarray
    C: np.ndarray
    D: np.ndarray
    m_r0: np.ndarray
    m_psi: np.ndarray
    M_dd: np.ndarray
    K: np.ndarray
    end_t: np.ndarray
    end_phi: np.ndarray
    J_body: np.ndarray
    E0: np.ndarray
    has_rotary: bool
    end_is_rigid: bool
    directions: tuple = ()


def shape_functions(link: Link, x, derivative: int = 0) -> tuple[tuple, np.ndarray]:
    """The link's shape functions at abscissae x (K,) [m]: (directions (m,), psi (m, K)).

    Assumed modes or Hermite element functions in the order of the link's
    elastic coordinates; ``derivative`` 0 .. 2 gives the x-derivatives.
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    l = link.length
    if link.elements:
        psi = hermite_shape(link.elements, l, x, derivative)
        return tuple(d for d in link.element_directions for _ in range(psi.shape[0])), \
            np.concatenate([psi] * len(link.element_directions))
    psi = np.array([shape(md, l, x, derivative) for md in link.modes]).reshape(len(link.modes), x.size)
    return tuple(md.direction for md in link.modes), psi


def link_deflection(model, q, i: int, x, derivative: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Deflection of link i (0-based) at material abscissae x (K,) [m]: (v (K,), w (K,)) [m].

    v along the link frame's y axis, w along z (docs/theory.md §2, §4, §7.4);
    ``derivative`` 0 .. 2 gives x-derivatives. A link behind a FixedPrismatic guide
    (protruding length d) bends only on sigma = x - (l - d) in [0, d]:
    v = sum_k d^(a_k) N_k(sigma / d) delta_k (stretching elements), 0 behind the guide.
    """
    q = np.asarray(q, dtype=float)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    lk = model.chain.links[i]
    idx = model.delta_index[i]
    v, w = np.zeros(x.size), np.zeros(x.size)
    if len(idx) == 0:
        return v, w
    delta = q[idx]
    if model.chain.joints[i].kind == "Pb":
        d = q[model.theta_index[i]]
        sigma = x - (lk.length - d)
        inside = sigma >= 0.0
        N = hermite_shape(lk.elements, 1.0, np.clip(sigma / d, 0.0, 1.0), derivative)  # (m, K)
        a = np.tile([0.0, 1.0], lk.elements)
        # d/dx = (1/d) d/dxi
        v = np.where(inside, (d ** (a - derivative) * delta) @ N, 0.0)
        return v, w
    directions, psi = shape_functions(lk, x, derivative)
    for p_k, dk, s in zip(psi, delta, directions):
        if s == "y":
            v = v + p_k * dk
        else:
            w = w + p_k * dk
    return v, w


def _basis(link: Link, x: np.ndarray):
    """The link's shape functions: directions (m,), psi and psi'' at x (m, K), psi and psi' at l (m,)."""
    l = [link.length]
    directions, psi = shape_functions(link, x, 0)
    return (list(directions), psi, shape_functions(link, x, 2)[1],
            shape_functions(link, l, 0)[1][:, 0], shape_functions(link, l, 1)[1][:, 0])


def link_integrals(link: Link, quadrature: tuple[int, int] = DEFAULT_QUADRATURE) -> LinkData:
    """Precompute the modal integrals of ``link`` with composite Gauss-Legendre.

    A finite-element link uses a rule aligned with its element nodes
    (elements.element_quadrature) instead of ``quadrature``.
    """
    l = link.length
    x, w = gauss_legendre(l, *(element_quadrature(link.elements) if link.elements else quadrature))
    mu = np.asarray(_as_function(link.mass_per_length)(x), dtype=float) * np.ones_like(x)
    if np.any(~np.isfinite(mu)) or np.any(mu <= 0):
        raise ValueError("Link mass_per_length(x) must be positive and finite on [0, length]")
    EI_fun = {"y": _as_function(link.EI_z), "z": _as_function(link.EI_y)}
    directions, psi, psi2, end_v, end_dv = _basis(link, x)
    m = len(directions)
    axes = [_AXIS[d] for d in directions]
    ei = {}
    for d in set(directions):
        ei[d] = np.asarray(EI_fun[d](x), dtype=float) * np.ones_like(x)
        if np.any(~np.isfinite(ei[d])) or np.any(ei[d] <= 0):
            raise ValueError("Link EI(x) must be positive and finite on [0, length]")
    wm = w * mu

    mass = wm.sum()
    s1 = wm @ x
    s2 = wm @ (x * x)
    P0 = np.zeros((4, 4))
    P0[0, 0], P0[0, 3], P0[3, 0], P0[3, 3] = s2, s1, s1, mass
    m_r0 = np.array([s1, 0.0, 0.0, mass])

    C = np.zeros((m, 4, 4))
    m_psi = np.zeros((m, 4))
    D = np.zeros((m, m, 4, 4))
    K = np.zeros((m, m))
    int_psi = psi @ wm
    int_xpsi = psi @ (wm * x)
    int_psipsi = (psi * wm) @ psi.T
    ax = np.array(axes, dtype=int)
    km = np.arange(m)
    C[km, 0, ax] = int_xpsi
    C[km, 3, ax] = int_psi
    m_psi[km, ax] = int_psi
    D[km[:, None], km[None, :], ax[:, None], ax[None, :]] = int_psipsi
    for d in set(directions):
        sel = np.array([dk == d for dk in directions])
        K[np.ix_(sel, sel)] = (psi2[sel] * (w * ei[d])) @ psi2[sel].T
    M_dd = np.einsum("klaa->kl", D)

    end_t = np.zeros((m, 3))
    end_phi = np.zeros((m, 3))
    for k, direction in enumerate(directions):
        end_t[k, axes[k]] = end_v[k]
        # phi = (theta_x, -w'(l), v'(l))
        if direction == "y":
            end_phi[k, 2] = end_dv[k]
        else:
            end_phi[k, 1] = -end_dv[k]
    # Clamped-clamped and pinned-pinned shapes vanish at x = l to round-off;
    # treat |value| < 1e-12 as exact zeros so the tip transform is constant.
    end_t[np.abs(end_t) < 1e-12] = 0.0
    end_phi[np.abs(end_phi) < 1e-12 / l] = 0.0
    J_body = l * np.diag(link.rotary_inertia)
    E0 = np.eye(4)
    E0[0, 3] = l
    arrays = dict(P0=P0, C=C, D=D, m_r0=m_r0, m_psi=m_psi, M_dd=M_dd, K=K, end_t=end_t, end_phi=end_phi,
                  J_body=J_body, E0=E0)
    for a in arrays.values():
        a.setflags(write=False)
    return LinkData(
        length=l,
        mass=float(mass),
        has_rotary=bool(np.any(J_body)),
        end_is_rigid=not (np.any(end_t) or np.any(end_phi)),
        directions=tuple(directions),
        **arrays,
    )


_F64 = np.dtype(np.float64)


@functools.cache
def _dynamics():
    """gibbsimpact.dynamics.gibbs_appell, for the alias methods of Model (Model.mass_matrix calls
    dynamics.mass_matrix, ...); imported at their first use, since dynamics comes after model in
    the stage order (docs/architecture.md)."""
    from ..dynamics import gibbs_appell

    return gibbs_appell


@functools.cache
def _kinematics():
    """gibbsimpact.dynamics.kinematics, for Model.joint_positions and joint_jacobians (as _dynamics)."""
    from ..dynamics import kinematics

    return kinematics


class Model:
    """Immutable simulation model: a chain, gravity and precomputed link data.

    Parameters
    ----------
    chain : Chain
    gravity : (3,) array_like
        Gravitational acceleration in the inertial frame [m/s^2].
    quadrature : (int, int)
        Composite Gauss-Legendre rule (panels, points) for the modal integrals.

    Attributes
    ----------
    n_dof : int
        N = 3 + (n + 2) + sum m_i (free base), 2 + n + sum m_i (planar base),
        n + sum m_i (fixed base).
    coordinate_names : tuple of str, length N
        ``X1 X2 X3 theta_-1 theta_0 theta_1 ... theta_n delta_1_1 ...`` (free base),
        ``X1 X2 j_1 ... j_n delta_1_1 ...`` (planar base), ``j_1 ... j_n delta_1_1 ...``
        (fixed base), with j_i = ``theta_i`` (revolute) or ``d_i`` (prismatic).
    """

    def __init__(self, chain: Chain, gravity: Sequence[float] = (0.0, -9.81, 0.0), quadrature=DEFAULT_QUADRATURE):
        if isinstance(chain, (list, tuple)):
            chain = Chain(chain)
        if not isinstance(chain, Chain):
            raise ValueError(f"Model chain={chain!r} must be a gibbsimpact.Chain")
        g = np.asarray(gravity, dtype=float) if not isinstance(gravity, str) else np.array([])
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"Model gravity={gravity!r} must be three finite numbers (m/s^2), e.g. (0, -9.81, 0)")
        n = chain.n_links
        self._chain = chain
        self._quadrature = (int(quadrature[0]), int(quadrature[1]))
        self._gravity = g
        g.setflags(write=False)
        self._links = tuple(link_integrals(lk, quadrature) for lk in chain.links)
        # Free base: q = [X1, X2, X3, theta_-1, theta_0, theta_1 .. theta_n, deltas]; planar base:
        # [X1, X2, j_1 .. j_n, deltas]; fixed base: [j_1 .. j_n, deltas] (docs/theory.md §1, §8).
        base = {"free": ["X1", "X2", "X3", "theta_-1", "theta_0"], "planar": ["X1", "X2"]}.get(
            chain.base if chain.free_base else "", [])
        kinds = [j.kind for j in chain.joints]
        names = base + [f"theta_{i}" if kd == "R" else f"d_{i}" for i, kd in enumerate(kinds, start=1)]
        delta_index = []
        directions = []
        k = len(names)
        for i, (lk, ld) in enumerate(zip(chain.links, self._links), start=1):
            idx = []
            for j in range(1, ld.K.shape[0] + 1):
                names.append(f"delta_{i}_{j}")
                idx.append(k)
                k += 1
            directions += list(ld.directions)
            delta_index.append(np.array(idx, dtype=int))
        self._names = tuple(names)
        self._delta_index = tuple(delta_index)
        # The same indices as slices (each link's modes are contiguous): cheap views in the kernel.
        self._delta_slice = tuple(slice(int(d[0]), int(d[-1]) + 1) if d.size else slice(0, 0) for d in delta_index)
        self._theta_index = tuple(range(len(base), len(base) + n))
        self._bending = tuple([""] * (len(base) + n) + directions)
        # Unit of each coordinate: angles and FE node slopes in rad, the rest in m.
        units = ["m", "m", "m", "rad", "rad"][:len(base)]
        units += ["rad" if kd == "R" else "m" for kd in kinds]
        for lk, ld in zip(chain.links, self._links):
            units += (["m", "rad"] * (ld.K.shape[0] // 2)) if lk.elements else ["m"] * ld.K.shape[0]
        self._units = tuple(units)
        self._base_transform = None if chain.free_base else chain.base.transform
        K = np.zeros((k, k))
        for d, ld in zip(delta_index, self._links):
            K[np.ix_(d, d)] = ld.K
        K.setflags(write=False)
        self._K = K
        self._total_mass = sum(ld.mass for ld in self._links)

    # -- read-only views ---------------------------------------------------
    chain = property(lambda self: self._chain, doc="The Chain.")
    gravity = property(lambda self: self._gravity, doc="Gravity (3,) [m/s^2].")
    quadrature = property(lambda self: self._quadrature, doc="(panels, points) of the modal-integral rule.")
    link_data = property(lambda self: self._links, doc="Per-link LinkData.")
    coordinate_names = property(lambda self: self._names, doc="Names of q, length N.")
    delta_index = property(lambda self: self._delta_index, doc="Indices of each link's modal coordinates in q.")
    delta_slice = property(lambda self: self._delta_slice, doc="The same as slices of q.")
    theta_index = property(lambda self: self._theta_index,
                           doc="Index in q of joint i's variable (theta_i or d_i), i = 1..n.")
    joint_index = theta_index
    free_base = property(lambda self: self._chain.free_base,
                         doc="True for a floating base: X1..X3, theta_-1, theta_0 ('free') or X1, X2 ('planar') in q.")
    planar = property(lambda self: self._chain.planar, doc="True for a planar chain (docs/theory.md §8).")
    joint_kinds = property(lambda self: tuple(j.kind for j in self._chain.joints),
                           doc="'R', 'Pa' or 'Pb' per joint (n,).")
    base_transform = property(lambda self: self._base_transform, doc="T_0 (4, 4) of a fixed base, None for a free one.")
    coordinate_units = property(lambda self: self._units, doc="Unit of each coordinate, 'm' or 'rad' (N,).")
    bending_directions = property(
        lambda self: self._bending, doc="Per coordinate: 'y' or 'z' for an elastic coordinate, '' otherwise (N,).")
    stiffness_matrix = property(lambda self: self._K, doc="Block-diagonal modal stiffness K (N, N) [N/m].")
    total_mass = property(lambda self: self._total_mass, doc="Total mass [kg].")

    def __getstate__(self):
        # Pickled (a sweep's spawned workers) without kernel_call: it holds the kernel's dispatcher,
        # which a worker must take from its own import of the kernel.
        state = self.__dict__.copy()
        state.pop("_kernel_call", None)
        return state

    @property
    def kernel_data(self):
        """(fdat (F,), idat (I,), zeros (N,), v): the model packed for the compiled kernel (built once);
        v is its kernel variant (gibbsimpact.kernel.variant), a pair passed as the last two arguments."""
        try:
            return self._kernel_data
        except AttributeError:
            data = None
        if data is None:
            fdat, idat = pack(self)
            # Writable on purpose: numba types read-only arrays differently, and contact_terms
            # (resting.py) takes these zeros as a writable array (the kernel takes either).
            zeros = np.zeros(self.n_dof)
            data = self._kernel_data = (fdat, idat, zeros, variant(idat))
        return data

    @property
    def kernel_call(self) -> tuple:
        """(kernel, fdat, idat, zeros (N,), v0, v1, outputs): the compiled kernel of this model's variant
        (compiled at its first use) and its arguments, unpacked once for the documented entry points;
        ``outputs`` {job: length of the kernel's output for one state}, filled by :meth:`kernel_output`."""
        try:
            return self._kernel_call
        except AttributeError:
            fdat, idat, zeros, v = self.kernel_data
            call = self._kernel_call = (compiled(v), fdat, idat, zeros, v[0], v[1], {})
            return call

    def kernel_output(self, job: int) -> np.ndarray:
        """A new (uninitialised) output array of the kernel for one state and the JOB_* bits ``job``."""
        sizes = self.kernel_call[6]
        try:
            return np.empty(sizes[job])
        except KeyError:
            out = output(self.kernel_data[1], 1, job)
            sizes[job] = out.size
            return out

    @property
    def n_dof(self) -> int:
        return len(self._names)

    @property
    def n_links(self) -> int:
        return self._chain.n_links

    @property
    def n_joints(self) -> int:
        """Number P of contact points O_1 ... O_P (wall contact candidates).

        O_1 ... O_(n+1): the frame origins (each joint, the last link's tip; for a Pa
        link the carriage centre, for a Pb link its rear end). Then, in joint order,
        the tip of every host link whose child joint i >= 2 is prismatic: that tip is
        not a frame origin (a carriage rides along the host; a guide sits at its tip).
        """
        try:
            return self._n_joints  # computed once: the event layer asks for it at every gap evaluation
        except AttributeError:
            pass
        P = self._n_joints = self._chain.n_links + 1 + sum(
            1 for i, j in enumerate(self._chain.joints) if i > 0 and j.kind != "R")
        return P

    @property
    def contact_point_names(self) -> tuple:
        """A label per contact point (P,): 'O1' ... and 'tip of link i' for the extra tips."""
        names = [f"O{j}" for j in range(1, self._chain.n_links + 2)]
        names += [f"tip of link {i}" for i, j in enumerate(self._chain.joints) if i > 0 and j.kind != "R"]
        return tuple(names)

    def check_state(self, q, qdot=None, name_q: str = "q", name_qdot: str = "qdot"):
        """Validate and return ``q`` (and ``qdot``) as float arrays of shape (N,).

        The common case, float64 arrays of shape (N,) with finite entries, costs a shape compare
        and one dot product (q.q + qdot.qdot is finite exactly when every entry is, or overflowed
        beyond 1e154, which the full check below then clears), so that the alias methods cost
        what the kernel costs.
        """
        N = len(self._names)
        if q.__class__ is np.ndarray and q.dtype is _F64 and q.shape == (N,):
            if qdot is None:
                if isfinite(q.dot(q)):
                    return q
            elif qdot.__class__ is np.ndarray and qdot.dtype is _F64 and qdot.shape == (N,) \
                    and isfinite(q.dot(q) + qdot.dot(qdot)):
                return q, qdot
        qa = np.asarray(q, dtype=float)
        if qa.shape != (N,):
            raise ValueError(f"{name_q} has shape {qa.shape}; this model needs shape ({N},) ordered as {', '.join(self._names)}")
        if not np.all(np.isfinite(qa)):
            bad = [self._names[i] for i in np.nonzero(~np.isfinite(qa))[0]]
            raise ValueError(f"{name_q} has non-finite entries: {', '.join(bad)}")
        if qdot is None:
            return qa
        qd = np.asarray(qdot, dtype=float)
        if qd.shape != (N,):
            raise ValueError(f"{name_qdot} has shape {qd.shape}; this model needs shape ({N},)")
        if not np.all(np.isfinite(qd)):
            bad = [self._names[i] for i in np.nonzero(~np.isfinite(qd))[0]]
            raise ValueError(f"{name_qdot} has non-finite entries: {', '.join(bad)}")
        return qa, qd

    def state(self, **values) -> np.ndarray:
        """Build a q (or qdot) vector (N,) from coordinate names; missing ones are 0.

        Example: ``model.state(X1=-0.5, theta_1=0.3)``. Names use ``theta_m1``
        as an alias of ``theta_-1``.
        """
        q = np.zeros(self.n_dof)
        for k, v in values.items():
            name = k.replace("theta_m1", "theta_-1")
            if name not in self._names:
                raise ValueError(f"unknown coordinate {k!r}; this model has {', '.join(self._names)}")
            q[self._names.index(name)] = float(v)
        return q

    # -- algorithms (thin delegations to pure functions) ---------------------
    def mass_matrix(self, q):
        """Mass matrix M(q), shape (N, N) [kg, kg m, kg m^2 by block]."""
        return _dynamics().mass_matrix(self, self.check_state(q))

    def bias_forces(self, q, qdot):
        """Velocity-product terms h(q, qdot), shape (N,) [N, N m]."""
        return _dynamics().bias_forces(self, *self.check_state(q, qdot))

    def potential_forces(self, q):
        """Gradient dV/dq of gravity plus strain energy, shape (N,) [N, N m]."""
        return _dynamics().potential_forces(self, self.check_state(q))

    def forward_dynamics(self, q, qdot):
        """Generalised accelerations qddot, shape (N,): M qddot = -h - dV/dq."""
        return _dynamics().forward_dynamics(self, *self.check_state(q, qdot))

    def energy(self, q, qdot):
        """Energy(kinetic, gravity, strain, total) in joules."""
        return _dynamics().energy(self, *self.check_state(q, qdot))

    def joint_positions(self, q):
        """Inertial positions of O_1 ... O_(n+1), shape (n+1, 3) [m]."""
        return _kinematics().joint_positions(self, self.check_state(q))

    def joint_jacobians(self, q):
        """Jacobians d O_j / d q, shape (n+1, 3, N)."""
        return _kinematics().joint_jacobians(self, self.check_state(q))

    def joint_velocities(self, q, qdot):
        """Inertial velocities of O_1 ... O_(n+1), shape (n+1, 3) [m/s]."""
        q, qdot = self.check_state(q, qdot)
        return self.joint_jacobians(q) @ qdot

    def linear_momentum(self, q, qdot):
        """Total linear momentum, shape (3,) [kg m/s]."""
        return _dynamics().momentum(self, *self.check_state(q, qdot))[0]

    def angular_momentum(self, q, qdot, about=None):
        """Angular momentum about ``about`` (3,) [m], default the mass centre; (3,) [kg m^2/s]."""
        momentum = _dynamics().momentum
        q, qdot = self.check_state(q, qdot)
        L, H0, c = momentum(self, q, qdot)
        point = c if about is None else np.asarray(about, dtype=float)
        # H_P = H_0 - P x L
        return H0 - np.cross(point, L)

    def center_of_mass(self, q):
        """Mass centre, shape (3,) [m]."""
        return _dynamics().center_of_mass(self, self.check_state(q))

    def __repr__(self):
        return f"Model(n_links={self.n_links}, n_dof={self.n_dof}, gravity={tuple(self._gravity)})"
