"""Prescribed joint motion (simulate's ``prescribed``; formulation §16): efforts, impacts, energy audit, errors."""

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gibbsimpact as gi

EPS = np.finfo(float).eps
G = 9.81


def _rod_model(n_links=1, gravity=G):
    """Rigid rods, l = 1 m, mu = 1 kg/m, on a fixed pivot at the origin (no rotary inertia: planar)."""
    rod = gi.Link(1.0, 1.0, 1e4)
    return gi.Model(gi.Chain([rod] * n_links, base=gi.FixedBase((0.0, 0.0))), gravity=(0.0, -gravity, 0.0))


def _flexible_arm():
    """Two links, l = 1 m, mu = 1 kg/m, EI = 50 N m^2, one clamped-free y-mode each, on a fixed pivot, N = 4."""
    link = gi.Link(1.0, 1.0, 50.0, modes=[gi.Mode("clamped-free", "y")])
    return gi.Model(gi.Chain([link, link], base=gi.FixedBase((0.0, 0.0))), gravity=(0.0, -G, 0.0))


def _start(profile):
    q, qd, _ = profile(0.0)
    return np.array([q]), np.array([qd])


@pytest.mark.parametrize("profile", [gi.profiles.constant_speed(0.3, 2.0),
                                     gi.profiles.point_to_point(-0.4, 1.2, 0.1, 0.8)], ids=["constant", "quintic"])
def test_rigid_pendulum_effort_is_the_closed_form_torque(profile):
    """A rod (m = 1 kg, l = 1 m) whose angle is prescribed needs the torque Q = I theta'' + m g (l/2) cos theta,
    I = m l^2 / 3, at every sample (the pendulum's equation of motion solved for the torque), and the angle
    follows the profile exactly. Tolerance: the round-off of M, dV/dq (a few eps of their size)."""
    model = _rod_model()
    res = gi.simulate(model, *_start(profile), (0.0, 1.0), prescribed={"theta_1": profile}, output_dt=0.01)
    assert res.status == "finished" and res.prescribed == ("theta_1",)
    ref = np.array([profile(t) for t in res.t])
    assert np.array_equal(res.q[:, 0], ref[:, 0]) and np.array_equal(res.qdot[:, 0], ref[:, 1])
    torque = ref[:, 2] / 3.0 + G * 0.5 * np.cos(ref[:, 0])
    scale = np.abs(ref[:, 2]) / 3.0 + G * 0.5
    assert res.effort.shape == (res.t.size, 1)
    assert np.all(np.abs(res.effort[:, 0] - torque) <= 16 * EPS * scale)
    # The actuator's work is the energy it put in: E(t) - E(0) = W_act(t) (no other force works).
    assert res.work.shape == (res.t.size, 3)
    assert res.energy_error_whole_run <= 1e-9


def test_carriage_on_an_inclined_rail_needs_m_times_its_acceleration_plus_weight():
    """A rigid rod (m = 1 kg) on a carriage (Pa, joint 1) running along a base rail inclined at beta = 0.4 rad,
    d_1 prescribed by a quintic move: the actuator's force along the rail is m (d'' + g sin beta) at every sample
    (Newton's law along the rail; the rod does not turn). Tolerance: round-off of M, dV/dq."""
    beta = 0.4
    rod = gi.Link(1.0, 1.0, 1e4)
    model = gi.Model(gi.Chain([rod], joints=[gi.SlidingPrismatic(angle=0.3, range=(-1.0, 2.0))],
                              base=gi.FixedBase((0.0, 0.0), beta)), gravity=(0.0, -G, 0.0))
    move = gi.profiles.point_to_point(0.0, 1.5, 0.1, 0.6)
    res = gi.simulate(model, np.zeros(1), np.zeros(1), (0.0, 0.8), prescribed={"d_1": move}, output_dt=0.01)
    assert res.status == "finished" and model.coordinate_names == ("d_1",)
    qdd = np.array([move(t)[2] for t in res.t])
    force = qdd + G * math.sin(beta)
    assert np.all(np.abs(res.effort[:, 0] - force) <= 16 * EPS * (np.abs(qdd) + G))
    assert res.energy_error_whole_run <= 1e-9


