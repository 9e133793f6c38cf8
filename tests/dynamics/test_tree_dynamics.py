"""Flexible trees in motion (formulation §17): invariants in flight and through impacts at e = 1,
and the mirror symmetry of a symmetric tree."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gibbsimpact as gi

CF_Y, CF_Z = gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")


def _integrate(model, q, qd, t_end):
    N = model.n_dof
    f = lambda t, y: np.concatenate((y[N:], model.forward_dynamics(y[:N], y[N:])))  # noqa: E731
    sol = solve_ivp(f, (0, t_end), np.concatenate((q, qd)), method="DOP853", rtol=1e-12, atol=1e-13)
    assert sol.success
    return sol.y[:N].T, sol.y[N:].T


@pytest.mark.slow
def test_spatial_tree_conserves_energy_and_momenta_in_flight():
    """A free-floating 3D flexible tree (two children on one flexible root, one at x_a = 0.5 with a
    tilted axis, a welded tip link, foreshortening on): no gravity, no walls, so E, L and H_0 are
    invariants; DOP853 at rtol 1e-12 over 0.3 s keeps them to 1e-9 relative (the step error
    accumulates to ~1e-11 here: the bound leaves two decades)."""
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(0.6), -np.sin(0.6)], [0.0, np.sin(0.6), np.cos(0.6)]])
    a = gi.Link(1.0, 1.2, (15.0, 25.0), modes=[CF_Y, CF_Z], rotary_inertia=(2e-4, 1e-4, 1e-4))
    b = gi.Link(0.6, 0.8, 10.0, modes=[CF_Y, CF_Z], rotary_inertia=(1e-4, 1e-4, 1e-4))
    c = gi.Link(0.4, 0.5, 8.0, modes=[CF_Y], rotary_inertia=(1e-4, 1e-4, 1e-4))
    chain = gi.Chain([a, b, b, c], joints=[gi.Revolute(), gi.Revolute(axis_rotation=Rx), gi.Revolute(),
                                           gi.Weld(angle=-0.5)], parents=[-1, 0, 0, 2], attach=[None, 0.5, None, None])
    model = gi.Model(chain, gravity=(0.0, 0.0, 0.0))
    rng = np.random.default_rng(11)
    q0 = rng.uniform(-0.4, 0.4, model.n_dof) * np.array([1.0 if u == "rad" else 0.1 for u in model.coordinate_units])
    qd0 = rng.uniform(-1.0, 1.0, model.n_dof)
    qs, qds = _integrate(model, q0, qd0, 0.3)
    E = np.array([model.energy(q, qd).total for q, qd in zip(qs, qds)])
    L = np.array([model.linear_momentum(q, qd) for q, qd in zip(qs, qds)])
    H = np.array([model.angular_momentum(q, qd, about=np.zeros(3)) for q, qd in zip(qs, qds)])
    assert model.energy(q0, qd0).strain > 0
    assert np.max(np.abs(E - E[0])) <= 1e-9 * E[0]
    assert np.max(np.abs(L - L[0])) <= 1e-9 * np.linalg.norm(L[0])
    assert np.max(np.abs(H - H[0])) <= 1e-9 * np.linalg.norm(H[0])


@pytest.fixture(scope="module")
def planar_tree():
    """A planar floating flexible tree: root 0, link 1 at x = 0.4 on it, link 2 at its tip, link 3
    at 1's tip (link 2's tip carries no child: a contact point of its own)."""
    L = lambda l: gi.Link(l, 1.0, 20.0, modes=[CF_Y])  # noqa: E731
    chain = gi.Chain([L(0.6), L(0.5), L(0.5), L(0.3)], parents=[-1, 0, 0, 1], attach=[None, 0.4, None, None],
                     base="planar")
    return gi.Model(chain, gravity=(0.0, 0.0, 0.0))


@pytest.mark.slow
def test_tree_impacts_in_a_circle_conserve_energy_and_angular_momentum(planar_tree):
    """Newton impacts at e = 1 inside a circle: energy is conserved through flight and impacts, and
    so is the angular momentum about the centre (every wall force passes through it); the tips and
    joints of every branch are contact candidates (O5 the last tip, 'tip of link 3' a free tip)."""
    m = planar_tree
    assert m.contact_point_names == ("O1", "O2", "O3", "O4", "O5", "tip of link 3")
    q0 = m.state(X1=-0.2, theta_1=0.3, theta_2=0.8, theta_3=-0.7, theta_4=0.5)
    qd0 = m.state(X1=1.5, X2=0.8, theta_1=2.0, delta_1_1=0.3)
    with pytest.warns(gi.ValidityWarning):
        r = gi.simulate(m, q0, qd0, (0, 0.3), walls=[gi.Circle(1.3, (0, 0))], restitution=1.0, rtol=1e-12,
                        atol=1e-13)
    assert len(r.impacts) >= 2
    E = np.array([m.energy(q, qd).total for q, qd in zip(r.q, r.qdot)])
    H = np.array([m.angular_momentum(q, qd, about=np.zeros(3))[2] for q, qd in zip(r.q, r.qdot)])
    assert np.max(np.abs(E - E[0])) <= 1e-9 * E[0]
    assert np.max(np.abs(H - H[0])) <= 1e-9 * np.max(np.abs(H))


def test_mirror_symmetric_tree_stays_symmetric():
    """A root along X1 on a fixed base with two mirror branches at its tip (theta_2 = -theta_3,
    delta_2 = -delta_3, rates likewise; gravity along -X1): the mirror image about the X1 axis is
    the same motion, so theta_1 = delta_1 = 0 and the branches stay mirrored, to round-off
    accumulated over the run (~1e-13 here; bound 1e-10 rad or m)."""
    lk = gi.Link(0.5, 1.0, 15.0, modes=[CF_Y])
    model = gi.Model(gi.Chain([gi.Link(0.8, 1.0, 25.0, modes=[CF_Y]), lk, lk], parents=[-1, 0, 0],
                              base=gi.FixedBase()), gravity=(-9.81, 0.0, 0.0))
    q0 = model.state(theta_2=0.9, theta_3=-0.9, delta_2_1=0.02, delta_3_1=-0.02)
    qd0 = model.state(theta_2=1.5, theta_3=-1.5, delta_2_1=-0.1, delta_3_1=0.1)
    qs, qds = _integrate(model, q0, qd0, 0.5)
    ix = {nm: k for k, nm in enumerate(model.coordinate_names)}
    assert np.max(np.abs(qs[:, ix["theta_2"]])) > 0.5  # it moves
    for a, b in (("theta_2", "theta_3"), ("delta_2_1", "delta_3_1")):
        assert np.max(np.abs(qs[:, ix[a]] + qs[:, ix[b]])) <= 1e-10
    for a in ("theta_1", "delta_1_1"):
        assert np.max(np.abs(qs[:, ix[a]])) <= 1e-10


@pytest.mark.slow
def test_path_tree_impacts_like_the_chain():
    """A tree whose branches form one path (each child attached explicitly at its parent's tip: the
    tree's own contact-point and attachment code) hits a circle like the serial chain: the same
    impacts at the same times, and the same final state, to the integrator's tolerance."""
    cc = gi.Mode("clamped-clamped", "y")
    links = [gi.Link(1.0, 1.0, 50.0, modes=[cc]), gi.Link(1.0, 1.0, 50.0, modes=[cc])]
    out = []
    for kw in ({}, dict(parents=[-1, 0], attach=[None, 1.0])):
        m = gi.Model(gi.Chain(links, **kw), gravity=(0.0, -9.81, 0.0))
        q0 = m.state(X1=-0.5, theta_1=0.4, theta_2=0.5)
        qd0 = m.state(X1=2.0, theta_2=1.0)
        out.append(gi.simulate(m, q0, qd0, (0, 0.4), walls=[gi.Circle(1.6, (0, 0))], rtol=1e-11, atol=1e-12))
    a, b = out
    assert len(a.impacts) == len(b.impacts) >= 1
    np.testing.assert_allclose([i.time for i in b.impacts], [i.time for i in a.impacts], rtol=0, atol=1e-9)
    np.testing.assert_allclose(b.q[-1], a.q[-1], rtol=0, atol=1e-8)
