"""Friction in resting contact (stick and slip): a rigid rod on inclined and horizontal planes.

Contract under test (public API only): a pair in resting contact on a wall with Coulomb
coefficient mu either sticks (its contact point does not move; tangential force F_t inside
the cone |F_t| <= mu N) or slips (F_t = -mu N along the slip direction); stick -> slip when
|F_t| reaches mu N, slip -> stick when the slip velocity reaches 0 (an event). A rigid rod
lying on a plane at rest at t0 starts in resting contact. ``Result.contact_forces`` (K, W, P)
[N] holds the normal force N of wall w on contact point O_(j+1), ``Result.friction_forces``
(K, W, P, 3) [N] its tangential force as a world vector (None when no wall has friction).

Every expected number is derived in the comments from Newton's laws of a rigid rod,
independently of the package. The rod is a line mass (l = 1 m, 2 kg/m: m = 2 kg) with
coordinates (X1, X2, X3, theta_-1, theta_0, theta_1): O1 = (X1, X2, X3) and, in the X1-X2
plane, O2 = O1 + l (cos theta_1, sin theta_1, 0); j_x > 0 (spin about its own axis) only
keeps M regular. Its mass centre G (model.center_of_mass) is the midpoint of O1 O2.

Plane inclined at alpha through the origin: n = (-sin a, cos a, 0) (into the free side),
surface y = x tan a, up-slope unit vector u = (cos a, sin a, 0). The rod lies along u with
O1 at the origin (theta_1 = a, both ends on the plane, at rest). Gravity m g_vec, g_vec =
(0, -g, 0), splits into -m g sin(a) u (down the slope) and -m g cos(a) n (into the plane).
Statics/dynamics of the rod on the plane:
  * along n: the rod does not leave the plane, so N_1 + N_2 = m g cos a;
  * moments about G: G, O1, O2 and the friction forces (along the rod's axis, which lies
    in the plane) are all on one line, so only the normal forces have moments about G,
    (l/2)(N_2 - N_1) = 0: N_1 = N_2 = m g cos(a) / 2 (determinate, stick or slip);
  * along u: m s'' = m g sin a - F, s = -(G - G0) . u the distance slid down, F the total
    friction force up the slope.
"""

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.link_points import link_points

G = 9.81
CONTACT_TOL = 1e-9  # simulate's default contact_tol [m]
L, MU_L = 1.0, 2.0  # rod length [m], mass per length [kg/m]
M = L * MU_L  # 2 kg
ALPHA = np.radians(20.0)  # tan(alpha) = 0.364
N_IN = np.array([-np.sin(ALPHA), np.cos(ALPHA), 0.0])  # incline normal, into the free side
U_UP = np.array([np.cos(ALPHA), np.sin(ALPHA), 0.0])  # up the slope, along the rod


def planar_rod():
    # As tests/test_friction_impacts.planar_rod: a rigid line mass (no modes), I_G = m l^2 / 12.
    link = gi.Link(L, MU_L, 20.0, modes=[], rotary_inertia=(1e-4, 0.0, 0.0))
    return gi.Model(gi.Chain([link]), gravity=(0.0, -G, 0.0))


def incline(mu):
    return gi.Plane((0.0, 0.0, 0.0), tuple(N_IN), friction=mu)


def run_on_incline(mu, t_end):
    """The rod lying along the line of steepest descent, O1 at the origin, released at rest."""
    model = planar_rod()
    q0 = model.state(theta_1=ALPHA)
    wall = incline(mu)
    # Exactly on the plane: both ends at gap 0 (round-off).
    assert np.max(np.abs(wall.gap(model.joint_positions(q0)))) <= 1e-15
    res = gi.simulate(model, q0, np.zeros(6), (0.0, t_end), walls=[wall], restitution=0.5, output_dt=1e-2)
    assert res.status == "finished", res.message
    assert res.t[-1] == pytest.approx(t_end, abs=1e-12)
    assert res.impacts == []  # resting contact from t0: no impact, no bounce (e = 0.5 is unused)
    return model, res


