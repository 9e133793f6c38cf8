"""[initial] into (q0, qdot0) and the checks at t = 0 (gibbsimpact.case.initial): coordinates by name
and unit, the mass centre, joint ranges, contact points beyond a wall, a regular mass matrix."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.link_points import material_points
from case_texts import CASES, GOOD, write, problems_of, ARM, with_inputs, TWO, PB, START
from conftest import deepest_point


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


def test_joint_outside_wall(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("X1_m = -0.5", "X1_m = 1.0"))
    assert len(err.problems) == 1
    path, msg = err.problems[0]
    assert path == "initial"
    assert "joint O2" in msg and "outside walls[1]" in msg and "circle R=1.5" in msg and "by 0.5 m" in msg


def test_singular_mass_matrix_is_reported(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("rotary_inertia_kg_m = [5e-5, 2.5e-5, 2.5e-5]\n", ""))
    (path, msg), = err.problems
    assert path == "links" and "singular" in msg and "rotary_inertia" in msg


def test_a_free_base_at_gimbal_lock_is_a_valid_start(tmp_path):
    # docs/case-format.md: theta_0 = +-90 deg is no singular start, a run re-charts the base there (theory
    # §2.1). The case check computed M in the given chart and refused it; in the run's start chart M is
    # regular. A single link without rotary inertia stays singular in every chart, and is still refused.
    text = GOOD.replace("X1_m = -0.5", "X1_m = -0.5\ntheta_0_deg = 90.0")
    case = gi.load_case(write(tmp_path, text))
    assert case.q0[4] == pytest.approx(math.pi / 2, abs=1e-15)
    err = problems_of(tmp_path, text.replace("rotary_inertia_kg_m = [5e-5, 2.5e-5, 2.5e-5]\n", ""))
    assert [p for p, _ in err.problems] == ["links"] and "rotary_inertia" in err.problems[0][1]


# -- without a chain, no problem blames a correct key (issue 23 item 11) ----------------------

def test_a_slope_of_a_finite_element_link_is_not_judged_without_the_chain(tmp_path):
    text = (CASES / "fixed_base_fe_arm.toml").read_text().replace(
        "theta_2_deg = 0.0", "theta_2_deg = 0.0\ndelta_1_2_rad = 0.01\ndelta_1_1_m = 0.001")
    bad = text.replace("EI_N_m2 = 8.0", "EI_N_m2 = -8.0")
    assert [p for p, _ in problems_of(tmp_path, bad).problems] == ["links[2].EI_N_m2"]
    bad = text.replace('type = "fixed"\n', "")
    assert problems_of(tmp_path, bad).problems == [("base.type", "missing ('fixed', 'free' or 'planar')")]
    # With the chain built, the same keys are judged: a slope takes an angle unit.
    assert problems_of(tmp_path, text.replace("delta_1_2_rad", "delta_1_2_m")).problems == [
        ("initial.coordinates.delta_1_2_m", "delta_1_2 takes unit rad or deg, not m")]
    # Units that hold for every model are judged without one.
    bad = text.replace("EI_N_m2 = 8.0", "EI_N_m2 = -8.0").replace("theta_2_deg = 0.0", "theta_2_m = 0.0")
    assert dict(problems_of(tmp_path, bad).problems)["initial.coordinates.theta_2_m"] == "theta_2 takes unit rad or deg, not m"


def test_a_planar_center_of_mass_is_not_judged_without_the_base_type(tmp_path):
    # The R-R chain of TWO on a planar floating base, placed by its mass centre (two numbers).
    planar = TWO.replace('type = "fixed"', 'type = "planar"') + "\n[initial]\ncenter_of_mass_m = [0.3, 0.2]\n" \
        "\n[time]\nt_end_s = 0.1\n"
    p = tmp_path / "planar.toml"
    p.write_text(planar)
    assert gi.load_case(p).model.chain.base == "planar"
    assert problems_of(tmp_path, planar.replace('type = "planar"\n', "")).problems == [
        ("base.type", "missing ('fixed', 'free' or 'planar')")]


# -- a link bent across a wall at t = 0 (issue 23 item 12) --------------------------------------

# One finite-element link on a fixed base, both joints inside the floor y = 0 (and inside the
# circle), its middle bent below it by the initial deflection delta_1_1.
BENT = """
gravity_m_per_s2 = [0.0, -9.81, 0.0]

[base]
type = "fixed"
position_m = [0.0, 0.15]
angle_deg = 3.0

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 10.0
elements = 2

[[walls]]
{wall}

[initial.coordinates]
delta_1_1_m = -0.25
delta_1_2_rad = 0.2
delta_1_3_m = 0.02

[time]
t_end_s = 0.1
"""
WALLS = {"plane": 'type = "plane"\nnormal = [0.0, 1.0, 0.0]', "circle": 'type = "circle"\nradius_m = 1.2\ncenter_m = [0.5, 1.2]'}


@pytest.mark.parametrize("wall", sorted(WALLS))
def test_a_link_bent_across_a_wall_names_the_link_its_point_and_the_depth(tmp_path, wall):
    text = BENT.format(wall=WALLS[wall])
    # Joints only ([solver] link_contacts = false, the published model): the state loads, every joint inside.
    (tmp_path / "joints_only.toml").write_text(text + "\n[solver]\nlink_contacts = false\n")
    case = gi.load_case(tmp_path / "joints_only.toml")
    (w,) = case.walls
    assert np.all(w.gap(case.model.joint_positions(case.q0)) > 0.03)
    (path, message), = problems_of(tmp_path, text).problems
    m = re.fullmatch(r"link 1 at x = (\S+) m of its 1 m, the point \((\S+), (\S+), (\S+)\) m, is beyond "
                     r"walls\[1\] \((.+)\) by (\S+) m at t = 0: link 1 is bent across the wall between its joints; "
                     r"move the chain inside or straighten the link \(its initial.coordinates.delta_1_\*\)", message)
    assert path == "initial" and m, message
    x_ref, depth_ref = deepest_point(case.model, case.q0, 0, w)
    assert depth_ref > 0.07  # well beyond the wall
    # Printed to 6 significant digits: off by half a unit of the 6th digit, relative 5e-6, at most.
    assert float(m[6]) == pytest.approx(depth_ref, rel=5e-6)
    assert float(m[1]) == pytest.approx(x_ref, rel=5e-6)
    p_ref = material_points(case.model, case.q0, 0, [x_ref])[0]
    np.testing.assert_allclose([float(m[k]) for k in (2, 3, 4)], p_ref, rtol=5e-6, atol=1e-12)


def test_a_link_through_an_obstacle_names_the_obstacle_and_the_fix(tmp_path):
    # GOOD's link lies straight on X1 from -0.5 to 0.5 m; a post of R = 0.1 m at the origin has it 0.1 m deep.
    text = GOOD + '\n[[walls]]\ntype = "circle"\nradius_m = 0.1\ninside = false\n'
    (path, message), = problems_of(tmp_path, text).problems
    assert path == "initial"
    assert re.fullmatch(r"link 1 at x = 0\.5 m of its 1 m, the point \(0, 0, 0\) m, is beyond walls\[2\] \(circle "
                        r"R=0\.1 m centre \(0, 0\) \(obstacle: the chain stays outside\)\) by 0\.1 m at t = 0: link 1 "
                        r"passes through it between its joints; move the chain out of the obstacle", message), message
