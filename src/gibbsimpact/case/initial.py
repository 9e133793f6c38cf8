"""The initial state of a case file: ``[initial]`` read into (q0, qdot0), and its checks at t = 0.

Keys of ``[initial.coordinates]`` / ``[initial.velocities]`` are ``<coordinate>_<unit>``. The
unit of X_k, d_i (lengths) and theta_i (angles) is fixed by the name; that of an elastic
coordinate delta_i_k follows link i's discretisation (Model.coordinate_units: a finite-element
node slope is an angle, every other delta a length). When the chain could not be built (a
problem reported at the link, joint or base key), a coordinate is not judged against the model
that does not exist: only its spelling, its value and whether it is set twice are checked, so that
no problem blames a correct key for a wrong one elsewhere (docs/case-format.md).
"""

from __future__ import annotations

import inspect
import math
import re

import numpy as np

from ..dynamics.gibbs_appell import SingularMassMatrixError, forward_dynamics
from ..dynamics.inputs import is_angle_coordinate
from ..model.model import FixedBase
from ..contact.walls import describe
from ..simulation.charts import charted, start_chart
from ..simulation.joint_limits import joint_limits, limit_gaps
from ..simulation.outside import outside_walls, point_name
from ..simulation.simulate import simulate
from .keypaths import join, key_path
from .reader import _BAD, _Reader
from .schema import _COORD, _FREE_BASE_COORDINATES, _INITIAL_KEYS, _RATE, _SPATIAL_COORDINATES, RANGES
from .text import fmt, type_name

__all__ = ["read_initial", "check_start"]

#: Units of the keys of [initial.coordinates] and [initial.velocities] by the kind of coordinate.
_STATE_UNITS = {
    "initial.coordinates": {"length": ("m",), "angle": ("rad", "deg")},
    "initial.velocities": {"length": ("m_per_s",), "angle": ("rad_per_s", "deg_per_s")},
}
_STATE_PATTERNS = {"initial.coordinates": _COORD, "initial.velocities": _RATE}
#: simulate's own defaults of the [solver] keys the start checks use (a case that leaves them out).
_DEFAULTS = {k: p.default for k, p in inspect.signature(simulate).parameters.items()}


def read_initial(r: _Reader, top: dict, model, base) -> tuple:
    """(q0, qdot0), each (N,) [m, rad] and [m/s, rad/s], of the case table's [initial]; (None, None)
    without a model (the chain has problems) or on a problem of [initial]."""
    it = r.table(top.get("initial", {}), "initial", _INITIAL_KEYS, "an [initial] table")
    if it is None:
        return None, None
    cq = _state_table(r, it.get("coordinates", {}), "initial.coordinates", model)
    cv = _state_table(r, it.get("velocities", {}), "initial.velocities", model)
    com, comv = _center_of_mass_keys(r, it, base, model, cq, cv)
    if model is None or _BAD in (cq, cv, com, comv):
        return None, None
    q0, qdot0 = np.zeros(model.n_dof), np.zeros(model.n_dof)
    for i, v in cq.items():
        q0[i] = v
    for i, v in cv.items():
        qdot0[i] = v
    coords = it.get("coordinates", {})
    if not _joint_ranges_ok(r, model, q0, coords if isinstance(coords, dict) else {}):
        return None, None  # the kinematics need d inside its range (a Pb link: d > 0)
    _place_center_of_mass(model, q0, qdot0, com, comv)
    return q0, qdot0


def _kind(name: str, model) -> str | None:
    """'length' or 'angle', the kind of coordinate ``name`` (as its input, dynamics.inputs.is_angle_coordinate);
    None for an elastic coordinate delta_i_k without a model: its link may be the one that could not be built."""
    if model is not None and name in model.coordinate_names:
        return "angle" if is_angle_coordinate(model, model.coordinate_names.index(name)) else "length"
    if name.startswith("delta"):
        return None
    return "angle" if name.startswith("theta") else "length"


def _state_table(r: _Reader, tbl, path: str, model):
    """{coordinate index: value in SI} of [initial.coordinates] or [initial.velocities] (``path``);
    {} without a model (only the keys and values are checked), _BAD on a problem."""
    if not isinstance(tbl, dict):
        r.add(path, f"expected a table, got {type_name(tbl)}")
        return _BAD
    units, names = _STATE_UNITS[path], model.coordinate_names if model is not None else None
    out, seen, ok = {}, {}, True
    for key, v in tbl.items():
        p = join(path, key)
        m = _STATE_PATTERNS[path].match(key)
        name, unit = (m.group(1).replace("theta_m1", "theta_-1"), m.group(2)) if m else (None, None)
        problem = _key_problem(key, units, model) if m is None else _unit_problem(name, unit, units, model)
        if problem is None:
            val = r.value(v, p, "number", RANGES[f"{path}.*_{unit}"])
            if val is _BAD:
                ok = False
                continue
            problem = f"sets {name} again (already set by {seen[name]})" if name in seen else None
        if problem is not None:
            r.add(p, problem)
            ok = False
            continue
        seen[name] = key
        if names is not None:
            out[names.index(name)] = math.radians(val) if unit.startswith("deg") else val
    return out if ok else _BAD


