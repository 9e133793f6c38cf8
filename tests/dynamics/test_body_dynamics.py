"""Attached rigid bodies in the dynamics (docs/theory.md §6.8): rigid pendulums with a payload
against their closed forms, and a hub inertia adding exactly its J_zz to the joint."""

import numpy as np
import pytest

import gibbsimpact as gi

from conftest import random_state

G = 9.81
# Link 2 (or the pendulum) carries at its tip a payload: mass m, centre offset (c_x, c_y), J_zz.
M_B, CX, CY, JZZ = 1.3, 0.15, -0.08, 0.04
BODY = gi.RigidBody(M_B, center=(CX, CY, 0.02), inertia=(0.01, 0.03, JZZ))


def _payload_moments(l2, m2):
    """Link 2 with its payload as one rigid body about joint 2: first moment s (2,) [kg m] and
    I_z [kg m^2] in link-2 axes (uniform rod m2 l2^2/3, body m |c_O|^2 + J_zz)."""
    X = l2 + CX
    return np.array([m2 * l2 / 2 + M_B * X, M_B * CY]), m2 * l2 ** 2 / 3 + M_B * (X ** 2 + CY ** 2) + JZZ


def test_rigid_pendulum_with_payload_closed_form_and_period():
    l, m1, beta = 0.9, 2.0, 0.3
    model = gi.Model(gi.Chain([gi.Link(l, m1 / l, 1.0, bodies=[BODY])], base=gi.FixedBase((0.1, 0.2), beta)),
                     gravity=(0.0, -G, 0.0))
    s, I = _payload_moments(l, m1)
    # V = g (s_x sin phi + s_y cos phi), phi = beta + theta: dV/dtheta = g (s_x cos phi - s_y sin phi)
    for th in np.linspace(-3, 3, 7):
        q, qd = np.array([th]), np.array([1.7])
        phi = beta + th
        assert model.mass_matrix(q)[0, 0] == pytest.approx(I, rel=1e-13)
        assert abs(model.bias_forces(q, qd)[0]) < 1e-13 * I
        assert model.potential_forces(q)[0] == pytest.approx(G * (s[0] * np.cos(phi) - s[1] * np.sin(phi)), rel=1e-12)
    # Equilibrium where the centre of mass hangs below O: phi_eq = -pi/2 - atan2(s_y, s_x); the gravity
    # torque is the sinusoid g |s| cos(phi - phi_eq - pi/2)... so its stiffness g |s| is dV/dtheta at
    # phi_eq + pi/2 exactly, and T = 2 pi sqrt(I / (g |s|)).
    phi_eq = -np.pi / 2 - np.arctan2(s[1], s[0])
    q_eq = np.array([phi_eq - beta])
    assert abs(model.potential_forces(q_eq)[0]) < 1e-13 * G * np.linalg.norm(s)
    k = model.potential_forces(q_eq + np.pi / 2)[0]
    period = 2 * np.pi * np.sqrt(model.mass_matrix(q_eq)[0, 0] / k)
    assert period == pytest.approx(2 * np.pi * np.sqrt(I / (G * np.linalg.norm(s))), rel=1e-12)


def test_rigid_double_pendulum_with_payload_closed_form(rng):
    # phi_1 = beta + theta_1, phi_2 = phi_1 + theta_2; with A = m1 l1^2/3 + (m2 + m) l1^2,
    # kappa(theta_2) = l1 (s_x cos theta_2 - s_y sin theta_2):
    # M = [[A + I + 2 kappa, I + kappa], [I + kappa, I]],
    # h = kappa' (2 thd1 thd2 + thd2^2, -thd1^2), kappa' = -l1 (s_x sin theta_2 + s_y cos theta_2).
    l1, l2, m1, m2, beta = 1.0, 0.7, 2.0, 1.4, 0.4
    links = [gi.Link(l1, m1 / l1, 1.0), gi.Link(l2, m2 / l2, 1.0, bodies=[BODY])]
    model = gi.Model(gi.Chain(links, base=gi.FixedBase((0.3, -0.2), beta)), gravity=(0.0, -G, 0.0))
    s, I = _payload_moments(l2, m2)
    A = m1 * l1 ** 2 / 3 + (m2 + M_B) * l1 ** 2
    for _ in range(10):
        q, qd = rng.uniform(-3, 3, 2), rng.normal(size=2)
        c2, s2 = np.cos(q[1]), np.sin(q[1])
        kap = l1 * (s[0] * c2 - s[1] * s2)
        dkap = -l1 * (s[0] * s2 + s[1] * c2)
        M = np.array([[A + I + 2 * kap, I + kap], [I + kap, I]])
        h = dkap * np.array([2 * qd[0] * qd[1] + qd[1] ** 2, -qd[0] ** 2])
        p1, p2 = beta + q[0], beta + q[0] + q[1]
        tau2 = G * (s[0] * np.cos(p2) - s[1] * np.sin(p2))
        dV = np.array([G * (m1 / 2 + m2 + M_B) * l1 * np.cos(p1) + tau2, tau2])
        np.testing.assert_allclose(model.mass_matrix(q), M, rtol=0, atol=1e-12 * np.abs(M).max())
        np.testing.assert_allclose(model.bias_forces(q, qd), h, rtol=0, atol=1e-12 * max(1.0, np.abs(h).max()))
        np.testing.assert_allclose(model.potential_forces(q), dV, rtol=0, atol=1e-12 * np.abs(dV).max())


