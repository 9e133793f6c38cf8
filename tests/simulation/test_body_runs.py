"""Attached rigid bodies in a run (docs/theory.md §6.8): energy and momentum of a free chain with a
payload and a hub, impacts at e = 1."""

import numpy as np
import pytest

import gibbsimpact as gi


@pytest.mark.slow  # 15 s of CPU (2026-11-27, docs/design-notes.md#running-the-tests)
def test_free_chain_with_payload_conserves_energy_and_momentum_through_impacts():
    # Planar floating base, no gravity: between impacts E, the linear momentum and the angular
    # momentum about the origin are invariants; an e = 1 impact on the circle keeps E only.
    # (Link 2 is rigid so that the impacts at its tip are well posed, docs/theory.md §11.4.)
    payload = gi.RigidBody(0.6, center=(0.08, 0.0, 0.0), inertia=(0.002, 0.01, 0.011), at=0.35)
    hub = gi.RigidBody(0.4, inertia=(0.002, 0.002, 0.004), at=0.0)
    tip = gi.RigidBody(0.3, center=(0.05, 0.02, 0.0), inertia=(0.001, 0.002, 0.003))
    links = [gi.Link(0.5, 1.0, 20.0, elements=2, bodies=[payload]), gi.Link(0.4, 0.8, 10.0, bodies=[hub, tip])]
    model = gi.Model(gi.Chain(links, base="planar"), gravity=(0.0, 0.0, 0.0))
    q = model.state(X1=-0.3, X2=0.1, theta_1=0.3, theta_2=0.8)
    qd = model.state(X1=1.5, X2=-0.8, theta_1=2.0, theta_2=-3.0)
    res = gi.simulate(model, q, qd, (0.0, 1.0), walls=[gi.Circle(1.0)], restitution=1.0, rtol=1e-12, atol=1e-14)
    assert res.status == "finished", res.message
    assert len(res.impacts) >= 2
    E = res.energy().total
    assert np.max(np.abs(E - E[0])) <= 1e-9 * abs(E[0])
    before = res.t < res.impacts[0].time
    P = np.array([model.linear_momentum(a, b) for a, b in zip(res.q[before], res.qdot[before])])
    H = np.array([model.angular_momentum(a, b, about=np.zeros(3)) for a, b in zip(res.q[before], res.qdot[before])])
    assert np.max(np.abs(P - P[0])) <= 1e-9 * np.linalg.norm(P[0])
    assert np.max(np.abs(H - H[0])) <= 1e-9 * np.linalg.norm(H[0])


def test_an_offset_payload_strikes_the_floor_with_its_centre():
    # A two-link arm on a fixed base whose link-2 payload sits 0.15 m beyond the tip and 0.05 m to the
    # side: its centre is a contact candidate of its own ("body 1", after O1-O3), so it stops at the
    # floor (gap >= 0) with Newton's law v+ = -e v- along the floor's normal.
    payload = gi.RigidBody(0.8, center=(0.15, -0.05, 0.0), inertia=(0.001, 0.004, 0.004))
    links = [gi.Link(0.5, 1.0, 1.0), gi.Link(0.4, 1.0, 1.0, bodies=[payload])]
    model = gi.Model(gi.Chain(links, base=gi.FixedBase((0.0, 0.6), 0.0)))
    floor = gi.Plane((0, 0, 0), (0, 1, 0))
    res = gi.simulate(model, model.state(theta_1=-0.4, theta_2=-0.2), np.zeros(2), (0.0, 0.6), walls=[floor],
                      restitution=0.5, rtol=1e-10, atol=1e-12)
    assert res.status in ("finished", "zeno"), res.message
    first = res.impacts[0]
    assert first.joints == (model.n_joints + 1,)
    from gibbsimpact.dynamics.link_points import body_centers, body_jacobian

    P = body_centers(model, res.q)[0][:, 0]  # (K, 3)
    assert P[:, 1].min() > -1e-9
    i = np.searchsorted(res.t, first.time)
    assert abs(body_centers(model, res.q[i])[0][0, 1]) < 1e-8
    np.testing.assert_allclose(first.v_after, -0.5 * first.v_before, rtol=0, atol=1e-10 * abs(first.v_before[0]))
    # The Jacobian of the centre against central differences of its position (error ~ h^2 |p'''| ~ 1e-10).
    q = np.array([0.3, -0.7])
    _, J = body_jacobian(model, q, 1, payload)
    h = 1e-5
    fd = np.array([(body_centers(model, q + h * e)[0][0] - body_centers(model, q - h * e)[0][0]) / (2 * h)
                   for e in np.eye(2)]).T
    np.testing.assert_allclose(J, fd, rtol=0, atol=1e-9)


def test_body_candidates_in_the_contact_columns_and_the_start_check():
    # Columns: O1-O3, the span of flexible link 2 (one column per element), then the offset payload ("body 1"); a body with
    # c = 0 is the tip point O3 itself and holds it (Newton's law well posed there).
    from gibbsimpact.simulation.contact_points import contact_points

    at_tip = gi.RigidBody(0.3)
    offset = gi.RigidBody(0.2, center=(0.1, 0.0, 0.0))
    links = [gi.Link(0.5, 1.0, 1.0), gi.Link(0.4, 1.0, 5.0, elements=2, bodies=[at_tip, offset])]
    model = gi.Model(gi.Chain(links, base=gi.FixedBase((0.0, 0.6), 0.0)))
    points = contact_points(model)
    assert [p.name for p in points] == ["O1", "O2", "O3", "link 2.1", "link 2.2", "body 1"]
    assert [p.newton_ill_posed for p in points] == [False, False, False, True, True, False]
    bare = gi.Model(gi.Chain([links[0], gi.Link(0.4, 1.0, 5.0, elements=2)], base=gi.FixedBase((0.0, 0.6), 0.0)))
    assert contact_points(bare)[2].newton_ill_posed
    # Start check: link 2 hanging straight down from O2 at y = 0.6 puts O3 at y = 0.2 and the payload's
    # centre 0.1 m further, at y = 0.1: 0.05 m beyond a floor at y = 0.15 that O3 clears.
    q = model.state(theta_2=-np.pi / 2)
    with pytest.raises(ValueError, match=r"puts an attached body outside a wall: the centre of body 1 \(on link 2 at "
                                         r"x = 0.4 m\) at \[0.5, 0.1, 0.0\] m is 0.05 m outside wall 1"):
        gi.simulate(model, q, np.zeros(model.n_dof), (0.0, 0.01), walls=[gi.Plane((0, 0.15, 0), (0, 1, 0))])
