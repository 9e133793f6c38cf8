"""Time-stepping contact phases (simulation/stepping.py, docs/theory.md §15.5): a beam dropped flat comes to rest."""

import warnings

import numpy as np
import pytest

import gibbsimpact as gi
from conftest import pressed_arm_moment
from gibbsimpact.dynamics.link_points import link_points, material_point_jacobians, material_points

G = 9.81


def test_material_point_jacobians_are_the_derivatives_of_the_material_points():
    """dynamics.link_points.material_point_jacobians (vectorised over the grid points) against central differences of
    the public material points, on a stiffened finite-element link and a modal link of one chain: the positions
    agree to round-off, the Jacobians to the differences' O(eps^2) truncation."""
    links = [gi.Link(1.0, 1.0, (20.0, 20.0), elements=3),
             gi.Link(0.7, 1.0, (20.0, 20.0), modes=[gi.Mode("clamped-free", "y", 1), gi.Mode("clamped-free", "y", 2)])]
    model = gi.Model(gi.Chain(links, base="planar"))
    q = np.random.default_rng(3).normal(size=model.n_dof) * 0.2
    eps = 1e-6
    for i, lk in enumerate(links):
        x = lk.length * np.linspace(0.03, 0.97, 9)
        p, J = material_point_jacobians(model, q, i, x)
        assert np.abs(p - material_points(model, q, i, x)).max() < 1e-14
        for c in range(model.n_dof):
            dq = np.zeros(model.n_dof)
            dq[c] = eps
            fd = (material_points(model, q + dq, i, x) - material_points(model, q - dq, i, x)) / (2 * eps)
            assert np.abs(J[:, :, c] - fd).max() < 1e-8, (i, c)


@pytest.mark.slow
def test_a_beam_dropped_flat_comes_to_rest():
    """Issue 25, first bullet (the beam): a flexible beam (4 stiffened Hermite elements, l = 1 m, 1 kg/m,
    EI = 20 N m^2, damping 0.05, planar free base) dropped nearly flat (2 cm, tilted 0.01 rad) onto a floor with
    e = 0.3 ends resting at t_end = 1.5 s. On main it crawled through micro-impacts (0.07 s in 60 s of CPU):
    the accumulation at its span now hands the run to a time-stepping contact phase (simulation.stepping).
    Checked: status finished at t_end, through at least one stepped phase; at every stored sample no material
    point (64 per link, public kinematics) below the floor by more than contact_tol; the impacts never raise
    the energy, and along the run E - W rises only by the work of the loads over contact_tol (the projections of
    the mode decisions and of the stepped phases' drift, equation (6)) plus the measured integration error; at
    the end the floor's forces sum to the weight m g to 1e-6 (the beam at rest: momentum balance, independent of
    how the redundant grid points share the load)."""
    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=4, damping=0.05)
    model = gi.Model(gi.Chain([link], base="planar"), gravity=(0.0, -G, 0.0))
    q0 = model.state()
    q0[0], q0[1], q0[2] = -0.5, 0.02, 0.01
    contact_tol = 1e-6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, q0, np.zeros(model.n_dof), (0.0, 1.5), walls=[gi.Plane((0, 0, 0), (0, 1, 0))],
                          restitution=0.3, contact_tol=contact_tol, contact_step=1e-3, max_cpu_time=600.0)
    assert res.status == "finished" and res.t[-1] == 1.5, res.message
    assert res.settings["stepped_phases"] >= 1
    lowest = min(float(link_points(model, q, 64)[0, :, 1].min()) for q in res.q)
    assert lowest >= -contact_tol, lowest
    assert all(r.energy_after <= r.energy_before for r in res.impacts)
    balance = res.energy().total - res.work.sum(axis=1)
    total = res.contact_forces.sum(axis=(1, 2))
    loads = np.maximum(total[:-1], total[1:]) + G * model.total_mass
    rise = np.diff(balance)
    assert np.all(rise <= loads * contact_tol + res.energy_error_per_phase * res.energy_scale), \
        (rise - loads * contact_tol).max()
    weight = G * model.total_mass
    assert abs(total[-1] - weight) <= 1e-6 * weight, (total[-1] - weight) / weight
    # The stepped phases' contacts dissipate (Newton's law at e = 0.3; their projections add less than that).
    assert res.energy_audit()["stepped_contacts"] < 0.0
    # At rest on the floor: no vertical or angular motion is left (it may slide: the floor has no friction).
    assert np.abs(res.qdot[-1, 1:]).max() < 1e-6, res.qdot[-1]


