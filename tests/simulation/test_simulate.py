"""Impact phase and event loop: Newton's law, closed forms, invariants, the published cases."""

import warnings
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.contact.impact import solve_impulses

ROOT = Path(__file__).resolve().parents[2]

from conftest import (
    single_link_sphere_model,
    single_link_sphere_state,
    two_link_circle_model,
    two_link_circle_state,
)

G = 9.81


@pytest.fixture(scope="module")
def case1():
    model = two_link_circle_model()
    q, qd = two_link_circle_state(model)
    with warnings.catch_warnings():
        # The published cases give no validity warning, in particular none about Newton's law at a point whose
        # effective mass depends on the discretisation (their clamped-clamped joints stay on the link frames).
        warnings.simplefilter("error", gi.ValidityWarning)
        return gi.simulate(model, q, qd, (0.0, 1.0), walls=[gi.Circle(1.5, (0.0, 0.0))], restitution=1.0,
                           rtol=1e-10, atol=1e-12, method="DOP853")


@pytest.fixture(scope="module")
def case2():
    model = single_link_sphere_model()
    q, qd = single_link_sphere_state(model)
    with warnings.catch_warnings():
        warnings.simplefilter("error", gi.ValidityWarning)  # as case1
        return gi.simulate(model, q, qd, (0.0, 1.0), walls=[gi.Sphere(1.0)], restitution=1.0,
                           rtol=1e-10, atol=1e-12, method="DOP853")


def rigid_rod(l=1.0, mu=2.0, gravity=(0.0, 0.0, 0.0)):
    # j_x > 0 only so that the straight link's spin about its own axis is defined.
    return gi.Model(gi.Chain([gi.Link(l, mu, 1.0, rotary_inertia=(1e-4, 0.0, 0.0))]), gravity=gravity)


def check_newton_law(res):
    for rec in res.impacts:
        active = rec.impulses > 0
        assert np.all(rec.impulses >= 0)
        scale = np.max(np.abs(rec.v_before))
        # Carrying an impulse: v+ = -e v- (one round); not carrying: not penetrating.
        if rec.rounds == 1:
            np.testing.assert_allclose(rec.v_after[active], -rec.restitution[active] * rec.v_before[active],
                                       rtol=0, atol=1e-10 * scale)
        assert np.all(rec.v_after >= -1e-10 * scale)
        assert rec.energy_after.kinetic <= rec.energy_before.kinetic * (1 + 1e-12)
        assert np.all(rec.v_after[~active] >= -rec.restitution[~active] * rec.v_before[~active] - 1e-10 * scale)
        # Recomputed from scratch: n.J qdot+ at the impact configuration.
        k = np.searchsorted(res.t, rec.time)
        q_before, q_after = res.q[k], res.q[k + 1]
        assert res.t[k] == res.t[k + 1] == rec.time
        np.testing.assert_array_equal(q_before, q_after)  # q does not jump
        J = res.model.joint_jacobians(q_before)
        v = np.array([n @ J[j - 1] @ rec.qdot_after for j, n in zip(rec.joints, rec.normals)])
        np.testing.assert_allclose(v, rec.v_after, rtol=0, atol=1e-12 * scale)


def test_case1_impact_pattern(case1):
    assert case1.status == "finished", case1.message
    ref = [(0.451524, (2,)), (0.474918, (1, 3)), (0.506715, (2,)), (0.890135, (2,))]
    assert len(case1.impacts) == len(ref)
    for rec, (t, joints) in zip(case1.impacts, ref):
        assert rec.time == pytest.approx(t, abs=1e-6)
        assert tuple(sorted(rec.joints)) == joints
    sim = case1.impacts[1]
    assert sim.impulses[0] == pytest.approx(sim.impulses[1], rel=1e-7)  # equal impulses on O1 and O3


