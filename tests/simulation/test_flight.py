"""Event location inside a step (flight.py): grazing passes between accepted steps are impacts."""

import numpy as np
import pytest

import gibbsimpact as gi
from scipy.integrate import DOP853, RK45

from gibbsimpact.simulation import flight
from gibbsimpact.simulation.flight import _Dop853Interpolant, _first_crossing, _interpolant, dip_allowance, hermite_positions

L_ROD = 1.0


def spinning_rod():
    # Rigid (no modes), no gravity: with qdot0 below the centre (0.1, 0) stays put and
    # the rod spins at 10 rad/s about it, so O1 circles (0.1, 0) with radius 0.5 and
    # |O1| peaks at 0.6 m at t = pi/20 s.
    link = gi.Link(L_ROD, 1.0, (20.0, 20.0), modes=[], rotary_inertia=(5e-5, 2.5e-5, 2.5e-5))
    model = gi.Model(gi.Chain([link]), gravity=(0.0, 0.0, 0.0))
    q0 = np.array([0.1, -0.5, 0.0, 0.0, 0.0, np.pi / 2])
    qd0 = np.array([5.0, 0.0, 0.0, 0.0, 0.0, 10.0])
    return model, q0, qd0


def first_crossing_time(R):
    # |O1|^2 = 0.26 - 0.1 cos(theta), theta = pi/2 + 10 t.
    return (np.arccos((0.26 - R * R) / 0.1) - np.pi / 2) / 10.0


def closed_form_gap(R, t):
    """R - |O1(t)| of the undisturbed spinning rod [m]."""
    return R - np.sqrt(0.26 - 0.1 * np.cos(np.pi / 2 + 10.0 * t))


def test_reproducer_grazing_pass_inside_one_step_is_an_impact():
    # Issue 12.1: O1 passes 1e-4 m beyond a circle of radius 0.5999 m within one
    # accepted step (the rigid rod's steps are ~20 ms long); the signs at the step
    # ends never change.
    model, q0, qd0 = spinning_rod()
    R = 0.5999
    res = gi.simulate(model, q0, qd0, (0.0, 0.2), walls=[gi.Circle(R)], restitution=1.0, output_dt=1e-4)
    assert res.status == "finished", res.message
    assert res.n_steps < 20  # the pass is much shorter than a step
    assert len(res.impacts) == 1
    (rec,) = res.impacts
    assert rec.joints == (1,)
    assert rec.time == pytest.approx(first_crossing_time(R), abs=1e-9)
    assert abs(closed_form_gap(R, rec.time)) < 1e-10
    # Without the in-step search (solve_ivp's sign test at step ends only) the pass is missed.
    blind = gi.simulate(model, q0, qd0, (0.0, 0.2), walls=[gi.Circle(R)], restitution=1.0, output_dt=1e-4,
                        _in_step_check=False)
    assert blind.status == "finished" and blind.impacts == []
    assert (R - np.linalg.norm(blind.joint_positions()[:, 0, :2], axis=1)).min() < -9e-5
    # v_n = -d|O1|/dt = -0.1 sin(theta) theta_dot / (2 R) at the crossing.
    theta = np.pi / 2 + 10.0 * rec.time
    assert rec.v_before[0] == pytest.approx(-0.1 * np.sin(theta) * 10.0 / (2 * R), rel=1e-6)
    # No joint beyond the wall at any sample of the dense output.
    g = R - np.linalg.norm(res.joint_positions()[:, :, :2], axis=2)
    assert g.min() > -1e-12
    E = res.energy().total
    assert np.max(np.abs(E - E[0])) <= 1e-9 * E[0]


@pytest.mark.parametrize("depth", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 2e-9])
def test_grazing_scan_every_pass_deeper_than_contact_tol_is_an_impact(depth):
    model, q0, qd0 = spinning_rod()
    R = 0.6 - depth
    res = gi.simulate(model, q0, qd0, (0.0, 0.2), walls=[gi.Circle(R)], restitution=1.0, contact_tol=1e-9)
    assert res.status == "finished", res.message
    assert len(res.impacts) >= 1, f"pass {depth:g} m deep was missed"
    assert res.impacts[0].joints == (1,)
    # The first crossing, located to the integration accuracy: the closed-form gap
    # there is zero to 1e-10 m (in time that is 1e-10 m / v_n, large for a shallow pass).
    t_imp = res.impacts[0].time
    assert abs(closed_form_gap(R, t_imp)) < 1e-10
    assert t_imp <= first_crossing_time(R) + 1e-6
    g = R - np.linalg.norm(res.joint_positions()[:, :, :2], axis=2)
    assert g.min() > -1e-12


