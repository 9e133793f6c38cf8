"""The compliant (Hunt-Crossley) contact law in the event loop (gibbsimpact.simulation.compliant, issue 26):
a rigid rod falling end-first against Hertz's closed form, the law's own restitution against the closed
form of its one-degree-of-freedom rebound, the energy balance of the damping, mixed Newton/compliant runs."""

import functools

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import beta

import gibbsimpact as gi
from gibbsimpact.contact.compliant import damping_factor

#: The rod: l = 1 m, mu = 1 kg/m (m = 1 kg), a round section's rotary inertia (a free-flying link needs j_x > 0).
ROD = gi.Link(1.0, 1.0, 20.0, rotary_inertia=(5e-5, 2.5e-5, 2.5e-5))
MASS = 1.0


def falling_rod(v, k, e=1.0, damping="flores", gap=0.01, t_end=None, gravity=0.0, **kw):
    """The rod hanging vertical (O1 on top, O2 below) at ``gap`` [m] above the floor Y = 0, falling at v [m/s]
    without rotation onto a compliant floor (k [N/m^1.5], exponent 1.5): the Result."""
    model = gi.Model(gi.Chain([ROD]), gravity=(0.0, -gravity, 0.0))
    q0 = model.state(X2=1.0 + gap, theta_1=-np.pi / 2)
    qd0 = model.state(X2=-v)
    floor = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=e, stiffness=k, exponent=1.5, damping=damping)
    t_end = gap / v + 3.0 * hertz_duration(MASS, v, k) if t_end is None else t_end
    return gi.simulate(model, q0, qd0, (0.0, t_end), walls=[floor], **kw)


def hertz_duration(m, v, k):
    """Contact time [s] of a mass m [kg] striking at v [m/s] a spring F = k d^(3/2) (Hertz):

    (1/2) m v^2 = (1/2) m d'^2 + (2/5) k d^(5/2)  ->  t = 2 (d_max / v) int_0^1 dx / sqrt(1 - x^(5/2))
    = 2 (d_max / v) (2/5) B(2/5, 1/2) = 2.94325 d_max / v,  d_max = (5 m v^2 / (4 k))^(2/5)."""
    return 2.0 * 0.4 * beta(0.4, 0.5) * hertz_penetration(m, v, k) / v


def hertz_penetration(m, v, k):
    return (5.0 * m * v * v / (4.0 * k)) ** 0.4


def hunt_crossley_restitution(chi):
    """The rebound of one degree of freedom under F = k d^p (1 + chi d' / v0), v0 = d'(0): with u = d',
    m u du/dd = -k d^p (1 + a u), a = chi / v0, integrates to m [u/a - ln(1 + a u)/a^2] = -k d^(p+1)/(p+1) + C,
    so the exit speed u_f = -e v0 (d = 0 again) solves

        -chi e - ln(1 - chi e) = chi - ln(1 + chi)

    (independent of m, k, p and v0; 1 - chi e > 0: the clamp F >= 0 is never reached)."""
    if chi == 0.0:
        return 1.0
    rhs = chi - np.log1p(chi)
    return brentq(lambda e: -chi * e - np.log1p(-chi * e) - rhs, 0.0, (1.0 - 1e-15) / chi, xtol=1e-15)


def test_hertz_rod_penetration_and_duration():
    """(a) e = 1, p = 3/2: the deepest penetration and the contact time of Hertz's closed forms to 1e-4, the
    rod's velocity reversed, no rotation."""
    v, k = 1.0, 1e6
    dt = hertz_duration(MASS, v, k)
    res = falling_rod(v, k, output_dt=dt / 4000)
    (contact,) = res.compliant_contacts
    assert contact.approach_speed == pytest.approx(v, rel=1e-9)
    assert contact.start == pytest.approx(0.01 / v, abs=1e-13)  # the start event located on the dense output
    assert (contact.end - contact.start) / dt == pytest.approx(1.0, abs=1e-4)
    depth = -res.joint_positions()[:, 1, 1].min()
    assert depth / hertz_penetration(MASS, v, k) == pytest.approx(1.0, abs=1e-4)
    theta = res.q[:, 5]
    assert np.ptp(theta) < 1e-12
    assert res.qdot[-1, 1] == pytest.approx(v, rel=1e-8)
    # The normal impulse, integrated with the state, is the momentum change 2 m v.
    assert res.compliant_integrals[-1, 2] == pytest.approx(2.0 * MASS * v, rel=1e-8)