def test_published_impacts_are_one_episode_each(case1, case2):
    # Their joints stay on the link frames (dwell 0) and every rebound leaves the contact band: one episode per
    # impact, at its time, with the impact's contacts; e = 1 loses nothing (to the energy error of the run).
    for res in (case1, case2):
        assert [ep.impacts for ep in res.episodes] == [(i,) for i in range(len(res.impacts))]
        for ep, rec in zip(res.episodes, res.impacts):
            assert ep.start == rec.time and ep.points == tuple(dict.fromkeys(rec.joints)) and ep.ended
            assert abs(ep.energy_lost) <= 2 * res.energy_error * res.energy_scale
            assert ep.impulse == pytest.approx(float(np.sum(rec.impulses)), rel=1e-15)


def test_case1_first_episode_restitution_closed_form(case1):
    # Falling freely the chain does not deform, so it meets the circle with no elastic velocity; then
    # e_eff = (1 + e) rho - 1 (docs/theory.md §14.7), rho = m_eff / m_eff,rigid at O2 along the normal, m_eff of
    # the flexible chain from its M and J, m_eff,rigid from a second model with rigid links.
    rec, ep = case1.impacts[0], case1.episodes[0]
    q = case1.q[ep.samples[0]]
    n = rec.normals[0]
    flexible = case1.model
    rigid = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0)] * 2), gravity=flexible.gravity)
    q_rigid = np.delete(q, np.concatenate(flexible.delta_index))

    def m_eff(model, q):
        w = model.joint_jacobians(q)[1].T @ n
        return 1.0 / (w @ np.linalg.solve(model.mass_matrix(q), w))

    rho = m_eff(flexible, q) / m_eff(rigid, q_rigid)
    elastic = np.concatenate(flexible.delta_index)
    assert np.max(np.abs(q[elastic])) < 1e-9 and np.max(np.abs(rec.qdot_before[elastic])) < 1e-9
    assert rho == pytest.approx(0.8466, abs=1e-4)
    assert ep.restitution == pytest.approx(2.0 * rho - 1.0, abs=1e-8)


def test_case1_mirror_symmetry(case1):
    # Mirror S: X1 -> -X1. A symmetric V satisfies O3 = S O1, theta_2 = -2 theta_1, delta_2 = delta_1
    # (clamped-clamped mode 1 is symmetric about l/2), theta_-1 = theta_0 = X3 = 0, and the same for rates.
    S = np.diag([-1.0, 1.0, 1.0])
    P = case1.joint_positions()
    V = case1.joint_velocities()
    err = max(
        np.max(np.abs(P[:, 2] - P[:, 0] @ S)), np.max(np.abs(V[:, 2] - V[:, 0] @ S)),
        np.max(np.abs(P[:, 1, 0])), np.max(np.abs(V[:, 1, 0])),
        np.max(np.abs(case1.q[:, 6] + 2 * case1.q[:, 5])), np.max(np.abs(case1.qdot[:, 6] + 2 * case1.qdot[:, 5])),
        np.max(np.abs(case1.q[:, 7] - case1.q[:, 8])), np.max(np.abs(case1.qdot[:, 7] - case1.qdot[:, 8])),
        np.max(np.abs(case1.q[:, 2:5])), np.max(np.abs(case1.qdot[:, 2:5])),
    )
    assert err <= 1e-7


def test_case1_energy_and_newton(case1):
    E = case1.energy().total
    assert E[0] == pytest.approx(-4.905, rel=1e-12)
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= 1e-8
    assert case1.energy_error <= 1e-8
    check_newton_law(case1)


def test_case2_impact_pattern_energy_newton(case2):
    assert case2.status == "finished", case2.message
    ref = [(0.540052, (1,)), (0.661352, (2,)), (0.775988, (1,))]
    assert len(case2.impacts) == len(ref)
    for rec, (t, joints) in zip(case2.impacts, ref):
        assert rec.time == pytest.approx(t, abs=1e-6)
        assert rec.joints == joints
    E = case2.energy().total
    assert E[0] == pytest.approx(1.807549, abs=5e-7)
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= 1e-8
    check_newton_law(case2)
    # Spatial motion: the chain leaves the X1-X2 plane.
    assert np.ptp(case2.joint_positions()[:, :, 2]) > 0.1


