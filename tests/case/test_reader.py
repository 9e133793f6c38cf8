"""Case files: the published cases load to the binding parameters; every kind of bad input
gives its own message with the key path; several problems come in one CaseError."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.case import RANGES, CaseError, case_from_dict
from gibbsimpact.case.reader import _Reader
from conftest import PB_DROP_CASE

CASES = Path(__file__).resolve().parents[2] / "cases"

# A small valid case (two rigid links would be singular when straight; one flexible
# link with rotary inertia is the smallest regular chain).
GOOD = """
name = "tiny"
gravity_m_per_s2 = [0.0, -9.81, 0.0]
restitution = 1.0

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 20.0
rotary_inertia_kg_m = [5e-5, 2.5e-5, 2.5e-5]
modes = [{ kind = "clamped-clamped", direction = "y" }]

[[walls]]
type = "circle"
radius_m = 1.5

[initial.coordinates]
X1_m = -0.5

[time]
t_end_s = 0.1
"""


def write(tmp_path, text, name="case.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def problems_of(tmp_path, text):
    with pytest.raises(CaseError) as info:
        gi.load_case(write(tmp_path, text))
    return info.value


def Rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def Ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def Rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


# -- the published cases ----------------------------------------------------

def test_case1_parameters():
    case = gi.load_case(CASES / "circle_two_link.toml")
    m = case.model
    assert case.name == "circle_two_link"
    assert m.n_dof == 9 and m.n_links == 2
    for lk in m.chain.links:
        assert lk.length == 1.0 and lk.mass_per_length == 1.0 and lk.EI == (20.0, 20.0)
        assert lk.modes == (gi.Mode("clamped-clamped", "y", 1),) and lk.rotary_inertia == (0.0, 0.0, 0.0)
    assert np.array_equal(m.gravity, [0.0, -9.81, 0.0])
    assert case.walls == (gi.Circle(radius=1.5, center=(0.0, 0.0)),)
    assert case.restitution == 1.0
    expected = m.state(X1=-math.cos(math.pi / 6), theta_1=-math.pi / 6, theta_2=math.pi / 3)
    np.testing.assert_allclose(case.q0, expected, rtol=0, atol=1e-15)
    assert not np.any(case.qdot0)
    assert case.t_span == (0.0, 1.0)
    assert case.solver == {"method": "DOP853", "rtol": 1e-10, "atol": 1e-12, "output_dt": 1e-3}
    assert case.initial_energy().total == pytest.approx(-4.905, abs=1e-12)
    # O1 and O3 on the X1 axis, O2 below: gaps R - |p|.
    np.testing.assert_allclose(case.initial_gaps(), [[1.5 - math.cos(math.pi / 6), 1.0, 1.5 - math.cos(math.pi / 6)]],
                               atol=1e-12)


def test_case2_parameters_and_center_of_mass_placement():
    case = gi.load_case(CASES / "sphere_single_link.toml")
    m = case.model
    assert m.n_dof == 8
    (lk,) = m.chain.links
    assert lk.EI == (20.0, 20.0)
    np.testing.assert_allclose(lk.rotary_inertia, [1e-4 / 2, 1e-4 / 4, 1e-4 / 4], rtol=1e-15)
    assert lk.modes == (gi.Mode("clamped-clamped", "y"), gi.Mode("clamped-clamped", "z"))
    assert case.walls == (gi.Sphere(radius=1.0, center=(0.0, 0.0, 0.0)),)
    R1 = Rx(0.3) @ Ry(0.2) @ Rz(0.5)
    np.testing.assert_allclose(case.q0[:3], -R1 @ [0.5, 0.0, 0.0], atol=1e-15)
    np.testing.assert_array_equal(case.q0[3:], [0.3, 0.2, 0.5, 0.0, 0.0])
    np.testing.assert_array_equal(case.qdot0, [0.4, 0.8, 0.24, 0.0, 0.0, 2.0, 0.2, -0.1])
    np.testing.assert_allclose(m.center_of_mass(case.q0), 0.0, atol=1e-15)
    assert case.initial_energy().total == pytest.approx(1.807549, abs=5e-7)


def test_degrees_alias_and_center_of_mass_velocity(tmp_path):
    text = GOOD.replace("X1_m = -0.5", "theta_1_deg = 30.0\ntheta_m1_rad = 0.1") + """
[initial]
center_of_mass_m = [0.1, -0.2, 0.05]
center_of_mass_velocity_m_per_s = [1.0, 2.0, -0.5]

