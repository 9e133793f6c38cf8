"""Validity warnings: each limit fires with a message naming the quantity, its value and the limit;
the published cases are within every limit; nothing is changed."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.simulation import validity
from gibbsimpact.simulation.results import Result
from gibbsimpact.simulation.validity import ValidityWarning, check_state, check_stop, warn_state

CASES = Path(__file__).resolve().parents[2] / "cases"


@pytest.fixture(scope="module")
def circle():
    return gi.load_case(CASES / "circle_two_link.toml")


def with_coordinate(case, **values):
    q = case.q0.copy()
    for name, v in values.items():
        q[case.model.coordinate_names.index(name)] = v
    return q


@pytest.mark.parametrize("name", ["circle_two_link", "sphere_single_link", "fixed_base_fe_arm"])
def test_published_cases_are_within_the_limits(name):
    case = gi.load_case(CASES / f"{name}.toml")
    assert check_state(case.model, case.q0, case.qdot0, case.walls) == []
    with warnings.catch_warnings():
        warnings.simplefilter("error", ValidityWarning)
        assert warn_state(case.model, case.q0, case.qdot0, case.walls) == []


def test_the_issue_example_five_metre_deflection(circle):
    # delta_1_1_m = 5.0 on a 1 m link: 49,616 J of strain energy, the link loops outside the circle.
    q = with_coordinate(circle, delta_1_1=5.0)
    q_before = q.copy()
    msgs = check_state(circle.model, q, circle.qdot0, circle.walls)
    np.testing.assert_array_equal(q, q_before)  # nothing clipped or changed
    deflection = [m for m in msgs if "peak deflection" in m]
    assert len(deflection) == 1 and deflection[0].startswith("link 1:")
    assert "5 m" in deflection[0] and "0.1 l = 0.1 m" in deflection[0]
    strain = [m for m in msgs if "strain energy" in m]
    assert len(strain) == 1 and "49616 J" in strain[0] and "limit of 100 times" in strain[0]
    assert "39.24 J" in strain[0]  # the scale it is compared with: m g L = 2 kg 9.81 m/s^2 2 m
    outside = [m for m in msgs if "beyond wall 1" in m]
    assert len(outside) == 1 and "limit 1e-06 m" in outside[0]


def test_deflection_limit_is_a_tenth_of_the_length(circle):
    model = circle.model
    just_in = with_coordinate(circle, delta_2_1=0.099)
    assert check_state(model, just_in, circle.qdot0) == []
    out = check_state(model, with_coordinate(circle, delta_2_1=-0.101), circle.qdot0)
    assert len(out) == 1 and out[0].startswith("link 2: initial peak deflection 0.101 m")
    assert validity.DEFLECTION_LIMIT == 0.1


def test_deflection_of_finite_element_links():
    case = gi.load_case(CASES / "fixed_base_fe_arm.toml")
    # delta_1_7: the node-4 (tip) deflection of link 1 (l = 1 m); delta_2_5: link 2's tip (l = 0.6 m).
    q = with_coordinate(case, delta_1_7=0.3, delta_2_5=0.05)
    msgs = check_state(case.model, q, case.qdot0)
    assert [m.split(":")[0] for m in msgs if "peak deflection" in m] == ["link 1"]
    assert "0.3 m (at x = 1 m)" in msgs[0]


def test_strain_energy_limit_names_both_energies():
    # No gravity and little motion: a modest deflection already dwarfs the kinetic energy.
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")])
    model = gi.Model([link], gravity=(0.0, 0.0, 0.0))
    q = model.state(delta_1_1=0.05)
    qdot = model.state(X1=0.01)
    E = model.energy(q, qdot)
    assert E.strain > 100 * E.kinetic
    msgs = check_state(model, q, qdot)
    assert len(msgs) == 1 and "strain energy" in msgs[0]
    assert f"{E.strain:.5g} J" in msgs[0] and f"kinetic {E.kinetic:.4g} J" in msgs[0]
    # At rest without gravity the strain energy is the whole (vibration) energy: no scale, no warning.
    assert check_state(model, q, np.zeros(model.n_dof)) == []


def test_initial_state_at_gimbal_lock_is_no_longer_refused():
    # Issue 28: a run re-charts the free base (simulation.charts), so theta_0 near or at +-pi/2 at t0 is no
    # longer outside the model's validity (it was warned within GIMBAL_MARGIN = 0.05 rad before).
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")], rotary_inertia=(1e-4, 1e-4, 1e-4))
    model = gi.Model([link], gravity=(0.0, 0.0, 0.0))
    for theta_0 in (-np.pi / 2 + 0.01, np.pi / 2, np.pi / 2 - 0.06):
        assert check_state(model, model.state(theta_0=theta_0), np.zeros(model.n_dof)) == []
    q, qd = model.state(theta_0=np.pi / 2), model.state(theta_0=1.0, theta_1=0.5)
    res = gi.simulate(model, q, qd, (0.0, 0.01))
    assert res.status == "finished" and res.charts[0].time == 0.0 and res.charts[0].sample == 1
    np.testing.assert_allclose(res.energy().total, res.energy().total[0], rtol=1e-12)


def _stopped(model, theta_0, status):
    q = np.zeros((2, model.n_dof))
    if model.free_base:
        q[:, 4] = [0.0, theta_0]
    return Result(model=model, walls=(), t=np.array([0.0, 0.37]), q=q, qdot=np.zeros_like(q),
                  phase=np.zeros(2, dtype=int), impacts=[], status=status,
                  message="the ODE solver failed after t = 0 s: Required step size is less than spacing")


def test_stop_near_gimbal_lock():
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")], rotary_inertia=(1e-4, 1e-4, 1e-4))
    model = gi.Model([link])
    res = _stopped(model, np.pi / 2 - 1e-5, "failed")
    msgs = check_stop(model, res)
    assert len(msgs) == 1
    assert "theta_0 = 1.57078633 rad" in msgs[0] and "1e-05 rad from +-pi/2" in msgs[0]
    assert "margin 0.05 rad" in msgs[0] and "t = 0.37 s" in msgs[0]
    assert validity.check_result(res) == msgs
    with pytest.warns(ValidityWarning, match="gimbal-lock margin"):
        validity.warn_result(res)
    # Equivalent angles pi/2 + k pi count too; other stops, other angles and fixed bases do not.
    assert check_stop(model, _stopped(model, -3 * np.pi / 2 + 0.02, "failed"))
    assert check_stop(model, _stopped(model, np.pi / 2 - 1e-5, "zeno")) == []
    assert check_stop(model, _stopped(model, np.pi / 2 - 0.2, "failed")) == []
    arm = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, elements=1)], base=gi.FixedBase((0.0, 0.0), 0.0)))
    assert check_stop(arm, _stopped(arm, 0.0, "failed")) == []


def test_warnings_point_at_the_caller(circle):
    q = with_coordinate(circle, delta_1_1=2.0)

    def simulate_like():  # a library function that checks its input
        return warn_state(circle.model, q, circle.qdot0)

    with pytest.warns(ValidityWarning) as record:
        msgs = simulate_like()
    assert [str(w.message) for w in record] == msgs and len(msgs) == 2
    assert all(Path(w.filename).name == "test_validity.py" for w in record)
    assert issubclass(ValidityWarning, UserWarning)


def test_simulate_warns_once_wired(circle):
    # simulate warns at the start (stages.start -> validity.warn_state); the test once skipped itself
    # when simulate's own source did not name warn_state, which the split into stages would have hidden.
    q = with_coordinate(circle, delta_1_1=0.5)
    with pytest.warns(ValidityWarning, match="peak deflection"):
        gi.simulate(circle.model, q, circle.qdot0, (0.0, 1e-3), walls=circle.walls, rtol=1e-6, atol=1e-8)


# -- Newton's law at a point whose effective mass depends on the discretisation (issue 26 item 3) --------

def record(joints, walls, impulses, t=0.25):
    """An ImpactRecord with only what check_impact reads (time, contacts, walls, impulses)."""
    from gibbsimpact.simulation.results import ImpactRecord

    k, E = len(joints), gi.Energy(0.0, 0.0, 0.0, 0.0)
    return ImpactRecord(t, tuple(joints), tuple(walls), np.tile([0.0, 1.0, 0.0], (k, 1)), np.asarray(impulses),
                        -np.ones(k), np.ones(k), np.ones(k), np.zeros(1), np.zeros(1), E, E)


def test_newton_at_a_finite_element_tip_warns_once_at_its_first_impact():
    from conftest import ISSUE26_FLOOR, issue26_model

    model = issue26_model(elements=1)
    q0 = np.zeros(model.n_dof)
    with pytest.warns(ValidityWarning) as caught:
        res = gi.simulate(model, q0, np.zeros_like(q0), (0.0, 0.2687), walls=[ISSUE26_FLOOR])
    newton = [w for w in caught if "Newton's law" in str(w.message)]
    assert len(newton) == 1 and len(res.impacts) >= 4  # once per run, whatever the impacts there
    msg = str(newton[0].message)
    assert msg.startswith(f"Newton's law applied at O2 (tip of link 1) on wall 1 (plane through (0, 0, 0) normal "
                          f"(0, 1, 0)) at t = {res.impacts[0].time:.9g} s")
    for text in ("(link 1: 1 finite element)", "halves with every doubling of elements", "docs/theory.md §11.4",
                 "stiffness=k", "docs/theory.md §11.5", "make link 1 rigid", "clamped-clamped modes",
                 "Result.episodes"):
        assert text in msg, text
    assert "link_contacts=False" not in msg and "§15.5" not in msg  # only where a span point struck
    assert Path(newton[0].filename).name == "test_validity.py"  # the line that called simulate


def test_check_run_recomputes_the_warnings_a_run_issued():
    # gibbsimpact show prints a saved run's warnings from check_run: the same messages, in the same order, as
    # the run issued while it ran (a second route: warn_state at the start, warn_impact in the loop, warn_result
    # at the end), also after a save and load.
    from conftest import warning_run

    res, live = warning_run()
    assert [m.split(" ")[0] for m in live] == ["link", "Newton's", "link"]
    assert "initial peak deflection 0.15 m" in live[0] and "turns across its axis" in live[2]
    assert validity.check_run(res) == live


def test_check_impact_names_the_point_and_only_ill_posed_ones():
    from conftest import issue26_model, two_link_circle_model

    from gibbsimpact.simulation.validity import check_impact

    fe = issue26_model(elements=2)
    floor = (gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),)
    (span,) = check_impact(fe, record([3], [0], [0.1]), floor)  # column 3: the lowest point of link 1's element 1
    assert "at link 1.1 (span of link 1)" in span and "2 finite elements" in span and "link_contacts=False" in span
    # No impulse there, an end stop, the joint O1: nothing to say.
    assert check_impact(fe, record([2, 1], [0, 0], [0.0, 0.3]), floor) == []
    assert check_impact(fe, record([1], [-1], [0.3]), floor) == []
    cf = issue26_model(elements=0, modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "y", 2)])
    (tip,) = check_impact(cf, record([2], [0], [0.2]), floor)
    assert "(link 1: 2 assumed modes (clamped-free))" in tip
    # The published chains' joints (clamped-clamped modes) never warn, nor does a rigid rod's tip.
    circle = (gi.Circle(1.5, (0.0, 0.0)),)
    assert check_impact(two_link_circle_model(), record([1, 2, 3], [0, 0, 0], [1.0, 1.0, 1.0]), circle) == []
    assert check_impact(issue26_model(elements=0), record([2], [0], [1.0]), floor) == []


def test_check_impact_advice_fits_the_wall_and_the_prescribed_run():
    """The advice to give the wall a stiffness names the wall's own class (a post is a gi.Circle, not a gi.Plane),
    and in a run with prescribed coordinates (the impact then carries actuator impulses), where simulate refuses
    a compliant wall, says so and what to do instead."""
    from conftest import issue26_model

    from gibbsimpact.simulation.validity import check_impact

    fe = issue26_model(elements=2)
    post = (gi.Circle(0.05, (0.5, -0.1), inside=False),)
    (free,) = check_impact(fe, record([2], [0], [0.1]), post)
    assert "gi.Circle(..., restitution=e, stiffness=k)" in free and "prescribed" not in free
    (held,) = check_impact(fe, record([2], [0], [0.1])._replace(actuator_impulses=np.zeros(1)), post)
    assert "not with prescribed coordinates yet: drive the joint by inputs instead" in held


# -- spinning flexible links (no geometric stiffening: issue 24 item 4) ----------------------------

BETA1_L = 1.8751040687119611  # first root of cos(b) cosh(b) = -1: clamped-free beam


def _spinning_link(modes=("clamped-free",), stiffening=False):
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode(k, "y") for k in modes], geometric_stiffening=stiffening)
    return gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.0))))


def test_first_frequency_is_the_clamped_free_closed_form():
    # omega_1 = (beta_1 l)^2 sqrt(EI / (mu l^4)): the clamped-free mode is exact, so only the quadrature
    # of the modal integrals (error < 1e-12 on M, tests/model/test_quadrature.py) separates the two.
    w1 = _spinning_link().link_data[0].first_frequency
    assert w1 == pytest.approx(BETA1_L ** 2 * np.sqrt(20.0), rel=1e-9)
    assert np.isnan(gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0)])).link_data[0].first_frequency)


def test_spin_rate_is_the_angular_velocity_across_the_link():
    model = _spinning_link()
    q, qd = model.state(theta_1=0.7), model.state(theta_1=3.0, delta_1_1=0.2)
    assert validity.spin_rates(model, q[None], qd[None])[0, 0] == pytest.approx(3.0, rel=1e-14)
    # A free link spinning about its own axis (theta_-1 turns about X1, the link's x axis here) is not
    # spinning across it; turning about X3 (theta_1) is.
    free = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")])]))
    rates = validity.spin_rates(free, np.zeros((2, free.n_dof)),
                                np.array([free.state(theta_m1=5.0), free.state(theta_1=2.0, theta_m1=5.0)]))
    assert rates[0, 0] == pytest.approx(0.0, abs=1e-14) and rates[1, 0] == pytest.approx(2.0, rel=1e-14)


@pytest.mark.parametrize("fraction, warned", [(0.2, False), (0.5, True)])
def test_a_link_spinning_near_its_bending_frequency_is_warned(fraction, warned):
    model = _spinning_link()
    w1 = model.link_data[0].first_frequency
    q0, qd0 = model.state(), model.state(theta_1=fraction * w1)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always", ValidityWarning)
        res = gi.simulate(model, q0, qd0, (0.0, 0.05))
    spin = [str(w.message) for w in record if "turns across its axis" in str(w.message)]
    assert res.status == "finished"
    assert bool(spin) is warned
    if warned:
        assert f"omega_1 = {w1:.4g} rad/s" in spin[0] and f"(limit {validity.SPIN_LIMIT:g})" in spin[0]


def test_a_stiffened_link_spinning_fast_is_not_warned():
    # Its centrifugal stiffening is modelled (formulation §15): the warning is for linear beams only.
    model = _spinning_link(stiffening=True)
    qd0 = model.state(theta_1=0.5 * model.link_data[0].first_frequency)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always", ValidityWarning)
        res = gi.simulate(model, model.state(), qd0, (0.0, 0.05))
    assert res.status == "finished"
    assert not [w for w in record if "turns across its axis" in str(w.message)]


@pytest.mark.parametrize("name", ["circle_two_link", "sphere_single_link"])
def test_published_runs_spin_well_below_the_limit(name):
    case = gi.load_case(CASES / f"{name}.toml")
    res = case.simulate(t_end=1.0)
    assert validity.check_spin(case.model, res) == []
    rates = validity.spin_rates(case.model, res.q, res.qdot).max(axis=0)
    assert np.all(rates < 0.15 * np.array([ld.first_frequency for ld in case.model.link_data]))