def test_single_contact_energy_loss_closed_form():
    # Flexible two-link chain, one joint hitting a plane obliquely with e = 0.6.
    model = two_link_circle_model()
    rng = np.random.default_rng(5)
    q = model.state(theta_1=0.3, theta_2=0.9, delta_1_1=0.01, delta_2_1=-0.02)
    qd = rng.normal(size=9)
    J = model.joint_jacobians(q)[1]
    n = np.array([0.3, 0.9, 0.2])
    n /= np.linalg.norm(n)
    w = J.T @ n
    qd -= w * (w @ qd + 1.3) / (w @ w)  # approach at v_n = -1.3 m/s
    M = model.mass_matrix(q)
    e = 0.6
    sol = solve_impulses(M, w[:, None], qd, e)
    loss = 0.5 * qd @ M @ qd - 0.5 * sol.qdot_after @ M @ sol.qdot_after
    v = w @ qd
    expected = 0.5 * (1 - e**2) * v**2 / (w @ np.linalg.solve(M, w))
    assert loss == pytest.approx(expected, rel=1e-10)
    assert sol.v_after[0] == pytest.approx(-e * v, rel=1e-12)


def test_flat_rigid_link_bounces_without_rotation():
    # Falls flat (gravity off, uniform velocity): both ends touch at once.
    e, v, h = 0.7, 2.0, 0.3
    model = rigid_rod()
    q = model.state(X2=h)
    qd = model.state(X2=-v)
    res = gi.simulate(model, q, qd, (0.0, 0.25), walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=e)
    assert len(res.impacts) == 1
    rec = res.impacts[0]
    assert rec.time == pytest.approx(h / v, rel=1e-10)
    assert rec.joints == (1, 2)
    assert rec.impulses[0] == pytest.approx(rec.impulses[1], rel=1e-10)
    np.testing.assert_allclose(rec.qdot_after, model.state(X2=e * v), atol=1e-10)


def test_tilted_rigid_link_textbook_impact():
    # Rod (m, l) at angle a to the plane, translating down at v, lower end O1 hits.
    # 1/m_eff = 1/m + r_x^2 / I_c with r the contact point from the centre, I_c = m l^2 / 12.
    e, v, a, l, mu = 0.5, 1.5, 0.4, 1.2, 2.0
    m, Ic = mu * l, mu * l**3 / 12
    model = rigid_rod(l, mu)
    h = 0.1
    q = model.state(X2=h, theta_1=a)
    qd = model.state(X2=-v)
    res = gi.simulate(model, q, qd, (0.0, 0.1), walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=e)
    assert len(res.impacts) == 1 and res.impacts[0].joints == (1,)
    rec = res.impacts[0]
    r_x = l / 2 * np.cos(a)  # contact point relative to the centre: (-r_x, -r_y)
    m_eff = 1.0 / (1.0 / m + r_x**2 / Ic)
    Lam = (1 + e) * v * m_eff
    assert rec.impulses[0] == pytest.approx(Lam, rel=1e-10)
    q_imp = res.q[np.searchsorted(res.t, rec.time)]
    vc = model.linear_momentum(q_imp, rec.qdot_after) / m
    np.testing.assert_allclose(vc, [0.0, -v + Lam / m, 0.0], atol=1e-10)
    omega = -Lam * r_x / Ic  # (r x n)_z = -r_x: the impulse at the lower-left end spins it clockwise
    assert rec.qdot_after[5] == pytest.approx(omega, rel=1e-10)