def centre(model, res):
    """(K, 3) mass centre at the samples [m]."""
    return np.array([model.center_of_mass(q) for q in res.q])


def gaps(res):
    P = res.joint_positions()
    return np.stack([w.gap(P) for w in res.walls], axis=1)  # (K, W, P)


def check_forces(res):
    """Shapes, N >= 0, F_t tangential, inside the cone |F_t| <= mu N; returns (N (K, P), F_t (K, P, 3))."""
    K, P = res.t.size, res.model.n_joints
    N = np.asarray(res.contact_forces)
    Ft = np.asarray(res.friction_forces)
    assert N.shape == (K, 1, P) and Ft.shape == (K, 1, P, 3)
    assert np.all(np.isfinite(N)) and np.all(np.isfinite(Ft))
    N, Ft = N[:, 0], Ft[:, 0]
    assert N.min() >= -1e-12 * M * G
    n = res.walls[0].normal(res.joint_positions().reshape(-1, 3)).reshape(K, P, 3)
    assert np.max(np.abs(np.einsum("kpc,kpc->kp", Ft, n))) <= 1e-9 * M * G  # no normal part
    mu = res.walls[0].friction
    assert np.all(np.linalg.norm(Ft, axis=2) <= mu * N + 1e-12 * M * G)  # Coulomb cone
    assert np.max(np.abs(Ft[:, :, 2])) <= 1e-9 * M * G  # no load along X3
    return N, Ft


def test_rod_sticks_on_an_incline_steeper_friction_than_slope():
    # mu = 0.5 > tan(20 deg) = 0.364: the cone holds the rod. Statics (module docstring):
    #   sum_j N_j = m g cos a = 18.437 N, N_1 = N_2 = m g cos(a) / 2,
    #   sum_j F_t,j = m g sin(a) u = 6.711 N up the slope (F = m g sin a, s'' = 0),
    # the split of F between the ends is statically indeterminate (only the sum is checked),
    # and the cone holds: |F| = m g sin a <= mu m g cos a = sum_j mu N_j.
    mu, t_end = 0.5, 1.0
    assert mu > np.tan(ALPHA)
    _, res = run_on_incline(mu, t_end)
    N, Ft = check_forces(res)
    P = res.joint_positions()
    assert np.max(np.abs(P - P[0])) <= 1e-9  # nothing moves
    assert np.max(np.abs(gaps(res))) <= CONTACT_TOL
    np.testing.assert_allclose(N.sum(axis=1), M * G * np.cos(ALPHA), rtol=1e-8, atol=0)
    np.testing.assert_allclose(N, M * G * np.cos(ALPHA) / 2, rtol=1e-8, atol=0)
    np.testing.assert_allclose(Ft.sum(axis=1), np.tile(M * G * np.sin(ALPHA) * U_UP, (res.t.size, 1)),
                               rtol=0, atol=1e-8 * M * G * np.sin(ALPHA))


@pytest.mark.parametrize("excess", [0.0, 1e-12, -1e-12])
def test_rod_at_the_friction_angle_stays_at_rest(excess):
    # mu = tan(alpha) (1 + excess): the friction force m g sin(alpha) sits at the cone's edge, and
    # sticking or slipping both give zero acceleration. The rod stays where it is, with
    # m g cos(alpha) / 2 normal and m g sin(alpha) / 2 friction at each end. (Before the slip
    # offset of resting.py's "stick" event, the slip that starts from rest stopped at once and
    # slipped again: "event loop stalled at t = 0 s".)
    model = planar_rod()
    q0 = model.state(theta_1=ALPHA)
    res = gi.simulate(model, q0, np.zeros(6), (0.0, 1.0), walls=[incline(np.tan(ALPHA) * (1.0 + excess))],
                      restitution=0.5, output_dt=1e-2)
    assert res.status == "finished", res.message
    assert np.max(np.abs(centre(model, res) - centre(model, res)[0])) <= 1e-9
    N = res.contact_forces[:, 0, :2]
    np.testing.assert_allclose(N, M * G * np.cos(ALPHA) / 2, rtol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(res.friction_forces[:, 0, :2], axis=-1), M * G * np.sin(ALPHA) / 2,
                               rtol=1e-9)


