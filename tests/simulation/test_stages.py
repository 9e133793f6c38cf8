"""Single stages of the event loop (simulation.stages), driven on a started run."""

import numpy as np

import gibbsimpact as gi
from conftest import started_run
from gibbsimpact.simulation.stages import _decide_walls


def test_a_mode_decision_leaves_no_pair_beyond_the_wall():
    """A rigid rod (1 m, 1 kg, free in the plane) lies on the floor with O1 0.9 contact_tol under it (sunk: a
    candidate whatever its velocity, stages._sunk) and O2 0.2 contact_tol under it, rising at 1e-3 m/s (above
    grazing_velocity: no candidate by itself). Projecting O1 alone onto g = 0 along the metric of M lifts it by an
    upward impulse-like correction, which moves the other end down by half as much (a uniform rod: end velocities
    4 P/m and -2 P/m), to -0.65 contact_tol, where no event of the next phase would catch it. The decision must
    project again with O2 among the candidates: afterwards every pair is on the wall to the projection's
    tolerance (1e-3 contact_tol), and both ends rest (gravity presses them)."""
    tol = 1e-6
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, (1e3, 1e3))], base="planar"), gravity=(0.0, -9.81, 0.0))
    theta = np.arcsin(0.7 * tol)                       # O2 0.7 tol above O1
    q0 = model.state(X1=0.0, X2=-0.9 * tol, theta_1=theta)
    qd0 = np.zeros(model.n_dof)
    qd0[model.coordinate_names.index("theta_1")] = 1e-3 / np.cos(theta)   # O2 rises at 1e-3 m/s
    run = started_run(model, q0, qd0, [gi.Plane((0, 0, 0), (0, 1, 0))], contact_tol=tol)
    g = run.contacts.gaps(q0)[0, :2]
    np.testing.assert_allclose(g, [-0.9 * tol, -0.2 * tol], atol=1e-15)
    assert _decide_walls(run)
    g = run.contacts.gaps(run.y[:model.n_dof])[0, :2]
    assert np.all(np.abs(g) <= 1e-3 * tol), g
    assert run.resting.active[0, :2].all(), run.resting.active


def test_a_mode_decision_sets_no_pulling_force_under_structural_damping():
    """Unilateral contact: every pair a mode decision sets resting carries lambda >= 0 at the state the decision
    returns, with the forces the phase will use there (RestingContacts.force_matrix with the applied forces at
    that state). A fixed-base arm of 2 linear elements (EI = 20 N m^2, damping 0.5: Q = -beta K delta_dot) with its
    tip 0.9 contact_tol under the floor (sunk: a candidate whatever its velocity) and 40 random velocities (seeded):
    the projection onto g = 0, v_n = 0 changes delta_dot and so the damping force. With the applied forces taken
    before the projection the decision set the tip resting with lambda > 0 that the phase then found negative
    (-51.6 N in one of these states; a pressed stiffened arm's tip pulled on the floor with -0.54 N to its end)."""
    tol = 1e-6
    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=2, damping=0.5, geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.02), 0.0)), gravity=(0.0, -9.81, 0.0))
    q0 = model.state(theta_1=-np.arcsin(0.02 + 0.9 * tol))
    N, rng, rested = model.n_dof, np.random.default_rng(1), 0
    for _ in range(40):
        qd0 = rng.normal(scale=0.3, size=N)
        run = started_run(model, q0, qd0, [gi.Plane((0, 0, 0), (0, 1, 0))], contact_tol=tol, inputs={"theta_1": -2.0})
        if not _decide_walls(run):
            continue
        q, qd = run.y[:N], run.y[N:2 * N]
        F, _ = run.resting.force_matrix(q, qd, run.equations.applied(0.0, q, qd))
        active = run.resting.active
        rested += bool(active.any())
        assert np.all(F[active] >= 0.0), F[active]
    assert rested >= 10, rested     # not vacuous: the tip rests in most of these states
