"""[initial] into (q0, qdot0) and the checks at t = 0 (gibbsimpact.case.initial)."""

from __future__ import annotations

from pathlib import Path

import pytest

import gibbsimpact as gi
from gibbsimpact.case import CaseError

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