def test_rod_slides_down_an_incline_against_coulomb_friction():
    # mu = 0.2 < tan(20 deg): the cone cannot hold the rod; it slides down along its own axis
    # without turning. Slip down the slope (-u), so each end's friction is +mu N_j u:
    #   F = mu (N_1 + N_2) = mu m g cos a,  s'' = A = g (sin a - mu cos a) = 1.5115 m/s^2,
    #   s(t) = A t^2 / 2,  N_j = m g cos(a) / 2,  F_t,j = mu m g cos(a) / 2 u.
    # Energy E = T + m g y_G: T = m (A t)^2 / 2 = m A s, V - V0 = -m g sin(a) s, so
    #   E(t) - E(0) = m s (A - g sin a) = -mu m g cos(a) s(t)    (the work of friction).
    mu, t_end = 0.2, 1.0
    assert mu < np.tan(ALPHA)
    model, res = run_on_incline(mu, t_end)
    N, Ft = check_forces(res)
    A = G * (np.sin(ALPHA) - mu * np.cos(ALPHA))
    Gp = centre(model, res)
    s = -(Gp - Gp[0]) @ U_UP
    late = res.t >= 1e-3
    assert np.count_nonzero(late) >= 90
    np.testing.assert_allclose(s[late], A * res.t[late] ** 2 / 2, rtol=1e-8, atol=0)
    # Along the line of steepest descent: no sideways motion, no lift-off, no turn.
    assert np.max(np.abs((Gp - Gp[0]) @ N_IN)) <= CONTACT_TOL
    assert np.max(np.abs(Gp[:, 2])) <= 1e-12
    assert np.max(np.abs(gaps(res))) <= CONTACT_TOL
    np.testing.assert_allclose(res.q[:, model.coordinate_names.index("theta_1")], ALPHA, rtol=0, atol=1e-9)
    # Forces at every sample (the first at t0 included: it slips from the start).
    np.testing.assert_allclose(N, M * G * np.cos(ALPHA) / 2, rtol=1e-8, atol=0)
    ref = mu * M * G * np.cos(ALPHA) / 2 * U_UP  # up the slope: opposite to the motion
    np.testing.assert_allclose(Ft, np.broadcast_to(ref, Ft.shape), rtol=0, atol=1e-8 * np.linalg.norm(ref))
    # Work of friction.
    E = res.energy().total
    W = -mu * M * G * np.cos(ALPHA) * s
    np.testing.assert_allclose((E - E[0])[late], W[late], rtol=1e-8, atol=0)


