"""Foreshortening and geometric stiffening of flexible links (formulation §15).

Closed forms: the rotating clamped-free link's frequencies (§15's table) and the tip of a bent
link at x = l + u_f(l); invariants: energy and momenta of a free-flying stiffened chain, with
and without impacts at e = 1.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gibbsimpact as gi
from gibbsimpact.dynamics.gibbs_appell import bias_forces, mass_matrix, potential_forces

# formulation §15: lambda -> the first two flapwise omega_bar = omega sqrt(mu l^4 / EI) of a
# uniform clamped-free link spinning at Omega = lambda sqrt(EI / (mu l^4)) about its joint axis.
FLAPWISE = {0.0: (3.5160, 22.0345), 1.0: (3.6816, 22.1810), 2.0: (4.1373, 22.6149),
            5.0: (6.4495, 25.4461), 10.0: (11.2023, 33.6404)}
# The table's 5 significant digits: a rounding error <= 0.00005 / 3.516 = 1.4e-5 relative.
ROUND = 1.5e-5


def _spinning_link(discretisation, stiffening=True):
    """A uniform clamped-free link, l = mu = EI = 1, bending in y (in the plane of rotation) and
    z (flapwise), on a fixed base, no gravity: 12 Hermite elements or 10 clamped-free modes per
    direction (both converge to below 2e-5 of the table at lambda = 10)."""
    if discretisation == "elements":
        link = gi.Link(1.0, 1.0, 1.0, elements=12, element_directions=("y", "z"), geometric_stiffening=stiffening)
    else:
        link = gi.Link(1.0, 1.0, 1.0, modes=[gi.Mode("clamped-free", d, k + 1) for d in "yz" for k in range(10)],
                       geometric_stiffening=stiffening)
    return gi.Model(gi.Chain([link], base=gi.FixedBase()), gravity=(0.0, 0.0, 0.0))


def _effective_stiffness(model, omega):
    """-d(deltaddot)/d(delta) (m, m) [1/s^2] at delta = deltadot = 0, theta_1 spinning at omega
    [rad/s] with thetaddot_1 = 0 held (formulation §16's partition: M_dd deltaddot = -h_d - dV_d),
    by central differences (the equations are smooth in delta: error ~1e-10 of the entries)."""
    N = model.n_dof
    d = np.arange(1, N)
    qd = np.zeros(N)
    qd[0] = omega

    def deltaddot(delta):
        q = np.zeros(N)
        q[d] = delta
        M = mass_matrix(model, q)
        return -np.linalg.solve(M[np.ix_(d, d)], (bias_forces(model, q, qd) + potential_forces(model, q))[d])

    eps = 1e-6
    cols = [(deltaddot(eps * e) - deltaddot(-eps * e)) / (2 * eps) for e in np.eye(N - 1)]
    return -np.array(cols).T


def _frequencies(model, lam):
    """Squared non-dimensional frequencies (sorted) of the in-plane (y) and flapwise (z) blocks."""
    K = _effective_stiffness(model, lam)  # l = mu = EI = 1: Omega = lambda, omega_bar = omega
    dirs = np.array(model.link_data[0].directions)
    y, z = np.flatnonzero(dirs == "y"), np.flatnonzero(dirs == "z")
    # the two planes decouple in the linearised motion
    assert np.abs(K[np.ix_(y, z)]).max() <= 1e-6 * np.abs(K).max()
    return np.sort(np.linalg.eigvals(K[np.ix_(y, y)]).real), np.sort(np.linalg.eigvals(K[np.ix_(z, z)]).real)


@pytest.mark.parametrize("discretisation", ["elements", "modes"])
def test_rotating_link_frequencies_match_formulation_table(discretisation):
    model = _spinning_link(discretisation)
    for lam, (w1, w2) in FLAPWISE.items():
        inplane, flap = _frequencies(model, lam)
        assert np.sqrt(flap[:2]) == pytest.approx([w1, w2], rel=1e-4)
        # in-plane: omega^2 = omega_flap^2 - lambda^2 (the table's values, so their rounding counts twice)
        assert np.sqrt(inplane[:2]) == pytest.approx(np.sqrt(np.array([w1, w2]) ** 2 - lam**2), rel=1e-4 + 2 * ROUND)
        # and against this model's own flapwise frequencies, with no rounding in between
        np.testing.assert_allclose(inplane[:2], flap[:2] - lam**2, rtol=1e-8, atol=1e-8 * flap[1])


@pytest.mark.parametrize("discretisation", ["elements", "modes"])
def test_linear_beam_goes_unstable_in_plane_above_lambda_3516(discretisation):
    # Without foreshortening K_eff = K - Omega^2 M in the plane of rotation (formulation §15):
    # unstable once lambda exceeds the first non-rotating frequency 3.51602; flapwise unchanged.
    model = _spinning_link(discretisation, stiffening=False)
    for lam in (0.0, 2.0, 3.50, 3.53, 5.0, 10.0):
        inplane, flap = _frequencies(model, lam)
        assert np.sqrt(flap[0]) == pytest.approx(3.5160, rel=1e-4)
        assert (inplane[0] < 0.0) == (lam > 3.516)


def _free_chain(gravity=(0.0, 0.0, 0.0)):
    """A free-flying spatial chain of two stiffened links: 2 Hermite elements in y and z (an interior
    node: foreshortening couples the elements), then a y and a z clamped-free mode and a y
    clamped-clamped one (rotary inertia: M regular). Two elements, not three: the highest frequency
    at the test state is 1023 rad/s instead of 2042, so DOP853 at rtol 1e-12 takes half the steps."""
    a = gi.Link(1.0, 1.2, (15.0, 25.0), elements=2, element_directions=("y", "z"), rotary_inertia=(2e-4, 1e-4, 1e-4))
    b = gi.Link(0.7, 0.8, 10.0, modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z"),
                                       gi.Mode("clamped-clamped", "y")], rotary_inertia=(1e-4, 1e-4, 3e-4))
    return gi.Model(gi.Chain([a, b]), gravity=gravity)


def _free_state(model):
    rng = np.random.default_rng(24)
    q = rng.uniform(-0.5, 0.5, model.n_dof)
    qd = rng.normal(scale=1.0, size=model.n_dof)
    for idx in model.delta_index:
        q[idx] = rng.uniform(-0.05, 0.05, idx.size)
        qd[idx] *= 0.3
    return q, qd


@pytest.mark.slow  # 13 s of CPU (2026-11-27, docs/design-notes.md#running-the-tests)
def test_free_flight_conserves_energy_and_momenta():
    # Exact holonomic system (formulation §15): E, L and H0 constant to the integrator's error.
    model = _free_chain()
    q, qd = _free_state(model)
    N = model.n_dof
    sol = solve_ivp(lambda t, y: np.concatenate((y[N:], model.forward_dynamics(y[:N], y[N:]))), (0.0, 1.0),
                    np.concatenate((q, qd)), method="DOP853", rtol=1e-12, atol=1e-13)
    assert sol.success
    E0, L0, H0 = model.energy(q, qd), model.linear_momentum(q, qd), model.angular_momentum(q, qd)
    scale = E0.kinetic + E0.strain
    assert E0.strain > 0.0
    for y in sol.y.T:
        assert abs(model.energy(y[:N], y[N:]).total - E0.total) <= 1e-9 * scale
        assert np.linalg.norm(model.linear_momentum(y[:N], y[N:]) - L0) <= 1e-9 * np.linalg.norm(L0)
        assert np.linalg.norm(model.angular_momentum(y[:N], y[N:]) - H0) <= 1e-9 * np.linalg.norm(H0)


@pytest.mark.slow  # 5 s of CPU with a warm cache (2026-11-27; 0.4 s span, was 1 s and 57 s)
def test_impacts_at_e1_conserve_energy_and_angular_momentum_about_the_centre():
    # Frictionless impacts on a sphere push through its centre: H about it and E stay (e = 1).
    # The base starts at the centre, moving at ~3.8 m/s (4x the random state's base velocity), inside a
    # sphere of R = 1.8 m (the chain reaches 1.65 m): three impacts (O3, O2, O3) by t = 0.4 s.
    model = _free_chain()
    q, qd = _free_state(model)
    q[:3] = 0.0
    qd[:3] *= 4.0
    res = gi.simulate(model, q, qd, (0.0, 0.4), walls=[gi.Sphere(1.8)], restitution=1.0, rtol=1e-12,
                      atol=1e-13)
    assert res.status == "finished", res.message
    assert len(res.impacts) >= 3
    E = res.energy()
    scale = E.kinetic[0] + E.strain[0]
    assert np.max(np.abs(E.total - E.total[0])) <= 1e-9 * scale
    H0 = model.angular_momentum(res.q[0], res.qdot[0], about=np.zeros(3))
    # Each sample's q is in its own chart of the free base (the run re-charts near theta_0 = +-pi/2): Result.model_at.
    H = np.array([res.model_at(k).angular_momentum(a, b, about=np.zeros(3)) for k, (a, b) in enumerate(zip(res.q, res.qdot))])
    assert np.max(np.linalg.norm(H - H0, axis=1)) <= 1e-9 * np.linalg.norm(H0)


def test_tip_of_a_bent_link_sits_at_l_plus_u_f_everywhere():
    # One Hermite element (l = 0.8 m) bent by a tip deflection w1 and slope t1: v(x) = w1 H3 + l t1 H4,
    # u_f(l) = -1/2 int_0^l v'^2 dx by numpy's exact polynomial integration (no package code).
    from numpy.polynomial import Polynomial as P

    from gibbsimpact.contact.closest_points import closest_points
    from gibbsimpact.dynamics.link_points import link_points, material_jacobian, material_points
    from gibbsimpact.plotting.geometry import _link_parts

    l, th, w1, t1 = 0.8, 0.4, 0.12, 0.2
    xi = P([0.0, 1.0 / l])
    v = w1 * (3 * xi**2 - 2 * xi**3) + l * t1 * (-xi**2 + xi**3)
    u_f = -0.5 * (v.deriv() ** 2).integ()(l)
    R = np.array([[np.cos(th), -np.sin(th), 0.0], [np.sin(th), np.cos(th), 0.0], [0.0, 0.0, 1.0]])
    tip = R @ [l + u_f, v(l), 0.0]
    model = gi.Model(gi.Chain([gi.Link(l, 1.0, 5.0, elements=1)], base=gi.FixedBase()), gravity=(0.0, 0.0, 0.0))
    q = np.array([th, w1, t1])
    assert u_f < -1e-3  # a visible shortening: 1.2 % of l
    np.testing.assert_allclose(model.joint_positions(q)[1], tip, rtol=0, atol=1e-15)  # kernel end transform
    np.testing.assert_allclose(material_points(model, q, 0, [l])[0], tip, rtol=0, atol=1e-15)
    np.testing.assert_allclose(material_jacobian(model, q, np.zeros(3), 0, l)[0], tip, rtol=0, atol=1e-15)
    np.testing.assert_allclose(link_points(model, q)[0, -1], tip, rtol=0, atol=1e-15)
    np.testing.assert_allclose(_link_parts(model, q)[0][0][-1], tip, rtol=0, atol=1e-15)  # what the figures draw
    # mid-span: x = l/2 + u_f(l/2), the same integral up to l/2
    mid = R @ [l / 2 - 0.5 * (v.deriv() ** 2).integ()(l / 2), v(l / 2), 0.0]
    np.testing.assert_allclose(material_points(model, q, 0, [l / 2])[0], mid, rtol=0, atol=1e-15)
    # a plane wall across the link axis beyond the tip: the closest point is the tip, its gap the tip's
    ex = R[:, 0]
    wall = gi.Plane(point=tuple(R @ [l + 0.05, 0.0, 0.0]), normal=tuple(-ex))
    cp = closest_points(model, q, [wall])
    assert cp.x[0, 0] == pytest.approx(l, abs=1e-9)
    assert cp.gap[0, 0] == pytest.approx(float(ex @ (R @ [l + 0.05, 0.0, 0.0] - tip)), abs=1e-12)


@pytest.mark.slow  # 2 s of CPU with a warm cache (2026-11-27; 0.2 s span, was 0.5 s and 144 s)
def test_attached_bodies_foreshorten_with_their_link_and_conserve_energy():
    # A tip payload (axial lever: its points sit at x_a + s) and a hub on stiffened links: the
    # foreshortening sums run over the same mass points (model.shapes.mass_points), so E stays.
    # The span ends before the base's Euler angles near gimbal lock (theta_0 -> pi/2 at t = 0.476 s),
    # where solve_ivp on the raw coordinates (no re-charting, unlike simulate) shrinks its step to
    # 3e-11 s: 2.1e6 right-hand sides in all, 97 % of them in the last 0.05 s of a 0.5 s span.
    body = gi.RigidBody(0.3, center=(0.05, 0.0, 0.0), inertia=np.diag([2e-4, 1e-3, 1e-3]))
    a = gi.Link(1.0, 1.2, (15.0, 25.0), elements=3, element_directions=("y", "z"), rotary_inertia=(2e-4, 1e-4, 1e-4),
                bodies=[body])
    b = gi.Link(0.7, 0.8, 10.0, modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")],
                rotary_inertia=(1e-4, 1e-4, 3e-4), bodies=[body])
    model = gi.Model(gi.Chain([a, b]), gravity=(0.0, 0.0, 0.0))
    q, qd = _free_state(model)
    N = model.n_dof
    sol = solve_ivp(lambda t, y: np.concatenate((y[N:], model.forward_dynamics(y[:N], y[N:]))), (0.0, 0.2),
                    np.concatenate((q, qd)), method="DOP853", rtol=1e-12, atol=1e-13)
    assert sol.success
    assert np.abs(sol.y[model.coordinate_names.index("theta_0")]).max() < 1.2  # away from pi/2
    E0 = model.energy(q, qd)
    E = np.array([model.energy(y[:N], y[N:]).total for y in sol.y.T])
    assert np.max(np.abs(E - E0.total)) <= 1e-9 * (E0.kinetic + E0.strain)


@pytest.mark.parametrize("gravity", [(0.0, 0.0, 0.0), (0.0, -9.81, 0.0)])
def test_carriage_on_a_stiffened_host_conserves_energy(gravity):
    # formulation §15: a Pa carriage at d +- c rides on the foreshortened host (kernel/frames.py,
    # _carriage_foreshortening), both links stiffened, no damping: an exact holonomic system, so
    # max |E(t) - E(0)| / (|T| + |V_g| + |V_s|)_0 <= 1e-9 over 0.5 s (DOP853 rtol 1e-11), through
    # the carriage's crossings of the host's nodes and elastic end stops (e = 1).
    host = gi.Link(1.0, 1.0, 10.0, elements=3)
    arm = gi.Link(0.6, 0.5, 2.0, elements=2)
    pa = gi.SlidingPrismatic(angle=0.6, half_length=0.04, range=(0.05, 0.95))
    model = gi.Model(gi.Chain([host, arm], joints=[gi.Revolute(), pa], base=gi.FixedBase((0.1, 0.2), 0.3)),
                     gravity=gravity)
    assert host.stiffened and arm.stiffened
    q0, qd0 = np.zeros(model.n_dof), np.zeros(model.n_dof)
    (q0[model.theta_index[0]], q0[model.theta_index[1]]) = 0.4, 0.30
    (qd0[model.theta_index[0]], qd0[model.theta_index[1]]) = 2.0, 0.8
    for idx in model.delta_index:
        q0[idx] = np.random.default_rng(24).normal(scale=0.02, size=idx.size)
    res = gi.simulate(model, q0, qd0, (0.0, 0.5), rtol=1e-11, atol=1e-12, joint_limit="impact", joint_restitution=1.0)
    assert res.status == "finished", res.message
    E = res.energy()
    drift = np.abs(E.total - E.total[0]).max() / (abs(E.kinetic[0]) + abs(E.gravity[0]) + abs(E.strain[0]))
    assert drift <= 1e-9, drift
    d = res.q[:, model.theta_index[1]]
    assert any(np.any(np.diff(np.sign(d + s * 0.04 - x))) for x in (1 / 3, 2 / 3) for s in (1, -1)), (d.min(), d.max())