[initial.velocities]
theta_1_deg_per_s = 90.0
delta_1_1_m_per_s = 0.3
"""
    case = gi.load_case(write(tmp_path, text))
    m = case.model
    assert case.q0[5] == pytest.approx(math.radians(30.0), rel=1e-15)
    assert case.q0[3] == 0.1
    assert case.qdot0[5] == pytest.approx(math.pi / 2, rel=1e-15)
    np.testing.assert_allclose(m.center_of_mass(case.q0), [0.1, -0.2, 0.05], atol=1e-15)
    v_c = m.linear_momentum(case.q0, case.qdot0) / m.total_mass
    np.testing.assert_allclose(v_c, [1.0, 2.0, -0.5], atol=1e-14)


def test_cross_section_radius_gives_round_section_inertia(tmp_path):
    text = GOOD.replace("rotary_inertia_kg_m = [5e-5, 2.5e-5, 2.5e-5]", "cross_section_radius_m = 0.01")
    (lk,) = gi.load_case(write(tmp_path, text)).model.chain.links
    np.testing.assert_allclose(lk.rotary_inertia, [5e-5, 2.5e-5, 2.5e-5], rtol=1e-12)


def test_defaults_and_simulate_overrides(tmp_path):
    case = gi.load_case(write(tmp_path, GOOD))
    assert case.name == "tiny" and case.t_span == (0.0, 0.1) and case.solver == {}
    assert case.output["plots"] is True and case.output["animate"] is False
    assert case.output_directory == Path("out") / "tiny"
    kw = case.simulate_kwargs(t_end=0.05, rtol=1e-6)
    assert kw["t_span"] == (0.0, 0.05) and kw["rtol"] == 1e-6 and kw["walls"] == case.walls
    res = case.simulate(t_end=0.01, rtol=1e-8, atol=1e-10)
    assert res.status == "finished" and res.t[-1] == pytest.approx(0.01)


def test_name_defaults_to_file_stem(tmp_path):
    case = gi.load_case(write(tmp_path, GOOD.replace('name = "tiny"\n', ""), name="my_case.toml"))
    assert case.name == "my_case"


def test_case_from_dict_equals_file(tmp_path):
    import tomllib

    a = gi.load_case(write(tmp_path, GOOD))
    b = case_from_dict(tomllib.loads(GOOD))
    np.testing.assert_array_equal(a.q0, b.q0)


# -- one message per kind of problem ----------------------------------------

def test_unknown_key_names_path_and_suggestion(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("length_m = 1.0", "length_m = 1.0\nlenght_m = 2.0"))
    assert err.problems == [("links[1].lenght_m", "unknown key (did you mean 'length_m'?)")]
    assert "links[1].lenght_m: unknown key" in str(err)


def test_unknown_top_level_and_wall_keys(tmp_path):
    err = problems_of(tmp_path, "colour = 'red'\n" + GOOD.replace("radius_m = 1.5", "radius = 1.5"))
    paths = [p for p, _ in err.problems]
    assert "colour" in paths
    assert "walls[1].radius" in paths
    assert "walls[1].radius_m" in paths  # and the required key is then missing


def test_missing_key(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("EI_N_m2 = 20.0\n", ""))
    assert len(err.problems) == 1
    path, msg = err.problems[0]
    assert path == "links[1].EI_N_m2" and msg.startswith("missing")


def test_missing_sections(tmp_path):
    text = GOOD.split("[[links]]")[0].replace("gravity_m_per_s2 = [0.0, -9.81, 0.0]\n", "")
    err = problems_of(tmp_path, text)
    paths = [p for p, _ in err.problems]
    assert paths == ["gravity_m_per_s2", "links", "time"]


def test_wrong_type(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("length_m = 1.0", 'length_m = "1.0"'))
    assert err.problems == [("links[1].length_m", "expected a number, got the string '1.0'")]


def test_wrong_type_vector_and_bool(tmp_path):
    text = GOOD.replace("gravity_m_per_s2 = [0.0, -9.81, 0.0]", "gravity_m_per_s2 = [0.0, -9.81]")
    text = text.replace("restitution = 1.0", "restitution = true")
    err = problems_of(tmp_path, text)
    assert ("gravity_m_per_s2", "expected an array of 3 numbers, got an array of 2") in err.problems
    assert ("restitution", "expected a number, got the boolean true") in err.problems


def test_negative_length(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("length_m = 1.0", "length_m = -1.0"))
    assert err.problems == [("links[1].length_m", "must be in [1e-6, 1e6] m (a micrometre to 1000 km), got -1")]


def test_joint_outside_wall(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("X1_m = -0.5", "X1_m = 1.0"))
    assert len(err.problems) == 1
    path, msg = err.problems[0]
    assert path == "initial"
    assert "joint O2" in msg and "outside walls[1]" in msg and "circle R=1.5" in msg and "by 0.5 m" in msg


def test_several_problems_in_one_error(tmp_path):
    text = GOOD.replace("length_m = 1.0", "length_m = -1.0")
    text = text.replace("radius_m = 1.5", "radius_m = 1.5\ncolor = 'grey'")
    text = text.replace("t_end_s = 0.1", 't_end_s = "soon"')
    text = text.replace("EI_N_m2 = 20.0\n", "")
    err = problems_of(tmp_path, text)
    paths = [p for p, _ in err.problems]
    assert paths == ["links[1].length_m", "links[1].EI_N_m2", "walls[1].color", "time.t_end_s"]
    first = str(err).splitlines()[0]
    assert first.endswith("case.toml: 4 problems:")
    assert len(str(err).splitlines()) == 5


def test_problems_in_second_link_and_mode(tmp_path):
    text = GOOD + """