def test_rod_slips_then_sticks_on_a_horizontal_floor():
    # Floor y = 0 (n = (0, 1, 0)), mu = 0.3, the rod on it along X1, sliding along its axis
    # at v0 = 1 m/s. N_1 = N_2 = m g / 2 (moments about G as in the module docstring), the
    # friction -mu N_j x_hat at each end, so while it slips
    #   x_G'' = -mu g,  v(t) = v0 - mu g t,  x_G(t) - x_G(0) = v0 t - mu g t^2 / 2,
    # until v = 0 at t* = v0 / (mu g) = 0.33979 s, after d = v0^2 / (2 mu g) = 0.16990 m.
    # Then no horizontal load: the cone holds it with F_t = 0 (stick) up to t_end = 2 t*.
    # Energy (y_G = 0): E(t) - E(0) = m (v^2 - v0^2) / 2 = -mu m g s(t), s = x_G(t) - x_G(0).
    mu, v0 = 0.3, 1.0
    t_star, d = v0 / (mu * G), v0**2 / (2 * mu * G)
    t_end = 2 * t_star
    model = planar_rod()
    wall = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), friction=mu)
    res = gi.simulate(model, model.state(), model.state(X1=v0), (0.0, t_end), walls=[wall], restitution=0.5,
                      output_dt=1e-2)
    assert res.status == "finished", res.message
    assert res.t[-1] == pytest.approx(t_end, abs=1e-12)
    assert res.impacts == []
    N, Ft = check_forces(res)
    assert np.max(np.abs(gaps(res))) <= CONTACT_TOL
    np.testing.assert_allclose(N, M * G / 2, rtol=1e-8, atol=0)

    Gp = centre(model, res)
    vG = np.array([model.linear_momentum(q, qd) for q, qd in zip(res.q, res.qdot)]) / M
    s = Gp[:, 0] - Gp[0, 0]
    assert np.max(np.abs(Gp[:, 1:])) <= CONTACT_TOL
    # The slip -> stick event is located, so its instant is a sample: the first sample at rest.
    at_rest = np.linalg.norm(vG, axis=1) <= 1e-6
    k_stop = int(np.argmax(at_rest))
    assert at_rest[k_stop] and np.all(at_rest[k_stop:])
    assert res.t[k_stop] == pytest.approx(t_star, rel=1e-8)
    before, after = res.t < res.t[k_stop], res.t > res.t[k_stop]
    assert np.count_nonzero(before) >= 30 and np.count_nonzero(after) >= 30
    t = res.t[before]
    np.testing.assert_allclose(vG[before, 0], v0 - mu * G * t, rtol=0, atol=1e-8 * v0)
    np.testing.assert_allclose(s[before], v0 * t - mu * G * t**2 / 2, rtol=0, atol=1e-8 * d)
    np.testing.assert_allclose(s[k_stop:], d, rtol=1e-8, atol=0)
    assert np.max(np.abs(vG[after])) <= 1e-9
    # Friction: mu N_j against the motion while slipping, zero once stuck.
    np.testing.assert_allclose(Ft[before], np.broadcast_to([-mu * M * G / 2, 0.0, 0.0], Ft[before].shape),
                               rtol=0, atol=1e-8 * mu * M * G / 2)
    assert np.max(np.abs(Ft[after])) <= 1e-9
    # Work of friction.
    E = res.energy().total
    late = res.t >= 1e-3
    np.testing.assert_allclose((E - E[0])[late], -mu * M * G * s[late], rtol=1e-8, atol=0)


def test_frictionless_rod_slides_down_an_incline():
    # mu = 0: the regression anchor of the frictionless path (resting contact without friction).
    #   s(t) = g sin(a) t^2 / 2,  N_1 = N_2 = m g cos(a) / 2,  E(t) = E(0) (workless wall).
    model, res = run_on_incline(0.0, 1.0)
    assert getattr(res, "friction_forces", None) is None  # no wall has friction
    N = np.asarray(res.contact_forces)
    assert N.shape == (res.t.size, 1, model.n_joints)
    np.testing.assert_allclose(N[:, 0], M * G * np.cos(ALPHA) / 2, rtol=1e-8, atol=0)
    Gp = centre(model, res)
    s = -(Gp - Gp[0]) @ U_UP
    late = res.t >= 1e-3
    np.testing.assert_allclose(s[late], G * np.sin(ALPHA) * res.t[late] ** 2 / 2, rtol=1e-8, atol=0)
    assert np.max(np.abs((Gp - Gp[0]) @ N_IN)) <= CONTACT_TOL
    assert np.max(np.abs(gaps(res))) <= CONTACT_TOL
    E = res.energy().total
    s_end = G * np.sin(ALPHA) / 2  # s(1 s): the energy scale, m g sin(a) s_end = 11.2 J
    assert np.max(np.abs(E - E[0])) <= 1e-8 * M * G * np.sin(ALPHA) * s_end


