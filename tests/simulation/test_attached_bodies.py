"""Attached rigid bodies in a run (docs/theory.md §6.8): energy and momentum of a free chain with a
payload and a hub, impacts at e = 1."""

import numpy as np

import gibbsimpact as gi


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