def test_bouncing_rod_restart_no_refire_no_tunnel():
    # e = 1 under gravity: impacts at t_k = t1 (2k + 1), exactly as many as fit; nothing passes the plane.
    h = 0.2
    model = rigid_rod(gravity=(0.0, -G, 0.0))
    t1 = np.sqrt(2 * h / G)
    res = gi.simulate(model, model.state(X2=h), np.zeros(6), (0.0, 6.5 * t1), walls=[gi.Plane((0, 0, 0), (0, 1, 0))])
    assert res.status == "finished", res.message
    np.testing.assert_allclose(res.impact_times, t1 * np.array([1, 3, 5]), rtol=1e-9)
    assert all(r.joints == (1, 2) for r in res.impacts)
    assert res.joint_positions()[:, :, 1].min() > -1e-9
    assert res.q[-1, 1] == pytest.approx(h - 0.5 * G * (0.5 * t1) ** 2, abs=1e-9)


def test_grazing_is_not_an_impact():
    # O1 flies a parabola whose apex just touches a ceiling: v_n = 0 there.
    v0 = 2.0
    apex = v0**2 / (2 * G)
    model = rigid_rod(gravity=(0.0, -G, 0.0))
    q, qd = model.state(), model.state(X1=0.5, X2=v0)
    walls = [gi.Plane((0.0, apex, 0.0), (0.0, -1.0, 0.0))]
    res = gi.simulate(model, q, qd, (0.0, 2 * v0 / G), walls=walls)
    assert res.status == "finished", res.message
    assert res.impacts == []
    # Exact arithmetic touches the ceiling at the apex t_a with v_n = 0. In floating point the
    # gap g = 1/2 G (t - t_a)^2 is known only to its round-off eps_g (~16 ulps of the height:
    # the 4x4 products), so round-off decides whether the event fires, anywhere within
    # |t - t_a| <= dt = sqrt(2 eps_g / G) of the apex; if it does, the contact-mode stage removes
    # the normal velocity G dt there (a grazing pair, |v_n| <= grazing_velocity), which moves
    # the landing point by up to G dt (T - t_a). With AVX-512 BLAS kernels the event fires and
    # X2(T) = -1.4e-8 m; with Haswell's it does not and X2(T) = -3e-16 m.
    eps_g = 16 * np.finfo(float).eps * apex
    dt = np.sqrt(2 * eps_g / G)
    assert res.q[-1, 1] == pytest.approx(0.0, abs=G * dt * (2 * v0 / G - v0 / G))
    # Sliding along a wall with v_n = 0 from the start: no impact either.
    res2 = gi.simulate(rigid_rod(), model.state(), model.state(X1=1.0), (0.0, 0.5),
                       walls=[gi.Plane((0, 0, 0), (0, 1, 0))])
    assert res2.status == "finished" and res2.impacts == []
    assert res2.q[-1, 0] == pytest.approx(0.5, abs=1e-12)


def test_accumulation_of_impacts_stops_with_status():
    # Flat rod dropped from h with e = 0.5: impacts accumulate at
    # t_inf = t1 + 2 e v1 / (g (1 - e)),  v1 = sqrt(2 g h).
    # accumulation="stop": the detector's own result (the default goes on resting, below).
    e, h = 0.5, 0.1
    model = rigid_rod(gravity=(0.0, -G, 0.0))
    v1 = np.sqrt(2 * G * h)
    t_inf = np.sqrt(2 * h / G) + 2 * e * v1 / (G * (1 - e))
    errors = {}
    for tol in (1e-9, 1e-12):
        res = gi.simulate(model, model.state(X2=h), np.zeros(6), (0.0, 2.0),
                          walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=e, contact_tol=tol,
                          accumulation="stop")
        assert res.status == "zeno"
        assert "accumulation" in res.message
        est = float(res.message.split("estimated accumulation time ")[1].split(" s")[0])
        # Stopped at the accumulation (within the last, band-limited micro-bounces),
        # with every result up to the last impact kept.
        assert res.t[-1] == res.impacts[-1].time
        assert abs(res.t[-1] - t_inf) < 2e-6
        assert len(res.impacts) >= 10
        # Early impacts follow the geometric sequence exactly.
        k = np.arange(8)
        np.testing.assert_allclose(res.impact_times[:8], np.sqrt(2 * h / G) + 2 * v1 / G * e * (1 - e**k) / (1 - e), rtol=1e-9)
        errors[tol] = abs(est - t_inf) / t_inf
    # The estimate extrapolates the most geometric pair of intervals, before the
    # bounces become as small as the sink depth (~1e-14 m).
    assert errors[1e-9] < 1e-6
    assert errors[1e-12] < 1e-6


