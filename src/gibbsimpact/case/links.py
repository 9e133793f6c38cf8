"""The chain of a case file: ``[[links]]``, ``[links.joint]`` and ``[base]`` read into a Model.

Each reader returns the object (Link, joint, base) or ``_BAD`` after reporting its problems
at their keys (gibbsimpact.case.reader). The rules that involve several links and joints
(docs/theory.md §7.3, §7.4, §8, §9, §13) are checked once every link and joint reads, each at
the key to change (:func:`_chain_ok`); the Model is built only from a chain that passes.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sl

from ..model.bodies import RigidBody
from ..model.joints import JOINT_KINDS
from ..model.model import Chain, FixedBase, FixedPrismatic, Link, Model, Revolute, SlidingPrismatic, Weld
from ..model.modes import MODE_DIRECTIONS, MODE_KINDS, Mode, natural_frequency
from .keypaths import join, key_path
from .reader import _BAD, _MISSING, _build_each, _Reader
from .schema import _BASE_KEYS, _BODY_KEYS, _JOINT_KEYS, _JOINT_TYPES, _LINK_KEYS, _MODE_KEYS, MAX_MODE_FREQUENCY
from .text import fmt, type_name

__all__ = ["read_chain"]


def read_chain(r: _Reader, top: dict, gravity):
    """(Model or None, base) of the case table ``top``: base 'free', 'planar', a FixedBase or _BAD.

    The Model is None when a link, a joint, the base or gravity has a problem (reported), or when
    the chain breaks a rule of prismatic joints or planar bases.
    """
    raw_links = top.get("links", _MISSING)
    links = joints = _BAD
    if raw_links is _MISSING:
        r.add("links", "missing (at least one [[links]] table with length_m, mass_per_length_kg_per_m, EI_N_m2)")
    elif not isinstance(raw_links, list) or not raw_links:
        r.add("links", f"expected one or more [[links]] tables, got {type_name(raw_links)}")
    else:
        links = _build_each(raw_links, lambda k, lt: _link(r, lt, join("links", k)))
        joints = _build_each(raw_links, lambda k, lt: _joint(r, lt, join("links", k)))
    base = _base(r, top["base"]) if "base" in top else "free"
    tree = _tree(r, raw_links) if links is not _BAD else _BAD
    if _BAD in (links, joints, gravity, base, tree) or not _chain_ok(r, links, joints, base):
        return None, base
    try:
        chain = Chain(tuple(links), joints=tuple(joints), base=base, parents=tree[0], attach=tree[1])
    except ValueError as exc:  # a tree's rules (formulation §17): Chain names the 0-based entry
        r.add("links", f"{exc} (Chain's parents[i], attach[i] are links[i + 1].joint.parent - 1 and .at_m)")
        return None, base
    model = Model(chain, gravity=tuple(gravity))
    return (model if _element_frequencies_ok(r, model) else None), base


# -- one link -------------------------------------------------------------------------------

def _link(r: _Reader, tbl, path: str):
    """The Link of one [[links]] table at ``path`` (links[i]), _BAD on a problem."""
    tbl = r.table(tbl, path, _LINK_KEYS, "a [[links]] table")
    if tbl is None:
        return _BAD
    length = r.get(tbl, path, "length_m", "number", required=True, what=_LINK_KEYS["length_m"])
    mu = r.get(tbl, path, "mass_per_length_kg_per_m", "number", required=True,
               what=_LINK_KEYS["mass_per_length_kg_per_m"])
    ei = _bending_stiffness(r, tbl, path)
    j = _rotary_inertia(r, tbl, path, mu)
    modes = _modes(r, tbl, join(path, "modes"))
    elements, directions, zeta = _discretisation(r, tbl, path, modes)
    stiff = r.get(tbl, path, "geometric_stiffening", "bool", default=True)
    bodies = _bodies(r, tbl, join(path, "bodies"))
    if _BAD in (length, mu, ei, j, elements, directions, zeta, stiff) or _BAD in (modes, bodies):
        return _BAD
    try:
        link = Link(length=length, mass_per_length=mu, EI=ei, modes=tuple(modes),
                    rotary_inertia=tuple(j) if j is not None else (0.0, 0.0, 0.0),
                    elements=elements, element_directions=directions, damping=zeta, bodies=tuple(bodies),
                    geometric_stiffening=stiff)
    except ValueError as exc:
        # Only the bodies' rules that involve the link (at <= l, on the axis of a bending link)
        # reach here; every other check above mirrors Link's.
        k = str(exc).partition("bodies[")[2].partition("]")[0]
        r.add(join(join(path, "bodies"), int(k)) if k.isdigit() else path, str(exc))
        return _BAD
    return link if _mode_frequencies_ok(r, link, path) else _BAD


def _bending_stiffness(r: _Reader, tbl: dict, path: str):
    """EI_N_m2: a number (EI_y = EI_z) or [EI_y, EI_z] [N m^2]; _BAD on a problem."""
    p = join(path, "EI_N_m2")
    if "EI_N_m2" not in tbl:
        r.add(p, f"missing ({_LINK_KEYS['EI_N_m2']})")
        return _BAD
    if isinstance(tbl["EI_N_m2"], list):
        ei = r.value(tbl["EI_N_m2"], p, "vector2")
        return tuple(ei) if ei is not _BAD else _BAD
    return r.value(tbl["EI_N_m2"], p, "number")


def _rotary_inertia(r: _Reader, tbl: dict, path: str, mu):
    """[j_x, j_y, j_z] [kg m] from rotary_inertia_kg_m, or from cross_section_radius_m r of a solid
    round section, j = mu r^2 (1/2, 1/4, 1/4); None when neither is given, _BAD on a problem."""
    j = r.get(tbl, path, "rotary_inertia_kg_m", "vector3", default=None)
    radius = r.get(tbl, path, "cross_section_radius_m", "number", default=None)
    if j is not None and radius is not None:
        r.add(join(path, "cross_section_radius_m"), "give either rotary_inertia_kg_m or cross_section_radius_m, "
                                                    "not both")
        return _BAD
    if radius is _BAD or radius is None:
        return j if radius is None else _BAD
    return _BAD if mu is _BAD else [mu * radius**2 / 2.0, mu * radius**2 / 4.0, mu * radius**2 / 4.0]


def _sub_tables(r: _Reader, tbl: dict, path: str, allowed: dict):
    """The entries of the array of tables at ``path`` (links[i].modes, links[i].bodies) as a list of
    (their key path, the table or None when it is no table; its unknown keys reported), _BAD when the
    key holds no array."""
    key = path.rpartition(".")[2]
    raw = tbl.get(key, [])
    if not isinstance(raw, list):
        r.add(path, f"expected [[links.{key}]] tables, got {type_name(raw)}")
        return _BAD
    return [(join(path, k), r.table(t, join(path, k), allowed, f"a [[links.{key}]] table")) for k, t in enumerate(raw)]


def _bodies(r: _Reader, tbl: dict, path: str):
    """The [[links.bodies]] of a link (path links[i].bodies) as a list of RigidBody, _BAD on a problem.

    inertia_kg_m2 are the diagonal (J_xx, J_yy, J_zz) and inertia_products_kg_m2 (J_xy, J_xz, J_yz)
    the off-diagonal entries of J about the body's centre in link axes [kg m^2].
    """
    entries = _sub_tables(r, tbl, path, _BODY_KEYS)
    if entries is _BAD:
        return _BAD
    bodies = []
    for pb, bt in entries:
        if bt is None:
            bodies = _BAD
            continue
        m = r.get(bt, pb, "mass_kg", "number", required=True, what=_BODY_KEYS["mass_kg"])
        c = r.get(bt, pb, "center_m", "vector3", default=[0.0, 0.0, 0.0])
        d = r.get(bt, pb, "inertia_kg_m2", "vector3", default=[0.0, 0.0, 0.0])
        o = r.get(bt, pb, "inertia_products_kg_m2", "vector3", default=[0.0, 0.0, 0.0])
        at = r.get(bt, pb, "at_m", "number", default=None)
        if _BAD in (m, c, d, o, at) or bodies is _BAD:
            bodies = _BAD
            continue
        J = [[d[0], o[0], o[1]], [o[0], d[1], o[2]], [o[1], o[2], d[2]]]
        try:
            bodies.append(RigidBody(m, center=tuple(c), inertia=J, at=at))
        except ValueError as exc:  # the triangle inequality of the inertia: the one rule not a range
            r.add(join(pb, "inertia_kg_m2"), str(exc))
            bodies = _BAD
    return bodies


def _modes(r: _Reader, tbl: dict, path: str):
    """The [[links.modes]] of a link (path links[i].modes) as a list of Mode, _BAD on a problem."""
    entries = _sub_tables(r, tbl, path, _MODE_KEYS)
    if entries is _BAD:
        return _BAD
    modes = []
    for k, (pm, mt) in enumerate(entries):
        if mt is None:
            modes = _BAD
            continue
        kind = r.get(mt, pm, "kind", "str", required=True, what=_MODE_KEYS["kind"])
        direction = r.get(mt, pm, "direction", "str", default="y")
        number = r.get(mt, pm, "number", "number", default=1)
        if kind is not _BAD and kind not in MODE_KINDS:
            r.add(join(pm, "kind"), f"unknown kind {kind!r}; use one of {', '.join(MODE_KINDS)}")
            kind = _BAD
        if direction is not _BAD and direction not in MODE_DIRECTIONS:
            r.add(join(pm, "direction"), f"unknown direction {direction!r}; use 'y' or 'z'")
            direction = _BAD
        if _BAD in (kind, direction, number) or modes is _BAD:
            modes = _BAD
            continue
        mode = Mode(kind, direction, number)
        if mode in modes:
            r.add(pm, f"repeats mode {k}: the same mode twice makes the mass matrix singular")
            modes = _BAD
            continue
        modes.append(mode)
    return modes


def _discretisation(r: _Reader, tbl: dict, path: str, modes):
    """(elements, element_directions, damping ratio) of a [[links]] table; _BAD entries on a problem."""
    elements = r.get(tbl, path, "elements", "number", default=0)
    if "elements" in tbl and "modes" in tbl:
        r.add(join(path, "elements"), "give either modes (assumed modes) or elements (finite elements), not both")
        elements = _BAD
    directions = ("y",)
    p_dirs = join(path, "element_directions")
    if "element_directions" in tbl:
        raw = tbl["element_directions"]
        if not isinstance(raw, list) or not raw or not all(isinstance(d, str) for d in raw):
            r.add(p_dirs, f"expected an array of directions, ['y'] or ['y', 'z'], got {type_name(raw)}")
            directions = _BAD
        elif any(d not in MODE_DIRECTIONS for d in raw) or len(set(raw)) != len(raw):
            r.add(p_dirs, f"must be ['y'], ['z'] or ['y', 'z'] ('y': in-plane bending v, 'z': out-of-plane w), "
                          f"got {raw!r}")
            directions = _BAD
        else:
            directions = tuple(raw)
        if elements == 0:
            r.add(p_dirs, "applies to finite elements only: set elements (at least 1) or remove element_directions")
            directions = _BAD
    zeta = r.get(tbl, path, "damping_ratio", "number", default=0.0)
    if zeta not in (_BAD, 0.0) and elements == 0 and not (modes is _BAD or modes):
        r.add(join(path, "damping_ratio"), "needs elastic coordinates: give the link modes or elements")
        zeta = _BAD
    return elements, directions, zeta


def _mode_frequencies_ok(r: _Reader, link: Link, path: str) -> bool:
    """Every assumed mode's natural frequency at most MAX_MODE_FREQUENCY, else a problem at EI_N_m2.

    omega = (beta l)^2 sqrt(EI / (mu l^4)); a y-mode bends against EI_z, a z-mode against EI_y.
    """
    for k, md in enumerate(link.modes, start=1):
        ei_mode = link.EI_z if md.direction == "y" else link.EI_y
        omega = natural_frequency(md, link.length, link.mass_per_length, ei_mode)
        if omega > MAX_MODE_FREQUENCY:
            r.add(join(path, "EI_N_m2"),
                  f"makes modes[{k}] ({md.kind} number {md.number} in {md.direction}) vibrate at omega = "
                  f"{fmt(omega)} rad/s with length_m = {fmt(link.length)} and mass_per_length_kg_per_m = "
                  f"{fmt(link.mass_per_length)}; above {fmt(MAX_MODE_FREQUENCY)} rad/s (periods of picoseconds) a "
                  f"beam model has no meaning: lower EI_N_m2 or the mode number, or drop the mode")
            return False
    return True


def _element_frequencies_ok(r: _Reader, model: Model) -> bool:
    """Every finite-element link's highest eigenfrequency at most MAX_MODE_FREQUENCY (the modes' limit).

    omega_max = sqrt of the largest generalised eigenvalue of the link's (K, M_dd) (clamped at its frame).
    A link behind a Pb guide bends over its protruding length d only (stretching elements):
    omega scales as (l / d)^2, largest at d_min.
    """
    ok = True
    for i, (link, ld, jt) in enumerate(zip(model.chain.links, model.link_data, model.chain.joints)):
        if not link.elements:
            continue
        omega = math.sqrt(max(float(sl.eigh(ld.K, ld.M_dd, eigvals_only=True)[-1]), 0.0))
        at = ""
        if jt.spec.guide:
            omega *= (link.length / jt.range[0]) ** 2
            at = (f" at the shortest protruding length d_min = {fmt(jt.range[0])} m "
                  f"({key_path('links', i, 'joint', 'range_m')})")
        if not omega <= MAX_MODE_FREQUENCY:
            r.add(key_path("links", i, "EI_N_m2"),
                  f"makes the highest mode of elements = {link.elements} vibrate at omega = {fmt(omega)} rad/s with "
                  f"length_m = {fmt(link.length)} and mass_per_length_kg_per_m = {fmt(link.mass_per_length)}{at}; "
                  f"above {fmt(MAX_MODE_FREQUENCY)} rad/s (periods of picoseconds) a beam model has no meaning: "
                  f"lower EI_N_m2 or elements")
            ok = False
    return ok


# -- the base -------------------------------------------------------------------------------

def _base(r: _Reader, tbl):
    """'free', 'planar' or a FixedBase from the [base] table; _BAD on a problem."""
    tbl = r.table(tbl, "base", _BASE_KEYS, "a [base] table")
    if tbl is None:
        return _BAD
    kind = r.get(tbl, "base", "type", "str", required=True, what="'fixed', 'free' or 'planar'")
    if kind is _BAD:
        return _BAD
    if kind not in ("fixed", "free", "planar"):
        r.add("base.type",
              f"unknown base type {kind!r}; use 'fixed' (joint 1 at a fixed point), 'free' (free-flying in "
              "space) or 'planar' (free-flying in the X1-X2 plane)")
        return _BAD
    if kind in ("free", "planar"):
        extra = [k for k in ("position_m", "angle_deg", "angle_rad") if k in tbl]
        for k in extra:
            r.add(join("base", k),
                  f"a {'planar ' if kind == 'planar' else ''}free-flying base has no fixed position or angle: "
                  "remove it or set type = 'fixed'")
        return _BAD if extra else kind
    position = [0.0, 0.0, 0.0]
    if "position_m" in tbl:
        raw = tbl["position_m"]
        if isinstance(raw, list) and len(raw) in (2, 3):
            position = r.value(raw, "base.position_m", f"vector{len(raw)}")
        else:
            r.add("base.position_m", f"expected an array of 2 or 3 numbers (b1, b2[, b3]) in m, got {type_name(raw)}")
            position = _BAD
    angle = _angle(r, tbl, "base", "base")
    if _BAD in (position, angle):
        return _BAD
    return FixedBase(position=tuple(position), angle=angle)


def _angle(r: _Reader, tbl: dict, path: str, what: str):
    """A fixed angle [rad] given as angle_deg or angle_rad (0 without either); _BAD on a problem."""
    if "angle_deg" in tbl and "angle_rad" in tbl:
        r.add(join(path, "angle_rad"), f"sets the {what} angle again (already set by angle_deg); give one of them")
        return _BAD
    if "angle_deg" in tbl:
        angle = r.get(tbl, path, "angle_deg", "number")
        return math.radians(angle) if angle is not _BAD else _BAD
    if "angle_rad" in tbl:
        return r.get(tbl, path, "angle_rad", "number")
    return 0.0


# -- one joint ------------------------------------------------------------------------------

def _joint(r: _Reader, link_tbl, path: str):
    """The joint of one [[links]] table (its [links.joint]; Revolute() without one), _BAD on a problem.

    path is the link's key path (links[i]); the joint's keys are links[i].joint.<key>.
    """
    if not isinstance(link_tbl, dict):
        return _BAD  # _link reports it
    if "joint" not in link_tbl:
        return Revolute()
    path = join(path, "joint")
    tbl = r.table(link_tbl["joint"], path, _JOINT_KEYS, "a [links.joint] table")
    if tbl is None:
        return _BAD
    kind = r.get(tbl, path, "type", "str", required=True, what=_JOINT_KEYS["type"])
    if kind is _BAD:
        return _BAD
    if kind not in _JOINT_TYPES:
        close = [k for k in _JOINT_TYPES if k.lower() == kind.lower()]
        hint = f"did you mean {close[0]!r}? " if close else ""
        r.add(join(path, "type"), f"unknown joint type {kind!r}; {hint}use "
                                  + ", ".join(f"{k!r} ({what})" for k, what in _JOINT_TYPES.items()))
        return _BAD
    spec = JOINT_KINDS[kind]
    ok = _keys_of_joint_type(r, tbl, path, spec)
    rot = None if spec.prismatic else _joint_rotation(r, tbl, path)
    angle = None if spec.turns else _angle(r, tbl, path, "joint")
    half = r.get(tbl, path, "half_length_m", "number", default=0.0) if spec.carriage else None
    rng = _joint_range(r, tbl, path, spec) if spec.prismatic else None
    if not ok or any(v is _BAD for v in (rot, angle, half, rng)):
        return _BAD
    if spec.turns:
        return Revolute(axis_rotation=rot)
    if not spec.has_coordinate:
        return Weld(angle=angle, rotation=rot)
    if spec.carriage:
        return SlidingPrismatic(angle=angle, half_length=half, range=tuple(rng))
    return FixedPrismatic(angle=angle, range=tuple(rng))


def _joint_rotation(r: _Reader, tbl: dict, path: str):
    """R = Rx(a) Ry(b) Rz(c) (3, 3) from rotation_xyz_deg = [a, b, c] [deg] (None without the key; _BAD on a
    problem): the constant rotation of a revolute's axis (gi.Revolute(axis_rotation=R)) or of a weld."""
    abc = r.get(tbl, path, "rotation_xyz_deg", "vector3", default=None)
    if abc is None or abc is _BAD:
        return abc
    a, b, c = np.radians(np.asarray(abc, dtype=float))
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return rx @ ry @ rz