[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 0.0
EI_N_m2 = [20.0, -1.0]
modes = [{ kind = "free-free" }, { kind = "clamped-clamped", direction = "x" }]
"""
    err = problems_of(tmp_path, text)
    d = dict(err.problems)
    assert d["links[2].mass_per_length_kg_per_m"] == "must be in [1e-12, 1e9] kg/m, got 0"
    assert d["links[2].EI_N_m2"].startswith("every component must be in [1e-15, 1e15] N m^2")
    assert d["links[2].modes[1].kind"].startswith("unknown kind 'free-free'")
    assert d["links[2].modes[2].direction"].startswith("unknown direction 'x'")


def test_unknown_coordinate_and_missing_unit(tmp_path):
    text = GOOD.replace("X1_m = -0.5", "X1_m = -0.5\ntheta_2_rad = 0.1\nX2 = 0.0\ntheta_1_m = 0.3")
    err = problems_of(tmp_path, text)
    d = dict(err.problems)
    assert "unknown coordinate theta_2" in d["initial.coordinates.theta_2_rad"]
    assert d["initial.coordinates.X2"] == "add the unit to the key: X2_m"
    assert d["initial.coordinates.theta_1_m"] == "theta_1 takes unit rad or deg, not m"


def test_coordinate_twice_and_com_conflict(tmp_path):
    text = GOOD.replace("X1_m = -0.5", "X1_m = -0.5\ntheta_1_deg = 10\ntheta_1_rad = 0.2")
    text = text.replace("[initial.coordinates]", "[initial]\ncenter_of_mass_m = [0, 0, 0]\n\n[initial.coordinates]")
    err = problems_of(tmp_path, text)
    d = dict(err.problems)
    assert d["initial.coordinates.theta_1_rad"] == "sets theta_1 again (already set by theta_1_deg)"
    # The conflict with X1_m is only judged once the coordinates themselves are valid.
    text2 = GOOD.replace("[initial.coordinates]", "[initial]\ncenter_of_mass_m = [0, 0, 0]\n\n[initial.coordinates]")
    err2 = problems_of(tmp_path, text2)
    assert err2.problems[0][0] == "initial.center_of_mass_m" and "X1_m" in err2.problems[0][1]


def test_ranges_and_choices(tmp_path):
    text = GOOD.replace("restitution = 1.0", "restitution = 1.5")
    text = text.replace('type = "circle"', 'type = "ellipse"')
    text = text.replace("t_end_s = 0.1", "t_start_s = 0.2\nt_end_s = 0.1")
    text += '\n[solver]\nmethod = "Euler"\nrtol = -1e-8\nzeno_count = 2.5\n'
    err = problems_of(tmp_path, text)
    d = dict(err.problems)
    assert d["restitution"] == "must be in [0, 1] (1 = elastic, 0 = plastic), got 1.5"
    assert d["walls[1].type"].startswith("unknown wall type 'ellipse'")
    assert d["time.t_end_s"] == "must be after t_start_s = 0.2 s, got 0.1"
    assert d["solver.method"].startswith("unknown method 'Euler'")
    assert d["solver.rtol"] == "must be in [1e-13, 0.1] (solve_ivp cannot go below 2.2e-14), got -1e-8"
    assert d["solver.zeno_count"] == "expected an integer, got the number 2.5"


def test_plane_wall_and_zero_normal(tmp_path):
    text = GOOD.replace('type = "circle"\nradius_m = 1.5', 'type = "plane"\npoint_m = [0, -1, 0]\nnormal = [0, 0, 0]')
    err = problems_of(tmp_path, text)
    assert err.problems == [("walls[1].normal", "is the zero vector; give a direction")]
    ok = gi.load_case(write(tmp_path, text.replace("normal = [0, 0, 0]", "normal = [0, 2, 0]")))
    assert ok.walls[0].normal_vector == (0.0, 1.0, 0.0) and ok.walls[0].point == (0.0, -1.0, 0.0)


def test_singular_mass_matrix_is_reported(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("rotary_inertia_kg_m = [5e-5, 2.5e-5, 2.5e-5]\n", ""))
    (path, msg), = err.problems
    assert path == "links" and "singular" in msg and "rotary_inertia" in msg


def test_invalid_toml_and_missing_file(tmp_path):
    err = problems_of(tmp_path, "name = \n")
    assert "not valid TOML" in str(err)
    with pytest.raises(FileNotFoundError):
        gi.load_case(tmp_path / "nope.toml")


def test_case_error_is_value_error():
    assert issubclass(CaseError, ValueError)
    with pytest.raises(ValueError):
        case_from_dict({"links": 3})


# -- ranges: every numeric key, both bounds (docs/case-format.md lists them) ---

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
    if section == "links.modes":
        link["modes"][0][key] = value
        return d, f"links[1].modes[1].{key}"
    if section == "links.joint":
        # A rigid rod whose carriage (joint 1, Pa) runs on the base rail: any range, any c, any angle.
        coords.pop("X1_m")
        d["base"] = {"type": "fixed"}
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
    assert section == "output", range_key
    d["output"] = {key: value}
    return d, f"output.{key}"


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
    if (range_key, side) in (("time.t_start_s", "high"), ("time.t_end_s", "low"), ("inputs.end_s", "low")):
        with pytest.raises(CaseError) as info:
            case_from_dict(d)
        assert path not in dict(info.value.problems)
    elif (range_key, side) == ("links.elements", "high"):
        # The reader's range check alone: building a 200-element link's integrals takes seconds.
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


def test_integers_beyond_the_double_range_are_too_large(tmp_path):
    huge = "1" + "0" * 400
    text = GOOD.replace("length_m = 1.0", f"length_m = {huge}").replace("[0.0, -9.81, 0.0]", f"[0.0, -{huge}, 0.0]")
    text = text.replace('direction = "y"', f'direction = "y", number = {huge}')
    d = dict(problems_of(tmp_path, text).problems)
    assert d["links[1].length_m"] == ("too large for a number: must be in [1e-6, 1e6] m (a micrometre to 1000 km), "
                                      "got 1e400")
    assert d["gravity_m_per_s2"].startswith("too large for a number: must be in [-1e4, 1e4] m/s^2")
    assert d["links[1].modes[1].number"].startswith("too large for a number: must be in [1, 50]")


def test_nan_and_inf(tmp_path):
    text = GOOD.replace("length_m = 1.0", "length_m = nan").replace("t_end_s = 0.1", "t_end_s = inf")
    d = dict(problems_of(tmp_path, text).problems)
    assert d["links[1].length_m"].endswith("got nan") and d["time.t_end_s"].endswith("got inf")
    case = gi.load_case(write(tmp_path, GOOD + "\n[solver]\nmax_step_s = inf\n"))
    assert case.solver["max_step"] == math.inf  # no limit: the one key where inf is a value


def test_mode_frequency_limit(tmp_path):
    # omega = (beta l)^2 sqrt(EI / (mu l^4)) <= 1e12 rad/s, reported at EI_N_m2.
    mode = gi.Mode("clamped-clamped", "y", 1)
    l = 1e-4
    ei_limit = (1e12 / mode.beta_l**2) ** 2 * l**4  # mu = 1 kg/m
    text = GOOD.replace("length_m = 1.0", f"length_m = {l!r}").replace("X1_m = -0.5", "X1_m = -5e-5")
    text = text.replace("rotary_inertia_kg_m = [5e-5, 2.5e-5, 2.5e-5]", "rotary_inertia_kg_m = [1e-9, 1e-9, 1e-9]")
    gi.load_case(write(tmp_path, text.replace("EI_N_m2 = 20.0", f"EI_N_m2 = {ei_limit * 0.999!r}")))
    err = problems_of(tmp_path, text.replace("EI_N_m2 = 20.0", f"EI_N_m2 = {ei_limit * 1.001!r}"))
    (path, msg), = err.problems
    assert path == "links[1].EI_N_m2" and "modes[1] (clamped-clamped number 1 in y)" in msg
    assert "omega = 1.0005e12 rad/s" in msg and "above 1e12 rad/s" in msg


@pytest.mark.parametrize("key,kw", [("output_dt_s", "output_dt"), ("max_step_s", "max_step")])
def test_at_most_1e7_samples_or_steps(tmp_path, key, kw):
    # t_end_s = 0.1 s: 1e7 intervals of 1e-8 s.
    case = gi.load_case(write(tmp_path, GOOD + f"\n[solver]\n{key} = 1e-8\n"))
    assert case.solver[kw] == 1e-8
    err = problems_of(tmp_path, GOOD + f"\n[solver]\n{key} = 0.99e-8\n")
    (path, msg), = err.problems
    assert path == f"solver.{key}"
    assert msg.startswith(f"(time.t_end_s - time.t_start_s) / solver.{key} = 0.1 s / 9.9e-9 s = 1.0101e7 ")
    assert msg.endswith(f"make solver.{key} at least 1e-8 s or shorten the time span")


def test_simulate_overrides_are_held_to_the_ranges(tmp_path):
    case = gi.load_case(write(tmp_path, GOOD))
    with pytest.raises(CaseError) as info:
        case.simulate(t_end=-1.0, rtol=1.0, method="Euler")
    d = dict(info.value.problems)
    assert set(d) == {"t_end", "rtol", "method"}
    assert d["rtol"] == "must be in [1e-13, 0.1] (solve_ivp cannot go below 2.2e-14), got 1"
    assert d["t_end"] == "must be after time.t_start_s = 0 s, got -1"
    with pytest.raises(CaseError) as info:
        case.simulate_kwargs(output_dt=1e-12)
    (path, msg), = info.value.problems
    assert path == "output_dt" and msg.startswith("(time.t_end_s - time.t_start_s) / output_dt = 0.1 s / 1e-12 s")
    assert case.simulate_kwargs(t_end=0.5, output_dt=None)["output_dt"] is None


def test_boolean_solver_keys_can_be_overridden(tmp_path):
    # link_contacts is the one boolean [solver] key: overriding it used to raise KeyError.
    case = gi.load_case(write(tmp_path, GOOD))
    assert case.simulate_kwargs(link_contacts=False)["link_contacts"] is False
    with pytest.raises(CaseError) as info:
        case.simulate_kwargs(link_contacts="no")
    assert dict(info.value.problems) == {"link_contacts": "expected true or false, got the string 'no'"}


# -- finite elements, a fixed base and inputs -----------------------------------

# A rigid rod on a fixed base, no gravity, driven by a constant motor torque.
ROD = """
name = "rod"
gravity_m_per_s2 = [0.0, 0.0, 0.0]

[base]
type = "fixed"
position_m = [0.5, 1.0]
angle_deg = 30.0

[[links]]
length_m = 0.8
mass_per_length_kg_per_m = 2.0
EI_N_m2 = 10.0

[[inputs]]
coordinate = "theta_1"
kind = "constant"
value_N_m = 0.3

[time]
t_end_s = 0.5
"""

# Two links on a fixed base, the second with one finite element: theta_1, theta_2
# (angles), delta_2_1 (tip deflection, m) and delta_2_2 (tip slope, rad).
ARM = """
gravity_m_per_s2 = [0.0, -9.81, 0.0]

[base]
type = "fixed"

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 25.0

[[links]]
length_m = 0.6
mass_per_length_kg_per_m = 0.5
EI_N_m2 = 8.0
elements = 1

[time]
t_end_s = 0.1
"""


def with_inputs(text, *tables):
    """text plus one [[inputs]] table per dict."""
    def toml(v):
        return f'"{v}"' if isinstance(v, str) else repr(v)

    return text + "".join("\n[[inputs]]\n" + "".join(f"{k} = {toml(v)}\n" for k, v in t.items()) for t in tables)


def test_fixed_base_rod_under_constant_torque_closed_form(tmp_path):
    case = gi.load_case(write(tmp_path, ROD))
    m = case.model
    assert m.coordinate_names == ("theta_1",) and not m.free_base
    assert m.chain.base == gi.FixedBase((0.5, 1.0, 0.0), math.radians(30.0))
    np.testing.assert_allclose(m.joint_positions(case.q0)[1], [0.5 + 0.8 * math.cos(math.pi / 6),
                                                             1.0 + 0.8 * math.sin(math.pi / 6), 0.0], atol=1e-15)
    assert set(case.simulate_kwargs()["inputs"]) == {"theta_1"}
    res = case.simulate(rtol=1e-12, atol=1e-14, output_dt=0.05)
    # I theta'' = tau, I = m l^2 / 3 about the base joint: theta = tau t^2 / (2 I).
    inertia = 2.0 * 0.8 * 0.8**2 / 3.0
    np.testing.assert_allclose(res.q[:, 0], 0.3 * res.t**2 / (2 * inertia), rtol=0, atol=1e-11)
    np.testing.assert_allclose(res.work[-1, 0], 0.3 * res.q[-1, 0], rtol=1e-9)  # W = tau theta


def test_finite_element_link_keys(tmp_path):
    text = ARM.replace("elements = 1", 'elements = 3\nelement_directions = ["y", "z"]\ndamping_ratio = 0.02')
    case = gi.load_case(write(tmp_path, text))
    lk = case.model.chain.links[1]
    assert (lk.elements, lk.element_directions, lk.damping, lk.modes) == (3, ("y", "z"), 0.02, ())
    assert case.model.n_dof == 2 + 12
    assert case.model.chain.links[0].elements == 0 and case.model.chain.links[0].damping == 0.0


def test_modes_and_elements_are_exclusive(tmp_path):
    err = problems_of(tmp_path, GOOD.replace('modes = [', 'elements = 2\nmodes = ['))
    (path, msg), = err.problems
    assert path == "links[1].elements" and "modes" in msg and "elements" in msg and "not both" in msg


def test_element_directions_and_damping_errors(tmp_path):
    text = ARM.replace("elements = 1", 'elements = 1\nelement_directions = ["y", "y"]')
    text = text.replace("EI_N_m2 = 25.0", 'EI_N_m2 = 25.0\ndamping_ratio = 0.1\nelement_directions = ["z"]')
    d = dict(problems_of(tmp_path, text).problems)
    assert d["links[2].element_directions"].startswith("must be ['y'], ['z'] or ['y', 'z']")
    assert d["links[1].damping_ratio"] == "needs elastic coordinates: give the link modes or elements"
    assert d["links[1].element_directions"].startswith("applies to finite elements only")
    d = dict(problems_of(tmp_path, ARM.replace("elements = 1", 'elements = 1\nelement_directions = "y"')).problems)
    assert d["links[2].element_directions"].startswith("expected an array of directions")


def test_base_table_errors(tmp_path):
    d = dict(problems_of(tmp_path, ARM.replace('type = "fixed"', 'type = "floating"')).problems)
    assert d["base.type"].startswith("unknown base type 'floating'")
    text = ARM.replace('type = "fixed"', 'type = "free"\nposition_m = [0.0, 1.0]')
    d = dict(problems_of(tmp_path, text).problems)
    assert d["base.position_m"].startswith("a free-flying base has no fixed position")
    text = ARM.replace('type = "fixed"', 'type = "fixed"\nposition_m = [0.0]\nangle_deg = 10\nangle_rad = 0.1')
    d = dict(problems_of(tmp_path, text).problems)
    assert d["base.position_m"] == "expected an array of 2 or 3 numbers (b1, b2[, b3]) in m, got an array of 1"
    assert d["base.angle_rad"].startswith("sets the base angle again")
    no_type = ARM.replace("[base]\n", "[base]\nposition_m = [0, 0, 0]\n").replace('type = "fixed"\n', "")
    err = problems_of(tmp_path, no_type)
    assert err.problems == [("base.type", "missing ('fixed', 'free' or 'planar')")]
    # type = "free" is the free-flying default.
    free = gi.load_case(write(tmp_path, GOOD + '\n[base]\ntype = "free"\n'))
    assert free.model.free_base and free.model.n_dof == 7


def test_fixed_base_has_no_base_coordinates(tmp_path):
    text = ARM + "\n[initial.coordinates]\nX1_m = 0.2\ntheta_0_rad = 0.1\ntheta_2_deg = 10\n"
    d = dict(problems_of(tmp_path, text).problems)
    assert set(d) == {"initial.coordinates.X1_m", "initial.coordinates.theta_0_rad"}
    assert d["initial.coordinates.X1_m"] == (
        "unknown coordinate X1 (a fixed base has no X1, X2, X3, theta_-1, theta_0: [base] type = 'fixed'); "
        "this model has theta_1, theta_2, delta_2_1, delta_2_2")
    text = ARM + "\n[initial]\ncenter_of_mass_m = [0, 0, 0]\ncenter_of_mass_velocity_m_per_s = [1, 0, 0]\n"
    d = dict(problems_of(tmp_path, text).problems)
    assert set(d) == {"initial.center_of_mass_m", "initial.center_of_mass_velocity_m_per_s"}
    assert all(msg.startswith("needs a free-flying base (it sets X1, X2, X3)") for msg in d.values())
    ok = gi.load_case(write(tmp_path, ARM + "\n[initial.coordinates]\ntheta_2_deg = 10\ndelta_2_2_rad = 0.01\n"))
    np.testing.assert_allclose(ok.q0, [0.0, math.radians(10), 0.0, 0.01], atol=1e-16)


POINTS = [(0.0, (0.1, -0.2, 0.003, 0.02), (1.0, 0.5, -0.1, 0.2)),
          (0.37, (-1.2, 0.4, -0.01, 0.0), (-2.0, 3.0, 0.4, -0.3)),
          (2.5, (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0))]


def test_every_input_kind_against_its_closed_form(tmp_path):
    text = with_inputs(
        ARM,
        dict(coordinate="theta_1", kind="constant", value_N_m=1.5),
        dict(coordinate="theta_1", kind="sine", amplitude_N_m=-2.0, frequency_hz=1.5, phase_deg=30.0, offset_N_m=0.25),
        dict(coordinate="theta_2", kind="ramp", slope_N_m_per_s=4.0, start_s=0.2, end_s=1.2),
        dict(coordinate="theta_2", kind="pd", target_deg=20.0, stiffness_N_m_per_rad=7.0, damping_N_m_s_per_rad=0.3),
        dict(coordinate="delta_2_1", kind="pd", target_m=0.01, stiffness_N_per_m=50.0),
        dict(coordinate="delta_2_2", kind="ramp", slope_N_m_per_s=-3.0),
    )
    case = gi.load_case(write(tmp_path, text))
    assert [s.kind for s in case.inputs] == ["constant", "sine", "ramp", "pd", "pd", "ramp"]
    f = case.simulate_kwargs()["inputs"]
    assert set(f) == {"theta_1", "theta_2", "delta_2_1", "delta_2_2"}
    for t, q, qd in POINTS:
        q, qd = np.array(q), np.array(qd)
        # Several inputs on one coordinate add up.
        assert f["theta_1"](t, q, qd) == pytest.approx(1.5 + 0.25 - 2.0 * math.sin(3.0 * math.pi * t + math.pi / 6),
                                                       rel=1e-14, abs=1e-14)
        ramp = 4.0 * (min(max(t, 0.2), 1.2) - 0.2)  # 0 before 0.2 s, held at 4 N m after 1.2 s
        pd = 7.0 * (math.radians(20.0) - q[1]) - 0.3 * qd[1]
        assert f["theta_2"](t, q, qd) == pytest.approx(ramp + pd, rel=1e-14, abs=1e-14)
        assert f["delta_2_1"](t, q, qd) == pytest.approx(50.0 * (0.01 - q[2]), rel=1e-14, abs=1e-14)
        assert f["delta_2_2"](t, q, qd) == pytest.approx(-3.0 * t, rel=1e-14, abs=1e-14)
    assert case.simulate_kwargs(inputs=None)["inputs"] is None  # an override replaces them
    assert gi.load_case(write(tmp_path, ARM)).simulate_kwargs()["inputs"] is None


def test_input_errors_name_the_key(tmp_path):
    text = with_inputs(
        ARM,
        dict(coordinate="theta_1", kind="constant", value_N=1.0),                         # 1: force on an angle
        dict(coordinate="delta_2_1", kind="sine", amplitude_N_m=1.0, frequency_hz=2.0),   # 2: torque on a length
        dict(coordinate="delta_2_2", kind="constant", value_N=1.0),                       # 3: an FE slope is an angle
        dict(coordinate="theta_1", kind="constant", value_N_m=1.0, frequency_hz=2.0),     # 4: key of another kind
        dict(coordinate="theta_1", kind="sine", amplitude_N_m=1.0),                       # 5: missing frequency
        dict(coordinate="X1", kind="constant", value_N=1.0),                              # 6: no X on a fixed base
        dict(coordinate="theta_1", kind="spring"),                                        # 7: unknown kind
        dict(coordinate="theta_1", kind="ramp", slope_N_m_per_s=1.0, start_s=1.0, end_s=0.5),  # 8: end before start
        dict(coordinate="theta_2", kind="pd", stiffness_N_m_per_rad=1.0, target_rad=0.1, target_deg=5.0),  # 9
        dict(kind="constant", value_N_m=1.0, colour="red"),                               # 10
    )
    d = dict(problems_of(tmp_path, text).problems)
    assert d["inputs[1].value_N"] == "theta_1 is an angle: its input is a torque in N m; use value_N_m"
    assert d["inputs[2].amplitude_N_m"] == "delta_2_1 is a length: its input is a force in N; use amplitude_N"
    assert d["inputs[3].value_N"] == "delta_2_2 is an angle: its input is a torque in N m; use value_N_m"
    assert d["inputs[4].frequency_hz"] == "not a key of a 'constant' input (its keys: value_N_m)"
    assert d["inputs[5].frequency_hz"] == "missing (a 'sine' input on theta_1 needs amplitude_N_m, frequency_hz)"
    assert d["inputs[6].coordinate"].startswith("unknown coordinate X1 (a fixed base has no X1")
    assert d["inputs[7].kind"] == "unknown input kind 'spring'; use one of constant, sine, ramp, pd"
    assert d["inputs[8].end_s"] == "must be after start_s = 1 s, got 0.5"
    assert d["inputs[9].target_deg"] == "sets the target again (already set by target_rad); give one of them"
    assert d["inputs[10].coordinate"].startswith("missing") and d["inputs[10].colour"].startswith("unknown key")
    d = dict(problems_of(tmp_path, "inputs = 3\n" + ARM).problems)
    assert d["inputs"] == "expected [[inputs]] tables, got the number 3"


def test_fe_slopes_take_angle_units(tmp_path):
    # An FE node slope is an angle: delta_1_2_deg is read in degrees; delta_1_2_m is refused.
    text = (CASES / "fixed_base_fe_arm.toml").read_text()
    head, sep, tail = text.partition("[initial.coordinates]")
    good = tmp_path / "good.toml"
    good.write_text(head + sep + "\ndelta_1_2_deg = 1.0\ndelta_1_1_m = 0.001\n" + tail)
    case = gi.load_case(good)
    names = case.model.coordinate_names
    assert case.q0[names.index("delta_1_2")] == pytest.approx(np.radians(1.0))
    assert case.q0[names.index("delta_1_1")] == pytest.approx(0.001)
    bad = tmp_path / "bad.toml"
    bad.write_text(head + sep + "\ndelta_1_2_m = 0.01\n" + tail)
    with pytest.raises(gi.CaseError, match=r"delta_1_2 takes unit rad or deg, not m"):
        gi.load_case(bad)


# -- prismatic joints, the planar base, joint limits --------------------------

# A rigid rod hanging from a guide at the base origin (Pb, joint 1): d_1'' = g, so from
# d_1 = 0.2 m at rest it reaches d_max = 0.5 m at t = sqrt(2 * 0.3 / 9.81) = 0.24731 s.
DROP = PB_DROP_CASE

# An R-Pb chain and an R-Pa chain on a fixed base, finite-element links: the joint tables
# are appended to the second [[links]] table.
TWO = """
gravity_m_per_s2 = [0.0, -9.81, 0.0]

[base]
type = "fixed"

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 25.0
elements = 2

[[links]]
length_m = 0.6
mass_per_length_kg_per_m = 0.5
EI_N_m2 = 8.0
elements = 2
"""
PB = TWO + '\n[links.joint]\ntype = "Pb"\nrange_m = [0.2, 0.6]\n'
PA = TWO + '\n[links.joint]\ntype = "Pa"\nangle_rad = 0.6\nhalf_length_m = 0.04\nrange_m = [0.1, 0.95]\n'
START = "\n[initial.coordinates]\nd_2_m = 0.4\n\n[time]\nt_end_s = 0.1\n"


def test_R_Pb_case_parameters():
    case = gi.load_case(CASES / "fixed_base_R_Pb_arm.toml")
    m = case.model
    assert m.joint_kinds == ("R", "Pb")
    assert m.chain.joints == (gi.Revolute(), gi.FixedPrismatic(angle=0.0, range=(0.25, 0.75)))
    assert m.chain.base == gi.FixedBase((0.0, 0.0), 0.0)
    assert [(lk.length, lk.mass_per_length, lk.EI, lk.elements) for lk in m.chain.links] == [
        (1.0, 1.0, (25.0, 25.0), 3), (0.8, 0.5, (2.0, 2.0), 2)]
    assert m.coordinate_names == ("theta_1", "d_2", *(f"delta_1_{k}" for k in range(1, 7)),
                                  *(f"delta_2_{k}" for k in range(1, 5)))
    assert m.coordinate_units[:2] == ("rad", "m")
    np.testing.assert_allclose(case.q0, m.state(theta_1=-math.pi / 2, d_2=0.45), rtol=0, atol=1e-16)
    assert not np.any(case.qdot0) and case.t_span == (0.0, 2.0) and case.walls == ()
    assert case.solver == {"method": "DOP853", "rtol": 1e-8, "atol": 1e-10, "output_dt": 1e-3, "joint_limit": "stop"}
    assert [(s.coordinate, s.kind) for s in case.inputs] == [("theta_1", "sine"), ("d_2", "sine"), ("d_2", "pd")]
    assert dict(case.inputs[1].parameters) == {"amplitude": 6.0, "frequency": 0.5, "phase": 0.0, "offset": -3.9}
    assert dict(case.inputs[2].parameters) == {"target": 0.45, "stiffness": 50.0, "damping": 4.0}
    # Hanging straight down: the mass centres of link 1 (0.5 m) and of link 2 (1 + d - l/2 = 1.05 m) below O1.
    assert case.initial_energy().total == pytest.approx(-9.81 * (1.0 * 0.5 + 0.4 * 1.05), rel=1e-13)
    # The slide's inputs about hold link 2 against its weight at t = 0.
    f = case.simulate_kwargs()["inputs"]
    assert f["d_2"](0.0, case.q0, case.qdot0) == pytest.approx(-3.9)


def test_R_Pa_case_parameters():
    case = gi.load_case(CASES / "fixed_base_R_Pa_arm.toml")
    m = case.model
    assert m.joint_kinds == ("R", "Pa") and m.coordinate_names[:3] == ("theta_1", "d_2", "delta_1_1")
    (jt,) = m.chain.joints[1:]
    assert isinstance(jt, gi.SlidingPrismatic)
    assert jt.angle == pytest.approx(math.pi / 2, rel=1e-15)  # angle_deg = 90 in radians
    assert (jt.half_length, jt.range) == (0.04, (0.1, 0.9))
    np.testing.assert_allclose(case.q0, m.state(theta_1=-math.pi / 2, d_2=0.6), rtol=0, atol=1e-16)


@pytest.mark.parametrize("name", ["fixed_base_R_Pb_arm", "fixed_base_R_Pa_arm"])
def test_joint_cases_round_trip_through_case_from_dict(name):
    import tomllib

    path = CASES / f"{name}.toml"
    a = gi.load_case(path)
    b = case_from_dict(tomllib.loads(path.read_text()), name=name)
    assert a.model.chain.joints == b.model.chain.joints and a.model.coordinate_names == b.model.coordinate_names
    np.testing.assert_array_equal(a.q0, b.q0)
    assert a.solver == b.solver and a.inputs == b.inputs


def test_inline_joint_table_and_defaults(tmp_path):
    # joint = { ... } inline is the same as [links.joint]; angle defaults to 0; "R" is the default joint.
    text = TWO.replace('EI_N_m2 = 8.0\n', 'EI_N_m2 = 8.0\njoint = { type = "Pb", range_m = [0.2, 0.6] }\n')
    case = gi.load_case(write(tmp_path, text + START))
    assert case.model.chain.joints == (gi.Revolute(), gi.FixedPrismatic(range=(0.2, 0.6)))
    explicit_r = TWO.replace('EI_N_m2 = 25.0\n', 'EI_N_m2 = 25.0\njoint = { type = "R" }\n')
    case = gi.load_case(write(tmp_path, explicit_r + "\n[time]\nt_end_s = 0.1\n"))
    assert case.model.joint_kinds == ("R", "R")


def test_pa_joint_angle_rad_and_inputs_on_d(tmp_path):
    text = with_inputs(PA + START, dict(coordinate="d_2", kind="pd", target_m=0.5, stiffness_N_per_m=20.0,
                                        damping_N_s_per_m=1.5),
                       dict(coordinate="d_2", kind="ramp", slope_N_per_s=2.0, end_s=0.5))
    text = text.replace("d_2_m = 0.4", "d_2_m = 0.4\n\n[initial.velocities]\nd_2_m_per_s = 0.1")
    case = gi.load_case(write(tmp_path, text))
    assert case.model.chain.joints[1] == gi.SlidingPrismatic(angle=0.6, half_length=0.04, range=(0.1, 0.95))
    k = case.model.coordinate_names.index("d_2")
    assert (case.q0[k], case.qdot0[k]) == (0.4, 0.1)
    f = case.simulate_kwargs()["inputs"]["d_2"]
    assert f(1.0, case.q0, case.qdot0) == pytest.approx(20.0 * 0.1 - 1.5 * 0.1 + 2.0 * 0.5)


def test_planar_base(tmp_path):
    text = TWO.replace('type = "fixed"', 'type = "planar"') + """
[initial]
center_of_mass_m = [0.3, 0.2]
center_of_mass_velocity_m_per_s = [0.1, -0.2, 0.0]

[initial.coordinates]
theta_1_deg = 30.0

[time]
t_end_s = 0.1
"""
    case = gi.load_case(write(tmp_path, text))
    m = case.model
    assert m.chain.base == "planar" and m.coordinate_names[:4] == ("X1", "X2", "theta_1", "theta_2")
    assert case.q0[2] == pytest.approx(math.radians(30.0), rel=1e-15)
    np.testing.assert_allclose(m.center_of_mass(case.q0), [0.3, 0.2, 0.0], atol=1e-15)
    np.testing.assert_allclose(m.linear_momentum(case.q0, case.qdot0) / m.total_mass, [0.1, -0.2, 0.0], atol=1e-14)
    bad = text.replace("[0.1, -0.2, 0.0]", "[0.1, -0.2, 0.5]") + "\n[initial.velocities]\nX1_m_per_s = 1.0\n"
    bad = bad.replace("theta_1_deg = 30.0", "theta_1_deg = 30.0\ntheta_0_rad = 0.1")
    d = dict(problems_of(tmp_path, bad).problems)
    assert d["initial.center_of_mass_velocity_m_per_s"].startswith(
        "a planar base ([base] type = 'planar') moves in the X1-X2 plane: the third component must be 0, got 0.5")
    assert d["initial.coordinates.theta_0_rad"].startswith("unknown coordinate theta_0 (a planar base has no X3, "
                                                           "theta_-1, theta_0")
    d = dict(problems_of(tmp_path, text.replace('type = "planar"', 'type = "planar"\nangle_deg = 5')).problems)
    assert d["base.angle_deg"].startswith("a planar free-flying base has no fixed position or angle")
    # center_of_mass_m together with X1_m names the planar coordinates.
    both = text.replace("theta_1_deg = 30.0", "theta_1_deg = 30.0\nX2_m = 0.1")
    d = dict(problems_of(tmp_path, both).problems)
    assert d["initial.center_of_mass_m"] == "sets X1, X2; remove X1_m/X2_m from [initial.coordinates]"


JOINT_ERRORS = [
    # (base text, old, new, key path, start of the message)
    (PB, 'type = "Pb"', 'type = "P"', "links[2].joint.type", "unknown joint type 'P'; use 'R' (revolute"),
    (PB, 'type = "Pb"', 'type = "pb"', "links[2].joint.type", "unknown joint type 'pb'; did you mean 'Pb'?"),
    (PB, 'type = "Pb"\n', "", "links[2].joint.type", "missing ('R' (revolute, the default)"),
    (PB, "range_m = [0.2, 0.6]", "rang_m = [0.2, 0.6]", "links[2].joint.rang_m",
     "unknown key (did you mean 'range_m'?)"),
    (PB, "range_m = [0.2, 0.6]", "angle_deg = 5.0", "links[2].joint.range_m", "missing ([d_min, d_max] in m"),
    (PB, "[0.2, 0.6]", "[0.6, 0.2]", "links[2].joint.range_m",
     "must be [d_min, d_max] with d_min < d_max, got [0.6, 0.2]"),
    (PB, "[0.2, 0.6]", "[0.2]", "links[2].joint.range_m", "expected an array of 2 numbers, got an array of 1"),
    (PB, "[0.2, 0.6]", "[0.0, 0.6]", "links[2].joint.range_m", "d_min = 0 m must be > 0: a Pb joint's d is the "
                                                               "length protruding from the guide"),
    (PB, "[0.2, 0.6]", "[0.2, 0.7]", "links[2].joint.range_m",
     "d_max = 0.7 m is more than links[2].length_m = 0.6: d_2 is the length protruding from the guide"),
    (PB, "range_m", "half_length_m = 0.1\nrange_m", "links[2].joint.half_length_m",
     "only a Pa carriage has a half-length"),
    (PB, "range_m", "angle_deg = 1.0\nangle_rad = 0.1\nrange_m", "links[2].joint.angle_rad",
     "sets the joint angle again (already set by angle_deg)"),
    (PB, 'type = "Pb"', 'type = "R"', "links[2].joint.range_m",
     "a revolute joint (type = 'R') has no [d_min, d_max]: remove it, or set type = 'Pa' or 'Pb'"),
    (PB, "[base]\ntype = \"fixed\"\n", "", "links[2].joint.type",
     "a prismatic joint ('Pb') needs a planar chain, and a chain without [base]"),
    (PB, 'elements = 2\n\n[links.joint]', 'modes = [{ kind = "clamped-free" }]\n\n[links.joint]',
     "links[2].modes", "link 2 slides through a Pb guide (links[2].joint): it is discretised by stretching"),
    (PB, "EI_N_m2 = 25.0\nelements = 2", 'EI_N_m2 = 25.0\nelements = 2\nelement_directions = ["y", "z"]',
     "links[1].element_directions", "a planar chain (prismatic joints or [base] type = 'planar') bends in the plane"),
    # A Pb link's element frequencies grow like (l / d)^2: fine at d = l (2.7e10 rad/s), not at d_min.
    (PB.replace("[0.2, 0.6]", "[0.05, 0.6]"), "EI_N_m2 = 8.0", "EI_N_m2 = 1e15", "links[2].EI_N_m2",
     "makes the highest mode of elements = 2 vibrate at omega = 3.90217e12 rad/s with length_m = 0.6 and "
     "mass_per_length_kg_per_m = 0.5 at the shortest protruding length d_min = 0.05 m (links[2].joint.range_m)"),
    (PA, "half_length_m = 0.04", "half_length_m = 0.0", "links[2].joint.half_length_m",
     "must be > 0 on a finite-element host (links[1].elements = 2), got 0"),
    (PA, "[0.1, 0.95]", "[0.02, 0.95]", "links[2].joint.range_m",
     "the carriage must stay on link 1: half_length_m <= d_min < d_max <= links[1].length_m - half_length_m = "
     "0.96 m, got [0.02, 0.95] with half_length_m = 0.04"),
    (PA, "EI_N_m2 = 25.0\nelements = 2", 'EI_N_m2 = 25.0\nmodes = [{ kind = "clamped-free" }]',
     "links[2].joint.type", "a Pa carriage rides on link 1, which has assumed modes"),
    (PA, '[base]\ntype = "fixed"', '[base]\ntype = "planar"', "links[2].element_directions", None),
]


@pytest.mark.parametrize("text,old,new,key,message", JOINT_ERRORS, ids=[e[3] + "-" + str(k) for k, e in
                                                                       enumerate(JOINT_ERRORS)])
def test_joint_errors_name_the_key(tmp_path, text, old, new, key, message):
    assert old in text
    bad = text.replace(old, new, 1) + START
    if message is None:  # a planar base and a carriage: valid
        assert gi.load_case(write(tmp_path, bad)).model.coordinate_names[:4] == ("X1", "X2", "theta_1", "d_2")
        return
    d = dict(problems_of(tmp_path, bad).problems)
    assert key in d, d
    assert d[key].startswith(message), d[key]


def test_planar_base_needs_a_revolute_joint_1(tmp_path):
    text = DROP.replace('type = "fixed"\nangle_deg = -90.0', 'type = "planar"')
    d = dict(problems_of(tmp_path, text).problems)
    assert d["links[1].joint.type"].startswith("on a planar free-flying base ([base] type = 'planar') joint 1 "
                                               "must be 'R'")


def test_pa_carriage_on_a_pb_link_must_start_on_its_protruding_part(tmp_path):
    # R, Pb (flexible link 2), Pa on link 2: the carriage's state-dependent bound
    # d_3 - c >= l_2 - d_2 (gibbsimpact.limits) is checked at t = 0 and named.
    three = PB + """
[[links]]
length_m = 0.3
mass_per_length_kg_per_m = 0.5
EI_N_m2 = 8.0

[links.joint]
type = "Pa"
half_length_m = 0.02
range_m = [0.05, 0.5]
""" + START
    ok = gi.load_case(write(tmp_path, three.replace("d_2_m = 0.4", "d_2_m = 0.4\nd_3_m = 0.4")))
    assert ok.model.joint_kinds == ("R", "Pb", "Pa")
    d = dict(problems_of(tmp_path, three.replace("d_2_m = 0.4", "d_2_m = 0.4\nd_3_m = 0.1")).problems)
    assert list(d) == ["initial.coordinates.d_3_m"]
    assert d["initial.coordinates.d_3_m"].startswith("d_3 = 0.1 m, d_2 = 0.4 m is outside the range of joint 3: "
                                                     "d_3 - c >= l_")
    assert d["initial.coordinates.d_3_m"].endswith("(links[3].joint.range_m); change the initial value")


def test_initial_d_outside_its_range_names_the_key(tmp_path):
    d = dict(problems_of(tmp_path, PB + START.replace("d_2_m = 0.4", "d_2_m = 0.7")).problems)
    assert d == {"initial.coordinates.d_2_m": "d_2 = 0.7 m is outside the range of joint 2: d_2 <= d_max = 0.6 m "
                                              "(links[2].joint.range_m); change the initial value"}
    # Not given: d_2 = 0, outside every Pb range (and the kinematics would divide by d).
    d = dict(problems_of(tmp_path, PB + START.replace("d_2_m = 0.4", "theta_1_deg = 10")).problems)
    assert d == {"initial.coordinates": "d_2 = 0 m is outside the range of joint 2: d_2 >= d_min = 0.2 m "
                                        "(links[2].joint.range_m); set initial.coordinates.d_2_m (0 when not given)"}


def test_joint_coordinate_names_and_units(tmp_path):
    text = PB + START.replace("d_2_m = 0.4", "d_2_m = 0.4\ntheta_2_deg = 5\nd_1_m = 0.1")
    d = dict(problems_of(tmp_path, text).problems)
    assert d["initial.coordinates.theta_2_deg"].startswith(
        "unknown coordinate theta_2 (joint 2 is prismatic: its coordinate is d_2 in m, set by links[2].joint.type)")
    assert d["initial.coordinates.d_1_m"].startswith(
        "unknown coordinate d_1 (joint 1 is revolute: its coordinate is theta_1")
    d = dict(problems_of(tmp_path, PB + START.replace("d_2_m = 0.4", "d_2_deg = 20")).problems)
    assert d["initial.coordinates.d_2_deg"] == "d_2 takes unit m, not deg"
    d = dict(problems_of(tmp_path, PB + START.replace("d_2_m = 0.4", "d_2 = 0.4")).problems)
    assert d["initial.coordinates.d_2"] == "add the unit to the key: d_2_m"
    text = with_inputs(PB + START, dict(coordinate="d_2", kind="constant", value_N_m=1.0))
    d = dict(problems_of(tmp_path, text).problems)
    assert d["inputs[1].value_N_m"] == "d_2 is a length: its input is a force in N; use value_N"


def test_joint_limit_solver_keys(tmp_path):
    from gibbsimpact.case.schema import _SOLVER_CHOICES
    from gibbsimpact.simulation.joint_limits import JOINT_LIMIT_MODES

    assert tuple(_SOLVER_CHOICES["joint_limit"]) == JOINT_LIMIT_MODES
    case = gi.load_case(write(tmp_path, DROP + '\n[solver]\njoint_limit = "impact"\njoint_restitution = 1.0\n'))
    assert case.solver == {"joint_limit": "impact", "joint_restitution": 1.0}
    kw = case.simulate_kwargs(joint_limit="stop")
    assert kw["joint_limit"] == "stop" and kw["joint_restitution"] == 1.0
    d = dict(problems_of(tmp_path, DROP + '\n[solver]\njoint_limit = "bounce"\njoint_restitution = 1.5\n').problems)
    assert d["solver.joint_limit"] == ("unknown value 'bounce'; use 'stop' (end the run with status joint_limit) or "
                                       "'impact' (an end-stop impact)")
    assert d["solver.joint_restitution"] == "must be in [0, 1] (1 = elastic, 0 = plastic), got 1.5"
    problems = dict(case.override_problems(joint_limit="bounce", joint_restitution=2.0))
    assert problems["joint_limit"].startswith("unknown value 'bounce'")
    assert problems["joint_restitution"].startswith("must be in [0, 1]")
    with pytest.raises(CaseError, match="joint_limit: unknown value 'bounce'"):
        case.simulate_kwargs(joint_limit="bounce")


def test_rod_through_a_base_guide_reaches_its_limit_in_closed_form(tmp_path):
    case = gi.load_case(write(tmp_path, DROP))
    m = case.model
    assert m.coordinate_names == ("d_1",) and m.joint_kinds == ("Pb",)
    # The rod points down from the guide; its rear end is l - d behind it: O1 at (0, l - d), O2 at (0, -d).
    np.testing.assert_allclose(m.joint_positions(case.q0)[:, :2], [[0.0, 0.4], [0.0, -0.2]], atol=1e-15)
    res = case.simulate(rtol=1e-11, atol=1e-13)  # joint_limit "stop" by default
    assert res.status == "joint_limit" and "joint 1 reached its limit d_1 <= d_max = 0.5 m" in res.message
    assert res.t[-1] == pytest.approx(math.sqrt(2 * 0.3 / 9.81), rel=1e-8)
    # "impact" with e = 1: the rod bounces off the end stop and energy is kept.
    res = case.simulate(rtol=1e-11, atol=1e-13, joint_limit="impact", joint_restitution=1.0)
    assert res.status == "finished" and [(r.wall, r.joints) for r in res.impacts] == [((-1,), (1,))]
    assert res.impacts[0].time == pytest.approx(math.sqrt(2 * 0.3 / 9.81), rel=1e-8)
    E = res.energy().total
    assert abs(E[-1] - E[0]) < 1e-9
