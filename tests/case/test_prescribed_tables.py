"""[[prescribed]] tables of a case file (gibbsimpact.case.prescribed): profiles, the start on them, key-path errors."""

import tomllib

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.case import case_from_dict

HUB = """
name = "hub"
gravity_m_per_s2 = [0.0, 0.0, 0.0]
[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 1e4
[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 1e4
[base]
type = "fixed"
[[prescribed]]
coordinate = "theta_1"
PROFILE
[time]
t_end_s = 0.5
"""


def _case(profile: str, extra: str = ""):
    return case_from_dict(tomllib.loads(HUB.replace("PROFILE", profile) + extra))


@pytest.mark.parametrize("table, python", [
    ('profile = "spin_up"\nOmega_rad_per_s = 6.0\nT_s = 15.0', gi.profiles.spin_up(6.0, 15.0)),
    ('profile = "constant_speed"\nq0_rad = 0.5\nv_rad_per_s = 2.0', gi.profiles.constant_speed(0.5, 2.0)),
    ('profile = "point_to_point"\nq_a_rad = 0.1\nq_b_rad = 1.1\nt_a_s = 0.1\nt_b_s = 0.4',
     gi.profiles.point_to_point(0.1, 1.1, 0.1, 0.4)),
    ('profile = "samples"\nt_s = [0.0, 0.2, 0.4, 0.6]\nq_rad = [0.0, 0.1, 0.4, 0.9]',
     gi.profiles.samples([0.0, 0.2, 0.4, 0.6], [0.0, 0.1, 0.4, 0.9])),
])
def test_each_profile_kind_builds_the_python_profile_and_starts_on_it(table, python):
    """A [[prescribed]] table is the gi.profiles object of the same parameters, and the coordinate starts on it."""
    case = _case(table)
    (name, prof), = case.prescribed
    assert name == "theta_1" and prof.kind == python.kind
    for t in (0.0, 0.13, 0.37, 0.5):
        assert prof(t) == python(t)
    assert (case.q0[0], case.qdot0[0]) == python(0.0)[:2]
    assert case.simulate_kwargs()["prescribed"] == {"theta_1": prof}


def test_a_prescribed_case_runs():
    res = _case('profile = "constant_speed"\nv_rad_per_s = 2.0').simulate()
    assert res.status == "finished" and res.prescribed == ("theta_1",)
    assert res.q[-1, 0] == pytest.approx(1.0, abs=1e-15) and np.all(res.qdot[:, 0] == 2.0)


@pytest.mark.parametrize("table, extra, problem", [
    ('profile = "constant_speed"\nv_m_per_s = 2.0', "",
     "prescribed[1].v_m_per_s: not a key of a 'constant_speed' profile on theta_1 (its keys: q0_rad, v_rad_per_s)"),
    ('profile = "constant_speed"', "",
     "prescribed[1].v_rad_per_s: missing (a 'constant_speed' profile on theta_1 needs v_rad_per_s)"),
    ('profile = "ramp"', "", "prescribed[1].profile: unknown profile 'ramp'; use one of spin_up, constant_speed"),
    ('profile = "spin_up"\nOmega_rad_per_s = 6.0\nT_s = 0.0', "", "prescribed[1].T_s: must be in"),
    ('profile = "point_to_point"\nq_a_rad = 0.1\nq_b_rad = 1.1\nt_a_s = 0.4\nt_b_s = 0.1', "",
     "prescribed[1]: profile point_to_point t_b=0.1 must be later than t_a=0.4"),
    ('profile = "samples"\nt_s = [0.0, 0.2, 0.4, 0.6]\nq_rad = [0.0, "a", 0.4, 0.9]', "",
     "prescribed[1].q_rad: expected an array of numbers"),
    ('profile = "constant_speed"\nv_rad_per_s = 2.0', "\n[initial.velocities]\ntheta_1_rad_per_s = 1.0\n",
     "initial.velocities.theta_1_rad_per_s: 1 differs from the [[prescribed]] profile of theta_1 at t_start (2)"),
    ('profile = "constant_speed"\nv_rad_per_s = 2.0',
     '\n[[walls]]\ntype = "plane"\npoint_m = [0.0, -5.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\nstiffness = 1e5\n',
     "walls[1].stiffness: a compliant wall cannot be combined with [[prescribed]] coordinates yet: remove stiffness"),
])
def test_bad_tables_are_named_by_key_path(table, extra, problem):
    with pytest.raises(gi.CaseError) as err:
        _case(table, extra)
    assert problem in str(err.value)


def test_only_joint_coordinates_and_once():
    text = HUB.replace("PROFILE", 'profile = "constant_speed"\nv_rad_per_s = 2.0')
    with pytest.raises(gi.CaseError, match=r"prescribed\[1\].coordinate: 'delta_1_1' is not a joint coordinate"):
        case_from_dict(tomllib.loads(text.replace('"theta_1"', '"delta_1_1"')))
    twice = text.replace("[time]", '[[prescribed]]\ncoordinate = "theta_1"\nprofile = "constant_speed"\n'
                                   'v_rad_per_s = 2.0\n[time]')
    with pytest.raises(gi.CaseError, match=r"prescribed\[2\].coordinate: theta_1 is prescribed twice"):
        case_from_dict(tomllib.loads(twice))
