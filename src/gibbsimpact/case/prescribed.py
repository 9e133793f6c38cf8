"""[[prescribed]] tables of a case file: a joint coordinate that follows a built-in motion profile.

    [[prescribed]]
    coordinate = "theta_1"
    profile = "spin_up"          # spin_up, constant_speed, point_to_point, samples
    Omega_rad_per_s = 6.0
    T_s = 15.0

Each table becomes one gibbsimpact.profiles Profile (the same objects simulate takes from Python;
keys: gibbsimpact.case.schema._PRESCRIBED_KEYS, in rad on an angle and m on a length). The
coordinate's initial value and rate are its profile's at t_start: [initial] may leave it out, and a
value it gives that differs from the profile's is a problem of that key.
"""

from __future__ import annotations

import math

from ..contact.walls import is_compliant
from ..dynamics.inputs import is_angle_coordinate
from ..dynamics.profiles import profile
from .keypaths import join
from .reader import _BAD, _build_each, _Reader
from .schema import _PRESCRIBED_KEYS, _PRESCRIBED_TABLE_KEYS, _prescribed_keys, range_of
from .text import fmt, type_name

__all__ = ["check_no_compliant_walls", "read_prescribed", "start_on_profiles"]


def read_prescribed(r: _Reader, top: dict, model) -> dict:
    """{coordinate name: Profile} of the [[prescribed]] tables ({} on a problem: the case is refused anyway)."""
    raw = top.get("prescribed", [])
    if not isinstance(raw, list):
        r.add("prescribed", f"expected [[prescribed]] tables, got {type_name(raw)}")
        return {}
    built = _build_each(raw, lambda k, t: _prescribed(r, t, join("prescribed", k), model))
    if built is _BAD:
        return {}
    out = {}
    for k, (name, prof) in enumerate(built):
        if name in out:
            r.add(join(join("prescribed", k), "coordinate"), f"{name} is prescribed twice; keep one table")
        out[name] = prof
    return out


def check_no_compliant_walls(r: _Reader, prescribed: dict, walls):
    """A problem at walls[k].stiffness for each compliant wall of a case with [[prescribed]] tables: simulate refuses
    the pair (not modelled yet), so the loader says so before anything runs (``gibbsimpact show`` included)."""
    if not prescribed:
        return
    for k, wall in enumerate(walls):
        if is_compliant(wall):
            r.add(join(join("walls", k), "stiffness"),
                  "a compliant wall cannot be combined with [[prescribed]] coordinates yet: remove stiffness "
                  "(Newton's law) or drive the joint by [[inputs]] (e.g. a pd servo) instead of [[prescribed]]")


def _prescribed(r: _Reader, tbl, path: str, model):
    """(name, Profile) of one [[prescribed]] table, _BAD on a problem."""
    tbl = r.table(tbl, path, _PRESCRIBED_TABLE_KEYS, "a [[prescribed]] table")
    if tbl is None or model is None:
        return _BAD
    name = r.get(tbl, path, "coordinate", "str", required=True, what=_PRESCRIBED_TABLE_KEYS["coordinate"])
    kind = r.get(tbl, path, "profile", "str", required=True, what=_PRESCRIBED_TABLE_KEYS["profile"])
    joints = [model.coordinate_names[k] for k in model.theta_index if k >= 0][1 if model.chain.free_base else 0:]
    if name is not _BAD and name not in joints:
        r.add(join(path, "coordinate"), f"{name!r} is not a joint coordinate that can be prescribed; use one of "
                                        f"{', '.join(joints) or 'none (this chain has no joint besides its base)'}")
        name = _BAD
    if kind is not _BAD and kind not in _PRESCRIBED_KEYS:
        r.add(join(path, "profile"), f"unknown profile {kind!r}; use one of {', '.join(_PRESCRIBED_KEYS)}")
        kind = _BAD
    if _BAD in (name, kind):
        return _BAD
    keys = _prescribed_keys(kind, is_angle_coordinate(model, model.coordinate_names.index(name)))
    params, ok = {}, True
    for key in tbl:
        if key not in keys and key not in ("coordinate", "profile"):
            r.add(join(path, key), f"not a key of a {kind!r} profile on {name} (its keys: {', '.join(keys)})")
            ok = False
    for key, (param, required, default) in keys.items():
        if key not in tbl:
            if required:
                r.add(join(path, key), f"missing (a {kind!r} profile on {name} needs "
                                       f"{', '.join(k for k, v in keys.items() if v[1])})")
                ok = False
            else:
                params[param] = default
            continue
        v = _array(r, tbl[key], join(path, key)) if kind == "samples" else r.get(tbl, path, key, "number")
        ok = ok and v is not _BAD
        params[param] = v
    if not ok:
        return _BAD
    try:
        return name, profile(kind, **params)
    except ValueError as exc:
        r.add(path, str(exc))
        return _BAD


def _array(r: _Reader, v, p: str):
    """A list of numbers within the key's range, as floats; _BAD on a problem."""
    if not isinstance(v, list) or not v or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        r.add(p, f"expected an array of numbers, got {type_name(v)}")
        return _BAD
    return [float(x) for x in v] if r.in_range(p, v, range_of(p)) else _BAD


def start_on_profiles(r: _Reader, top: dict, model, prescribed: dict, q0, qdot0, t_start: float) -> None:
    """Set q0, qdot0 (N,) of every prescribed coordinate to its profile at t_start, in place; a value [initial]
    gives that differs (beyond 1e-9 relative) is a problem of its key."""
    initial = top.get("initial", {}) if isinstance(top.get("initial", {}), dict) else {}
    for name, prof in prescribed.items():
        k = model.coordinate_names.index(name)
        lo, hi = prof.domain
        if not lo <= t_start <= hi:
            continue  # simulate refuses the span with its own message
        values = prof(t_start)
        for table, state, v, suffixes in (("coordinates", q0, values[0], {"m": 1, "rad": 1, "deg": math.pi / 180}),
                                          ("velocities", qdot0, values[1],
                                           {"m_per_s": 1, "rad_per_s": 1, "deg_per_s": math.pi / 180})):
            given = initial.get(table, {}) if isinstance(initial.get(table, {}), dict) else {}
            for suffix, factor in suffixes.items():
                key = f"{name}_{suffix}"
                if key in given and isinstance(given[key], (int, float)) and \
                        abs(given[key] * factor - v) > 1e-9 * (1 + abs(v)):
                    r.add(join(join("initial", table), key), f"{fmt(given[key])} differs from the [[prescribed]] "
                          f"profile of {name} at t_start ({fmt(v / factor)}); leave it out: a prescribed "
                          "coordinate starts on its profile")
            state[k] = v
