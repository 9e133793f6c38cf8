"""A tree in a case file: [links.joint] parent, at_m and type = 'W' (formulation §17), and a tree's
model through the result files' plain data."""

from __future__ import annotations

import numpy as np

import gibbsimpact as gi
from case_texts import problems_of, write
from gibbsimpact.io.plain_data import model_from_dict, model_to_dict

TREE = """
name = "planar_tree"
gravity_m_per_s2 = [0.0, 0.0, 0.0]

[base]
type = "planar"

[[links]]
length_m = 0.6
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 20.0
modes = [{ kind = "clamped-free", direction = "y", number = 1 }]

[[links]]
length_m = 0.5
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 20.0
modes = [{ kind = "clamped-free", direction = "y", number = 1 }]
[links.joint]
type = "R"
parent = 1
at_m = 0.4

[[links]]
length_m = 0.5
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 20.0
[links.joint]
type = "W"
angle_deg = -40.0
parent = 1

[initial.coordinates]
theta_1_deg = 20.0

[time]
t_end_s = 0.1
"""


def test_case_reads_a_tree(tmp_path):
    chain = gi.load_case(write(tmp_path, TREE)).model.chain
    assert chain.parents == (-1, 0, 0) and chain.attach == (None, 0.4, None)
    assert chain.joints[2] == gi.Weld(angle=np.radians(-40.0))


def test_case_tree_problems_at_their_keys(tmp_path):
    bad = TREE.replace("parent = 1\nat_m = 0.4", "parent = 3\nat_m = 0.4")
    assert any(k == "links[2].joint.parent" for k, _ in problems_of(tmp_path, bad).problems)
    bad = TREE.replace("at_m = 0.4", "at_m = 0.9")
    assert any("attach[1]=0.9 must be an abscissa in [0, 0.6] m" in msg for _, msg in problems_of(tmp_path, bad).problems)
    bad = TREE.replace('angle_deg = -40.0\nparent = 1', 'angle_deg = -40.0\nrange_m = [0.1, 0.2]\nparent = 1')
    assert any(k == "links[3].joint.range_m" for k, _ in problems_of(tmp_path, bad).problems)


def test_tree_model_survives_the_result_files(tmp_path):
    """model_to_dict / model_from_dict keep parents, attach, welds and axis rotations: the same M."""
    Rx = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]
    lk = gi.Link(0.5, 1.0, 10.0, modes=[gi.Mode("clamped-free", "y")])
    chain = gi.Chain([lk, lk, lk], joints=[gi.Revolute(), gi.Revolute(axis_rotation=Rx), gi.Weld(0.3)],
                     parents=[-1, 0, 0], attach=[None, 0.2, None], base=gi.FixedBase())
    model = gi.Model(chain)
    back = model_from_dict(model_to_dict(model))
    assert back.chain == chain
    q = np.array([0.3, -0.4, 0.01, 0.02, -0.01])
    np.testing.assert_array_equal(back.mass_matrix(q), model.mass_matrix(q))


def test_case_turns_a_revolute_axis_and_a_weld_by_rotation_xyz_deg(tmp_path):
    """rotation_xyz_deg = [a, b, c] is R = Rx(a) Ry(b) Rz(c), checked against rotations built here by hand
    (a 3D fixed-base tree: a hip axis turned by 90 deg about x swings the leg out of the base's plane)."""
    text = (TREE.replace('type = "planar"', 'type = "fixed"')
            .replace('type = "R"\nparent = 1', 'type = "R"\nrotation_xyz_deg = [90.0, 0.0, 0.0]\nparent = 1')
            .replace('angle_deg = -40.0\nparent = 1', 'angle_deg = -40.0\nrotation_xyz_deg = [0.0, 30.0, 45.0]\nparent = 1'))
    chain = gi.load_case(write(tmp_path, text)).model.chain
    c30, s30, h = np.cos(np.pi / 6), np.sin(np.pi / 6), np.sqrt(0.5)
    rx90 = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]
    ry30_rz45 = np.array([[c30, 0, s30], [0, 1, 0], [-s30, 0, c30]]) @ np.array([[h, -h, 0], [h, h, 0], [0, 0, 1]])
    np.testing.assert_allclose(chain.joints[1].axis_rotation, rx90, atol=1e-15)
    np.testing.assert_allclose(chain.joints[2].rotation, ry30_rz45, atol=1e-15)
    bad = text.replace("rotation_xyz_deg = [90.0, 0.0, 0.0]", "rotation_xyz_deg = [90.0, 0.0]")
    assert any(k == "links[2].joint.rotation_xyz_deg" for k, _ in problems_of(tmp_path, bad).problems)