def test_accumulation_of_impacts_ends_in_resting_contact():
    # The same drop with the default accumulation="rest": at the accumulation the rod
    # settles on the plane and lies there with m g / 2 on each end until t_end.
    e, h = 0.5, 0.1
    model = rigid_rod(gravity=(0.0, -G, 0.0))
    v1 = np.sqrt(2 * G * h)
    t_inf = np.sqrt(2 * h / G) + 2 * e * v1 / (G * (1 - e))
    res = gi.simulate(model, model.state(X2=h), np.zeros(6), (0.0, 2.0), walls=[gi.Plane((0, 0, 0), (0, 1, 0))],
                      restitution=e)
    assert res.status == "finished", res.message
    assert res.t[-1] == 2.0
    assert res.impacts[-1].time == pytest.approx(t_inf, abs=2e-6)
    m = model.total_mass
    np.testing.assert_allclose(res.contact_forces[-1, 0], [m * G / 2] * 2, rtol=1e-12)
    assert res.resting_time == pytest.approx(2.0 - t_inf, abs=2e-6)
    assert np.abs(res.joint_positions()[:, :, 1]).min() >= 0.0 or res.joint_positions()[:, :, 1].min() > -1e-9
    # No force before the accumulation, both ends loaded after it.
    assert np.all(res.contact_forces[res.t < res.impacts[0].time] == 0.0)
    assert np.all(res.contact_forces[res.t > t_inf + 1e-5] > 0.0)


def test_sphere_no_gravity_conserves_angular_momentum_and_energy():
    model = gi.Model(single_link_sphere_model().chain, gravity=(0.0, 0.0, 0.0))
    q, qd = single_link_sphere_state(model)
    qd = qd * 3.0
    res = gi.simulate(model, q, qd, (0.0, 1.2), walls=[gi.Sphere(1.0)], restitution=1.0, rtol=1e-11, atol=1e-13)
    assert res.status == "finished", res.message
    assert len(res.impacts) >= 5
    H0 = model.angular_momentum(q, qd, about=np.zeros(3))
    H = np.array([model.angular_momentum(a, b, about=np.zeros(3)) for a, b in zip(res.q, res.qdot)])
    assert np.max(np.linalg.norm(H - H0, axis=1)) <= 1e-8 * np.linalg.norm(H0)
    E = res.energy().total
    assert np.max(np.abs(E - E[0])) <= 1e-8 * abs(E[0])


