"""Runs through the free base's gimbal lock: re-charting (formulation §18, simulation/charts.py)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gibbsimpact as gi
import gibbsimpact.simulation.stages as stages
from conftest import two_link_circle_model, two_link_circle_state

_R = 0.02  # section radius of the links [m]: rotary inertia (r^2/2, r^2/4, r^2/4) [kg m] per kg/m


def _rot(axis, a):
    """R_axis(a) written out (the test's own, not the package's)."""
    c, s = np.cos(a), np.sin(a)
    return {0: np.array([[1, 0, 0], [0, c, -s], [0, s, c]]), 1: np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            2: np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def _matrices(Q):
    """Rotation matrices (K, 3, 3) of unit quaternions [w, x, y, z] (K, 4)."""
    w, x, y, z = Q.T
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1).reshape(-1, 3, 3)


def _tumbling(modes):
    """Two links spinning at 15 rad/s about the chart's y axis, a little out of plane (theta_-1 = 0.05 rad) and
    folding (theta_2 rate 0.3 rad/s), no gravity: theta_0 runs through +-pi/2 again and again."""
    link = gi.Link(0.5, 1.0, (50.0, 50.0), modes=modes, rotary_inertia=(_R * _R / 2, _R * _R / 4, _R * _R / 4))
    model = gi.Model(gi.Chain([link, link]), gravity=(0.0, 0.0, 0.0))
    q = model.state(theta_m1=0.05, theta_0=0.2)
    qd = model.state(theta_m1=0.01, theta_0=15.0, theta_2=0.3)
    return model, q, qd


@pytest.fixture(scope="module", params=["rigid", "one mode each"])
def tumbling(request):
    modes = [] if request.param == "rigid" else [gi.Mode("clamped-free", "z")]
    model, q, qd = _tumbling(modes)
    return gi.simulate(model, q, qd, (0.0, 1.0), rtol=1e-12, atol=1e-13)


def test_tumbling_through_gimbal_lock_conserves_energy_and_momentum(tumbling):
    res = tumbling
    assert res.status == "finished" and len(res.charts) >= 10
    # The world chart's theta_0 = asin(R_02) reaches +-pi/2 (within 1 degree) at least four times.
    R = _matrices(res.base_orientation)
    near = np.abs(R[:, 0, 2]) > np.cos(np.radians(1.0))
    assert np.count_nonzero(np.diff(near.astype(int)) == 1) >= 4
    assert np.abs(res.q[:, 4]).max() <= 1.2 + 1e-9  # every chart stays 1.2 rad or more from its singularity
    E = res.energy()
    assert np.abs(E.total - E.total[0]).max() <= 1e-9 * abs(E.total[0])
    H = np.array([res.model_at(k).angular_momentum(q, v, about=np.zeros(3))
                  for k, (q, v) in enumerate(zip(res.q, res.qdot))])
    assert np.abs(H - H[0]).max() <= 1e-9 * np.linalg.norm(H[0])


def test_orientation_and_points_are_continuous_across_recharts(tumbling):
    res = tumbling
    Q = res.base_orientation
    np.testing.assert_allclose(np.linalg.norm(Q, axis=1), 1.0, atol=1e-14)
    # Between samples the base turns by at most |omega| dt (|omega| < 16 rad/s): |dq| <= |omega| dt / 2 + slack.
    dt = np.diff(res.t)
    assert np.all(np.linalg.norm(np.diff(Q, axis=0), axis=1) <= 0.5 * 16.0 * dt + 1e-12)
    P, V = res.joint_positions(), res.joint_velocities()
    for c in res.charts:
        k = c.sample
        assert res.t[k] == res.t[k - 1] == c.time
        np.testing.assert_allclose(res.q[k, [3, 4, 5]], 0.0, atol=0)
        np.testing.assert_allclose(c.angles_before, res.q[k - 1, [3, 4, 5]], atol=0)
        assert abs(abs(c.angles_before[1]) - 1.2) < 1e-9
        np.testing.assert_allclose(Q[k], Q[k - 1], atol=1e-15 * 4)
        np.testing.assert_allclose(P[k], P[k - 1], atol=1e-14)
        np.testing.assert_allclose(V[k], V[k - 1], atol=1e-13 * 15)
        np.testing.assert_allclose(res.base_chart[k], c.chart_after, atol=0)


def _euler_reference(I, R0, w0, t_end):
    """Torque-free rigid body: R' = R [w]x, I w' = -w x I w (body frame, principal axes I (3,)), by scipy."""
    def f(t, y):
        R, w = y[:9].reshape(3, 3), y[9:]
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.concatenate(((R @ W).ravel(), -np.cross(w, I * w) / I))

    sol = solve_ivp(f, (0.0, t_end), np.concatenate((R0.ravel(), w0)), method="DOP853", rtol=1e-13, atol=1e-14)
    return sol.y[:9, -1].reshape(3, 3)


def test_rigid_body_tumbling_matches_euler_equations():
    # One rigid uniform link (m = 1 kg, l = 1 m) about its mass centre: principal inertia l diag(j_x, j_y, j_z)
    # + m l^2/12 across it; y the major axis (j_y largest), a spin mostly about it that passes theta_0 = +-pi/2.
    j = np.array([1e-3, 5e-3, 1e-3])
    link = gi.Link(1.0, 1.0, 1.0, rotary_inertia=tuple(j))
    model = gi.Model(gi.Chain([link]), gravity=(0.0, 0.0, 0.0))
    a, b, c = 0.1, 0.3, 0.2
    rates = np.array([0.4, 12.0, -0.5])
    q = model.state(theta_m1=a, theta_0=b, theta_1=c)
    qd = model.state(theta_m1=rates[0], theta_0=rates[1], theta_1=rates[2])
    res = gi.simulate(model, q, qd, (0.0, 1.0), rtol=1e-12, atol=1e-13)
    assert res.status == "finished" and len(res.charts) >= 5
    # Body angular velocity of Rx(a) Ry(b) Rz(c): w = C^T (e_x a' + Rx e_y b' + Rx Ry e_z c'), written out.
    Rx, Ry, Rz = _rot(0, a), _rot(1, b), _rot(2, c)
    C = Rx @ Ry @ Rz
    w0 = C.T @ (np.array([1.0, 0, 0]) * rates[0] + Rx[:, 1] * rates[1] + (Rx @ Ry)[:, 2] * rates[2])
    I = np.array([j[0], 1.0 / 12 + j[1], 1.0 / 12 + j[2]])
    R_end = _euler_reference(I, C, w0, 1.0)
    np.testing.assert_allclose(_matrices(res.base_orientation[-1:])[0], R_end, atol=1e-8)


def test_recharting_during_resting_contact_keeps_the_contact():
    # A rigid rod with its end O_1 sticking on a frictional floor, swinging up about it at 3 rad/s in the X1-X2
    # plane: with theta_-1 = pi/2 that swing is theta_0, which passes 1.2 rad while O_1 rests.
    link = gi.Link(1.0, 1.0, 1.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
    model = gi.Model(gi.Chain([link]), gravity=(0.0, -9.81, 0.0))
    floor = gi.Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0), friction=2.0, restitution=0.0)
    q = model.state(theta_m1=np.pi / 2, theta_0=0.9)
    qd = model.state(theta_0=3.0)
    res = gi.simulate(model, q, qd, (0.0, 0.3), walls=[floor])
    assert len(res.charts) >= 1 and not res.impacts
    c = res.charts[0]
    k = c.sample
    F = res.contact_forces[:, 0, 0]
    assert F[k - 1] > 0 and F[k] > 0 and F[k + 1] > 0  # still resting after the re-chart
    np.testing.assert_allclose(F[k], F[k - 1], rtol=1e-9)  # the same force in either chart
    assert np.abs(res.joint_positions()[:, 0, 1]).max() < 1e-8  # O_1 stays on the floor
    assert np.abs(res.joint_positions()[:, 0, [0, 2]]).max() < 1e-8  # and sticks


def test_saved_result_keeps_its_charts(tumbling, tmp_path):
    res = tumbling
    back = gi.load_result(res.save(tmp_path / "tumbling.npz"))
    np.testing.assert_array_equal(back.base_chart, res.base_chart)
    assert [c.sample for c in back.charts] == [c.sample for c in res.charts]
    np.testing.assert_array_equal(back.base_orientation, res.base_orientation)
    np.testing.assert_array_equal(back.joint_positions(), res.joint_positions())
    paths = res.to_csv(tmp_path)
    table = np.genfromtxt(paths["timeseries"], delimiter=",", names=True)
    Q = np.column_stack([table[f"base_q{c}"] for c in "wxyz"])
    np.testing.assert_array_equal(Q, res.base_orientation)
    np.testing.assert_array_equal(table["O2_X3_m"], res.joint_positions()[:, 1, 2])
    s = res.summary()
    assert [r["time_s"] for r in s["base_recharts"]] == [c.time for c in res.charts]
    assert s["base_orientation_final_wxyz"] == res.base_orientation[-1].tolist()


def test_impacts_and_recharts_together_keep_energy_at_e_1():
    # The tumbling rigid chain inside a sphere of radius 0.8 m, e = 1, no gravity: impacts and re-charts
    # interleave, and E stays (impacts with e = 1 conserve it, re-charts do not touch it).
    model, q, qd = _tumbling([])
    res = gi.simulate(model, q, qd, (0.0, 0.6), walls=[gi.Sphere(0.8, (0.5, 0.0, 0.0))], restitution=1.0,
                      rtol=1e-12, atol=1e-13)
    assert res.status == "finished" and len(res.impacts) >= 2 and len(res.charts) >= 4
    first, last = res.impacts[0].time, res.impacts[-1].time
    assert any(first < c.time < last for c in res.charts)
    E = res.energy().total
    assert np.abs(E - E[0]).max() <= 1e-9 * abs(E[0])


def test_animation_frames_draw_each_sample_in_its_chart(tumbling):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from gibbsimpact.plotting import animation
    from gibbsimpact.plotting.geometry import _to3

    res = tumbling
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    actors = animation._actors(ax, res.model, res.q[0], planar=False)
    P = res.joint_positions()
    for k in (res.charts[0].sample - 1, res.charts[0].sample, res.charts[-1].sample + 3, len(res.t) - 1):
        animation._pose_sample(actors, res, k, float(res.t[k]), 0.0, 5, None, planar=False)
        np.testing.assert_allclose(np.array(actors["joints"].get_data_3d()), np.array(_to3(P[k])), atol=1e-14)
    plt.close(fig)


def test_prescribed_joint_effort_is_the_same_in_both_charts():
    # theta_2 driven at 0.3 rad/s while the chain tumbles: the actuator's torque is one physical quantity, so the
    # two samples of every re-chart carry the same effort (the Result computes every sample's effort in one chart:
    # a free-floating chain's joint efforts do not change under the rotation of the whole that a re-chart is).
    model, q, qd = _tumbling([])
    res = gi.simulate(model, q, qd, (0.0, 0.4), rtol=1e-12, atol=1e-13,
                      prescribed={"theta_2": lambda t: (0.3 * t, 0.3, 0.0)})
    assert len(res.charts) >= 3
    scale = np.abs(res.effort).max()
    for c in res.charts:
        np.testing.assert_allclose(res.effort[c.sample], res.effort[c.sample - 1], atol=1e-10 * scale)


def test_the_chart_event_costs_nothing_until_it_fires(monkeypatch):
    # Case 1 (free base, planar motion: theta_0 stays 0): watching |theta_0| must not add right-hand sides (an
    # event sampled inside every step would build the dense output at each: +21 % calls on this case).
    model = two_link_circle_model()
    q, qd = two_link_circle_state(model)
    walls = [gi.Circle(1.0, (0.0, 0.0))]
    watched = gi.simulate(model, q, qd, (0.0, 0.5), walls=walls)
    monkeypatch.setattr(stages, "charted", lambda model, prescribed=None: False)
    unwatched = gi.simulate(model, q, qd, (0.0, 0.5), walls=walls)
    assert watched.nfev == unwatched.nfev and np.array_equal(watched.q, unwatched.q) and not watched.charts


def test_a_run_starts_at_gimbal_lock_with_the_automatic_method():
    # At theta_0 = pi/2 exactly the first chart's M is singular: the checks and method="auto" (which looks at the
    # linearised dynamics of q0) work in the chart the run starts in.
    model, q, qd = _tumbling([gi.Mode("clamped-free", "z")])
    q[4] = np.pi / 2
    res = gi.simulate(model, q, qd, (0.0, 0.05), method="auto")
    assert res.status == "finished" and res.charts[0].sample == 1
    # Without gravity the free chain's frequencies do not depend on its orientation: "auto" must see those of
    # theta_0 = 0 (the singular chart's linearisation gives 216 rad/s instead of 744 rad/s).
    upright = gi.simulate(model, model.state(theta_m1=q[3]), qd, (0.0, 1e-3), method="auto")
    assert res.settings["method_choice"].split("mode at")[1] == upright.settings["method_choice"].split("mode at")[1]
    E = res.energy().total
    assert np.abs(E - E[0]).max() <= 1e-8 * abs(E[0])


def test_a_joint_input_keeps_the_power_balance_across_recharts():
    # A constant torque on theta_2 (a joint, the same in every chart): E(t) - E(0) = W(t), the input's work
    # integrated with the state, through every re-chart.
    model, q, qd = _tumbling([])
    res = gi.simulate(model, q, qd, (0.0, 0.5), inputs={"theta_2": 0.05}, rtol=1e-12, atol=1e-13)
    assert len(res.charts) >= 5 and abs(res.work[-1, 0]) > 1e-3
    E = res.energy().total
    assert np.abs(E - E[0] - res.work[:, 0]).max() <= 1e-9 * abs(E[0])


def test_a_tumbling_tree_with_a_turned_root_axis_goes_through_its_charts():
    # A rigid T (a hub link carrying two arms, one welded) whose root axis is turned by A = Rx(0.4): its chart is
    # singular where e_z . Ry(theta_0) A e_z = 0; E and H stay through the re-charts.
    link = gi.Link(0.5, 1.0, (50.0, 50.0), rotary_inertia=(_R * _R / 2, _R * _R / 4, _R * _R / 4))
    joints = [gi.Revolute(axis_rotation=_rot(0, 0.4)), gi.Revolute(), gi.Weld(angle=1.2)]
    model = gi.Model(gi.Chain([link, link, link], joints=joints, parents=[-1, 0, 0], attach=[None, 0.5, 0.25]),
                     gravity=(0.0, 0.0, 0.0))
    q = model.state(theta_0=0.2, theta_2=0.3)
    qd = model.state(theta_m1=0.2, theta_0=12.0, theta_2=0.5)
    res = gi.simulate(model, q, qd, (0.0, 0.5), rtol=1e-12, atol=1e-13)
    assert res.status == "finished" and len(res.charts) >= 2
    E = res.energy().total
    assert np.abs(E - E[0]).max() <= 1e-9 * abs(E[0])
    H = np.array([res.model_at(k).angular_momentum(a, b, about=np.zeros(3))
                  for k, (a, b) in enumerate(zip(res.q, res.qdot))])
    assert np.abs(H - H[0]).max() <= 1e-9 * np.linalg.norm(H[0])
    P = res.joint_positions()
    for c in res.charts:
        np.testing.assert_allclose(P[c.sample], P[c.sample - 1], atol=1e-14)


def test_recharting_during_a_compliant_contact_keeps_it():
    # The rod of the resting test dropped on a compliant floor (chi = 0 at e = 1): theta_0 passes 1.2 rad
    # while O_1 presses on it; the contact goes on as one (its force the same in both samples) and E comes back.
    link = gi.Link(1.0, 1.0, 1.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
    model = gi.Model(gi.Chain([link]), gravity=(0.0, -9.81, 0.0))
    floor = gi.Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0), restitution=1.0, stiffness=1e5)
    q, qd = model.state(theta_m1=np.pi / 2, theta_0=1.15, X2=0.01), model.state(theta_0=3.0, X2=-1.0)
    res = gi.simulate(model, q, qd, (0.0, 0.05), walls=[floor])
    assert len(res.charts) == 1 and len(res.compliant_contacts) == 1
    c, contact = res.charts[0], res.compliant_contacts[0]
    assert contact.start < c.time < contact.end
    F = res.compliant_forces[:, 0, 0]
    assert F[c.sample] > 0 and F[c.sample] == F[c.sample - 1]
    np.testing.assert_allclose(res.compliant_integrals[c.sample], res.compliant_integrals[c.sample - 1], atol=0)
    E = res.energy().total  # the chain's E, which lends the wall's spring energy during the contact only
    assert contact.end < res.t[-1] and abs(E[-1] - E[0]) <= 1e-9 * abs(E[0])