def _free_run_profile(model, q0, qd0, t_end, k):
    """The free motion of coordinate k from an independent integration (scipy solve_ivp, DOP853, rtol 1e-13)
    as a profile: (q_k, qdot_k, qddot_k)(t) from its dense output and the equations of motion there."""
    N = model.n_dof

    def rhs(t, y):
        return np.concatenate((y[N:], model.forward_dynamics(y[:N], y[N:])))

    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate((q0, qd0)), method="DOP853", rtol=1e-13, atol=1e-13,
                    dense_output=True)

    def f(t):
        y = sol.sol(t)
        return y[k], y[N + k], rhs(t, y)[N + k]

    return f, sol


def test_prescribing_the_free_motion_changes_nothing():
    """Prescribing theta_1 along the chain's own free motion leaves the free coordinates on their free trajectory
    and needs no effort: both to the integrators' tolerance (rtol 1e-10 here against 1e-13: the state agrees to
    ~1e-9 of its size over 1 s, the effort to the same fraction of the torques at play, m g l)."""
    model = _flexible_arm()
    q0 = model.state(theta_1=-1.0, theta_2=1.2, delta_1_1=0.01)
    qd0 = np.zeros_like(q0)
    f, ref = _free_run_profile(model, q0, qd0, 1.0, 0)
    res = gi.simulate(model, q0, qd0, (0.0, 1.0), prescribed={"theta_1": f}, output_dt=0.01)
    assert res.status == "finished"
    y = ref.sol(res.t).T
    N = model.n_dof
    assert np.max(np.abs(res.q - y[:, :N])) <= 1e-8
    assert np.max(np.abs(res.qdot - y[:, N:])) <= 1e-7
    torque_scale = 2.0 * G * 2.0  # m g l of the chain about its pivot [N m]
    assert np.max(np.abs(res.effort)) <= 1e-7 * torque_scale


SPIN = gi.profiles.spin_up(3.0, 0.5, -np.pi / 2)
FLOOR = gi.Plane((0.0, -1.6, 0.0), (0.0, 1.0, 0.0))


@pytest.mark.parametrize("e, t_end, n_impacts", [(None, 1.0, 0), (1.0, 1.0, 4), (0.5, 0.35, 4)])
def test_power_balance_closes_with_an_actuator(e, t_end, n_impacts):
    """Two-link flexible arm, theta_1 spun up by its actuator, link 2 free and hitting the floor with its tip: the
    energy balance E(t) - E(0) - W_act(t) (W_act = int qdot_p Q_p dt + sum Lambda_p qdot_p at the impacts) closes
    to 1e-9 of the energy scale, impacts with e = 1 included (e < 1: their loss is by design, as without
    prescribed coordinates)."""
    model = _flexible_arm()
    q0 = model.state(theta_1=-np.pi / 2, theta_2=1.2)
    walls = [] if e is None else [FLOOR]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, q0, np.zeros_like(q0), (0.0, t_end), walls=walls, restitution=e or 1.0,
                          prescribed={"theta_1": SPIN})
    assert res.status == "finished"
    assert len(res.impacts) == n_impacts
    assert res.energy_error_whole_run <= 1e-9 and res.energy_error <= 1e-9
    assert res.work[-1, 2] > 1.0  # the actuator did work [J]
    # The audit closes on the energies computed from the states: E(end) - E(0) = the sum of its parts.
    audit = res.energy_audit()
    E = res.energy().total
    assert audit["actuators"] == res.work[-1, 2]
    assert sum(audit.values()) == pytest.approx(E[-1] - E[0], abs=1e-9 * res.energy_scale)
    for rec in res.impacts:
        assert rec.qdot_after[0] == rec.qdot_before[0] == SPIN(rec.time)[1]  # the actuator holds its speed
    if e == 1.0:
        # Each impact's jump of E is the actuator's impulse times its speed: nothing else works.
        for rec in res.impacts:
            jump = rec.energy_after.total - rec.energy_before.total
            assert jump == pytest.approx(rec.actuator_impulses[0] * rec.qdot_before[0], rel=1e-9,
                                         abs=1e-12 * abs(rec.energy_before.total))