def test_simultaneous_lcp_never_pulls():
    # A rod jammed between a floor (under O1, normal +y) and a ceiling (over O2,
    # normal -y), both ends approaching. The two contacts are coupled positively, so
    # the plain solve of both Newton laws pulls at O2; the complementarity solution
    # puts the whole impulse on O1 and O2 separates.
    mu, l, e = 2.0, 1.0, 1.0
    m = mu * l
    model = rigid_rod(l, mu)
    q = model.state()
    J = model.joint_jacobians(q)
    W = np.stack([J[0].T @ [0.0, 1.0, 0.0], J[1].T @ [0.0, -1.0, 0.0]], axis=1)
    qd = model.state(X2=-1.0, theta_1=1.1 / l)  # v_n = (-1.0, -0.1) m/s
    M = model.mass_matrix(q)
    Gm = W.T @ np.linalg.solve(M, W)
    plain = -np.linalg.solve(Gm, (1 + e) * (W.T @ qd))
    assert plain[1] < 0  # the naive answer pulls
    sol = solve_impulses(M, W, qd, e)
    np.testing.assert_allclose(sol.v_before, [-1.0, -0.1], rtol=1e-12)
    # End of a free rod: effective mass m/4, so Lambda_1 = (1 + e) * 1.0 * m / 4.
    np.testing.assert_allclose(sol.impulses, [(1 + e) * m / 4, 0.0], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(sol.v_after, [1.0, 0.9], rtol=1e-12)


def test_bad_input_errors():
    model = two_link_circle_model()
    q, qd = two_link_circle_state(model)
    with pytest.raises(ValueError, match="joint O2 .* outside wall 1"):
        gi.simulate(model, q, qd, (0, 1), walls=[gi.Circle(0.4)])
    with pytest.raises(ValueError, match="restitution"):
        gi.simulate(model, q, qd, (0, 1), walls=[gi.Circle(1.5)], restitution=1.5)
    with pytest.raises(ValueError, match="t_span"):
        gi.simulate(model, q, qd, (1, 0))
    with pytest.raises(ValueError, match="method"):
        gi.simulate(model, q, qd, (0, 1), method="Euler")
    with pytest.raises(ValueError, match="walls"):
        gi.simulate(model, q, qd, (0, 1), walls=["circle"])
    with pytest.raises(ValueError, match="radius"):
        gi.Circle(-1.0)
    with pytest.raises(ValueError, match="normal"):
        gi.Plane((0, 0, 0), (0, 0, 0))
    single = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 1.0)]))
    with pytest.raises(gi.SingularMassMatrixError, match="rotary_inertia"):
        gi.simulate(single, np.zeros(6), np.zeros(6), (0, 1))


def test_low_bounces_after_a_sink_do_not_tunnel():
    # Regression: with loose tolerances the solver's steps are longer than the last,
    # tiny bounces; after an impact caught by the sink event the joint used to
    # restart exactly on the next sink level and fall through the plane unnoticed.
    e, h = 0.5, 0.01
    model = rigid_rod(1.0, 1.0, gravity=(0.0, -G, 0.0))
    res = gi.simulate(model, model.state(X1=-0.5, X2=h), np.zeros(6), (0.0, 1.0),
                      walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=e, rtol=1e-8, atol=1e-10,
                      accumulation="stop")
    assert res.status == "zeno", res.message
    assert res.joint_positions()[:, :, 1].min() > -1e-7
    v1 = np.sqrt(2 * G * h)
    t_inf = np.sqrt(2 * h / G) + 2 * e * v1 / (G * (1 - e))
    assert res.t[-1] == pytest.approx(t_inf, rel=1e-3)


def test_plastic_slide_along_a_circle_stops_in_bounded_time():
    # Issue 12.3: O1 of a rigid rod slides along the inside of a circle (no gravity,
    # e = 0). Each plastic impact leaves v_n = 0, the curved wall turns the path back
    # into it, and the joint chatters at the sink depth ~1.6e-6 s apart (above
    # zeno_interval): formerly 10,000 impacts and minutes of CPU for 16 ms. The
    # rebounds never leave the contact band, so the accumulation is detected after
    # zeno_count impacts whatever their interval.
    rod = gi.Model(gi.Chain([gi.Link(0.5, 1.0, 20.0, rotary_inertia=(5e-5, 0, 0))]), gravity=(0, 0, 0))
    q0 = rod.state(X2=-1.0 + 1e-12, theta_1=np.pi / 3)
    qd0 = rod.state(X1=0.15)
    res = gi.simulate(rod, q0, qd0, (0.0, 0.5), walls=[gi.Circle(1.0)], restitution=0.0, accumulation="stop")
    assert res.status == "zeno", res.message
    assert "joint O1 stayed within" in res.message and "wall 1" in res.message
    assert 10 <= len(res.impacts) <= 11
    d = np.diff(res.impact_times)
    assert np.all(d > 1e-6)  # the interval rule alone would never have stopped it
    assert res.t[-1] == res.impacts[-1].time < 1e-4
    # Estimated accumulation time: when the contact closed (intervals do not shrink).
    est = float(res.message.split("estimated accumulation time ")[1].split(" s")[0])
    assert est == pytest.approx(res.impacts[0].time, abs=2e-6)
    check_newton_law(res)


