"""The free base's chart (formulation §18): Model.with_base_chart and the re-chart map of dynamics.base_chart."""

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.base_chart import base_orientation_matrix, quaternion, rechart
from gibbsimpact.dynamics.kinematics import transforms


def _rot(axis, a):
    """R_axis(a) written out (not the package's axis_rotation)."""
    c, s = np.cos(a), np.sin(a)
    return {0: np.array([[1, 0, 0], [0, c, -s], [0, s, c]]), 1: np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            2: np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


@pytest.fixture(scope="module")
def model():
    r = 0.01
    link = gi.Link(1.0, 1.0, (20.0, 20.0), modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")],
                   rotary_inertia=(r * r / 2, r * r / 4, r * r / 4))
    return gi.Model(gi.Chain([link, link]), gravity=(0.0, -9.81, 0.0))


def test_chart_rotates_the_base_frame(model, rng):
    # T_1 = Trans(X) R_ref Rx Ry Rz(theta_1): the chart's base frame is R_ref times the world chart's rotation.
    q = rng.uniform(-1, 1, model.n_dof)
    R_ref = _rot(0, 0.4) @ _rot(2, -1.1) @ _rot(1, 2.0)
    T = transforms(model.with_base_chart(R_ref), q)[0]
    T0 = transforms(model, q)[0]
    np.testing.assert_allclose(T[:3, :3], R_ref @ T0[:3, :3], atol=1e-15)
    np.testing.assert_array_equal(T[:3, 3], q[:3])  # X stays the world position of O_1
    np.testing.assert_allclose(base_orientation_matrix(model, q, R_ref), T[:3, :3], atol=1e-15)
    assert model.base_chart is not None and np.array_equal(model.base_chart, np.eye(3))  # the model is unchanged


def test_rechart_keeps_positions_velocities_energy_momentum(model, rng):
    for _ in range(5):
        q, qd = rng.uniform(-1.5, 1.5, model.n_dof), rng.normal(size=model.n_dof)
        q[list(model.delta_index[0]) + list(model.delta_index[1])] *= 0.05
        new, q2, qd2 = rechart(model, q, qd)
        assert np.all(q2[[3, 4, 5]] == 0.0)
        np.testing.assert_array_equal(np.delete(q2, [3, 4, 5]), np.delete(q, [3, 4, 5]))
        np.testing.assert_array_equal(np.delete(qd2, [3, 4, 5]), np.delete(qd, [3, 4, 5]))
        np.testing.assert_allclose(new.joint_positions(q2), model.joint_positions(q), atol=1e-14)
        np.testing.assert_allclose(new.joint_velocities(q2, qd2), model.joint_velocities(q, qd), atol=1e-13)
        E, E2 = model.energy(q, qd), new.energy(q2, qd2)
        assert abs(E2.total - E.total) <= 1e-14 * (abs(E.kinetic) + abs(E.gravity) + abs(E.strain))
        np.testing.assert_allclose(new.angular_momentum(q2, qd2), model.angular_momentum(q, qd), atol=1e-13)
        # Twice: R_ref multiplies on (the chart of a chart), and stays a rotation.
        new2, q3, qd3 = rechart(new, q2 + 0.3, qd2)
        R = new2.base_chart
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
        np.testing.assert_allclose(new2.joint_positions(q3), new.joint_positions(q2 + 0.3), atol=1e-14)


def test_gimbal_lock_of_one_chart_is_named_and_another_chart_passes(model):
    q = model.state(theta_0=np.pi / 2, theta_2=0.5)
    with pytest.raises(gi.SingularMassMatrixError, match="simulate runs through it"):
        model.forward_dynamics(q, np.zeros(model.n_dof))
    new, q2, qd2 = rechart(model, q, np.zeros(model.n_dof))
    assert np.all(np.isfinite(new.forward_dynamics(q2, qd2)))


def test_quaternion_against_its_rotation_matrix(rng):
    angles = rng.uniform(-np.pi, np.pi, (200, 3))
    R = np.array([_rot(0, a) @ _rot(1, b) @ _rot(2, c) for a, b, c in angles])
    R[:4] = [np.eye(3), _rot(0, np.pi), _rot(1, np.pi), _rot(2, np.pi)]  # w = 0 and the trace branches
    Q = quaternion(R)
    w, x, y, z = Q.T
    back = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1).reshape(-1, 3, 3)
    np.testing.assert_allclose(back, R, atol=1e-15 * 8)
    np.testing.assert_allclose(np.linalg.norm(Q, axis=1), 1.0, atol=1e-15)
    # A sequence is made continuous: consecutive quaternions of a slow rotation have a positive dot product.
    path = quaternion(np.array([_rot(1, a) for a in np.linspace(0, 4 * np.pi, 401)]))
    assert np.all(np.sum(path[1:] * path[:-1], axis=1) > 0.99)
    assert quaternion(_rot(1, 1.9 * np.pi))[0] >= 0.0


