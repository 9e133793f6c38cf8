"""Prismatic joints (docs/theory.md §7.3, §7.4, §8, §9, §13; docs/design-notes.md, Tests): invariants of simulated motion,
stretching elements of a Pb link, joint limits.

The independent second derivation is in tests/test_planar_oracle.py, the rigid closed
forms in tests/test_prismatic_rigid.py.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import gibbsimpact as gi
from gibbsimpact.model.elements import assemble, element_mass, element_stiffness

G = 9.81
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382])  # roots of 1 + cos cosh = 0


def _model(joints, elements=(3, 2), gravity=(0.0, -G, 0.0), base=None, EI=(10.0, 2.0)):
    host = gi.Link(1.0, 1.0, EI[0], elements=elements[0], geometric_stiffening=False)
    arm = gi.Link(0.6, 0.5, EI[1], elements=elements[1], geometric_stiffening=False)
    base = gi.FixedBase((0.1, 0.2), 0.3) if base is None else base
    return gi.Model(gi.Chain([host, arm], joints=joints, base=base), gravity=gravity)


def _pa(**kw):
    return gi.SlidingPrismatic(**{"angle": 0.6, "half_length": 0.04, "range": (0.05, 0.95), **kw})


def _pb(**kw):
    return gi.FixedPrismatic(**{"angle": 0.3, "range": (0.15, 0.6), **kw})


def _state(model, joints, rng, delta=0.01):
    q = np.zeros(model.n_dof)
    qd = np.zeros(model.n_dof)
    for i, kind in enumerate(model.joint_kinds):
        k = model.theta_index[i]
        q[k] = joints[i]
        qd[k] = 0.8 if kind == "R" else 0.3
    for idx in model.delta_index:
        q[idx] = rng.normal(scale=delta, size=idx.size)
    return q, qd


def _energy_scale(E):
    return abs(E.kinetic[0]) + abs(E.gravity[0]) + abs(E.strain[0])


# -- invariants ----------------------------------------------------------------------

CHAINS = {
    # A Pa carriage starting at d = 0.30: d - c and d + c cross the host nodes at 1/3 and 2/3 m.
    "R-Pa": ([gi.Revolute(), _pa()], [0.4, 0.30]),
    # A Pb link whose material flows through the guide (d moves by ~0.1 m).
    "R-Pb": ([gi.Revolute(), _pb()], [0.4, 0.35]),
    "Pa-R": ([gi.SlidingPrismatic(angle=0.2, range=(-5.0, 5.0)), gi.Revolute()], [0.0, 0.5]),
    "Pb-R": ([gi.FixedPrismatic(angle=0.5, range=(0.6, 1.0)), gi.Revolute()], [0.8, 0.5]),
    # A carriage on a flexible sliding link: its frame depends on both prismatic variables.
    "Pb-Pa": ([gi.FixedPrismatic(angle=0.5, range=(0.6, 1.0)), _pa(range=(0.1, 0.9))], [0.8, 0.6]),
}
# Seconds simulated: a Pb link 1 that slides far in becomes stiff (element length d / n_e).
DURATION = {"R-Pa": 1.0, "R-Pb": 1.0, "Pa-R": 1.0, "Pb-R": 0.5, "Pb-Pa": 0.5}


@pytest.mark.parametrize("name", sorted(CHAINS))
def test_energy_is_conserved_without_inputs(name, rng):
    # docs/design-notes.md, Tests: max |E(t) - E(0)| / (|T| + |V_g| + |V_s|)_0 <= 1e-9 over 1 s, DOP853 rtol 1e-11.
    joints, values = CHAINS[name]
    model = _model(joints, elements=(3, 2) if name == "R-Pa" else (2, 2))
    q0, qd0 = _state(model, values, rng, delta=0.01 if name == "R-Pa" else 0.0)
    # Elastic end stops (e = 1) keep the sliding joints in range: energy is conserved through them too.
    res = gi.simulate(model, q0, qd0, (0.0, DURATION[name]), rtol=1e-11, atol=1e-12, joint_limit="impact", joint_restitution=1.0)
    assert res.status == "finished", res.message
    E = res.energy()
    drift = np.abs(E.total - E.total[0]).max() / _energy_scale(E)
    assert drift <= 1e-9, drift
    d = res.q[:, model.theta_index[1 if name.startswith("R") else 0]]
    if name == "R-Pa":
        # the carriage's contact points crossed host nodes (x = 1/3 or 2/3 m)
        c = 0.04
        crossed = [x for x in (1 / 3, 2 / 3) if np.any(np.diff(np.sign(d - c - x))) or np.any(np.diff(np.sign(d + c - x)))]
        assert crossed, (d.min(), d.max())
    if name == "R-Pb":
        assert d.max() - d.min() > 0.05  # material flowed through the guide


def test_power_balance_with_inputs(rng):
    # docs/design-notes.md, Tests: E(t) - E(0) - int qdot.Q dt = 0 (a torque on theta_1, a force on d_2).
    model = _model([gi.Revolute(), _pb()])
    q0, qd0 = _state(model, [0.4, 0.35], rng)
    inputs = {"theta_1": lambda t, q, qd: 2.0 * np.sin(3.0 * t), "d_2": lambda t, q, qd: 0.5 - 2.0 * (q[1] - 0.35)}
    res = gi.simulate(model, q0, qd0, (0.0, 0.6), rtol=1e-11, atol=1e-12, inputs=inputs, joint_limit="impact",
                      joint_restitution=1.0)
    assert res.status == "finished", res.message
    E = res.energy()
    W = res.work[:, 0]
    assert abs(W[-1]) > 0.05  # the inputs did work
    balance = np.abs(E.total - E.total[0] - (W - W[0])).max() / (_energy_scale(E) + np.abs(W).max())
    assert balance <= 1e-9, balance


def test_free_planar_chain_conserves_momentum(rng):
    # docs/design-notes.md, Tests: a floating planar chain without gravity keeps L and H (<= 1e-9).
    host = gi.Link(1.0, 1.0, 25.0, elements=2, geometric_stiffening=False)
    arm = gi.Link(0.6, 0.5, 4.0, elements=2, geometric_stiffening=False)
    model = gi.Model(gi.Chain([host, arm], joints=[gi.Revolute(), _pb()], base="planar"), gravity=(0.0, 0.0, 0.0))
    assert model.coordinate_names[:4] == ("X1", "X2", "theta_1", "d_2")
    q0, qd0 = _state(model, [0.4, 0.35], rng)
    qd0[:2] = (0.3, -0.2)
    res = gi.simulate(model, q0, qd0, (0.0, 0.5), rtol=1e-11, atol=1e-12, joint_limit="impact", joint_restitution=1.0)
    assert res.status == "finished", res.message
    L = np.array([model.linear_momentum(q, qd) for q, qd in zip(res.q[::20], res.qdot[::20])])
    H = np.array([model.angular_momentum(q, qd, about=np.zeros(3)) for q, qd in zip(res.q[::20], res.qdot[::20])])
    scale_L = np.abs(L[0]).max()
    scale_H = np.abs(H[0]).max() + scale_L * 1.6
    assert np.abs(L - L[0]).max() <= 1e-9 * scale_L
    assert np.abs(H - H[0]).max() <= 1e-9 * scale_H
    assert np.ptp(res.q[:, 3]) > 0.01  # the link slid


def test_planar_base_equals_fixed_base_with_frozen_translation(rng):
    # The planar floating base with X = b and zero base velocity: M, h, dV/dq restricted to the
    # other coordinates equal the fixed base at b (angle 0).
    joints = [gi.Revolute(), _pa()]
    fixed = _model(joints, base=gi.FixedBase((0.2, -0.1), 0.0))
    free = _model(joints, base="planar")
    q, qd = _state(fixed, [0.4, 0.5], rng)
    Q, QD = np.concatenate(([0.2, -0.1], q)), np.concatenate(([0.0, 0.0], qd))
    np.testing.assert_allclose(free.mass_matrix(Q)[2:, 2:], fixed.mass_matrix(q), rtol=0, atol=1e-13)
    np.testing.assert_allclose(free.bias_forces(Q, QD)[2:], fixed.bias_forces(q, qd), rtol=0, atol=1e-12)
    np.testing.assert_allclose(free.potential_forces(Q)[2:], fixed.potential_forces(q), rtol=0, atol=1e-12)
    # the base rows: total mass and gravity force
    np.testing.assert_allclose(free.mass_matrix(Q)[:2, :2], free.total_mass * np.eye(2), rtol=1e-14)
    np.testing.assert_allclose(free.potential_forces(Q)[:2], [0.0, free.total_mass * G], rtol=1e-13)


def test_mass_matrix_is_continuous_across_host_nodes():
    # docs/design-notes.md, Tests: the carriage's contact point d + c crosses the host node at 1/3 m.
    model = _model([gi.Revolute(), _pa()], gravity=(0.0, 0.0, 0.0))
    rng = np.random.default_rng(3)
    q, _ = _state(model, [0.4, 0.0], rng, delta=0.03)
    node = 1.0 / 3.0 - 0.04
    for eps in (1e-6, 1e-9):
        qa, qb = q.copy(), q.copy()
        qa[1], qb[1] = node - eps, node + eps
        Ma, Mb = model.mass_matrix(qa), model.mass_matrix(qb)
        assert np.abs(Ma - Mb).max() <= 20 * eps * np.abs(Ma).max()


def test_point_slider_on_a_finite_element_host_is_rejected():
    with pytest.raises(ValueError, match="half_length.*jump"):
        _model([gi.Revolute(), gi.SlidingPrismatic(angle=0.0, half_length=0.0, range=(0.1, 0.9))])


# -- a Pb link's stretching elements ---------------------------------------------------------

def _pb_arm(n_e, EI=3.0, mu=0.7, length=1.0):
    link = gi.Link(length, mu, EI, elements=n_e, geometric_stiffening=False)
    return gi.Model(gi.Chain([link], joints=[gi.FixedPrismatic(angle=0.0, range=(0.1, length))],
                             base=gi.FixedBase()), gravity=(0.0, 0.0, 0.0))


@pytest.mark.parametrize("d", [0.25, 0.6, 1.0])
def test_pb_element_matrices_equal_eq_13_and_27_with_the_protruding_length(d):
    # docs/design-notes.md, Tests: with h = d / n_e the elastic block of M and the stiffness are the
    # assembled eq. (13) and (27).
    n_e, EI, mu = 3, 3.0, 0.7
    model = _pb_arm(n_e, EI, mu)
    q = model.state(d_1=d)
    M = model.mass_matrix(q)[1:, 1:]
    K = np.array([model.potential_forces(q + 1e-3 * e)[1:] for e in np.eye(model.n_dof)[1:]]).T / 1e-3
    Me, Ke = assemble(element_mass(mu, d / n_e), n_e), assemble(element_stiffness(EI, d / n_e), n_e)
    np.testing.assert_allclose(M, Me, rtol=0, atol=1e-14 * np.abs(Me).max())
    np.testing.assert_allclose(K, Ke, rtol=0, atol=1e-11 * np.abs(Ke).max())


@pytest.mark.parametrize("d", [0.3, 0.7])
def test_pb_frequencies_converge_with_order_four(d):
    # docs/design-notes.md, Tests: clamped-free link of length d behind a fixed guide.
    EI, mu = 3.0, 0.7
    exact = BETA_L[:2] ** 2 * np.sqrt(EI / (mu * d**4))
    errs = []
    for n_e in (4, 8, 16):
        model = _pb_arm(n_e, EI, mu)
        q = model.state(d_1=d)
        M = model.mass_matrix(q)[1:, 1:]
        K = np.array([model.potential_forces(q + e)[1:] for e in np.eye(model.n_dof)[1:]]).T
        w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))[:2]
        errs.append(np.abs(w - exact) / exact)
    errs = np.array(errs)
    order = np.log2(errs[:-1] / errs[1:])
    assert np.all((order >= 3.8) & (order <= 4.2)), order
    assert np.all(errs[1:] < errs[:-1])


def test_pb_strain_force_on_the_sleeve():
    # dV_s/dd = 1/2 delta^T K'(d) delta, K'_kl = (a_k + a_l - 3) K_kl / d (docs/theory.md §7.6):
    # against a central difference of the strain energy at fixed delta.
    model = _pb_arm(3)
    rng = np.random.default_rng(2)
    q = model.state(d_1=0.55)
    q[1:] = rng.normal(scale=0.02, size=model.n_dof - 1)
    Vs = lambda d: model.energy(np.concatenate(([d], q[1:])), np.zeros(model.n_dof)).strain  # noqa: E731
    h = 1e-5
    fd = (Vs(0.55 + h) - Vs(0.55 - h)) / (2 * h)
    assert model.potential_forces(q)[0] == pytest.approx(fd, rel=1e-8)
    assert fd < 0  # a bent rod pushes itself out of the sleeve (d grows)


# -- joint limits ---------------------------------------------------------------------

def _limit_run(**kw):
    model = _model([gi.Revolute(), _pb(range=(0.15, 0.45))], elements=(2, 1))
    q0 = model.state(theta_1=0.4, d_2=0.35)
    qd0 = model.state(theta_1=0.8, d_2=-0.6)
    return model, q0, qd0, gi.simulate(model, q0, qd0, (0.0, 0.6), rtol=1e-11, atol=1e-12, **kw)


def test_joint_limit_stops_at_the_event_time():
    # docs/design-notes.md, Tests: the stop time against a root of d_2(t) - d_max on a dense trajectory
    # computed without events.
    model, q0, qd0, res = _limit_run()
    assert res.status == "joint_limit"
    assert "joint 2" in res.message and "d_min = 0.15" in res.message
    t_stop = res.t[-1]
    N = model.n_dof
    sol = solve_ivp(lambda t, y: np.concatenate((y[N:], model.forward_dynamics(y[:N], y[N:]))),
                    (0.0, t_stop + 0.02), np.concatenate((q0, qd0)), method="DOP853", rtol=1e-12, atol=1e-13,
                    dense_output=True)
    t_root = brentq(lambda t: sol.sol(t)[1] - 0.15, 0.0 + 1e-9, t_stop + 0.02, xtol=1e-14)
    assert abs(t_stop - t_root) <= 1e-9, (t_stop, t_root)
    assert res.q[-1, 1] == pytest.approx(0.15, abs=1e-9)


def test_joint_limit_impact_with_unit_restitution_conserves_energy():
    model, q0, qd0, res = _limit_run(joint_limit="impact", joint_restitution=1.0)
    assert res.status == "finished", res.message
    stops = [r for r in res.impacts if r.wall == (-1,)]
    assert len(stops) >= 2 and all(r.joints == (2,) for r in stops)
    for r in stops:
        assert r.v_after[0] == pytest.approx(-r.v_before[0], rel=1e-12)
    E = res.energy()
    assert np.abs(E.total - E.total[0]).max() / _energy_scale(E) <= 1e-9
    d = res.q[:, 1]
    assert d.min() >= 0.15 - 1e-9 and d.max() <= 0.45 + 1e-9


def test_initial_state_outside_a_range_is_rejected():
    model = _model([gi.Revolute(), _pb(range=(0.15, 0.45))])
    with pytest.raises(ValueError, match="joint 2.*d_2 <= d_max = 0.45"):
        gi.simulate(model, model.state(d_2=0.5), np.zeros(model.n_dof), (0.0, 0.1))
    with pytest.raises(ValueError, match="joint_limit"):
        gi.simulate(model, model.state(d_2=0.3), np.zeros(model.n_dof), (0.0, 0.1), joint_limit="bounce")


def test_fixed_base_fe_arm_with_a_sliding_link_strikes_a_plane():
    # Walls and impacts work for prismatic robots: the R-Pb arm falls onto a floor.
    model = _model([gi.Revolute(), _pb()], base=gi.FixedBase((0.0, 0.3), 0.0))
    q0 = model.state(theta_1=-0.1, d_2=0.4)
    floor = gi.Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0))
    res = gi.simulate(model, q0, np.zeros(model.n_dof), (0.0, 0.5), walls=[floor], restitution=1.0,
                      rtol=1e-10, atol=1e-12)
    assert res.impacts, res.message
    first = res.impacts[0]
    assert first.joints in ((2,), (3,))  # the rear end or the tip of the sliding link
    assert first.v_after[0] == pytest.approx(-first.v_before[0], rel=1e-9)
    E = res.energy()
    assert np.abs(E.total - E.total[0]).max() / _energy_scale(E) <= 1e-8


@pytest.mark.slow  # 27 s of CPU (2026-11-27, docs/design-notes.md#running-the-tests)
def test_damped_sliding_link_balance_closes():
    # Stiffness-proportional damping of a Pb link uses K(d) of the protruding part; the audit
    # E(t) - E(0) - W_in - W_damp still closes, and the damping only dissipates.
    host = gi.Link(1.0, 1.0, 10.0, elements=2, geometric_stiffening=False)
    arm = gi.Link(0.6, 0.5, 2.0, elements=2, damping=0.05, geometric_stiffening=False)
    model = gi.Model(gi.Chain([host, arm], joints=[gi.Revolute(), _pb()], base=gi.FixedBase((0.1, 0.2), 0.3)))
    q0 = model.state(theta_1=0.4, d_2=0.35, delta_2_3=0.01)
    res = gi.simulate(model, q0, model.state(theta_1=0.8), (0.0, 0.4), rtol=1e-11, atol=1e-12,
                      inputs={"d_2": 1.0}, joint_limit="impact", joint_restitution=1.0)
    assert res.status == "finished", res.message
    E = res.energy()
    W_in, W_damp = res.work[:, 0], res.work[:, 1]
    assert W_damp[-1] < 0 and np.all(np.diff(W_damp) <= 1e-15)
    balance = np.abs(E.total - E.total[0] - W_in - W_damp).max() / (_energy_scale(E) + np.abs(W_in).max())
    assert balance <= 1e-9, balance


def test_result_files_keep_prismatic_joints_and_end_stops(tmp_path):
    # result.npz rebuilds the same model (joint parameters, planar base); impacts.csv marks end stops.
    from gibbsimpact.io.result_files import load_result, model_from_dict, model_to_dict, read_csv, save_result, to_csv

    model, q0, qd0, res = _limit_run(joint_limit="impact", joint_restitution=0.5)
    assert any(r.wall == (-1,) for r in res.impacts)
    back = load_result(save_result(res, tmp_path / "result.npz"))
    assert back.model.chain.joints == model.chain.joints
    np.testing.assert_array_equal(back.q, res.q)
    q = res.q[-1]
    np.testing.assert_array_equal(back.model.mass_matrix(q), model.mass_matrix(q))
    rows = read_csv(to_csv(res, tmp_path)["impacts"])
    assert "end stop of joint 2" in list(rows["wall_description"])
    planar = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 5.0, elements=2, geometric_stiffening=False), gi.Link(0.6, 0.5, 2.0, elements=1, geometric_stiffening=False)],
                               joints=[gi.Revolute(), _pa(range=(0.1, 0.9))], base="planar"))
    again = model_from_dict(model_to_dict(planar))
    assert again.chain.base == "planar" and again.chain.joints == planar.chain.joints


def test_host_tip_of_a_carriage_is_a_contact_point():
    # The tip of a host link carrying a Pa carriage is not a frame origin; it is contact point
    # O_(n+2). Released over a floor, link 1's free tip must strike it (a new user's run had
    # it pass 0.5 m through the floor while only the carriage centre was watched).
    host = gi.Link(1.0, 1.0, 25.0, elements=2, geometric_stiffening=False)
    arm = gi.Link(0.3, 0.5, 8.0, elements=1, geometric_stiffening=False)
    model = gi.Model(gi.Chain([host, arm], joints=[gi.Revolute(), _pa(angle=np.pi / 2, range=(0.1, 0.9))],
                              base=gi.FixedBase((0.0, 0.5), 0.0)))
    assert model.n_joints == 4 and model.contact_point_names[3] == "tip of link 1"
    q0 = model.state(d_2=0.3)
    P = model.joint_positions(q0)
    np.testing.assert_allclose(P[3], [1.0, 0.5, 0.0], atol=1e-14)
    floor = gi.Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0))
    res = gi.simulate(model, q0, np.zeros(model.n_dof), (0.0, 0.6), walls=[floor], restitution=1.0,
                      rtol=1e-9, atol=1e-11, joint_limit="impact", joint_restitution=1.0)
    wall_hits = [r for r in res.impacts if r.wall != (-1,)]
    assert wall_hits and wall_hits[0].joints == (4,), [r.joints for r in res.impacts]
    rec = wall_hits[0]
    assert rec.v_after[0] == pytest.approx(-rec.v_before[0], rel=1e-9)
    tips = np.array([model.joint_positions(q)[3] for q in res.q])
    assert tips[:, 1].min() >= -1e-6


def test_planar_base_gives_no_gimbal_warning_and_no_symbolic_equations():
    # q[4] of a planar-base chain is not theta_0: no gimbal-lock warning from it; the symbolic
    # route refuses prismatic and planar chains instead of deriving the wrong equations.
    from gibbsimpact.simulation.validity import check_state

    host = gi.Link(1.0, 1.0, 10.0, elements=2, geometric_stiffening=False)
    model = gi.Model(gi.Chain([host, gi.Link(0.6, 0.5, 4.0, elements=1, geometric_stiffening=False)], joints=[gi.Revolute(), _pb()],
                              base="planar"))
    q0 = model.state(d_2=0.3, delta_1_1=0.0)
    q0[4] = np.pi / 2  # delta_1_1 here
    assert not any("theta_0" in m for m in check_state(model, q0, np.zeros(model.n_dof)))
    with pytest.raises(NotImplementedError, match="prismatic joints and the planar floating base"):
        gi.derive_equations(model)