@pytest.mark.parametrize("damping, e", [("flores", 0.5), ("flores", 0.9), ("lankarani-nikravesh", 0.8),
                                        ("lankarani-nikravesh", 0.3)])
def test_rod_rebounds_with_the_laws_own_restitution(damping, e):
    """(b) e < 1: the rod's exit speed over its approach speed is the closed form of the law's rebound."""
    v, k = 2.0, 1e6
    res = falling_rod(v, k, e=e, damping=damping)
    e_closed = hunt_crossley_restitution(damping_factor(e, damping))
    assert res.qdot[-1, 1] / v == pytest.approx(e_closed, abs=1e-7)
    assert res.compliant_integrals[-1, 2] == pytest.approx(MASS * v * (1.0 + e_closed), rel=1e-7)


@pytest.mark.parametrize("method", ["Radau", "BDF"])
def test_implicit_solvers_integrate_through_the_contact(method):
    """The stiff contact with scipy's implicit methods (rtol = 1e-8): the same closed-form rebound, to 1e-6
    (measured: Radau 1e-10, BDF 1e-7)."""
    res = falling_rod(2.0, 1e6, e=0.5, method=method, rtol=1e-8, atol=1e-10)
    assert res.status == "finished"
    assert res.qdot[-1, 1] / 2.0 == pytest.approx(hunt_crossley_restitution(damping_factor(0.5, "flores")), abs=1e-6)


def test_the_relations_rebound_table_of_the_docs():
    """The rebound each chi(e) gives (docs/theory.md §11.5): Flores et al. within 0.045 of e over the whole range,
    Lankarani-Nikravesh near e only close to 1 (at e = 0.5 the rod leaves at 0.73)."""
    table = {0.1: (0.0694, 0.6653), 0.3: (0.2562, 0.6842), 0.5: (0.4704, 0.7252), 0.8: (0.7885, 0.8471),
             0.9: (0.8939, 0.9132), 1.0: (1.0, 1.0)}
    for e, (flores, ln) in table.items():
        assert hunt_crossley_restitution(damping_factor(e, "flores")) == pytest.approx(flores, abs=5e-5)
        assert hunt_crossley_restitution(damping_factor(e, "lankarani-nikravesh")) == pytest.approx(ln, abs=5e-5)
        assert abs(flores - e) < 0.045


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_energy_balance_of_the_damping(e):
    """(c) e = 1 conserves E to the integrator's tolerance; e < 1 loses exactly the work of the damping
    (integrated as a state: Result.compliant_integrals[:, 0]), with gravity acting during the contact.
    Both are integrated quantities: at rtol = 1e-12 (some 60 steps) their balance holds to ~1e-11; the
    bound 1e-8 is the issue's (at the default rtol = 1e-10, atol = 1e-12 it is ~1e-7 of E)."""
    v, k = 1.5, 1e6
    res = falling_rod(v, k, e=e, gravity=9.81, rtol=1e-12, atol=1e-14)
    E = res.energy().total
    lost = E[0] - E[-1]
    damping_work = res.compliant_integrals[-1, 0] - res.compliant_integrals[0, 0]
    scale = 0.5 * MASS * v * v
    assert abs(lost + damping_work) / scale < 1e-8
    if e == 1.0:
        assert abs(lost) / scale < 1e-8 and damping_work == 0.0
    else:
        assert lost / scale > 0.5


def test_walls_check_the_compliant_parameters():
    for bad, match in [(dict(stiffness=-1.0), "stiffness"), (dict(stiffness=1e6, exponent=0.5), "exponent"),
                       (dict(stiffness=1e6, damping="hertz"), "damping")]:
        with pytest.raises(ValueError, match=match):
            gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), **bad)
        with pytest.raises(ValueError, match=match):
            gi.Circle(1.0, **bad)
    with pytest.raises(ValueError, match="e=0 with damping='flores'"):
        damping_factor(0.0, "flores")
    assert damping_factor(0.0, "lankarani-nikravesh") == 0.75
    assert gi.Sphere(2.0, stiffness=1e6).stiffness == 1e6