def _tree(r: _Reader, raw_links):
    """(parents, attach) of a tree from the joints' parent and at_m keys (formulation §17): parent
    is 1-based (0: the base; default the link before), at_m the abscissa on the host (default its
    tip); (None, None) when no joint has either; _BAD on a problem."""
    tables = [lt.get("joint") if isinstance(lt, dict) and isinstance(lt.get("joint"), dict) else {} for lt in raw_links]
    if not any("parent" in t or "at_m" in t for t in tables):
        return None, None
    parents, attach, ok = [], [], True
    for k, t in enumerate(tables):
        path = key_path("links", k, "joint")
        p = r.get(t, path, "parent", "number") if "parent" in t else k
        if p is not _BAD and not 0 <= p <= k:
            r.add(join(path, "parent"), f"must be 0 (the base) or the number of an earlier link (1 .. {k}): list "
                                        "the links parent first")
            p = _BAD
        a = r.get(t, path, "at_m", "number") if "at_m" in t else None
        ok = ok and _BAD not in (p, a)
        parents.append(p - 1 if p is not _BAD else p)
        attach.append(a)
    return (tuple(parents), tuple(attach)) if ok else _BAD


def _keys_of_joint_type(r: _Reader, tbl: dict, path: str, spec) -> bool:
    """False (and a problem per key) when the joint table has keys its type has not."""
    ok = True
    allowed = {"R": ("rotation_xyz_deg",), "Pa": ("angle_deg", "angle_rad", "half_length_m", "range_m"),
               "Pb": ("angle_deg", "angle_rad", "range_m"), "W": ("angle_deg", "angle_rad", "rotation_xyz_deg")}[spec.code]
    for key in tbl:
        if key in ("type", "parent", "at_m") or key in allowed or key not in _JOINT_KEYS:
            continue
        ok = False
        if not spec.prismatic:
            name = "a revolute joint (type = 'R')" if spec.turns else "a weld (type = 'W')"
            r.add(join(path, key), f"{name} has no {_JOINT_KEYS[key].split(' of ')[0]}: "
                                   "remove it, or set type = 'Pa' or 'Pb' for a prismatic joint")
        elif key == "rotation_xyz_deg":
            r.add(join(path, key), "a prismatic joint has no constant rotation (only R and W joints, in trees): "
                                   "remove it, or give the angle by angle_deg")
        else:
            r.add(join(path, key), "only a Pa carriage has a half-length (a Pb guide sits at the host's tip): "
                                   "remove it or set type = 'Pa'")
    return ok