def test_plastic_slide_along_a_circle_goes_on_in_resting_contact():
    # The slide above with the default accumulation="rest": after the first plastic
    # impact O1 stays on the circle. Without gravity and friction the rod turns with
    # constant kinetic energy; the wall force holds O1 on its circular path.
    rod = gi.Model(gi.Chain([gi.Link(0.5, 1.0, 20.0, rotary_inertia=(5e-5, 0, 0))]), gravity=(0, 0, 0))
    q0 = rod.state(X2=-1.0 + 1e-12, theta_1=np.pi / 3)
    qd0 = rod.state(X1=0.15)
    res = gi.simulate(rod, q0, qd0, (0.0, 0.5), walls=[gi.Circle(1.0)], restitution=0.0)
    assert res.status == "finished", res.message
    assert len(res.impacts) <= 1
    r = np.hypot(res.q[:, 0], res.q[:, 1])
    assert np.max(np.abs(r - 1.0)) <= 1e-9  # O1 = (X1, X2) on the circle at every sample
    after = res.t > 1e-4
    assert np.all(res.contact_forces[after, 0, 0] > 0.0)
    E = res.energy().kinetic[after]
    assert np.max(np.abs(E - E[0])) <= 1e-9 * E[0]


def test_wall_restitution_overrides_global():
    # Rod between a floor (e = 0.3 on the wall) and a ceiling (global e = 0.9).
    v = 2.0
    model = rigid_rod()
    walls = [gi.Plane((0, 0, 0), (0, 1, 0), restitution=0.3), gi.Plane((0, 1.0, 0), (0, -1, 0))]
    res = gi.simulate(model, model.state(X2=0.5), model.state(X2=-v), (0.0, 2.5), walls=walls, restitution=0.9)  # hits at 0.25 s and 1.92 s
    assert [r.wall for r in res.impacts[:2]] == [(0, 0), (1, 1)]
    np.testing.assert_allclose(res.impacts[0].v_after, [0.3 * v, 0.3 * v], rtol=1e-10)
    np.testing.assert_allclose(res.impacts[1].v_after, [0.9 * 0.3 * v] * 2, rtol=1e-10)
    np.testing.assert_allclose(res.impacts[1].restitution, [0.9, 0.9])


def test_result_energy_matches_model_energy_at_every_sample(case1):
    # simulate hands its per-sample energies to the Result; they must be the model's.
    E = np.array(case1.energy()).T
    ref = np.array([case1.model.energy(q, qd) for q, qd in zip(case1.q, case1.qdot)])
    assert E.shape == ref.shape == (case1.t.size, 4)
    # Equal up to round-off (at impacts the stored q is a view, so BLAS may sum in another order).
    np.testing.assert_allclose(E, ref, rtol=1e-14, atol=1e-14)


def test_joint_at_the_centre_of_a_circle_or_sphere_is_fine():
    # The normal is undefined at the centre (R away from the wall): no 0/0 warning, no NaN.
    import warnings

    model = rigid_rod()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for wall in (gi.Circle(1.5), gi.Sphere(1.5)):
            res = gi.simulate(model, model.state(), model.state(X1=1.0, theta_1=1.0), (0.0, 1.0), walls=[wall])
            assert res.status == "finished" and len(res.impacts) >= 1
            assert np.all(np.isfinite(res.qdot))