def _key_problem(key: str, units: dict, model) -> str:
    """The message for a key that is no <coordinate>_<unit> of the table with ``units``."""
    names = model.coordinate_names if model is not None else None
    bare = re.sub(r"_(m|rad|deg|m_per_s|rad_per_s|deg_per_s)$", "", key)
    for stem in (key, bare):
        name = stem.replace("theta_m1", "theta_-1")
        if names is not None and name in names:
            use = " or ".join(f"{stem}_{u}" for u in units[_kind(name, model)])
            return f"add the unit to the key: {use}" if stem == key else \
                f"unit {key[len(bare) + 1:]} is not allowed here; use {use}"
    known = f"; this model has {', '.join(names)}" if names is not None else ""
    return (f"unknown coordinate (keys are <coordinate>_<unit>, e.g. X1_{units['length'][0]}, "
            f"theta_1_{units['angle'][-1]}){known}")


def _unit_problem(name: str, unit: str, units: dict, model) -> str | None:
    """The message for a coordinate the model does not have or a unit its kind does not take, else None."""
    if model is not None and name not in model.coordinate_names:
        return unknown_coordinate(name, model.coordinate_names)
    kind = _kind(name, model)
    if kind is not None and unit not in units[kind]:
        return f"{name} takes unit {' or '.join(units[kind])}, not {unit}"
    return None


def unknown_coordinate(name: str, names) -> str:
    """The message for a coordinate name the model (coordinate names ``names``) does not have."""
    hint = ""
    joint = re.fullmatch(r"(theta|d)_([1-9][0-9]*)", name)
    if name in _FREE_BASE_COORDINATES and "X1" not in names:
        hint = f" (a fixed base has no {', '.join(_FREE_BASE_COORDINATES)}: [base] type = 'fixed')"
    elif name in _SPATIAL_COORDINATES and "X1" in names and "X3" not in names:
        hint = (f" (a planar base has no {', '.join(_SPATIAL_COORDINATES)}: [base] type = 'planar' moves in "
                "the X1-X2 plane with X1, X2 and theta_1)")
    elif joint and f"{'d' if joint[1] == 'theta' else 'theta'}_{joint[2]}" in names:
        other = f"{'d' if joint[1] == 'theta' else 'theta'}_{joint[2]}"
        what = "prismatic: its coordinate is d_{0} in m" if other[0] == "d" else "revolute: its coordinate is theta_{0}"
        hint = f" (joint {joint[2]} is {what.format(joint[2])}, set by links[{joint[2]}].joint.type)"
    return f"unknown coordinate {name}{hint}; this model has {', '.join(names)}"


def _center_of_mass_keys(r: _Reader, it: dict, base, model, cq, cv) -> tuple:
    """(center_of_mass_m, center_of_mass_velocity_m_per_s) of [initial]: None when absent, _BAD on a
    problem: on a fixed base, or with X coordinates (or their rates) also set by name."""
    com = _com_vector(r, it, "center_of_mass_m", base)
    comv = _com_vector(r, it, "center_of_mass_velocity_m_per_s", base)
    if isinstance(base, FixedBase):
        # Both set the base coordinates X of a free-flying chain.
        for key, v in (("center_of_mass_m", com), ("center_of_mass_velocity_m_per_s", comv)):
            if v is not None:
                r.add(join("initial", key), "needs a free-flying base (it sets X1, X2, X3); a fixed base "
                                            "([base] type = 'fixed') has none: place the chain with "
                                            "base.position_m and the joint angles instead")
        return (_BAD if com is not None else None), (_BAD if comv is not None else None)
    nx = 2 if base == "planar" else 3  # X1, X2 (, X3) lead q on a free-flying base
    xs = ("X1", "X2", "X3")[:nx]
    if com not in (None, _BAD) and cq is not _BAD and model is not None and any(i < nx for i in cq):
        r.add("initial.center_of_mass_m",
              f"sets {', '.join(xs)}; remove {'/'.join(x + '_m' for x in xs)} from [initial.coordinates]")
        com = _BAD
    if comv not in (None, _BAD) and cv is not _BAD and model is not None and any(i < nx for i in cv):
        r.add("initial.center_of_mass_velocity_m_per_s",
              f"sets the rates of {', '.join(xs)}; remove {'/'.join(x + '_m_per_s' for x in xs)} from "
              "[initial.velocities]")
        comv = _BAD
    return com, comv


def _com_vector(r: _Reader, it: dict, key: str, base):
    """[initial] center_of_mass_m / center_of_mass_velocity_m_per_s: 3 numbers, or on a planar base 2
    (or 3 with the third 0), either while [base] has a problem; None when absent, _BAD on a problem."""
    raw = it.get(key)
    if base in ("planar", _BAD) and isinstance(raw, list) and len(raw) == 2:
        return r.get(it, "initial", key, "vector2")
    v = r.get(it, "initial", key, "vector3", default=None)
    if base == "planar" and v not in (None, _BAD) and v[2] != 0.0:
        r.add(join("initial", key), f"a planar base ([base] type = 'planar') moves in the X1-X2 plane: the third "
                                    f"component must be 0, got {fmt(v[2])}; or give two numbers")
        return _BAD
    return v