def test_flores_refuses_a_plastic_wall_at_the_start():
    with pytest.raises(ValueError, match="e=0"):
        falling_rod(1.0, 1e6, e=0.0)


def test_a_compliant_contact_is_one_episode():
    """Result.episodes: one episode from the start event to the rebound, its impulse the integrated normal impulse
    m v (1 + e'), its effective restitution e' (the law's closed form), energy lost = -damping work, the deepest
    penetration and largest force of the samples."""
    v, k, e = 2.0, 1e6, 0.5
    res = falling_rod(v, k, e=e)
    e_closed = hunt_crossley_restitution(damping_factor(e, "flores"))
    (ep,) = res.episodes
    (contact,) = res.compliant_contacts
    assert ep.start == contact.start and ep.end > contact.end
    assert ep.n_impacts == 0 and ep.points == (2,) and ep.first_point == 2 and ep.resting_time == 0.0
    assert ep.impulse == pytest.approx(MASS * v * (1.0 + e_closed), rel=1e-7)
    assert ep.restitution == pytest.approx(e_closed, abs=1e-7)
    assert ep.energy_lost == pytest.approx(-ep.damping_work, rel=1e-6)
    assert ep.friction_work == 0.0
    assert ep.max_force == pytest.approx(res.compliant_forces.max())
    assert 0.5 * hertz_penetration(MASS, v, k) < ep.max_penetration < hertz_penetration(MASS, v, k)


def test_resting_on_a_compliant_wall_is_a_steady_compliant_state():
    """Dropped with gravity and e = 0.5, the rod bounces twice and comes to rest in contact: no impact, no resting
    mode, the force m g at the static penetration (m g / k)^(1/p) (to the integrator's tolerance)."""
    g, k = 9.81, 1e6
    res = falling_rod(1.0, k, e=0.5, gravity=g, t_end=1.0)
    assert res.status == "finished" and not res.impacts and res.resting_time == 0.0
    assert [np.isnan(c.end) for c in res.compliant_contacts] == [False, False, True]
    assert res.compliant_forces[-1, 0, 1] == pytest.approx(MASS * g, rel=1e-6)
    assert 1.0 - res.q[-1, 1] == pytest.approx((MASS * g / k) ** (1 / 1.5), rel=1e-6)
    assert abs(res.qdot[-1, 1]) < 1e-9


def test_mixed_newton_and_compliant_walls():
    """A Newton ceiling (e = 1) above a compliant floor (e = 1): the rod rebounds from the floor, strikes the ceiling
    with O1 (one impact, Newton's law), and comes back onto the floor (a second compliant contact); energy kept."""
    v, k = 1.0, 1e6
    ceiling = gi.Plane((0.0, 1.05, 0.0), (0.0, -1.0, 0.0), restitution=1.0)
    model = gi.Model(gi.Chain([ROD]), gravity=(0.0, 0.0, 0.0))
    floor = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=1.0, stiffness=k)
    q0, qd0 = model.state(X2=1.01, theta_1=-np.pi / 2), model.state(X2=-v)
    res = gi.simulate(model, q0, qd0, (0.0, 0.15), walls=[floor, ceiling])
    assert [(r.wall, r.joints) for r in res.impacts] == [((1,), (1,))]
    assert [c.wall for c in res.compliant_contacts] == [0, 0]
    assert res.qdot[-1, 1] == pytest.approx(v, rel=1e-8)
    E = res.energy().total
    assert abs(E[-1] - E[0]) / E[0] < 1e-8
    # The flight between: O1 rises from 1.0 m to the ceiling at 1.05 m and falls back at v.
    first, second = res.compliant_contacts
    assert second.start - first.end == pytest.approx(2 * 0.05 / v, rel=1e-8)


# -- the flexible arm of issue 26 ----------------------------------------------------------------------------
#: Its floor, compliant: e = 0.5 (Flores), k = 1e4 N/m^1.5: the tip (effective mass 1/3 kg, 3.3 m/s) stays
#: 56 ms in contact, 14 periods of the first bending mode at EI = 1e4 (omega_1 = 15.4 sqrt(EI) rad/s, pinned-free).
ARM_FLOOR = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.5, stiffness=1e4)


