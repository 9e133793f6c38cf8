"""A case file into a Case (gibbsimpact.case.builders): the published cases, walls, inputs, the Case's
settings for simulate, and problems reported once, at the key to change."""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.case import CaseError, case_from_dict
from gibbsimpact.case.keypaths import within
from gibbsimpact.model.elements import MAX_ELEMENTS
from case_texts import CASES, GOOD, write, problems_of, ROD, ARM, with_inputs, DROP, PA, START

CASE_FILES = sorted(CASES.glob("*.toml"))


def Rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def Ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def Rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


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
    assert case.solver == {"method": "auto", "rtol": 1e-2, "atol": 1e-4, "output_dt": 1e-3, "joint_limit": "stop"}
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


def test_name_defaults_to_file_stem(tmp_path):
    case = gi.load_case(write(tmp_path, GOOD.replace('name = "tiny"\n', ""), name="my_case.toml"))
    assert case.name == "my_case"


def test_case_from_dict_equals_file(tmp_path):
    import tomllib

    a = gi.load_case(write(tmp_path, GOOD))
    b = case_from_dict(tomllib.loads(GOOD))
    np.testing.assert_array_equal(a.q0, b.q0)


def test_defaults_and_simulate_overrides(tmp_path):
    case = gi.load_case(write(tmp_path, GOOD))
    assert case.name == "tiny" and case.t_span == (0.0, 0.1) and case.solver == {}
    assert case.output["plots"] is True and case.output["animate"] is False
    assert case.output_directory == Path("out") / "tiny"
    kw = case.simulate_kwargs(t_end=0.05, rtol=1e-6)
    assert kw["t_span"] == (0.0, 0.05) and kw["rtol"] == 1e-6 and kw["walls"] == case.walls
    res = case.simulate(t_end=0.01, rtol=1e-8, atol=1e-10)
    assert res.status == "finished" and res.t[-1] == pytest.approx(0.01)


def test_unknown_top_level_and_wall_keys(tmp_path):
    err = problems_of(tmp_path, "colour = 'red'\n" + GOOD.replace("radius_m = 1.5", "radius = 1.5"))
    paths = [p for p, _ in err.problems]
    assert "colour" in paths
    assert "walls[1].radius" in paths
    assert "walls[1].radius_m" in paths  # and the required key is then missing


def test_plane_wall_and_zero_normal(tmp_path):
    text = GOOD.replace('type = "circle"\nradius_m = 1.5', 'type = "plane"\npoint_m = [0, -1, 0]\nnormal = [0, 0, 0]')
    err = problems_of(tmp_path, text)
    assert err.problems == [("walls[1].normal", "is the zero vector; give a direction")]
    ok = gi.load_case(write(tmp_path, text.replace("normal = [0, 0, 0]", "normal = [0, 2, 0]")))
    assert ok.walls[0].normal_vector == (0.0, 1.0, 0.0) and ok.walls[0].point == (0.0, -1.0, 0.0)


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


# -- problems that stand on their own (issue 23 item 11) -------------------------------------

def every_coordinate(data: dict) -> dict:
    """data with every coordinate and rate of its model in [initial.coordinates] / [initial.velocities],
    each in the model's own unit (an FE node slope in rad), so that every key there is checked."""
    case = case_from_dict(data)
    m, init = case.model, data.setdefault("initial", {})
    for table, values, suffix, com in (("coordinates", case.q0, "", "center_of_mass_m"),
                                       ("velocities", case.qdot0, "_per_s", "center_of_mass_velocity_m_per_s")):
        init[table] = {f"{n}_{u}{suffix}": float(v) for n, u, v in zip(m.coordinate_names, m.coordinate_units, values)
                       if not (com in init and n in ("X1", "X2", "X3"))}
    case_from_dict(data)  # still a valid case
    return data


def _setter(k, *keys, value=None, delete=False):
    """An edit of data['links'][k][keys...] (k None: of data[keys...]) that sets value or deletes the key."""
    def edit(data):
        node = data if k is None else data["links"][k]
        for key in keys[:-1]:
            node = node.setdefault(key, {})
        if delete:
            del node[keys[-1]]
        else:
            node[keys[-1]] = value
    return edit