def _joint_range(r: _Reader, tbl: dict, path: str, spec):
    """[d_min, d_max] [m] of a prismatic joint: d_min < d_max, and d_min > 0 for Pb; _BAD on a problem."""
    rng = r.get(tbl, path, "range_m", "vector2", required=True,
                what=f"[d_min, d_max] in m, the travel of the joint's coordinate ({_JOINT_KEYS['range_m']})")
    if rng is _BAD:
        return _BAD
    if not rng[0] < rng[1]:
        r.add(join(path, "range_m"), f"must be [d_min, d_max] with d_min < d_max, got [{fmt(rng[0])}, {fmt(rng[1])}]")
        return _BAD
    if spec.guide and not rng[0] > 0:
        r.add(join(path, "range_m"), f"d_min = {fmt(rng[0])} m must be > 0: a Pb joint's d is the length "
                                     "protruding from the guide, and the link's stiffness grows like 1/d^3 as d -> 0")
        return _BAD
    return rng


# -- rules of the whole chain ---------------------------------------------------------------

def _chain_ok(r: _Reader, links, joints, base) -> bool:
    """The rules of a chain with prismatic joints or a planar base (docs/theory.md §8, §7.3, §7.4, §9, §13),
    each reported at the key to change."""
    kinds = [j.spec for j in joints]
    prismatic = [k for k, kd in enumerate(kinds) if kd.prismatic]
    ok = True
    if base == "planar" and not kinds[0].turns:
        r.add("links[1].joint.type", "on a planar free-flying base ([base] type = 'planar') joint 1 must be 'R': "
                                     "theta_1 is the chain's orientation; set [base] type = 'fixed' for a "
                                     "prismatic joint 1")
        ok = False
    if not prismatic and base != "planar":
        return ok
    if base == "free":
        for k in prismatic:
            r.add(key_path("links", k, "joint", "type"),
                  f"a prismatic joint ({kinds[k].code!r}) needs a planar chain, and a chain without [base] (or with "
                  "type = 'free') flies in space: add [base] with type = 'fixed' (or 'planar' for a floating chain)")
        return False
    ok = _bends_in_plane(r, links) and ok
    for k in prismatic:
        rule = _pb_rules if kinds[k].guide else _pa_rules
        ok = rule(r, links, joints, k) and ok
    return ok


