"""What a chain is made of: Link (one Euler-Bernoulli beam, its mass, stiffness and discretisation)
and Chain (the links, their joints and the base), with the rules that tie joints to links
(docs/theory.md §7, §8). Both are frozen dataclasses, validated once when they are built.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real
from typing import Callable

import numpy as np

from .arguments import items_of
from .bodies import check_bodies
from .elements import MAX_ELEMENTS
from .joints import JOINT_TYPES, FixedBase, Revolute
from .modes import MODE_DIRECTIONS, Mode


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
    bodies : sequence of RigidBody
        Rigid bodies attached to the link (payloads, a hub at ``at=0``), docs/theory.md §6.8;
        each body's ``at=None`` is resolved to the tip l.
    geometric_stiffening : bool
        True (default): the bent centreline foreshortens, a point at x sits at
        ``x + u_f(x)`` along the link axis, ``u_f = -1/2 int_0^x (v'^2 + w'^2)``
        (docs/theory.md, foreshortening), so that an axial (centrifugal) force stiffens
        bending. False: the linear beam of the source papers (no axial motion). No effect
        on a rigid link. Not supported behind a FixedPrismatic guide: give that link
        ``geometric_stiffening=False``. A SlidingPrismatic carriage on a stiffened host rides on
        the foreshortened centreline (docs/theory.md §7.3).
    """

    length: float
    mass_per_length: float | Callable = 1.0
    EI: float | tuple | Callable = 1.0
    modes: tuple = ()
    rotary_inertia: tuple = (0.0, 0.0, 0.0)
    elements: int = 0
    element_directions: tuple = ("y",)
    damping: float = 0.0
    bodies: tuple = ()
    geometric_stiffening: bool = True

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
        modes = items_of(self.modes, Mode, "Link modes", "; build it as Mode('clamped-clamped', 'y')")
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
        object.__setattr__(self, "bodies", check_bodies(self.bodies, self.length, bool(modes or ne)))
        if not isinstance(self.geometric_stiffening, (bool, np.bool_)):
            raise ValueError(f"Link geometric_stiffening={self.geometric_stiffening!r} must be True (foreshortening, "
                             "the default) or False (the linear beam)")
        object.__setattr__(self, "geometric_stiffening", bool(self.geometric_stiffening))

    @property
    def stiffened(self) -> bool:
        """True when the link has elastic coordinates and geometric_stiffening: its points foreshorten."""
        return self.geometric_stiffening and bool(self.modes or self.elements)

    @property
    def EI_y(self):
        """Stiffness against the z-deflection w [N m^2]."""
        return self.EI[0]

    @property
    def EI_z(self):
        """Stiffness against the y-deflection v [N m^2]."""
        return self.EI[1]


@dataclass(frozen=True)
class Chain:
    """A chain of links on a free-flying or a fixed base: serial, or a tree (parents, attach).

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

    Trees (formulation §17): ``parents[i]`` is the 0-based index of an earlier link or -1 for
    the base, ``attach[i]`` the abscissa x_a [m] on the parent where link i's joint sits (None:
    the parent's tip), deflection and foreshortening of the parent included:
    T_i = T_p A_p(x_a) J_i. A floating base floats the one root link (parents[0] = -1 and no
    other -1); a fixed base may carry several roots. gi.Weld(angle) joins two links rigidly
    (no coordinate). Prismatic joints stand in serial chains only (parents a path, no attach).

    Parameters
    ----------
    links : sequence of Link (n >= 1)
    joints : sequence of n joints, or None for all revolute
    base : "free" (spatial floating base), "planar" or FixedBase
    parents : sequence of n ints, or None for the serial chain [-1, 0, 1, ..., n - 2]
    attach : sequence of n abscissae [m] (or None entries: the parent's tip), or None: all tips
    """

    links: tuple
    joints: tuple | None = None
    base: object = "free"
    parents: tuple | None = None
    attach: tuple | None = None

    def __post_init__(self):
        links = items_of(self.links, Link, "Chain links", "")
        if not links:
            raise ValueError("Chain links=[] is empty; give at least one gibbsimpact.Link")
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
                    f"Chain joints[{k}]={jt!r} is not a joint; use gi.Revolute(), gi.SlidingPrismatic(...), "
                    "gi.FixedPrismatic(...) or gi.Weld(...)")
        object.__setattr__(self, "joints", joints)
        if not (self.base in ("free", "planar") or isinstance(self.base, FixedBase)):
            raise ValueError(f"Chain base={self.base!r} must be 'free', 'planar' or "
                             "gi.FixedBase(position=(b1, b2), angle=beta)")
        parents, attach = _check_tree(links, joints, self.base, self.parents, self.attach)
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "attach", attach)
        _check_joints(links, joints, self.base)
        _check_moves(links, joints, self.base)

    @property
    def serial(self) -> bool:
        """True when every link hangs at the tip of the link before it (parents [-1, 0, 1, ...],
        no attach): today's serial chain."""
        return self.parents == tuple(range(-1, len(self.links) - 1)) and all(a is None for a in self.attach)

    @property
    def children(self) -> tuple:
        """children[i]: the links whose parent is link i, in link order (tuple of n tuples)."""
        return tuple(tuple(j for j, p in enumerate(self.parents) if p == i) for i in range(len(self.links)))

    @property
    def leaves(self) -> tuple:
        """The links that carry no child, in link order."""
        return tuple(i for i, c in enumerate(self.children) if not c)

    @property
    def free_tips(self) -> tuple:
        """The links whose tip carries no child (every child attached at x_a < l, or none): their
        tips are contact points of their own (formulation §17), in link order."""
        return tuple(i for i, c in enumerate(self.children)
                     if not any(self.attach[j] in (None, self.links[i].length) for j in c))

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
        return self.base == "planar" or any(j.spec.prismatic for j in self.joints)


