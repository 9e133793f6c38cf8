"""The schema of case files (gibbsimpact.case.schema): every numeric key has a range, enforced at both
bounds and listed in docs/case-format.md."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gibbsimpact.case import RANGES, CaseError, case_from_dict
from gibbsimpact.case.reader import _Reader
from case_texts import GOOD


def with_key(range_key, value):
    """GOOD as a dict with the key of RANGES entry ``range_key`` set to ``value`` (one
    component of an array key), the rest adjusted so that nothing else is in the way
    (the chain inside its wall, a regular mass matrix). Returns (dict, key path)."""
    import tomllib

    d = tomllib.loads(GOOD)
    link, coords = d["links"][0], d["initial"]["coordinates"]
    section, _, key = range_key.rpartition(".")
    if section not in ("walls", "links.modes") and key != "EI_N_m2":
        # A rigid link in free flight: extreme sizes and states need no wall and no frequency limit.
        del d["walls"], link["modes"]
    if section == "":
        d[key] = [0.0, value, 0.0] if key == "gravity_m_per_s2" else value
        return d, key
    if section == "links":
        if key == "rotary_inertia_kg_m":
            value = [value, 2.5e-5, 2.5e-5] if value > 0 else [5e-5, value, 2.5e-5]
        if key == "length_m":
            link["rotary_inertia_kg_m"] = [(0.3 * value) ** 2] * 3  # a stubby section keeps M regular
        if key == "cross_section_radius_m":
            del link["rotary_inertia_kg_m"]
            link["length_m"] = min(1.0, 1e3 * value)
        if key == "damping_ratio":
            link["elements"] = 1  # damping needs elastic coordinates
        link[key] = value
        return d, f"links[1].{key}"
    if section == "base":
        # A rigid rod on a fixed base: no X coordinates.
        coords.pop("X1_m")
        d["base"] = {"type": "fixed", key: [value, 0.6] if key == "position_m" else value}
        return d, f"base.{key}"
    if section == "inputs":
        # A length family key (N, m) acts on X1 of the free rod, an angle family key on theta_1.
        length = key.endswith(("_N", "_N_per_s", "_N_per_m", "_N_s_per_m", "target_m"))
        table = {"coordinate": "X1" if length else "theta_1"}
        stem = key.split("_")[0]
        F = "N" if length else "N_m"
        if stem == "value":
            table.update(kind="constant")
        elif stem in ("amplitude", "offset", "frequency", "phase"):
            table.update(kind="sine", **{f"amplitude_{F}": 1.0, "frequency_hz": 1.0})
        elif stem in ("slope", "start", "end"):
            table.update(kind="ramp", **{f"slope_{F}_per_s": 1.0})
            if stem == "end":
                table["start_s"] = value - 1.0  # out of its own range only below end_s's lowest value
        else:
            table.update(kind="pd", **{f"stiffness_{F}_per_{'m' if length else 'rad'}": 1.0})
        table[key] = value
        d["inputs"] = [table]
        return d, f"inputs[1].{key}"
    if section == "links.bodies":
        return d, _with_body_key(link, key, value)
    if section == "links.modes":
        link["modes"][0][key] = value
        return d, f"links[1].modes[1].{key}"
    if section == "links.joint":
        # A rigid rod whose carriage (joint 1, Pa) runs on the base rail: any range, any c, any angle.
        coords.pop("X1_m")
        d["base"] = {"type": "fixed"}
        if key == "rotation_xyz_deg":  # a revolute (3D: the fixed base's rod) with its axis turned about x
            link["joint"] = {"type": "R", key: [value, 0.0, 0.0]}
            return d, f"links[1].joint.{key}"
        lo, hi = (0.0, 1.0)
        if key == "range_m":
            lo, hi = (value, value + 1.0) if value < 0 else (value - 1.0, value)
        link["joint"] = {"type": "Pa", "range_m": [lo, hi], key: [lo, hi] if key == "range_m" else value}
        coords["d_1_m"] = (lo + hi) / 2
        return d, f"links[1].joint.{key}"
    if section == "walls":
        wall = d["walls"][0]
        if key == "radius_m":
            wall[key] = value  # a chain of the wall's size inside it
            link["length_m"] = value
            link["rotary_inertia_kg_m"] = [(0.3 * value) ** 2] * 3
            coords["X1_m"] = -value / 2
            if value < 1e-2:
                del link["modes"]
        elif key == "center_m":
            wall[key] = [value, 0.0]
            coords["X1_m"] = value - 1.0 if value > 0 else value  # the link from X1 to X1 + 1
        elif key in ("point_m", "normal"):
            side = 1.0 if key == "normal" or value < 0 else -1.0  # the free side towards the origin
            wall.clear()
            wall.update(type="plane", point_m=[0.0, value if key == "point_m" else 0.0, 0.0],
                        normal=[0.0, side * (value if key == "normal" else 1.0), 0.0])
            coords["X2_m"] = wall["point_m"][1] + side
            d["walls"] = [wall]
        else:
            wall[key] = value
        return d, f"walls[1].{key}"
    if section == "contact_filter":
        d["contact_filter"] = {"rule": "lead", "points": ["O1", "O2"], "direction": [1.0, 0.0, 0.0],
                               "clearance_m": 0.05}
        d["contact_filter"][key] = [value, 0.0, 0.0] if key == "direction" else value
        return d, f"contact_filter.{key}"
    if section == "initial":
        coords.pop("X1_m")
        d["initial"][key] = [value, 0.0, 0.0]
        return d, f"initial.{key}"
    if section in ("initial.coordinates", "initial.velocities"):
        unit = key[2:]
        name = f"{'X1' if unit in ('m', 'm_per_s') else 'theta_1'}_{unit}"
        coords.pop("X1_m")
        d["initial"].setdefault(section.split(".")[1], {})[name] = value
        return d, f"{section}.{name}"
    if section == "time":
        d["time"] = {"t_start_s": value, "t_end_s": value + 1.0} if key == "t_start_s" else {
            "t_start_s": value - 1.0, "t_end_s": value}
        return d, f"time.{key}"
    if section == "solver":
        d["solver"] = {key: value}
        if key in ("output_dt_s", "max_step_s"):
            d["time"]["t_end_s"] = 1e-9  # 1e6 samples at the smallest interval
        return d, f"solver.{key}"
    if section == "prescribed":
        return _prescribed_key(d, link, coords, key, value)
    assert section == "output", range_key
    d["output"] = {key: value}
    return d, f"output.{key}"


def _with_body_key(link: dict, key: str, value) -> str:
    """A [[links.bodies]] table with ``key`` = value on the rigid link ``link`` in free flight; its key path."""
    # A heavy body keeps M regular under the largest inertia: J / (m l^2) ~ 1e3.
    heavy = key == "inertia_products_kg_m2" or (key == "inertia_kg_m2" and value > 1.0)
    body = {"mass_kg": 1e12 if heavy else 1.0, "inertia_kg_m2": [1e15 if heavy else 0.1] * 3}
    if key == "at_m":
        link["length_m"] = max(value, 1e-6)
        link["rotary_inertia_kg_m"] = [(0.3 * link["length_m"]) ** 2] * 3
    body[key] = ([value] * 3 if key == "inertia_kg_m2" else [value, 0.0, 0.0]
                 if key in ("center_m", "inertia_products_kg_m2") else value)
    link["bodies"] = [body]
    return f"links[1].bodies[1].{key}"


def _prescribed_key(d, link, coords, key, value):
    """A rigid rod on a fixed base whose joint 1 follows the profile that has ``key``: an R joint for an angle
    key, a Pa carriage on the base rail for a length key (its range holds 0, where [initial] leaves d_1, and the
    profile's start)."""
    coords.pop("X1_m")
    d["base"] = {"type": "fixed"}
    length = key.endswith(("_m", "_m_per_s"))
    table = {"coordinate": "d_1" if length else "theta_1"}
    Q = "m" if length else "rad"
    stem = key.rsplit("_", 1)[0] if key in ("T_s", "t_s") else key.split(f"_{Q}")[0]
    start = 0.0
    if stem == "Omega" or key == "T_s":
        table.update(profile="spin_up", **{f"Omega_{Q}_per_s": 1.0, "T_s": 1.0})
    elif stem in ("q0", "v"):
        table.update(profile="constant_speed", **{f"v_{Q}_per_s": 0.0})
        start = value if stem == "q0" else 0.0
    elif stem in ("q_a", "q_b", "t_a_s", "t_b_s") or key in ("t_a_s", "t_b_s"):
        table.update(profile="point_to_point", **{f"q_a_{Q}": 0.0, f"q_b_{Q}": 0.0, "t_a_s": 0.0, "t_b_s": 1.0})
        if key == "t_a_s":
            table["t_b_s"] = value + 1.0 if value < 0 else value  # t_b > t_a only below the top of the range
        if key == "t_b_s":
            table["t_a_s"] = value - 1.0 if value > 0 else value
        start = value if stem == "q_a" else 0.0
    else:  # samples: four equal values, or four times ending / starting at value
        t = [value + k for k in range(4)] if value < 0 else [value - 3 + k for k in range(4)]
        table.update(profile="samples", t_s=t if key == "t_s" else [0.0, 1.0, 2.0, 3.0],
                     **{f"q_{Q}": [value] * 4 if key != "t_s" else [0.0] * 4})
        start = value if key != "t_s" else 0.0
        value = table[key]
    if key not in ("t_s", f"q_{Q}"):
        table[key] = value
    if length:
        lo, hi = max(min(0.0, start), -1e6), min(max(0.0, start), 1e6)  # clipped: a value outside is the key's
        link["joint"] = {"type": "Pa", "range_m": [lo, hi] if hi > lo else [-1.0, 1.0]}
    d["prescribed"] = [table]
    return d, f"prescribed[1].{key}"


def just_inside(rng, side):
    bound = rng.low if side == "low" else rng.high
    return int(bound) if rng.integer else bound


def just_outside(rng, side):
    if rng.integer:
        return int(rng.low) - 1 if side == "low" else int(rng.high) + 1
    return math.nextafter(rng.low, -math.inf) if side == "low" else math.nextafter(rng.high, math.inf)


BOUNDS = [(k, side) for k in RANGES for side in ("low", "high")]


@pytest.mark.parametrize("range_key,side", BOUNDS, ids=[f"{k}-{s}" for k, s in BOUNDS])
def test_every_range_bound_is_enforced(range_key, side):
    rng = RANGES[range_key]
    # Just inside loads; only the t_start upper and t_end lower bounds leave no room for the other time.
    d, path = with_key(range_key, just_inside(rng, side))
    if (range_key, side) in (("time.t_start_s", "high"), ("time.t_end_s", "low"), ("inputs.end_s", "low"),
                             ("prescribed.t_a_s", "high"), ("prescribed.t_b_s", "low")):
        with pytest.raises(CaseError) as info:
            case_from_dict(d)
        assert path not in dict(info.value.problems)
    elif (range_key, side) == ("links.elements", "high") or range_key in ("links.joint.parent", "links.joint.at_m"):
        # The reader's range check alone: building a 200-element link's integrals takes seconds; a
        # tree's parent and abscissa are valid only against the other links (an earlier link, [0, l_p]).
        reader = _Reader()
        assert reader.value(rng.high, path, "number") == rng.high and reader.problems == []
    else:
        case_from_dict(d)
    # Just outside names the key and the range.
    d, path = with_key(range_key, just_outside(rng, side))
    with pytest.raises(CaseError) as info:
        case_from_dict(d)
    problems = dict(info.value.problems)
    assert path in problems, info.value.problems
    assert str(rng) in problems[path]


def test_docs_give_every_range():
    docs = (Path(__file__).resolve().parents[2] / "docs" / "case-format.md").read_text()
    rows = [ln for ln in docs.splitlines() if ln.startswith("|")]
    for range_key, rng in RANGES.items():
        leaf = range_key.rpartition(".")[2].lstrip("*")
        interval = str(rng).split("]")[0] + "]"
        assert any(f"`{leaf}`" in row and interval in row for row in rows), (range_key, interval)
