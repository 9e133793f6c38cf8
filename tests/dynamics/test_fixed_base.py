"""Fixed-base chains (docs/theory.md §8, §9, §13): closed forms, the free-base route, energy, impacts, inputs."""

import numpy as np
import pytest

import gibbsimpact as gi

from conftest import random_state

G = 9.81


def double_pendulum(l1=1.0, l2=0.7, m1=2.0, m2=1.4, beta=0.4, base=(0.3, -0.2)):
    links = [gi.Link(l1, m1 / l1, 1.0), gi.Link(l2, m2 / l2, 1.0)]
    return gi.Model(gi.Chain(links, base=gi.FixedBase(base, beta)), gravity=(0.0, -G, 0.0))


def test_rigid_double_pendulum_closed_forms():
    # Uniform rods, theta_2 relative, absolute angles phi_1 = beta + theta_1, phi_2 = phi_1 + theta_2.
    l1, l2, m1, m2, beta = 1.0, 0.7, 2.0, 1.4, 0.4
    model = double_pendulum(l1, l2, m1, m2, beta)
    assert model.coordinate_names == ("theta_1", "theta_2")
    rng = np.random.default_rng(5)
    for _ in range(10):
        q, qd = rng.uniform(-3, 3, 2), rng.normal(size=2)
        c2, s2 = np.cos(q[1]), np.sin(q[1])
        k = m2 * l1 * l2 / 2
        b = m2 * l2**2 / 3 + k * c2
        M = np.array([[m1 * l1**2 / 3 + m2 * l1**2 + m2 * l2**2 / 3 + 2 * k * c2, b], [b, m2 * l2**2 / 3]])
        h = np.array([-k * s2 * (2 * qd[0] * qd[1] + qd[1] ** 2), k * s2 * qd[0] ** 2])
        p1, p2 = beta + q[0], beta + q[0] + q[1]
        dV = G * np.array([m1 * l1 / 2 * np.cos(p1) + m2 * (l1 * np.cos(p1) + l2 / 2 * np.cos(p2)),
                           m2 * l2 / 2 * np.cos(p2)])
        np.testing.assert_allclose(model.mass_matrix(q), M, rtol=0, atol=1e-12 * np.abs(M).max())
        np.testing.assert_allclose(model.bias_forces(q, qd), h, rtol=0, atol=1e-12 * max(1.0, np.abs(h).max()))
        np.testing.assert_allclose(model.potential_forces(q), dV, rtol=0, atol=1e-12 * np.abs(dV).max())
        O = model.joint_positions(q)
        np.testing.assert_allclose(O[0], [0.3, -0.2, 0.0], atol=1e-15)
        np.testing.assert_allclose(O[2] - O[1], l2 * np.array([np.cos(p2), np.sin(p2), 0.0]), atol=1e-14)


def _flexible_arm(base, EI=(25.0, 8.0), **disc):
    l1 = gi.Link(1.0, 1.0, EI[0], rotary_inertia=(0.0, 0.0, 1e-4), **disc)
    l2 = gi.Link(0.6, 0.5, EI[1], **disc)
    return gi.Model(gi.Chain([l1, l2], base=base), gravity=(0.0, -G, 0.0))


@pytest.mark.parametrize("disc", [dict(elements=2), dict(modes=[gi.Mode("clamped-free", "y", 1), gi.Mode("clamped-free", "y", 2)])])
def test_fixed_base_equals_free_base_with_frozen_base_coordinates(disc, rng):
    # Second route: the free-flying chain with X = base position, theta_-1 = theta_0 = 0 and
    # theta_1 = beta + theta_1, restricted to the arm's coordinates (base velocities zero),
    # has the same M, h and dV/dq: the fixed-base recursion must agree with it.
    beta, b = 0.7, (0.2, 0.5)
    fixed = _flexible_arm(gi.FixedBase(b, beta), **disc)
    free = _flexible_arm("free", **disc)
    keep = [free.coordinate_names.index(n) for n in fixed.coordinate_names]
    for _ in range(10):
        q, qd = random_state(fixed, rng, angle=3.0, delta=0.05)
        Q, QD = np.zeros(free.n_dof), np.zeros(free.n_dof)
        Q[keep], QD[keep] = q, qd
        Q[:2] = b
        Q[free.theta_index[0]] += beta
        for a, c in ((fixed.mass_matrix(q), free.mass_matrix(Q)[np.ix_(keep, keep)]),
                     (fixed.bias_forces(q, qd), free.bias_forces(Q, QD)[keep]),
                     (fixed.potential_forces(q), free.potential_forces(Q)[keep])):
            np.testing.assert_allclose(a, c, rtol=0, atol=1e-12 * np.abs(c).max())
        np.testing.assert_allclose(fixed.joint_positions(q), free.joint_positions(Q), atol=1e-14)


def test_fixed_base_fe_arm_conserves_energy():
    # Soft links, one element each: the highest frequency (a few hundred rad/s) sets the step.
    model = _flexible_arm(gi.FixedBase((0.0, 0.0), 0.0), EI=(4.0, 2.0), elements=1)
    q = model.state(theta_1=0.3, theta_2=-0.5, delta_1_1=0.01)
    qd = model.state(theta_1=1.0, theta_2=-2.0)
    res = gi.simulate(model, q, qd, (0.0, 0.3), rtol=1e-11, atol=1e-13)
    assert res.status == "finished", res.message
    assert res.energy_error <= 1e-9
    np.testing.assert_allclose(res.joint_positions()[:, 0], 0.0, atol=1e-15)  # the base joint does not move


def test_fixed_base_fe_arm_strikes_a_plane():
    # A two-link FE arm on a fixed base falls onto a floor under gravity and a motor torque.
    model = _flexible_arm(gi.FixedBase((0.0, 0.5), 0.0), EI=(4.0, 2.0), elements=1)
    q = model.state(theta_1=-0.2, theta_2=-0.3)
    floor = gi.Plane((0, 0, 0), (0, 1, 0))
    res = gi.simulate(model, q, np.zeros(model.n_dof), (0.0, 0.25), walls=[floor], restitution=0.8,
                      inputs={"theta_1": -1.0}, rtol=1e-9, atol=1e-11)
    assert res.status in ("finished", "zeno"), res.message
    assert len(res.impacts) >= 1
    first = res.impacts[0]
    assert first.joints == (3,)  # the tip hits first
    for rec in res.impacts:
        assert rec.energy_after.kinetic <= rec.energy_before.kinetic * (1 + 1e-12)
        if rec.rounds == 1:
            act = rec.impulses > 0
            np.testing.assert_allclose(rec.v_after[act], -0.8 * rec.v_before[act], atol=1e-10 * np.abs(rec.v_before).max())
    assert res.joint_positions()[:, :, 1].min() > -1e-9
    assert res.energy_error < 1e-7  # the power balance holds between impacts


def test_fixed_base_input_errors():
    with pytest.raises(ValueError, match="FixedBase position"):
        gi.FixedBase((0.0,), 0.0)
    with pytest.raises(ValueError, match="FixedBase angle"):
        gi.FixedBase((0.0, 0.0), float("nan"))
    link = gi.Link(1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="base"):
        gi.Chain([link], base="fixed-ish")
    with pytest.raises(ValueError, match="one joint per link"):
        gi.Chain([link, link], joints=[gi.Revolute()])
    with pytest.raises(ValueError, match="not a joint"):
        gi.Chain([link], joints=["R"])