@pytest.mark.parametrize("disc", [dict(elements=3, element_directions=("y", "z")),
                                  dict(modes=[gi.Mode("clamped-free", "y", 1), gi.Mode("clamped-free", "z", 1)])])
def test_hub_inertia_adds_its_J_zz_to_the_joint_only(disc, rng):
    # A hub (at = 0) on the first link of a fixed-base arm sits on the joint axis, where the clamped
    # shapes have psi = psi' = 0: it adds J_zz to M[theta_1, theta_1] and nothing else.
    hub = gi.RigidBody(5.0, inertia=(0.2, 0.15, 0.3), at=0.0)

    def arm(bodies):
        links = [gi.Link(1.0, 1.0, 30.0, bodies=bodies, **disc), gi.Link(0.6, 0.5, 10.0, **disc)]
        return gi.Model(gi.Chain(links, base=gi.FixedBase((0.2, 0.1), 0.5)), gravity=(0.0, -G, 0.0))

    bare, hubbed = arm(()), arm([hub])
    add = np.zeros((bare.n_dof, bare.n_dof))
    add[0, 0] = 0.3
    for _ in range(5):
        q, qd = random_state(bare, rng, angle=3.0, delta=0.05)
        M0 = bare.mass_matrix(q)
        np.testing.assert_allclose(hubbed.mass_matrix(q) - M0, add, rtol=0, atol=1e-12 * np.abs(M0).max())
        np.testing.assert_allclose(hubbed.bias_forces(q, qd), bare.bias_forces(q, qd), rtol=0, atol=1e-12)
        np.testing.assert_allclose(hubbed.potential_forces(q), bare.potential_forces(q), rtol=0, atol=1e-12)


def test_body_centres_and_the_kernel_centre_of_mass_agree(rng):
    # Two routes to the centre of mass: the kernel's from the link tables (m_r0, m_psi), and the
    # mass-weighted mean of the link's material points (a fine Gauss rule) and the body centres.
    from gibbsimpact.dynamics.link_points import body_centers, material_points

    payload = gi.RigidBody(0.7, center=(0.1, 0.0, 0.0), inertia=(0.004, 0.03, 0.032), at=0.6)
    links = [gi.Link(1.0, 1.5, 40.0, elements=2, bodies=[payload]),
             gi.Link(0.6, 0.8, 1.0, bodies=[gi.RigidBody(2.0, at=0.0), BODY])]
    model = gi.Model(gi.Chain(links, base=gi.FixedBase((0.2, -0.1), 0.3)))
    xg, wg = np.polynomial.legendre.leggauss(8)
    for _ in range(3):
        q = np.concatenate([rng.uniform(-3, 3, 2), rng.uniform(-0.1, 0.1, 4)])
        P, owner = body_centers(model, q)
        first = sum(b.mass * p for p, (_, b) in zip(P, owner))
        for i, lk in enumerate(links):
            for e in range(2):  # two pieces: the element nodes of link 1 (exact for its cubics)
                x = lk.length * (e + 0.5 * (xg + 1)) / 2
                first = first + lk.mass_per_length * lk.length / 4 * wg @ material_points(model, q, i, x)
        np.testing.assert_allclose(model.center_of_mass(q), first / model.total_mass, rtol=0, atol=1e-13)
    # A rigid link: the payload centre is O_2 + R(phi_2) (l_2 + c_x, c_y) (+ c_z along X3).
    q = np.array([0.4, -1.1, 0.0, 0.0, 0.0, 0.0])
    phi = 0.3 + q[0] + q[1]
    O2 = model.joint_positions(q)[1]
    X, Y = 0.6 + CX, CY
    np.testing.assert_allclose(body_centers(model, q)[0][2],
                               O2 + [X * np.cos(phi) - Y * np.sin(phi), X * np.sin(phi) + Y * np.cos(phi), 0.02],
                               atol=1e-14)