def test_stick_slip_under_an_oscillating_push_matches_a_one_dof_reference():
    # A rod lying on a floor (mu = 0.3) pushed along its axis by F(t) = 1.5 mu m g sin(2 pi t):
    # it sticks while |F| <= mu m g, slips with m a = F - mu m g sign(v) otherwise, and sticks
    # again where v returns to 0 with |F| <= mu m g. The reference integrates that 1-dof law
    # with scipy (its own events), independently of the package.
    from scipy.integrate import solve_ivp

    mu, T = 0.3, 2.0
    model = planar_rod()
    F0 = 1.5 * mu * M * G
    F = lambda t: F0 * np.sin(2 * np.pi * t)  # noqa: E731
    res = gi.simulate(model, model.state(), np.zeros(6), (0.0, T), walls=[gi.Plane((0, 0, 0), (0, 1, 0), friction=mu)],
                      inputs={"X1": lambda t, q, qd: F(t)}, output_dt=1e-3)
    assert res.status == "finished", res.message

    t, x, pieces = 0.0, 0.0, []
    while t < T:
        # stick until |F| reaches mu m g (on a fine grid, then brentq)
        from scipy.optimize import brentq
        grid = np.linspace(t, T, 4001)
        over = np.nonzero(np.abs(F(grid)) > mu * M * G)[0]
        if over.size == 0:
            pieces.append(("stick", t, T, x))
            break
        k = int(over[0])
        t1 = brentq(lambda s: abs(F(s)) - mu * M * G, grid[max(k - 1, 0)], grid[k], xtol=1e-15) if k else t
        pieces.append(("stick", t, t1, x))
        s = np.sign(F(t1 + 1e-9))
        stop = lambda tt, y: y[1]  # noqa: E731
        stop.terminal, stop.direction = True, -s
        sol = solve_ivp(lambda tt, y: [y[1], (F(tt) - mu * M * G * s) / M], (t1, T), [x, 0.0], rtol=1e-12,
                        atol=1e-14, events=stop, dense_output=True)
        pieces.append(("slip", t1, sol.t[-1], sol.sol))
        t, x = sol.t[-1], sol.y[0, -1]

    def x_ref(tt):
        for kind, a, b, data in pieces:
            if a <= tt <= b:
                return data if kind == "stick" else data(tt)[0]
        return np.nan

    ref = np.array([x_ref(tt) for tt in res.t])
    assert len([p for p in pieces if p[0] == "slip"]) >= 3
    np.testing.assert_allclose(res.q[:, 0], ref, atol=1e-8)
    Nsum = res.contact_forces[:, 0, :].sum(axis=1)
    assert np.all(np.abs(res.friction_forces[:, 0, :, 0].sum(axis=1)) <= mu * Nsum * (1 + 1e-9))
    assert res.energy_error <= 1e-8


# -- issue 25 item 9: contact phases with friction advance at the pace of the physics ------------

def _across_the_slope(mu, j=1e-4):
    """(model, q0, wall): the rod lying on the incline with its axis at 45 degrees to the line of
    steepest descent (theta_0 = -pi/4 tilts it out of the X1-X2 plane; tan theta_1 = cos theta_0
    tan alpha puts its X1-X2 projection along u), both ends on the plane."""
    link = gi.Link(L, MU_L, 20.0, modes=[], rotary_inertia=(j, j, j))
    model = gi.Model(gi.Chain([link]), gravity=(0.0, -G, 0.0))
    th0 = -np.pi / 4
    q0 = model.state(theta_0=th0, theta_1=np.arctan(np.cos(th0) * np.tan(ALPHA)))
    wall = incline(mu)
    assert np.max(np.abs(wall.gap(model.joint_positions(q0)))) <= 1e-15
    return model, q0, wall