def test_impact_on_a_prescribed_hub_closed_form():
    """A rigid rod (link 2, free angle theta_2) on a hub arm (link 1) turned at Omega = 2 rad/s, no gravity: the
    tip meets the plane y = 1.5 when sin theta_1 = 0.75 with v_n = -2 Omega cos theta_1. With theta_1' held,
    Newton's law on the free coordinate alone: W_2 = n . dp/dtheta_2 = -cos theta_1, M_22 = m l^2/3,
    dtheta_2' = -(1 + e) v_n / W_2, Lambda = M_22 dtheta_2' / W_2, and the actuator's impulse
    Lambda_p = M_12 dtheta_2' - W_1 Lambda with M_12 = m (l^2/2 + l^2/3), W_1 = -2 cos theta_1."""
    model = _rod_model(2, gravity=0.0)
    Om, e = 2.0, 0.5
    wall = gi.Plane((0.0, 1.5, 0.0), (0.0, -1.0, 0.0))
    res = gi.simulate(model, np.zeros(2), np.array([Om, 0.0]), (0.0, 1.0), walls=[wall], restitution=e,
                      prescribed={"theta_1": gi.profiles.constant_speed(0.0, Om)}, max_impacts=1,
                      link_contacts=False)
    rec = res.impacts[0]
    c = math.sqrt(1 - 0.75 ** 2)
    assert rec.time == pytest.approx(math.asin(0.75) / Om, rel=1e-9)
    v_n, W1, W2, M22, M12 = -2 * Om * c, -2 * c, -c, 1 / 3, 0.5 + 1 / 3
    dth2 = -(1 + e) * v_n / W2
    lam = M22 * dth2 / W2
    assert rec.joints == (3,)
    assert rec.qdot_after == pytest.approx([Om, dth2], rel=1e-9, abs=1e-12)
    assert rec.impulses == pytest.approx([lam], rel=1e-9)
    assert rec.v_after == pytest.approx([-e * v_n], rel=1e-9)
    assert rec.actuator_impulses == pytest.approx([M12 * dth2 - W1 * lam], rel=1e-9)
    # The actuator's impulse works at its held speed: W_act jumps by Lambda_p Omega.
    k = int(np.nonzero(res.t == rec.time)[0][-1])
    assert res.work[k, 2] - res.work[k - 1, 2] == pytest.approx(rec.actuator_impulses[0] * Om, rel=1e-12)


def test_contact_moved_only_by_the_actuator_stops_the_run():
    """The tip of the driven hub arm (O_2) meets a wall: no free coordinate can stop it; status "failed", a message."""
    model = _rod_model(2, gravity=0.0)
    wall = gi.Plane((0.0, 0.75, 0.0), (0.0, -1.0, 0.0))
    res = gi.simulate(model, np.zeros(2), np.array([2.0, 0.0]), (0.0, 1.0), walls=[wall],
                      prescribed={"theta_1": gi.profiles.constant_speed(0.0, 2.0)}, link_contacts=False)
    assert res.status == "failed" and "moved by prescribed coordinates only" in res.message


@pytest.mark.parametrize("prescribed, match", [
    ({"theta_3": gi.profiles.constant_speed(0.0, 1.0)}, r"prescribed\['theta_3'\] is not a coordinate of this model"),
    ({"delta_1_1": gi.profiles.constant_speed(0.0, 1.0)}, r"is an elastic coordinate; only joint coordinates"),
    ({"theta_1": 2.0}, r"must be a function f\(t\) -> \(q, qdot, qddot\)"),
    ({"theta_1": lambda t: (0.0, 0.0)}, r"must return three finite numbers"),
    ({"theta_1": gi.profiles.constant_speed(0.5, 0.0)},
     r"q0\[0\] = -1.0 \(theta_1\) differs from .* set q0\[0\] = 0.5"),
    ({"theta_1": gi.profiles.samples([0, 0.1, 0.2, 0.3], [-1.0, 0, 0, 0])},
     r"is defined on \[0, 0.3\] s only"),
    (["theta_1"], r"prescribed=\['theta_1'\] must be a dict"),
])
def test_bad_prescribed_arguments_name_the_fix(prescribed, match):
    model = _flexible_arm()
    q0 = model.state(theta_1=-1.0)
    with pytest.raises(ValueError, match=match):
        gi.simulate(model, q0, np.zeros_like(q0), (0.0, 1.0), prescribed=prescribed)


def test_a_moving_base_orientation_cannot_be_prescribed():
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 1e4)] * 2, base="planar"), gravity=(0.0, -G, 0.0))
    q0 = np.zeros(model.n_dof)
    with pytest.raises(ValueError, match=r"'theta_1'\] is a coordinate of the moving base; .*: theta_2"):
        gi.simulate(model, q0, q0, (0.0, 1.0), prescribed={"theta_1": gi.profiles.constant_speed(0.0, 0.0)})


