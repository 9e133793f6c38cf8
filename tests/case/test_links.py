"""[[links]], [links.joint] and [base] into a Model (gibbsimpact.case.links): each problem of a link, a
joint or the base, and each rule of the chain, at the key to change."""

from __future__ import annotations


import numpy as np
import pytest

import gibbsimpact as gi
from case_texts import GOOD, write, problems_of, ARM, DROP, TWO, PB, PA, START


def test_cross_section_radius_gives_round_section_inertia(tmp_path):
    text = GOOD.replace("rotary_inertia_kg_m = [5e-5, 2.5e-5, 2.5e-5]", "cross_section_radius_m = 0.01")
    (lk,) = gi.load_case(write(tmp_path, text)).model.chain.links
    np.testing.assert_allclose(lk.rotary_inertia, [5e-5, 2.5e-5, 2.5e-5], rtol=1e-12)


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


def test_finite_element_link_keys(tmp_path):
    text = ARM.replace("elements = 1", 'elements = 3\nelement_directions = ["y", "z"]\ndamping_ratio = 0.02')
    case = gi.load_case(write(tmp_path, text))
    lk = case.model.chain.links[1]
    assert (lk.elements, lk.element_directions, lk.damping, lk.modes) == (3, ("y", "z"), 0.02, ())
    assert case.model.n_dof == 2 + 12
    assert case.model.chain.links[0].elements == 0 and case.model.chain.links[0].damping == 0.0


def test_geometric_stiffening_key(tmp_path):
    # true by default (formulation §15), false the linear beam; a bool only.
    assert gi.load_case(write(tmp_path, GOOD)).model.chain.links[0].geometric_stiffening is True
    text = GOOD.replace("EI_N_m2 = 20.0", "EI_N_m2 = 20.0\ngeometric_stiffening = false")
    assert gi.load_case(write(tmp_path, text)).model.chain.links[0].geometric_stiffening is False
    d = dict(problems_of(tmp_path, GOOD.replace("EI_N_m2 = 20.0", "EI_N_m2 = 20.0\ngeometric_stiffening = 1")).problems)
    assert "true or false" in d["links[1].geometric_stiffening"]


@pytest.mark.parametrize("text, key", [(PB, "links[2].geometric_stiffening")])
def test_stiffening_refused_behind_a_guide(tmp_path, text, key):
    # Not modelled (formulation §15's last paragraph): the problem at the key, naming the fix.
    text = text.replace("geometric_stiffening = false", "geometric_stiffening = true")
    d = dict(problems_of(tmp_path, text + START).problems)
    assert "set geometric_stiffening = false" in d[key]


def test_a_carriage_rides_on_a_stiffened_host(tmp_path):
    # formulation §15: the carriage at d +- c uses the foreshortened centreline (kernel/frames.py), so the
    # case loads with the host stiffened and nothing else to set.
    text = PA.replace("geometric_stiffening = false", "geometric_stiffening = true") + START
    assert "geometric_stiffening = true" in text
    case = gi.load_case(write(tmp_path, text))
    assert all(lk.geometric_stiffening for lk in case.model.chain.links)


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


def test_inline_joint_table_and_defaults(tmp_path):
    # joint = { ... } inline is the same as [links.joint]; angle defaults to 0; "R" is the default joint.
    text = TWO.replace('EI_N_m2 = 8.0\n', 'EI_N_m2 = 8.0\njoint = { type = "Pb", range_m = [0.2, 0.6] }\n')
    case = gi.load_case(write(tmp_path, text + START))
    assert case.model.chain.joints == (gi.Revolute(), gi.FixedPrismatic(range=(0.2, 0.6)))
    explicit_r = TWO.replace('EI_N_m2 = 25.0\n', 'EI_N_m2 = 25.0\njoint = { type = "R" }\n')
    case = gi.load_case(write(tmp_path, explicit_r + "\n[time]\nt_end_s = 0.1\n"))
    assert case.model.joint_kinds == ("R", "R")


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


def _arm_with_bodies(hub="", payload=""):
    """ARM with [[links.bodies]]: a hub on link 1 (at its joint) and a payload on link 2 (its tip)."""
    link1 = "EI_N_m2 = 25.0\n"
    text = ARM.replace(link1, link1 + "\n[[links.bodies]]\nmass_kg = 2.0\ninertia_kg_m2 = [0.01, 0.01, 0.02]\n"
                       "at_m = 0.0\n" + hub, 1)
    return text.replace("elements = 1\n", "elements = 1\n\n[[links.bodies]]\nmass_kg = 0.5\n"
                        "center_m = [0.05, 0.0, 0.0]\n" + payload, 1)


def test_links_bodies_tables(tmp_path):
    links = gi.load_case(write(tmp_path, _arm_with_bodies(hub="inertia_products_kg_m2 = [0.001, 0.0, 0.0]\n"))
                         ).model.chain.links
    (hub,), (payload,) = links[0].bodies, links[1].bodies
    assert hub == gi.RigidBody(2.0, inertia=[[0.01, 0.001, 0.0], [0.001, 0.01, 0.0], [0.0, 0.0, 0.02]], at=0.0)
    assert payload == gi.RigidBody(0.5, center=(0.05, 0.0, 0.0), at=0.6)


@pytest.mark.parametrize("hub, payload, path, words", [
    ("colour = 1\n", "", "links[1].bodies[1].colour", "unknown key"),
    ("", "at_m = 0.7\n", "links[2].bodies[1]", "beyond the link's length"),
    ("", "center_m = [0.0, 0.1, 0.0]\n", "links[2].bodies[1]", "center=(c_x, 0, 0)"),
    ("inertia_products_kg_m2 = [0.0, 0.0, 0.3]\n", "", "links[1].bodies[1].inertia_kg_m2", "triangle"),
])
def test_links_bodies_problems_at_their_keys(tmp_path, hub, payload, path, words):
    # (a payload's own center_m replaces the default one: TOML refuses a repeated key)
    text = _arm_with_bodies(hub, payload).replace("center_m = [0.05, 0.0, 0.0]\ncenter_m", "center_m")
    d = dict(problems_of(tmp_path, text).problems)
    assert words in d[path], d


def test_links_bodies_mass_range(tmp_path):
    text = _arm_with_bodies().replace("mass_kg = 0.5", "mass_kg = 0.0")
    d = dict(problems_of(tmp_path, text).problems)
    assert d["links[2].bodies[1].mass_kg"] == "must be in [1e-12, 1e12] kg, got 0"