def test_singular_mass_matrix_at_a_trial_stage_rejects_the_step(monkeypatch):
    # Issue 9: a too-long trial step (e.g. DOP853's first step after an impact that
    # excites 11 modes per link) can land on a meaningless state whose M is singular.
    # That must shrink the step, not stop the run with a wrong diagnosis; only a
    # solver that cannot go on reports it. Simulated here: M "singular" at the first
    # three trial states that are more than 1 mm from the start.
    import sys

    sim = sys.modules["gibbsimpact.simulation.equations"]  # the right-hand side's module
    real = sim.forward_dynamics
    model = rigid_rod()
    q0 = model.state()
    calls = {"far": 0}

    def flaky(m, q, qd, Q=None):
        if abs(q[0] - q0[0]) > 1e-3 and calls["far"] < 3:
            calls["far"] += 1
            raise gi.SingularMassMatrixError("mass matrix is numerically singular (test)")
        return real(m, q, qd, Q)

    monkeypatch.setattr(sim, "forward_dynamics", flaky)
    res = gi.simulate(model, q0, model.state(X1=1.0), (0.0, 0.5))
    assert res.status == "finished", res.message
    assert calls["far"] == 3
    np.testing.assert_allclose(res.q[:, 0], res.t, atol=1e-12)  # X1 = t exactly

    # Singular everywhere beyond 1 mm: the solver cannot go on; the message says why.
    monkeypatch.setattr(sim, "forward_dynamics", lambda m, q, qd, Q=None: (
        (_ for _ in ()).throw(gi.SingularMassMatrixError("mass matrix is not positive definite: gimbal (test)"))
        if abs(q[0] - q0[0]) > 1e-3 else real(m, q, qd, Q)))
    res = gi.simulate(model, q0, model.state(X1=1.0), (0.0, 0.5))
    assert res.status == "failed"
    assert "the mass matrix was singular at a trial state" in res.message and "gimbal (test)" in res.message
    assert 9e-4 < res.q[-1, 0] <= 1e-3 + 1e-12  # everything up to there is kept


@pytest.mark.parametrize("rtol", [1e-6, 1e-4])
def test_simultaneous_impact_does_not_depend_on_rtol(rtol):
    # The contact band follows the integration error (simulate.contact_band): at a coarse
    # tolerance the published O1+O3 impact of case 1 stays one impact, at the published times
    # to within the tolerance's error, instead of splitting into O1 then O3 1e-9 s apart.
    from gibbsimpact.simulation.contacts import contact_band

    case = gi.load_case(ROOT / "cases" / "circle_two_link.toml")
    res = case.simulate(rtol=rtol, atol=rtol * 1e-2)
    assert res.status == "finished"
    assert [r.joints for r in res.impacts] == [(2,), (1, 3), (2,), (2,)]
    np.testing.assert_allclose(res.impact_times, [0.4515236410, 0.4749180111, 0.5067147308, 0.8901350725],
                               rtol=0, atol=10 * rtol + 1e-6)
    # at the default tolerances the band is 2 contact_tol (the published runs are unchanged)
    assert contact_band(1e-9, 5.0, 1e-10, 1e-12, case.q0) == 2e-9


@pytest.mark.parametrize("what", ["12 modes", "EI 1e6", "rtol 1e-3"])
def test_restarts_that_used_to_fail_with_dop853(what):
    # Issue 9: case 1's chain with 12 modes per link, or EI = 1e6, or rtol = 1e-3 stopped at a
    # restart after an impact ("mass matrix numerically singular", a wrong diagnosis). Each now
    # goes through its first impacts with DOP853 and finishes, Newton's law holding at each.
    n_modes, EI, kw, t_end = {"12 modes": (12, 20.0, {}, 0.45), "EI 1e6": (1, 1e6, {}, 0.325),
                              "rtol 1e-3": (1, 20.0, dict(rtol=1e-3, atol=1e-5), 0.6)}[what]
    link = gi.Link(1.0, 1.0, EI, modes=[gi.Mode("clamped-clamped", "y", k) for k in range(1, n_modes + 1)])
    model = gi.Model(gi.Chain([link, link]), gravity=(0.0, -9.81, 0.0))
    q, qd = two_link_circle_state(model)
    res = gi.simulate(model, q, qd, (0.0, t_end), walls=[gi.Circle(1.0)])
    assert res.status == "finished", res.message
    assert len(res.impacts) >= 1
    for r in res.impacts:
        np.testing.assert_allclose(r.v_after[r.impulses > 0], -r.v_before[r.impulses > 0], rtol=1e-9)