def test_effort_and_actuator_impulses_in_files_summary_and_figure(tmp_path):
    """timeseries.csv gains work_actuators_J and effort_theta_1_N_m; the NPZ keeps effort, the prescribed names and
    the actuators' impulses exactly; the summary lists the prescribed coordinates; the "effort" figure is drawn."""
    import csv

    model = _rod_model(2, gravity=0.0)
    res = gi.simulate(model, np.zeros(2), np.array([2.0, 0.0]), (0.0, 0.6), walls=[gi.Plane((0.0, 1.5, 0.0),
                      (0.0, -1.0, 0.0))], restitution=0.5, prescribed={"theta_1": gi.profiles.constant_speed(0.0, 2.0)},
                      link_contacts=False, output_dt=0.05)
    rows = list(csv.reader(res.to_csv(tmp_path)["timeseries"].open()))
    assert rows[0][-2:] == ["work_actuators_J", "effort_theta_1_N_m"]
    assert [float(r[-1]) for r in rows[1:]] == res.effort[:, 0].tolist()
    impacts = list(csv.reader(res.to_csv(tmp_path)["impacts"].open()))
    assert impacts[0][-1] == "actuator_impulse_theta_1_N_m_s"
    assert float(impacts[1][-1]) == res.impacts[0].actuator_impulses[0]
    back = gi.load_result(res.save(tmp_path / "r.npz"))
    assert back.prescribed == ("theta_1",) and np.array_equal(back.effort, res.effort)
    assert np.array_equal(back.impacts[0].actuator_impulses, res.impacts[0].actuator_impulses)
    summary = res.summary()
    assert summary["prescribed_coordinates"] == ["theta_1"]
    assert summary["work_final_J"]["actuators"] == res.work[-1, 2]
    assert res.plot("effort") is not None


def test_an_accumulation_with_prescribed_coordinates_stops_with_a_reason():
    """Resting contact is not modelled with prescribed coordinates (docs): the arm of the power-balance test with
    e = 0.5 accumulates impacts at its tip near t = 0.403 s and stops there with status "zeno", saying why."""
    model = _flexible_arm()
    q0 = model.state(theta_1=-np.pi / 2, theta_2=1.2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, q0, np.zeros_like(q0), (0.0, 0.5), walls=[FLOOR], restitution=0.5,
                          prescribed={"theta_1": SPIN})
    assert res.status == "zeno" and "resting contact is not modelled with prescribed coordinates" in res.message
    assert res.energy_error_whole_run <= 1e-9


def test_frictional_impact_on_a_prescribed_hub_balances_the_free_rows():
    """The hub impact of the closed-form test on a wall with friction mu = 0.3 (Moreau's law on the free partition):
    with the tip's Jacobian J written by hand, M (qdot+ - qdot-) = J^T (n P_n + F_t) + (Lambda_p, 0) row by row,
    v_n+ = -e v_n-, |F_t| <= mu P_n, and theta_1' is held."""
    from gibbsimpact.dynamics.gibbs_appell import mass_matrix

    model = _rod_model(2, gravity=0.0)
    Om, e, mu = 2.0, 0.5, 0.3
    wall = gi.Plane((0.0, 1.5, 0.0), (0.0, -1.0, 0.0), friction=mu)
    res = gi.simulate(model, np.zeros(2), np.array([Om, 0.0]), (0.0, 1.0), walls=[wall], restitution=e,
                      prescribed={"theta_1": gi.profiles.constant_speed(0.0, Om)}, max_impacts=1,
                      link_contacts=False)
    rec = res.impacts[0]
    th1, th2 = res.q[np.nonzero(res.t == rec.time)[0][0]]
    J = np.array([[-math.sin(th1) - math.sin(th1 + th2), -math.sin(th1 + th2)],
                  [math.cos(th1) + math.cos(th1 + th2), math.cos(th1 + th2)], [0.0, 0.0]])
    generalized = J.T @ (rec.normals[0] * rec.impulses[0] + rec.friction_impulses[0])
    residual = mass_matrix(model, np.array([th1, th2])) @ (rec.qdot_after - rec.qdot_before) - generalized
    scale = abs(generalized).max()
    assert abs(residual[1]) <= 1e-12 * scale
    assert residual[0] == pytest.approx(rec.actuator_impulses[0], abs=1e-12 * scale)
    assert rec.qdot_after[0] == Om and rec.v_after[0] == pytest.approx(-e * rec.v_before[0], rel=1e-12)
    assert np.linalg.norm(rec.friction_impulses[0]) <= mu * rec.impulses[0] * (1 + 1e-12)
    assert np.linalg.norm(rec.friction_impulses[0]) > 0