def _bends_in_plane(r: _Reader, links) -> bool:
    """A planar chain (prismatic joints or a planar base) bends in the plane only: y directions only."""
    ok = True
    for k, lk in enumerate(links):
        if lk.elements and lk.element_directions != ("y",):
            r.add(key_path("links", k, "element_directions"),
                  "a planar chain (prismatic joints or [base] type = 'planar') bends in the plane only: "
                  "set element_directions = ['y']")
            ok = False
        if any(md.direction != "y" for md in lk.modes):
            r.add(key_path("links", k, "modes"), "a planar chain (prismatic joints or [base] type = 'planar') "
                                                 "bends in the plane only: give modes in direction 'y' only")
            ok = False
    return ok


def _pb_rules(r: _Reader, links, joints, k: int) -> bool:
    """Link k (0-based) behind a Pb guide: stretching elements (no modes), no attached bodies, d_max at most
    its length."""
    ok, i, lk, hi = True, k + 1, links[k], joints[k].range[1]
    p = key_path("links", k, "joint")
    if lk.modes:
        r.add(key_path("links", k, "modes"), f"link {i} slides through a Pb guide ({p}): it is discretised by "
                                             "stretching finite elements; give it elements instead of modes (or "
                                             "neither: rigid)")
        ok = False
    if lk.stiffened:
        r.add(key_path("links", k, "geometric_stiffening"),
              f"link {i} slides through a Pb guide ({p}): the foreshortening of material flowing through a guide "
              "is not modelled; set geometric_stiffening = false (the linear beam)")
    if lk.bodies:
        r.add(key_path("links", k, "bodies"), f"link {i} slides through a Pb guide ({p}): its material moves along "
                                              "it with d, which attached bodies do not follow; attach them to a "
                                              "link on an 'R' or 'Pa' joint")
        ok = False
    if hi > lk.length + 1e-12:
        r.add(join(p, "range_m"), f"d_max = {fmt(hi)} m is more than {key_path('links', k, 'length_m')} = "
                                  f"{fmt(lk.length)}: d_{i} is the length protruding from the guide, at "
                                  "most the link's length")
        ok = False
    return ok