def test_with_base_chart_refuses_what_is_not_a_rotation(model):
    with pytest.raises(ValueError, match="R_ref=.*rotation matrix"):
        model.with_base_chart(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="R_ref=.*rotation matrix"):
        model.with_base_chart(np.eye(2))
    fixed = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 1.0)], base=gi.FixedBase()))
    with pytest.raises(ValueError, match="only a spatial free base"):
        fixed.with_base_chart(np.eye(3))


def test_rechart_of_a_tree_whose_root_axis_is_turned(rng):
    # A tree (link 0 carries links 1 and 2) whose root revolute's axis is turned by A = Rx(0.5) Ry(0.3): the chart
    # is T_1 = Trans(X) R_ref Rx Ry A Rz; the kernel's base frame, and every point, velocity, E and H, are kept.
    r = 0.01
    link = gi.Link(0.6, 1.0, (20.0, 20.0), modes=[gi.Mode("clamped-free", "z")],
                   rotary_inertia=(r * r / 2, r * r / 4, r * r / 4))
    A = _rot(0, 0.5) @ _rot(1, 0.3)
    joints = [gi.Revolute(axis_rotation=A), gi.Revolute(), gi.Weld(angle=0.4)]
    model = gi.Model(gi.Chain([link, link, link], joints=joints, parents=[-1, 0, 0], attach=[None, 0.6, 0.3]),
                     gravity=(0.0, -9.81, 0.0))
    for _ in range(3):
        q, qd = rng.uniform(-1.5, 1.5, model.n_dof), rng.normal(size=model.n_dof)
        for idx in model.delta_index:
            q[idx] *= 0.05
        T = transforms(model, q)[0]
        np.testing.assert_allclose(base_orientation_matrix(model, q), T[:3, :3], atol=1e-15)
        np.testing.assert_allclose(T[:3, :3], _rot(0, q[3]) @ _rot(1, q[4]) @ A @ _rot(2, q[5]), atol=1e-15)
        new, q2, qd2 = rechart(model, q, qd)
        np.testing.assert_allclose(new.joint_positions(q2), model.joint_positions(q), atol=1e-14)
        np.testing.assert_allclose(new.joint_velocities(q2, qd2), model.joint_velocities(q, qd), atol=1e-13)
        E, E2 = model.energy(q, qd), new.energy(q2, qd2)
        assert abs(E2.total - E.total) <= 1e-14 * (abs(E.kinetic) + abs(E.gravity) + abs(E.strain))
        np.testing.assert_allclose(new.angular_momentum(q2, qd2), model.angular_momentum(q, qd), atol=1e-13)
        # The new angles (0, b*, 0) put the chart where |det B| = |e_z . Ry(b*) A e_z| is largest: |(u_x, u_z)|.
        u = A[:, 2]
        assert q2[3] == q2[5] == 0.0
        assert abs((_rot(1, q2[4]) @ u)[2]) == pytest.approx(np.hypot(u[0], u[2]), abs=1e-15)