def arm_state(model, gap=1e-3):
    """(q, qdot) of the arm released horizontal at rest when its tip is ``gap`` [m] above the floor, undeformed, in
    the rigid rod's closed form: (1/2)(m l^2 / 3) omega^2 = m g (l / 2) sin|theta| -> omega^2 = 3 g sin|theta| / l."""
    s = 0.5 - gap  # l sin|theta| = 0.5 m - gap, l = 1 m
    q, qd = np.zeros(model.n_dof), np.zeros(model.n_dof)
    q[model.theta_index[0]], qd[model.theta_index[0]] = -np.arcsin(s), -np.sqrt(3.0 * 9.81 * s)
    return q, qd


@functools.cache
def arm_episode(elements, EI=1e4):
    """The one collision episode of the arm of issue 26 (``elements`` Hermite elements, 0: the rigid rod) on
    ARM_FLOOR, from 1 mm above the floor to 60 ms (the contact ends at 56.3 ms)."""
    from conftest import issue26_model

    model = issue26_model(elements, EI)
    q0, qd0 = arm_state(model)
    res = gi.simulate(model, q0, qd0, (0.0, 0.06), walls=[ARM_FLOOR])
    assert res.status == "finished" and not res.impacts
    (ep,) = res.episodes
    return ep


@pytest.mark.parametrize("elements", [2, pytest.param(4, marks=pytest.mark.slow),
                                      pytest.param(8, marks=pytest.mark.slow)])
def test_rigid_limit_of_the_flexible_arm(elements):
    """(d) EI = 1e4 (contact 14 first-bending periods long): the arm's effective restitution (angular momentum about
    the pivot after over before, gravity removed: Episode.restitution) is the rigid rod's within 0.02 for every
    mesh (measured: 0.59717 rigid, 0.59852, 0.59852, 0.59851 for n_e = 2, 4, 8), where Newton's law gave
    0.65-0.77; its impulse too (2.4138 rigid, 2.4158 N s)."""
    rigid, arm = arm_episode(0), arm_episode(elements)
    assert abs(arm.restitution - rigid.restitution) < 0.02
    assert arm.impulse == pytest.approx(rigid.impulse, rel=0.02)
    assert arm.non_contact_share < 0.25  # gravity's share of the 56 ms contact (0.195), removed from e_eff


@pytest.mark.slow
def test_compliant_collision_converges_with_the_mesh():
    """(e) EI = 1e3 (contact 4.4 first-bending periods long): the episode's total impulse and effective restitution
    change by less than 2 % from n_e = 8 to 16 (measured: 4e-6; Newton's law: the first impulse halves)."""
    coarse, fine = arm_episode(8, EI=1e3), arm_episode(16, EI=1e3)
    assert fine.impulse == pytest.approx(coarse.impulse, rel=0.02)
    assert fine.restitution == pytest.approx(coarse.restitution, rel=0.02)


def test_compliant_forces_in_the_files_and_the_figure(tmp_path):
    """contact_forces.csv holds the compliant force per sample (Fc_w<wall>_<point>_N), episodes.csv the damping
    work, result.npz gives back the same Result (forces, integrals, contacts, episodes), the figure is drawn."""
    from gibbsimpact.io.result_files import read_csv, to_csv

    res = falling_rod(2.0, 1e6, e=0.5)
    out = to_csv(res, tmp_path)
    table = read_csv(out["contact_forces"])
    assert np.array_equal(table["Fc_w1_O2_N"], res.compliant_forces[:, 0, 1]) and not np.any(table["Fc_w1_O1_N"])
    episodes = read_csv(out["episodes"])
    assert episodes["damping_work_J"][0] == res.episodes[0].damping_work < 0.0
    res.save(tmp_path / "result.npz")
    back = gi.load_result(tmp_path / "result.npz")
    assert back.compliant_contacts == res.compliant_contacts and back.episodes == res.episodes
    assert np.array_equal(back.compliant_integrals, res.compliant_integrals)
    assert res.plot("contact_forces") is not None


