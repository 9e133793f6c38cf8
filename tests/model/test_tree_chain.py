"""Chain(parents, attach), Weld and Revolute(axis_rotation): validation and the coordinates of a
tree (formulation §17)."""

import numpy as np
import pytest

import gibbsimpact as gi

LK = gi.Link(1.0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(parents=[-1, 2, 0]), r"parents\[1\]=2 must be -1 \(the base\) or the 0-based index of an earlier link"),
    (dict(parents=[-1, 0]), r"parents has 2 entries for 3 links"),
    (dict(parents=[-1, 0, -1]), r"parents\[2\]=-1: a floating base \(base='free'\) floats one root link"),
    (dict(parents=[-1, 0, 0], attach=[None, 1.5, None]), r"attach\[1\]=1.5 must be an abscissa in \[0, 1\] m"),
    (dict(parents=[-1, 0, 0], attach=[0.5, None, None]), r"attach\[0\]=0.5: links\[0\] \(link 1\) stands on the base"),
    (dict(parents=[-1, -1, 0]), r"give links\[1\] \(link 2\) an earlier link as parent"),
    (dict(parents=[-1, 0, 0], attach=[None, None, 1.5]), r"on its parent, links\[0\] \(link 1\)"),
    (dict(parents=[-1, 0, 0], joints=[gi.Weld(), gi.Revolute(), gi.Revolute()]),
     r"on a floating base \(base='free'\) the root's joint must be gi.Revolute\(\)"),
    (dict(parents=[-1, 0, 0], base=gi.FixedBase(),
          joints=[gi.Revolute(), gi.Revolute(), gi.FixedPrismatic(range=(0.2, 0.5))]),
     r"prismatic joints stand in serial chains only"),
    (dict(base="planar", joints=[gi.Revolute(), gi.Weld(rotation=[[1, 0, 0], [0, 0, -1], [0, 1, 0]]), gi.Revolute()]),
     r"a planar chain .* must keep the z axis"),
])
def test_chain_refuses_bad_trees(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gi.Chain([LK, LK, LK], **kwargs)


def test_joints_refuse_bad_rotations():
    with pytest.raises(ValueError, match=r"(?s)Revolute axis_rotation=.* must be a proper rotation matrix"):
        gi.Revolute(axis_rotation=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match=r"Weld angle='a' must be a finite number of radians"):
        gi.Weld(angle="a")


def test_tree_coordinates_skip_welds_and_default_is_the_serial_chain():
    """Coordinates: the base's, the joint variables in link order without the welds, then the deltas;
    parents=None is today's serial chain."""
    cf = gi.Mode("clamped-free", "y")
    chain = gi.Chain([gi.Link(1.0, modes=[cf]), LK, gi.Link(0.5, modes=[cf])],
                     joints=[gi.Revolute(), gi.Weld(0.3), gi.Revolute()], parents=[-1, 0, 0], attach=[None, 0.5, None])
    model = gi.Model(chain)
    assert model.coordinate_names == ("X1", "X2", "X3", "theta_-1", "theta_0", "theta_1", "theta_3", "delta_1_1",
                                      "delta_3_1")
    assert model.theta_index == (5, -1, 6)
    assert chain.children == ((1, 2), (), ()) and chain.free_tips == (1, 2)
    assert model.contact_point_names == ("O1", "O2", "O3", "O4", "tip of link 2")
    serial = gi.Chain([LK, LK])
    assert serial.parents == (-1, 0) and serial.attach == (None, None) and serial.serial


def test_symbolic_derivation_builds_a_tree_like_the_kernel():
    """derive_equations follows the tree (a child at x_a = 0.5 m on a bending parent): its M equals the kernel's
    to round-off (tests/symbolic/test_derive.py checks more trees, forcing and the Lagrange route)."""
    lk = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-free", "y")], geometric_stiffening=False)
    model = gi.Model(gi.Chain([lk, lk], parents=[-1, 0], attach=[None, 0.5], base=gi.FixedBase()))
    q = np.array([0.3, -0.7, 0.02, -0.01])
    M = model.mass_matrix(q)
    np.testing.assert_allclose(gi.derive_equations(model).numeric().mass_matrix(q), M, rtol=0,
                               atol=1e-12 * np.abs(M).max())


def test_a_weld_is_no_prescribable_joint():
    """A weld's theta_index is -1: the joints a profile may drive are the coordinates of the other
    joints (simulate's prescribed= names them), not the last delta that index -1 would pick."""
    cf = gi.Mode("clamped-free", "y")
    model = gi.Model(gi.Chain([gi.Link(1.0, modes=[cf]), gi.Link(0.5, modes=[cf])], joints=[gi.Revolute(), gi.Weld(0.2)],
                              base=gi.FixedBase()))
    with pytest.raises(ValueError, match=r"delta_2_1") as info:
        gi.simulate(model, np.zeros(model.n_dof), np.zeros(model.n_dof), (0.0, 0.01),
                    prescribed={"delta_2_1": gi.profiles.constant_speed(0.0, 0.0)})
    assert "theta_1" in str(info.value)


def test_chain_refuses_a_chain_with_no_coordinate():
    # Every joint welded on a fixed base and every link rigid: N = 0. simulate failed inside the kernel
    # (ZeroDivisionError); Chain now says what is missing. A flexible link keeps its deltas: accepted.
    with pytest.raises(ValueError, match=r"no coordinate \(N = 0\).*give a joint gi.Revolute\(\)"):
        gi.Chain([LK, LK], joints=[gi.Weld(), gi.Weld(angle=0.5)], base=gi.FixedBase())
    bending = gi.Link(1.0, 1.0, 10.0, modes=[gi.Mode("clamped-free", "y")])
    model = gi.Model(gi.Chain([LK, bending], joints=[gi.Weld(), gi.Weld()], base=gi.FixedBase()))
    assert model.coordinate_names == ("delta_2_1",)


def test_state_says_a_welded_joint_has_no_coordinate():
    # Model.state(theta_2=...) on a weld said only "unknown coordinate"; it now names the weld.
    model = gi.Model(gi.Chain([LK, LK], joints=[gi.Revolute(), gi.Weld(angle=0.3)], base=gi.FixedBase()))
    with pytest.raises(ValueError, match=r"unknown coordinate 'theta_2' \(joint 2 is a gi.Weld: .*no coordinate\); "
                                         r"this model has theta_1"):
        model.state(theta_2=0.1)
    with pytest.raises(ValueError, match=r"unknown coordinate 'theta_3'; this model"):
        model.state(theta_3=0.1)