def test_grazing_scan_passes_that_stay_inside_are_no_impacts():
    model, q0, qd0 = spinning_rod()
    for clearance in (1e-6, 1e-8):
        res = gi.simulate(model, q0, qd0, (0.0, 0.2), walls=[gi.Circle(0.6 + clearance)])
        assert res.status == "finished" and res.impacts == [], (clearance, res.impacts)


def test_hermite_interpolants_are_exact_for_their_degree():
    # Quintic Hermite on (q, qdot, qddot) reproduces any quintic, the cubic on (q, qdot) any cubic.
    from numpy.polynomial import Polynomial

    rng = np.random.default_rng(0)
    t_a, h = 0.3, 0.05
    s = np.array([0.0, 0.2, 0.5, 0.9, 1.0])
    for degree, pick in ((5, 0), (3, 1)):
        P = [Polynomial(rng.normal(size=degree + 1)) for _ in range(2)]  # N = 2 coordinates

        def state(t):
            y = np.array([p(t) for p in P] + [p.deriv()(t) for p in P])
            f = np.array([p.deriv()(t) for p in P] + [p.deriv(2)(t) for p in P])
            return y, f

        ya, fa = state(t_a)
        yb, fb = state(t_a + h)
        q = hermite_positions(s, h, ya, fa, yb, fb)[pick]
        np.testing.assert_allclose(q, [[p(t_a + si * h) for p in P] for si in s], atol=1e-13)


def test_dip_allowance_bounds_a_parabola_between_samples():
    # E(s) = (s - s0)^2 - c: the piecewise-linear interpolant through s = k/4 misses
    # the minimum by at most (1/4)^2 / 4; the allowance (max|D|/2 = (1/4)^2) covers it.
    for s0 in np.linspace(0, 1, 41):
        s = np.linspace(0, 1, 5)
        E = ((s - s0) ** 2)[None, :]
        assert E.min() - dip_allowance(E)[0] <= 0.0 + 1e-15


def test_dop853_interpolant_is_scipys_dense_output():
    # The event loop evaluates DOP853's dense output as y_old + w(x)^T F in one product; scipy's
    # nested evaluation is the reference. Scalars, the few points of the event loop (<= 16) and
    # the vectorised branch (> 16), inside the step and just outside it (extrapolation).
    def f(t, y):
        return np.array([y[1], -np.sin(y[0]) - 0.1 * y[1], np.cos(3.0 * t) * y[0], 5.0 * y[0] * y[1]])

    solver = DOP853(f, 0.0, np.array([1.0, 0.3, -0.2, 0.05]), 8.0, rtol=1e-10, atol=1e-12)
    worst, n = 0.0, 0
    while solver.status == "running" and n < 40:
        solver.step()
        n += 1
        ref, fast = solver.dense_output(), _interpolant(solver)
        assert isinstance(fast, _Dop853Interpolant)
        h = solver.t - solver.t_old
        for m in (1, 3, 16, 17, 101):
            ts = np.linspace(solver.t_old - 0.1 * h, solver.t + 0.1 * h, m)
            a, b = fast(ts), ref(ts)
            assert a.shape == b.shape == (4, m)
            worst = max(worst, float(np.max(np.abs(a - b) / (1.0 + np.abs(b)))))
        for t in (solver.t_old, solver.t_old + 0.37 * h, solver.t, np.float64(solver.t_old + 0.5 * h)):
            a, b = fast(t), ref(t)
            assert a.shape == b.shape == (4,)
            worst = max(worst, float(np.max(np.abs(a - b) / (1.0 + np.abs(b)))))
    assert n == 40
    assert worst < 1e-15


def test_other_methods_keep_scipys_dense_output():
    solver = RK45(lambda t, y: -y, 0.0, np.ones(3), 1.0)
    solver.step()
    dense = _interpolant(solver)
    assert not isinstance(dense, _Dop853Interpolant)
    assert np.array_equal(dense(0.5 * solver.t), solver.dense_output()(0.5 * solver.t))