def test_rod_across_the_slope_at_the_friction_angle_rests_without_crawling():
    # mu = tan(alpha): each end's friction sits at the cone's edge and balances the pull down the
    # slope (sum F_t = m g sin(a) u, sum N = m g cos(a): the rod's statics, any orientation in the
    # plane); slipping or sticking, the rod keeps zero acceleration and stays at rest. The slip
    # from rest kept its direction regularised over grazing_velocity = 1e-6 m/s, whose feedback on
    # a slip across s0 (mu N / (m v_tol) ~ 1e6 1/s) made the ODE stiff: 22 571 steps for 0.027 s.
    # Now the held direction (7') steps as the frictionless run does: at most 10 times its
    # right-hand sides.
    t_end = 0.05
    model, q0, wall = _across_the_slope(np.tan(ALPHA))
    frictionless = gi.simulate(model, q0, np.zeros(6), (0.0, t_end), walls=[incline(0.0)], output_dt=1e-2)
    res = gi.simulate(model, q0, np.zeros(6), (0.0, t_end), walls=[wall], output_dt=1e-2, max_cpu_time=60.0)
    assert res.status == "finished", res.message
    assert res.nfev <= 10 * frictionless.nfev, (res.nfev, frictionless.nfev)
    assert np.max(np.abs(centre(model, res) - centre(model, res)[0])) <= 1e-9
    np.testing.assert_allclose(res.contact_forces[:, 0, :2].sum(axis=1), M * G * np.cos(ALPHA), rtol=1e-9)
    np.testing.assert_allclose(res.friction_forces[:, 0, :2].sum(axis=1), np.tile(M * G * np.sin(ALPHA) * U_UP,
                                                                                   (res.t.size, 1)),
                               rtol=0, atol=1e-9 * M * G)
    assert gaps(res).min() >= -CONTACT_TOL


def test_rod_across_the_slope_slides_from_rest_when_the_cone_cannot_hold_it():
    # mu = 0.3 < tan(alpha): released at rest it slides down the slope without turning (both
    # ends' friction mu N_j up the slope, N_1 = N_2 by symmetry about G), s'' = g (sin a - mu cos a)
    # from rest: s = g (sin a - mu cos a) t^2 / 2. This slip from rest accelerates (|a_t| > 1e-2 g):
    # it keeps the regularised direction (7), which turns onto its acceleration (a direction held
    # at the active set's s0 lost 2e-6 m/s, 3e-8 m by t = 0.05 s), and it is not stiff for long.
    t_end = 0.05
    model, q0, wall = _across_the_slope(0.3)
    res = gi.simulate(model, q0, np.zeros(6), (0.0, t_end), walls=[wall], output_dt=1e-2, max_cpu_time=60.0)
    assert res.status == "finished", res.message
    s = -(centre(model, res) - centre(model, res)[0]) @ U_UP
    np.testing.assert_allclose(s, G * (np.sin(ALPHA) - 0.3 * np.cos(ALPHA)) * res.t ** 2 / 2, rtol=0, atol=1e-9)
    assert res.n_steps <= 100, res.n_steps
    assert gaps(res).min() >= -CONTACT_TOL


def test_fe_arm_tip_resting_on_a_rough_floor_advances():
    # A fixed-base FE arm (2 elements) falls from 30 degrees below horizontal with its tip on the
    # floor. With mu = 0.5 sticking would pull the tip off the floor (lambda_n = -5.6 N), so the
    # pair was dropped, and the tip then sank at -1.4e-6 m/s every 3e-8 s: max_impacts after
    # 32 s of CPU at t = 0.40 s (the frictionless run: 0.6 s). The sticking pair now tries to
    # slip before it separates. Bound: 10 times the frictionless run's right-hand sides.
    link = gi.Link(1.0, 1.0, 20.0, elements=2)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.5), 0.0)), gravity=(0.0, -G, 0.0))
    q0 = model.state(theta_1=-np.arcsin(0.5))
    runs = {mu: gi.simulate(model, q0, np.zeros(model.n_dof), (0.0, 0.5),
                            walls=[gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), friction=mu)], restitution=0.5,
                            max_cpu_time=60.0) for mu in (0.0, 0.5)}
    res = runs[0.5]
    assert res.status == "finished", res.message
    assert res.nfev <= 10 * runs[0.0].nfev, (res.nfev, runs[0.0].nfev)
    assert min(float(link_points(model, q, 64)[..., 1].min()) for q in res.q) >= -CONTACT_TOL
    assert res.contact_forces.min() >= 0.0
    E = res.energy()
    assert np.max(E.total - E.total[0] - res.work.sum(axis=1)) <= 1e-9 * (E.kinetic.max() + abs(E.gravity).max())