def test_a_span_contact_is_a_force_at_the_links_closest_point(tmp_path):
    """A flexible link bulging into a compliant floor between its joints: the link column carries the force, at
    the material point deepest in the floor (an independent search: conftest.deepest_point), recorded in
    Result.compliant_points and contact_forces.csv; the joints, above the floor, carry none."""
    from conftest import deepest_point

    from gibbsimpact.io.result_files import read_csv, to_csv

    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")], rotary_inertia=(5e-5, 2.5e-5, 2.5e-5),
                   geometric_stiffening=False)
    model = gi.Model(gi.Chain([link]), gravity=(0.0, 0.0, 0.0))
    floor = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.8, stiffness=1e5)
    res = gi.simulate(model, model.state(X1=-0.5, X2=1e-3), model.state(delta_1_1=-0.5), (0.0, 0.01), walls=[floor])
    assert res.status == "finished" and not res.impacts
    first, *later = res.compliant_contacts
    assert first.point == 3 and later[0].start > first.start  # column 3: link 1's closest point; its ends come later
    during = res.t < later[0].start
    F = res.compliant_forces[during, 0]
    assert not F[:, :2].any() and F[:, 2].max() > 0.0
    k = int(np.argmax(F[:, 2]))
    x, depth = deepest_point(model, res.q[k], 0, floor)
    assert res.compliant_points[k, 0, 2, 1] == pytest.approx(-depth, abs=1e-9)
    assert res.compliant_points[k, 0, 2, 0] == pytest.approx(res.q[k, 0] + x, abs=1e-6)
    table = read_csv(to_csv(res, tmp_path)["contact_forces"])
    assert np.array_equal(table["Xc_w1_link1_X2_m"], res.compliant_points[:, 0, 2, 1], equal_nan=True)


def test_regularised_coulomb_friction_slows_a_sliding_rod():
    """The rod lying on a compliant floor with friction mu = 0.3, sliding at 1 m/s: the floor's normal impulse is
    m (g T + v_y(T)) (vertical momentum: only gravity and the floor act vertically), so sliding throughout,
    v_x(T) = v_x(0) - mu (g T + v_y(T)), to the regularisation's v_eps^2 / (2 v^2) ~ 1e-6; the friction's work
    is recorded and the run's energy balance holds."""
    g, mu, T = 9.81, 0.3, 0.1
    model = gi.Model(gi.Chain([ROD]), gravity=(0.0, -g, 0.0))
    floor = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.5, stiffness=1e6, friction=mu)
    res = gi.simulate(model, model.state(), model.state(X1=1.0), (0.0, T), walls=[floor])
    assert res.status == "finished" and [c.point for c in res.compliant_contacts] == [1, 2]
    vx, vy = res.qdot[-1, 0], res.qdot[-1, 1]
    assert res.compliant_integrals[-1, 2] == pytest.approx(MASS * (g * T + vy), rel=1e-9)
    assert vx == pytest.approx(1.0 - mu * (g * T + vy), abs=1e-6)
    assert res.compliant_integrals[-1, 1] < -0.2 and res.energy_error < 1e-8


def test_compliant_obstacle_ball_struck_end_first():
    """The compliant law on an obstacle (Sphere(inside=False), gap |p - c| - R): the rod falling end-first onto the
    top of a ball (radius 0.5 m, its centre straight below O2) meets the same 1-DOF Hertz impact as on a floor: the
    contact point stays on the vertical through the centre (no rotation, no lateral force), so the penetration
    and the contact time are Hertz's closed forms (1e-4) and the rod leaves at v (e = 1)."""
    v, k, R, gap = 1.0, 1e6, 0.5, 0.01
    model = gi.Model(gi.Chain([ROD]), gravity=(0.0, 0.0, 0.0))
    ball = gi.Sphere(R, (0.0, -R, 0.0), restitution=1.0, inside=False, stiffness=k, exponent=1.5)
    dt = hertz_duration(MASS, v, k)
    res = gi.simulate(model, model.state(X2=1.0 + gap, theta_1=-np.pi / 2), model.state(X2=-v),
                      (0.0, gap / v + 3.0 * dt), walls=[ball], output_dt=dt / 4000)
    (contact,) = res.compliant_contacts
    assert (contact.end - contact.start) / dt == pytest.approx(1.0, abs=1e-4)
    depth = -res.joint_positions()[:, 1, 1].min()
    assert depth / hertz_penetration(MASS, v, k) == pytest.approx(1.0, abs=1e-4)
    assert res.qdot[-1, 1] == pytest.approx(v, rel=1e-8)
    assert np.abs(res.qdot[-1, [0, 2, 3, 4, 5]]).max() < 1e-9