def _per_link(name: str, value, n: int, what: str, fix: str) -> tuple:
    """Chain's argument ``name`` as a tuple of one entry per link (n); a ValueError names it and the fix."""
    try:
        value = tuple(value)
    except TypeError:
        raise ValueError(f"Chain {name}={value!r} must be a list of n = {n} {what}") from None
    if len(value) != n:
        raise ValueError(f"Chain {name} has {len(value)} entries for {n} links; give one per link ({fix})")
    return value


def _check_tree(links, joints, base, parents, attach) -> tuple:
    """(parents, attach) as tuples after the rules of formulation §17; a ValueError names the
    argument and the fix."""
    n = len(links)
    if parents is None:
        parents = tuple(range(-1, n - 1))
    parents = _per_link("parents", parents, n, "link indices (-1: the base)", "-1 for the base")
    for i, p in enumerate(parents):
        if isinstance(p, bool) or not isinstance(p, (int, np.integer)) or not -1 <= p < i:
            raise ValueError(f"Chain parents[{i}]={p!r} must be -1 (the base) or the 0-based index of an earlier "
                             f"link (0 .. {i - 1}): list the links parent first")
    parents = tuple(int(p) for p in parents)
    roots = [i for i, p in enumerate(parents) if p < 0]
    if isinstance(base, str) and len(roots) > 1:
        raise ValueError(f"Chain parents[{roots[1]}]=-1: a floating base (base={base!r}) floats one root link; "
                         "give " + ", ".join(f"links[{r}] (link {r + 1})" for r in roots[1:]) + " an earlier link as "
                         "parent (or use gi.FixedBase(...), which may carry several roots)")
    if attach is None:
        attach = (None,) * n
    attach = _per_link("attach", attach, n, "abscissae [m] or None", "None: the parent's tip")
    out = []
    for i, (p, a) in enumerate(zip(parents, attach)):
        if a is None:
            out.append(None)
            continue
        if p < 0:
            raise ValueError(f"Chain attach[{i}]={a!r}: links[{i}] (link {i + 1}) stands on the base (parents[{i}] = -1); give None "
                             "(place a root with the base's position instead)")
        lp = links[p].length
        if isinstance(a, bool) or not isinstance(a, Real) or not np.isfinite(a) or not 0.0 <= a <= lp:
            raise ValueError(f"Chain attach[{i}]={a!r} must be an abscissa in [0, {lp:g}] m on its parent, "
                             f"links[{p}] (link {p + 1}) (or None for the parent's tip)")
        out.append(float(a))
    serial = parents == tuple(range(-1, n - 1)) and all(a is None for a in out)
    for k, jt in enumerate(joints):
        if jt.spec.prismatic and not serial:
            raise ValueError(f"Chain joints[{k}]={jt!r}: prismatic joints stand in serial chains only (parents=None, "
                             "attach=None); in a tree, give this link a gi.Revolute() or gi.Weld()")
    if isinstance(base, str) and not joints[roots[0]].spec.turns:
        raise ValueError(f"Chain joints[{roots[0]}]={joints[roots[0]]!r}: on a floating base (base={base!r}) the root's "
                         "joint must be gi.Revolute(); its theta is part of the floating orientation")
    return parents, tuple(out)


def _check_moves(links, joints, base):
    """A chain with no coordinate (N = 0: a fixed base, every joint a weld, every link rigid) has
    nothing to integrate: refuse it here rather than fail inside the kernel."""
    if isinstance(base, str) or any(jt.spec.has_coordinate for jt in joints) or any(lk.modes or lk.elements for lk in links):
        return
    raise ValueError("Chain joints are all gi.Weld() on a fixed base and every link is rigid: the chain has no "
                     "coordinate (N = 0) and nothing moves; give a joint gi.Revolute() or a link modes=[...] or "
                     "elements=n_e")


def _check_joints(links, joints, base):
    """The rules of docs/theory.md §8, §7.3, §7.4 for prismatic joints."""
    prismatic = [k for k, j in enumerate(joints) if j.spec.prismatic]
    planar = base == "planar" or prismatic
    for k, jt in enumerate(joints):
        R = getattr(jt, "axis_rotation", None) or getattr(jt, "rotation", None)
        if planar and R is not None and not np.allclose(np.asarray(R)[:, 2], (0.0, 0.0, 1.0), atol=1e-12):
            raise ValueError(f"Chain joints[{k}]={jt!r}: a planar chain (base='planar' or prismatic joints) moves in "
                             "the X1-X2 plane; its joints' rotations must keep the z axis (R e_z = e_z)")
    if base == "planar" and not joints[0].spec.turns:
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
        if jt.spec.guide:
            lk = links[k]
            if lk.stiffened:
                raise ValueError(
                    f"Chain links[{k}] (link {k + 1}) slides through a FixedPrismatic guide with geometric_stiffening=True: "
                    "the foreshortening of material flowing through a guide is not modelled (docs/theory.md, "
                    "foreshortening); give this link geometric_stiffening=False (the linear beam)")
            if lk.bodies:
                raise ValueError(
                    f"Chain links[{k}] (link {k + 1}) slides through a FixedPrismatic guide and carries bodies: a Pb link's "
                    "material moves along it with d, which the attached-body model does not cover; attach the body to the "
                    "next link (at=0) or to a link on a revolute or SlidingPrismatic joint")
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
