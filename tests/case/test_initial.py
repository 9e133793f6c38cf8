"""[initial] into (q0, qdot0) and the checks at t = 0 (gibbsimpact.case.initial)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import gibbsimpact as gi
from gibbsimpact.case import CaseError
from gibbsimpact.dynamics.link_points import material_points

CASES = Path(__file__).resolve().parents[2] / "cases"


def problems_of(tmp_path, text):
    p = tmp_path / "case.toml"
    p.write_text(text)
    with pytest.raises(CaseError) as info:
        gi.load_case(p)
    return info.value.problems


# -- without a chain, no problem blames a correct key (issue 23 item 11) ----------------------

def test_a_slope_of_a_finite_element_link_is_not_judged_without_the_chain(tmp_path):
    text = (CASES / "fixed_base_fe_arm.toml").read_text().replace(
        "theta_2_deg = 0.0", "theta_2_deg = 0.0\ndelta_1_2_rad = 0.01\ndelta_1_1_m = 0.001")
    bad = text.replace("EI_N_m2 = 8.0", "EI_N_m2 = -8.0")
    assert [p for p, _ in problems_of(tmp_path, bad)] == ["links[2].EI_N_m2"]
    bad = text.replace('type = "fixed"\n', "")
    assert problems_of(tmp_path, bad) == [("base.type", "missing ('fixed', 'free' or 'planar')")]
    # With the chain built, the same keys are judged: a slope takes an angle unit.
    assert problems_of(tmp_path, text.replace("delta_1_2_rad", "delta_1_2_m")) == [
        ("initial.coordinates.delta_1_2_m", "delta_1_2 takes unit rad or deg, not m")]
    # Units that hold for every model are judged without one.
    bad = text.replace("EI_N_m2 = 8.0", "EI_N_m2 = -8.0").replace("theta_2_deg = 0.0", "theta_2_m = 0.0")
    assert dict(problems_of(tmp_path, bad))["initial.coordinates.theta_2_m"] == "theta_2 takes unit rad or deg, not m"


def test_a_planar_center_of_mass_is_not_judged_without_the_base_type(tmp_path):
    planar = """
gravity_m_per_s2 = [0.0, -9.81, 0.0]

[base]
type = "planar"

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 25.0
elements = 2

[initial]
center_of_mass_m = [0.3, 0.2]

[time]
t_end_s = 0.1
"""
    p = tmp_path / "planar.toml"
    p.write_text(planar)
    assert gi.load_case(p).model.chain.base == "planar"
    assert problems_of(tmp_path, planar.replace('type = "planar"\n', "")) == [
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


def deepest_point(model, q, i, wall):
    """(x [m], depth [m]) of link i's material point farthest beyond ``wall``, from material_points and
    the wall's gap alone: the lowest of 2001 samples, refined by Brent's method between its neighbours."""
    xs = np.linspace(0.0, model.chain.links[i].length, 2001)
    k = int(np.argmin(wall.gap(material_points(model, q, i, xs))))
    res = minimize_scalar(lambda x: wall.gap(material_points(model, q, i, [x]))[0], method="bounded",
                          bounds=(xs[max(k - 1, 0)], xs[min(k + 1, xs.size - 1)]), options={"xatol": 1e-12})
    return float(res.x), float(-res.fun)


@pytest.mark.parametrize("wall", sorted(WALLS))
def test_a_link_bent_across_a_wall_names_the_link_its_point_and_the_depth(tmp_path, wall):
    text = BENT.format(wall=WALLS[wall])
    # Joints only ([solver] link_contacts = false, the published model): the state loads, every joint inside.
    (tmp_path / "joints_only.toml").write_text(text + "\n[solver]\nlink_contacts = false\n")
    case = gi.load_case(tmp_path / "joints_only.toml")
    (w,) = case.walls
    assert np.all(w.gap(case.model.joint_positions(case.q0)) > 0.03)
    (path, message), = problems_of(tmp_path, text)
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
