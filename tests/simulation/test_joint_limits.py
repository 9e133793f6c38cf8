"""Resting at an end stop (simulation/joint_limits.py, equations (S1)-(S2); docs/theory.md §13).

A rigid rod of mass m = mu l slides through a guide at the base origin (Pb, joint 1, gravity off):
d'' = F(t) / m while it moves, and d stays at d_max with the stop force mu = F(t) while F pushes it
there (the guide's constraint takes nothing along the slide: the stop alone balances F).
"""

import numpy as np
import pytest

import gibbsimpact as gi

L_ROD, MU_ROD = 0.6, 1.0
MASS = L_ROD * MU_ROD
D_MAX = 0.5


def _slide(gravity=(0.0, 0.0, 0.0)):
    rod = gi.Link(L_ROD, MU_ROD, 1.0)
    chain = gi.Chain([rod], joints=[gi.FixedPrismatic(range=(0.1, D_MAX))], base=gi.FixedBase((0.0, 0.0), 0.0))
    return gi.Model(chain, gravity=gravity)


def _held(res):
    """Samples where the upper stop (limit 1: d_1 <= d_max) holds the slide."""
    return res.stop_forces[:, 1] > 0


def test_slide_pushed_into_its_stop_rests_there_with_the_stop_force_F():
    # e_stop = 0: the first end-stop impact stops the slide; from then on it is held at d_max with
    # the stop force mu = F (S2), to 1e-8 relative, and neither moves nor bounces again.
    F = 2.0
    model = _slide()
    res = gi.simulate(model, model.state(d_1=0.45), np.zeros(1), (0.0, 0.5), joint_limit="impact",
                      joint_restitution=0.0, inputs={"d_1": F})
    assert res.status == "finished", res.message
    assert len(res.impacts) == 1 and res.impacts[0].wall == (-1,)
    # Arrival: d = 0.45 + F t^2 / (2 m) reaches d_max at t = sqrt(2 m 0.05 / F).
    assert res.impacts[0].time == pytest.approx(np.sqrt(2 * MASS * 0.05 / F), rel=1e-9)
    held = _held(res)
    assert held.sum() >= 2 and res.t[held][-1] == 0.5
    assert np.abs(res.stop_forces[held, 1] - F).max() <= 1e-8 * F
    assert np.abs(res.q[res.t >= res.impacts[0].time, 0] - D_MAX).max() <= 1e-9  # contact_tol
    assert not np.any(res.stop_forces[:, 0])  # the lower stop never acts


def test_slide_leaves_its_stop_when_the_force_reverses_at_the_closed_form_time():
    # F(t) = F0 (1 - t / t_r): held with mu = F(t) until mu falls through 0 at t_r (the release
    # event), then d = d_max - F0 (t - t_r)^3 / (6 m t_r) (two integrations of F / m from rest).
    F0, t_r = 4.0, 0.4
    model = _slide()
    res = gi.simulate(model, model.state(d_1=0.45), np.zeros(1), (0.0, 0.6), joint_limit="impact",
                      joint_restitution=0.0, inputs={"d_1": lambda t, q, qd: F0 * (1.0 - t / t_r)})
    assert res.status == "finished", res.message
    held = _held(res)
    F_held = F0 * (1.0 - res.t[held] / t_r)
    assert np.abs(res.stop_forces[held, 1] - F_held).max() <= 1e-8 * F0
    # The release event: the last held sample is the phase end at t_r (mu = 0 there: not > 0).
    after = res.t > res.t[held][-1]
    t_release = res.t[after][0]
    assert t_release == pytest.approx(t_r, abs=1e-9)
    late = res.t > t_r + 0.05
    d_closed = D_MAX - F0 * (res.t[late] - t_r) ** 3 / (6 * MASS * t_r)
    assert np.abs(res.q[late, 0] - d_closed).max() <= 1e-8
    assert res.q[-1, 0] < D_MAX - 1e-3


def test_end_stop_accumulation_comes_to_rest_instead_of_stopping_the_run():
    # e_stop = 0.5 under a constant F: the bounces accumulate (each rebound half the last) at
    # t_inf = t_1 + 2 (v_1 e / a) / (1 - e) = 3 t_1 (t_1 the first arrival, a = F / m): then the
    # stop holds the slide with mu = F. accumulation="stop" keeps the old stop (status joint_limit).
    F = 2.0
    model = _slide()
    kw = dict(joint_limit="impact", joint_restitution=0.5, inputs={"d_1": F})
    res = gi.simulate(model, model.state(d_1=0.45), np.zeros(1), (0.0, 0.8), **kw)
    assert res.status == "finished", res.message
    t1 = np.sqrt(2 * MASS * 0.05 / F)
    held = _held(res)
    assert res.t[held][0] <= 3 * t1 + 1e-6
    assert np.abs(res.stop_forces[held, 1] - F).max() <= 1e-8 * F
    old = gi.simulate(model, model.state(d_1=0.45), np.zeros(1), (0.0, 0.8), accumulation="stop", **kw)
    assert old.status == "joint_limit" and "came to rest at its end stop" in old.message


def test_joint_limit_stop_keeps_todays_behaviour():
    F = 2.0
    model = _slide()
    res = gi.simulate(model, model.state(d_1=0.45), np.zeros(1), (0.0, 0.5), inputs={"d_1": F})
    assert res.status == "joint_limit"
    assert res.t[-1] == pytest.approx(np.sqrt(2 * MASS * 0.05 / F), rel=1e-9)
    assert not np.any(res.stop_forces)


def test_telescoping_arm_pushed_into_its_stop_finishes():
    # Issue 25: an R-R-Pb arm under gravity with +1 N on the slide stopped at 0.33 s of 1.5 s with
    # status joint_limit ("resting contact at an end stop is not modelled"). Now it finishes: the
    # slide rests at d_max between the releases its swinging and bending cause, never beyond it,
    # with mu >= 0, and the energy never rises above the work of the inputs (impacts with e_stop =
    # 0.5 and the stops' projections only dissipate).
    links = [gi.Link(0.5, 1.0, 20.0, elements=1), gi.Link(0.5, 1.0, 20.0, elements=1),
             gi.Link(0.4, 0.5, 10.0, elements=1, geometric_stiffening=False)]  # a stiffened Pb link is refused
    chain = gi.Chain(links, joints=[gi.Revolute(), gi.Revolute(), gi.FixedPrismatic(range=(0.1, 0.35))],
                     base=gi.FixedBase((0.0, 0.0), 0.0))
    model = gi.Model(chain, gravity=(0.0, -9.81, 0.0))
    q0 = model.state(theta_1=0.3, theta_2=0.4, d_3=0.3)
    res = gi.simulate(model, q0, np.zeros(model.n_dof), (0.0, 1.5), joint_limit="impact", inputs={"d_3": 1.0})
    assert res.status == "finished", res.message
    assert res.t[-1] == 1.5
    assert (res.stop_forces[:, 1] > 0).sum() > 100 and res.stop_forces.min() >= 0.0
    assert res.q[:, 2].max() <= 0.35 + 1e-9  # contact_tol
    E = res.energy()
    excess = E.total - E.total[0] - res.work.sum(axis=1)
    assert excess.max() <= 1e-9 * (abs(E.kinetic).max() + abs(E.gravity).max() + abs(res.work).max())
