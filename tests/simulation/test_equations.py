"""The right-hand side of the event loop's phases (simulation.equations.Equations)."""

import numpy as np
from scipy.integrate import DOP853

import gibbsimpact as gi
from conftest import started_run


def _seated_tip_run():
    """A run of the pressed 2-element arm (fixed base 2 cm above the floor, EI = 20 N m^2, tau = -2 N m) at rest on
    its tip, the tip held as a seated span point (cell 2's fixed material point x = l): a contact phase whose
    right-hand side goes through span_resting (model.check_state on every trial state)."""
    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=2, damping=0.05)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.02), 0.0)), gravity=(0.0, -9.81, 0.0))
    run = started_run(model, model.state(theta_1=-np.arcsin(0.02)), np.zeros(model.n_dof),
                      [gi.Plane((0, 0, 0), (0, 1, 0))], inputs={"theta_1": -2.0})
    col = model.n_joints + 1
    run.resting.active[0, col], run.resting.seat[0, col] = True, 1.0
    run.equations.resting_phase = True
    return run


def test_a_non_finite_trial_state_is_a_rejected_step_not_a_failed_run():
    """scipy's first step ignores stiffness: in a contact phase of the pressed 3-element arm (docs/benchmarks.md)
    DOP853 chose h = 4.7e-3 s where the constrained modes reach |lambda| = 3.7e4 1/s (h |lambda| = 172 against
    DOP853's stability radius 5.96); its trial stages overflowed, the span point's terms refused the non-finite q
    (ValueError) and the run failed ("integration failed ... q has non-finite entries"). A non-finite trial state
    now gives NaN, which the solver rejects, shrinking the step below the stability bound 5.96 / |lambda|."""
    run = _seated_tip_run()
    rhs, N = run.equations, run.N
    y0 = run.y.copy()
    bad = y0.copy()
    bad[0] = np.inf
    assert np.all(np.isnan(rhs(0.0, bad)))
    solver = DOP853(rhs, 0.0, y0, 1.0, rtol=1e-10, atol=1e-12, first_step=5e-3)
    solver.step()
    assert solver.status == "running" and np.all(np.isfinite(solver.y))
    J = np.array([(rhs(0.0, y0 + h) - rhs(0.0, y0 - h))[:2 * N] / (2e-7) for h in 1e-7 * np.eye(len(y0))]).T
    stiff = float(np.abs(np.linalg.eigvals(J[:2 * N, :2 * N])).max())
    assert solver.step_size * stiff < 5.96 < 5e-3 * stiff, (solver.step_size, stiff)