def wrong_keys(data: dict) -> dict:
    """{kind: [(key path, edit)]}: one wrong key each, of the kinds that keep the chain from being
    built: elements, EI_N_m2, a joint's type or range, a missing base.type."""
    out = {"elements": [], "EI_N_m2": [], "joint.type": [], "joint.range_m": [], "base.type": []}
    for k, link in enumerate(data["links"]):
        p = f"links[{k + 1}]"
        for v in (-1, MAX_ELEMENTS + 1, 2.5, "4", True) + ((2,) if "modes" in link else ()):  # 2: with modes
            out["elements"].append((f"{p}.elements", _setter(k, "elements", value=v)))
        for v in (-1.0, 0.0, 1e16, "stiff", [1.0], [20.0, -1.0]):
            out["EI_N_m2"].append((f"{p}.EI_N_m2", _setter(k, "EI_N_m2", value=v)))
        out["EI_N_m2"].append((f"{p}.EI_N_m2", _setter(k, "EI_N_m2", delete=True)))
        for v in ("P", "pb", "X", 1, ""):
            out["joint.type"].append((f"{p}.joint.type", _setter(k, "joint", "type", value=v)))
        joint = link.get("joint", {"type": "R"})
        if joint["type"] in ("R", "W"):  # a revolute joint or a weld has no range
            out["joint.range_m"].append((f"{p}.joint.range_m", _setter(k, "joint", value={**joint, "range_m": [0.1, 0.2]})))
            continue
        lo, hi = joint["range_m"]
        for v in ([hi, lo], [lo], "far", [lo, 100.0], [0.0 if joint["type"] == "Pb" else -1.0, hi]):
            out["joint.range_m"].append((f"{p}.joint.range_m", _setter(k, "joint", "range_m", value=v)))
        out["joint.range_m"].append((f"{p}.joint.range_m", _setter(k, "joint", "range_m", delete=True)))
    if "type" in data.get("base", {}):
        out["base.type"].append(("base.type", _setter(None, "base", "type", delete=True)))
    else:  # a [base] table without its type
        out["base.type"].append(("base.type", _setter(None, "base", value={"position_m": [0.0, 0.0]})))
    return out


def malformed(path: Path, n: int = 40, seed: int = 23) -> list:
    """n (key path, case table) of path's case, each with one wrong key, drawn with a fixed seed:
    a kind, then a key and value of that kind."""
    good = every_coordinate(tomllib.loads(path.read_text()))
    kinds = wrong_keys(good)
    rng = np.random.default_rng(seed)
    out = []
    for kind in rng.choice(sorted(kinds), size=n):
        key, edit = kinds[kind][rng.integers(len(kinds[kind]))]
        bad = copy.deepcopy(good)
        edit(bad)
        out.append((key, bad))
    return out


@pytest.mark.parametrize("path", CASE_FILES, ids=[p.stem for p in CASE_FILES])
def test_a_link_that_cannot_be_built_blames_no_correct_key(path):
    # Every problem names the wrong key or a key within it; none blames a correct key for the
    # wrong one (e.g. "delta_1_2 takes unit m, not rad" for a correct slope of an FE link).
    blamed = []
    for key, bad in malformed(path):
        with pytest.raises(CaseError) as info:
            case_from_dict(bad)
        problems = info.value.problems
        assert any(p == key for p, _ in problems), (key, problems)
        blamed += [(key, p, m) for p, m in problems if not within(p, key)]
    assert not blamed, "\n".join(f"{key} wrong, blamed {p}: {m}" for key, p, m in blamed[:10])


def test_obstacle_walls_in_a_case_file_round_trip_through_a_result_file(tmp_path):
    """[[walls]] with inside = false builds an obstacle (Circle/Sphere inside=False), inside = true or no key
    a container; the run's result file stores the obstacle and reads it back equal; a non-boolean is
    refused at its key."""
    text = GOOD + ('\n[[walls]]\ntype = "circle"\nradius_m = 0.1\ncenter_m = [0.3, 0.4]\ninside = false\n'
                   '\n[[walls]]\ntype = "sphere"\nradius_m = 0.2\ncenter_m = [-0.3, 0.5, 0.0]\ninside = false\n'
                   'friction = 0.3\n\n[[walls]]\ntype = "sphere"\nradius_m = 2.0\ninside = true\n')
    case = gi.load_case(write(tmp_path, text))
    assert case.walls == (gi.Circle(1.5), gi.Circle(0.1, (0.3, 0.4), inside=False),
                          gi.Sphere(0.2, (-0.3, 0.5, 0.0), friction=0.3, inside=False), gi.Sphere(2.0))
    res = case.simulate(t_end=0.01)
    back = gi.load_result(res.save(tmp_path / "r.npz"))
    assert back.walls == case.walls
    err = problems_of(tmp_path, text.replace("inside = false", 'inside = "no"', 1))
    assert [p for p, _ in err.problems] == ["walls[2].inside"]


def test_walls_of_the_compliant_law(tmp_path):
    """stiffness, exponent, damping of a [[walls]] table make the wall compliant (contact.compliant); without
    stiffness it keeps Newton's law; a bad damping name or exponent is a problem of that key; a result file
    keeps them."""
    from gibbsimpact.io.plain_data import wall_from_dict, wall_to_dict

    law = 'stiffness = 1e6\nexponent = 1.0\ndamping = "lankarani-nikravesh"'
    text = GOOD.replace('radius_m = 1.5', 'radius_m = 1.5\n' + law)
    (wall,) = gi.load_case(write(tmp_path, text)).walls
    assert wall == gi.Circle(radius=1.5, stiffness=1e6, exponent=1.0, damping="lankarani-nikravesh")
    assert wall_from_dict(wall_to_dict(wall)) == wall
    assert gi.load_case(write(tmp_path, GOOD)).walls[0].stiffness is None
    err = problems_of(tmp_path, text.replace('"lankarani-nikravesh"', '"hertz"'))
    assert [p for p, _ in err.problems] == ["walls[1].damping"]
    err = problems_of(tmp_path, text.replace("exponent = 1.0", "exponent = 0.5"))
    assert [p for p, _ in err.problems] == ["walls[1].exponent"]