@pytest.mark.slow
def test_a_lightly_damped_arm_pressed_onto_a_floor_comes_to_rest():
    """Issue 25, first bullet (the arm, lightly damped): a fixed-base arm of 3 stiffened Hermite elements (EI = 20
    N m^2, 1 kg/m, 1 m, damping 0.05; base 2 cm above the floor; e = 0; contact_tol = 1e-6 m) driven onto the floor
    by tau = -2 N m on theta_1. Event-driven it crawls (1 s in 200 s of CPU, 128 impacts, still moving at
    |qdot| = 0.05 at 1 s; the damping-0.5 linear arm of test_link_contacts settles event-driven): with
    accumulation="step" the first impact at its span starts a stepped phase, and it rests. Checked: finished at
    t_end with |qdot| < 1e-9; no material point (64, public kinematics) below the floor by more than contact_tol at
    any sample; E - W never rising by more than the work of the loads over contact_tol plus the measured
    integration error; and at the end the static balance about the base joint, computed independently of the
    dynamics: the moment of gravity on the material points (Gauss-Legendre, 8 points per element) plus the recorded
    contact forces at their recorded points (Result.contact_abscissae: a cell's grid points' force-weighted mean)
    equals -tau to 1e-6 relative."""
    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=3, damping=0.05)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.02), 0.0)), gravity=(0.0, -G, 0.0))
    contact_tol, tau = 1e-6, -2.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, model.state(), np.zeros(model.n_dof), (0.0, 1.0), walls=[gi.Plane((0, 0, 0), (0, 1, 0))],
                          restitution=0.0, contact_tol=contact_tol, inputs={"theta_1": tau}, accumulation="step",
                          contact_step=1e-3, max_cpu_time=300.0)
    assert res.status == "finished", res.message
    assert res.settings["stepped_phases"] >= 1 and np.abs(res.qdot[-1]).max() < 1e-9
    assert res.resting_time > 0.9, res.resting_time    # the stepped phase's time in contact (it lands at ~0.05 s)
    lowest = min(float(link_points(model, q, 64)[0, :, 1].min()) for q in res.q)
    assert lowest >= -contact_tol, lowest
    balance = res.energy().total - res.work.sum(axis=1)
    total = res.contact_forces.sum(axis=(1, 2))
    loads = np.maximum(total[:-1], total[1:]) + G * model.total_mass + abs(tau) / link.length
    assert np.all(np.diff(balance) <= loads * contact_tol + res.energy_error_per_phase * res.energy_scale)
    # Its contact-force figure keeps the resting level visible beside the stepped impact's spike of impulse / step.
    fig = res.plot("contact_forces")
    title = fig._suptitle.get_text() if fig._suptitle is not None else fig.axes[0].get_title()
    assert fig.axes[0].get_yscale() == "symlog" and "time-stepped" in title, title
    moment, F = pressed_arm_moment(model, res, G)
    assert F[model.n_joints + 2] > 0.9 * np.abs(F).sum(), F          # element 3's span carries the floor's force
    assert abs(moment + tau) <= 1e-6 * abs(tau), (moment + tau) / abs(tau)


def test_accumulation_step_warns_where_the_contact_phases_cannot_be_stepped():
    """accumulation='step' on a wall with friction (Coulomb's law is not in the stepped impulse problem): the run
    says so instead of falling back silently to event-driven contact phases."""
    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=2)
    model = gi.Model(gi.Chain([link], base="planar"), gravity=(0.0, -G, 0.0))
    with pytest.warns(gi.ValidityWarning, match=r"cannot be stepped \(a wall with friction"):
        gi.simulate(model, model.state(X2=0.5), np.zeros(model.n_dof), (0.0, 1e-3),
                    walls=[gi.Plane((0, 0, 0), (0, 1, 0), friction=0.5)], accumulation="step")