def _place_center_of_mass(model, q0, qdot0, com, comv) -> None:
    """Set the base coordinates X of q0 (and their rates in qdot0) in place so that the undeformed
    chain's mass centre is at ``com`` [m] and moves with ``comv`` [m/s] (each None: as given)."""
    nx = 2 if model.chain.base == "planar" else 3
    if com is not None:
        # c(q) = X + c(q with X = 0) because Trans(X) comes first; the undeformed chain: delta = 0.
        q_und = q0.copy()
        q_und[:nx] = 0.0
        for idx in model.delta_index:
            q_und[idx] = 0.0
        q0[:nx] = np.asarray(com)[:nx] - model.center_of_mass(q_und)[:nx]
    if comv is not None:
        # Linear momentum is m Xdot + (terms without Xdot).
        qd = qdot0.copy()
        qd[:nx] = 0.0
        qdot0[:nx] = np.asarray(comv)[:nx] - model.linear_momentum(q0, qd)[:nx] / model.total_mass


def _joint_ranges_ok(r: _Reader, model, q0, coordinates: dict) -> bool:
    """Every prismatic joint's initial d inside its range (gibbsimpact.limits), reported at its key."""
    ok = True
    names = model.coordinate_names
    for lim, g in zip(joint_limits(model), limit_gaps(joint_limits(model), q0)):
        if g >= 0:
            continue
        ok = False
        own = names[model.theta_index[lim.joint - 1]]
        touched = [own] + [names[k] for k in np.nonzero(lim.n)[0] if names[k] != own]  # the joint's own d first
        keys = sorted((key for key in coordinates if re.sub(r"_m$", "", key) in touched),
                      key=lambda key: touched.index(re.sub(r"_m$", "", key)))
        values = ", ".join(f"{n} = {fmt(float(q0[names.index(n)]))} m" for n in touched)
        unset = [n for n in touched if not any(re.sub(r"_m$", "", key) == n for key in keys)]
        fix = (f"set {' and '.join(f'initial.coordinates.{n}_m' for n in unset)} (0 when not given)" if unset
               else "change the initial value")
        r.add(join("initial.coordinates", keys[0]) if keys else "initial.coordinates",
              f"{values} is outside the range of joint {lim.joint}: {lim.name} "
              f"({key_path('links', lim.joint - 1, 'joint', 'range_m')}); {fix}")
    return ok


def check_start(r: _Reader, model, q0, qdot0, walls, solver: dict, prescribed=()) -> None:
    """Problems of the assembled initial state (q0, qdot0) (N,): a contact point beyond a wall by
    more than contact_tol (a joint, or with link contacts a link bent between its joints;
    simulation.outside), a singular mass matrix, a state that overflows floating point.

    The dynamics are evaluated in the chart the run starts in (simulation.charts.start_chart): a free
    base at theta_0 = +-pi/2 is re-charted there, not refused (prescribed: the names of the
    [[prescribed]] coordinates; a prescribed base angle keeps the given chart)."""
    tol = solver.get("contact_tol", _DEFAULTS["contact_tol"])
    for o in outside_walls(model, q0, walls, tol, solver.get("link_contacts", _DEFAULTS["link_contacts"])):
        r.add("initial", _outside_message(model, o, walls))
    fixed = [model.coordinate_names.index(name) for name in prescribed] or None
    model, q0, qdot0 = start_chart(model, q0, qdot0, charted(model, fixed))
    try:
        qddot0 = forward_dynamics(model, q0, qdot0)
    except SingularMassMatrixError as exc:
        r.add("links", f"the initial state has a singular mass matrix: {exc}")
        return
    if not (np.all(np.isfinite(q0)) and np.all(np.isfinite(qdot0)) and np.all(np.isfinite(qddot0))):
        r.add("initial", "the initial state overflows floating point; bring the links' parameters and "
                         "the initial values closer to 1 in SI units")


def _outside_message(model, o, walls) -> str:
    """The problem of one contact point beyond a wall at t = 0 (simulation.outside.Outside)."""
    pos = ", ".join(f"{c:.6g}" for c in o.point)
    wall = f"{key_path('walls', o.wall)} ({describe(walls[o.wall])})"
    fix = "out of the obstacle" if walls[o.wall].obstacle else "inside"
    if o.link is None:
        return f"{point_name(model, o)} at ({pos}) m is outside {wall} by {o.depth:.6g} m at t = 0; move the chain {fix}"
    i = o.link + 1
    if walls[o.wall].obstacle:   # a link, bent or straight, through an obstacle
        return (f"{point_name(model, o)}, the point ({pos}) m, is beyond {wall} by {o.depth:.6g} m at t = 0: link {i} "
                f"passes through it between its joints; move the chain {fix}")
    return (f"{point_name(model, o)}, the point ({pos}) m, is beyond {wall} by {o.depth:.6g} m at t = 0: link {i} "
            f"is bent across the wall between its joints; move the chain inside or straighten the link (its "
            f"initial.coordinates.delta_{i}_*)")