def test_examined_step_skips_the_minimisation_only_without_a_possible_dip(monkeypatch):
    # _first_crossing on E(t) given in closed form (the "dense output" is E itself).
    def crossing(E):
        def sol(t):
            return np.atleast_1d(E(np.asarray(t, dtype=float)))[None, :] if np.ndim(t) else np.array([E(t)])

        return _first_crossing(lambda t, y: float(y[0]), sol, 0.0, 1.0, E(0.0), E(1.0), lambda Y: Y[0])

    # A pair leaving the wall right after its impact: E(0) ~ 0, rising. The dense samples' dip
    # bound rules out a crossing: no minimisation.
    def no_minimisation(*args, **kwargs):
        raise AssertionError("minimize_scalar called")

    with monkeypatch.context() as m:
        m.setattr(flight, "minimize_scalar", no_minimisation)
        assert crossing(lambda t: 1e-17 + 0.3 * t + 0.05 * t * t) is None
    # A grazing dip between two samples (nearest samples at 0.47, 0.53 are positive): found,
    # at the parabola's first root.
    depth = 1e-9
    t_root = crossing(lambda t: (t - 0.5) ** 2 - depth)
    assert t_root == pytest.approx(0.5 - depth ** 0.5, abs=1e-12)
    # The same parabola staying above zero: examined, no crossing.
    assert crossing(lambda t: (t - 0.5) ** 2 + depth) is None


def test_contact_mode_events_see_an_excursion_between_the_samples_of_a_long_step():
    # A sticking contact does not change the state, so the solver's steps grow far beyond the time
    # scale of the applied force: in test_resting_friction's oscillating push a step ran from
    # t = 0.529 to 1.993 s, and mu N - |F_t| = 2.943 - 4.4145 |sin 2 pi t| [N] was positive at
    # its first two samples (t = 0.529, 0.895) while the force left the cone in between
    # (0.616 ... 0.884); the earliest sign change among the samples was the next excursion
    # (t = 1.116). The samples' dip bound sends that interval to a finer sampling.
    from gibbsimpact.simulation.flight import _earliest_bracket

    def v(t):
        return 2.943 - 4.4145 * abs(np.sin(2.0 * np.pi * t))

    ts = np.linspace(0.52889039, 1.99255551, 5)
    vs = [v(t) for t in ts]
    assert vs[0] > 0 and vs[1] > 0 and vs[2] < 0  # the samples alone bracket the later excursion
    lo, hi = _earliest_bracket(v, ts, vs)
    first = 0.5 + np.arcsin(2.943 / 4.4145) / (2.0 * np.pi)  # 0.6161 s
    assert lo <= first <= hi and hi - lo < 0.05
    # Well-sampled values keep their own bracket (no refinement), and no fall gives None.
    assert _earliest_bracket(v, np.array([0.6, 0.62]), [v(0.6), v(0.62)]) == (0.6, 0.62)
    assert _earliest_bracket(v, np.array([0.9, 0.95, 1.0]), [v(0.9), v(0.95), v(1.0)]) is None


@pytest.mark.slow
def test_in_step_samples_of_a_solver_stepping_over_fast_modes_come_from_its_dense_output():
    """Case 1 with EI_N_m2 = 1e9 on link 1 to 0.7 s under method="auto" (Radau with a cutoff at 1.27e4 rad/s): after
    O1's impact at 0.6704 s qddot at the step ends holds the damped 1.07e6 rad/s mode, and the quintic built on
    it dipped 2e-6 m below the wall where the motion does not (the run ended 'penetration' at 0.6743 s). Sampled
    on the collocation polynomial the run finishes, and O1 = (X1, X2) never leaves the circle R = 1.5 m by more
    than penetration_tol (its closed-form gap 1.5 - |(X1, X2)|, at every sample)."""
    import copy
    from pathlib import Path

    from gibbsimpact.case import case_from_dict

    src = copy.deepcopy(gi.load_case(Path(__file__).resolve().parents[2] / "cases" / "circle_two_link.toml").source)
    src["links"][0]["EI_N_m2"] = 1e9
    res = case_from_dict(src, name="case1_EI1e9").simulate(t_end=0.7, method="auto", max_rhs_calls=100_000)
    assert res.status == "finished" and res.settings["cutoff_frequency"] is not None
    assert len(res.impacts) >= 5 and res.impacts[4].time == pytest.approx(0.6704, abs=1e-4)
    assert np.hypot(res.q[:, 0], res.q[:, 1]).max() <= 1.5 + res.settings["penetration_tol"]