def _pa_rules(r: _Reader, links, joints, k: int) -> bool:
    """A Pa carriage of joint k + 1 on its host link k - 1: an element or rigid host, c > 0 on elements,
    the carriage on the host over its whole range. Joint 1 runs on the base's straight rail: any range."""
    if k == 0:
        return True
    ok, jt, host, h = True, joints[k], links[k - 1], k
    p, c, (lo, hi) = key_path("links", k, "joint"), jt.half_length, jt.range
    if host.modes:
        r.add(join(p, "type"), f"a Pa carriage rides on link {h}, which has assumed modes: give links[{h}] "
                               "elements instead of modes, or neither (rigid)")
        ok = False
    if host.elements and c <= 0:
        r.add(join(p, "half_length_m"),
              f"must be > 0 on a finite-element host (links[{h}].elements = {host.elements}), got {fmt(c)}: a "
              "point carriage follows the host's slope, whose derivative jumps at every element node, so the "
              f"mass matrix would jump there (docs/theory.md §7.3); e.g. half_length_m = "
              f"{fmt(float(f'{host.length / host.elements / 10:.1g}'))}")
        ok = False
    if lo < c - 1e-12 or hi > host.length - c + 1e-12:
        r.add(join(p, "range_m"), f"the carriage must stay on link {h}: half_length_m <= d_min < d_max <= "
                                  f"links[{h}].length_m - half_length_m = {fmt(host.length - c)} m, got "
                                  f"[{fmt(lo)}, {fmt(hi)}] with half_length_m = {fmt(c)}")
        ok = False
    return ok
