"""The chart stage of the event loop: re-charting the spatial free base (formulation §18, docs/theory.md §2.1).

A run measures the base angles from a reference orientation R_ref (Model.base_chart). When the chart
comes within RECHART_ANGLE of its singularity (|theta_0| = 1.2 rad for a root revolute without axis
rotation; the flight phase's "chart" event, or at the start), the chart stage moves R_ref to the current
orientation and maps the angles and their rates (dynamics.base_chart.rechart): positions, velocities,
energy and momenta are unchanged, and the chart's singularity (theta_0 = +-pi/2) stays away from the
motion. Like any event, a re-chart ends the flight phase; the contact mode (resting pairs, stick or
slip), the end stops, the work and compliant states carry over, since they are stated in world
quantities and gaps, never in the base angles.

Not re-charted: a run with a prescribed base angle (its profile is the user's, in the first chart), and a
root axis that leaves no chart room (charted).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..dynamics.base_chart import RECHART_ANGLE, base_angles, chart_margin, rechart, root_rotation

__all__ = ["ChartChange", "RECHART_ANGLE", "chart", "chart_event", "charted", "start_chart"]


class ChartChange(NamedTuple):
    """One re-chart of the free base (Result.charts).

    time : [s]; sample : index into Result.t of the sample after it (the one before is sample - 1, same time)
    angles_before : (3,) theta_-1, theta_0, theta_1 [rad] in the old chart (the new one starts at (0, b*, 0): dynamics.base_chart)
    chart_after : (3, 3) the new R_ref = R_ref_old Rx Ry Rz (Result.base_chart[sample])
    """

    time: float
    sample: int
    angles_before: np.ndarray
    chart_after: np.ndarray


def charted(model, prescribed=None) -> bool:
    """Whether a run of this model re-charts its base: a spatial free base none of whose angles is prescribed
    (prescribed: None or (n_p,) indices of the prescribed coordinates), and whose root revolute's axis u = A e_z
    leaves a re-chart room: the best chart's |det B| = |(u_x, u_z)| (dynamics.base_chart) at least twice the
    threshold cos(RECHART_ANGLE), i.e. u within 46 degrees of the chart's x-z plane (u = e_z: always)."""
    u = root_rotation(model)[:, 2]
    if model.chain.base != "free" or np.hypot(u[0], u[2]) < 2.0 * np.cos(RECHART_ANGLE):
        return False
    return prescribed is None or not set(np.asarray(prescribed).tolist()) & {3, 4, model.theta_index[0]}


def needs_chart(model, q) -> bool:
    """Whether the chart of q (N,) is within RECHART_ANGLE of its singularity (chart_margin <= 0)."""
    return chart_margin(model, q[4]) <= 0.0


def start_chart(model, q0, qdot0, charting: bool):
    """(model, q0, qdot0) in the chart a run starts in: re-charted (dynamics.base_chart.rechart) when charting and
    |theta_0| >= RECHART_ANGLE, else as given. What is computed from the initial state's dynamics (the checks,
    method="auto") is computed there, where the chart is regular."""
    if charting and needs_chart(model, q0):
        return rechart(model, q0, qdot0)
    return model, q0, qdot0


def chart_event(model):
    """The flight phase's chart event (fun(t, y) -> (1,), direction (-1,), inside (False,)): the chart's margin
    |det B| - cos(RECHART_ANGLE) (dynamics.base_chart.chart_margin; |theta_0| = RECHART_ANGLE for A = I) falls
    through zero. Seen by its sign change at the step ends (no dense output, so it costs a
    run nothing until it fires): a crossing that goes back within one step is missed, and harmless, since
    theta_0 then stayed away from +-pi/2 (the solver's steps shrink where the chart's B is ill-conditioned)."""
    return (lambda t, y: np.array([chart_margin(model, y[4])]), np.array([-1.0]), np.array([False]))


def chart(run) -> None:
    """The chart stage, before a flight phase: re-chart when the chart is within RECHART_ANGLE of its singularity
    (|theta_0| >= RECHART_ANGLE for a root without axis rotation), or when the last phase ended at the chart
    event (its located root may lie a round-off off the threshold)."""
    if not run.charting:
        return
    N = run.N
    q, qd = run.y[:N], run.y[N:2 * N]
    if not (run.pending_chart or needs_chart(run.model, q)):
        return
    run.pending_chart = False
    old = run.model
    new, q2, qd2 = rechart(old, q, qd)
    hand_over(run, old, new)
    run.y = np.concatenate((q2, qd2, run.y[2 * N:]))
    run.recorder.chart(run.t, q2, qd2, run.phase, ChartChange(run.t, 0, base_angles(old, q), new.base_chart))


def hand_over(run, old, new) -> None:
    """Give every part of the run that holds the model ``old`` the model ``new`` (a chart of it).

    The parts (contacts, resting, equations, recorder, compliant contacts, end stops) keep their state;
    their caches are keyed on q's bytes, which no state of the new chart shares with the last one of the
    old (its angles are (0, b*, 0), the old ones at the old chart's margin)."""
    run.model = new
    for part in (run.contacts, run.resting, run.equations, run.recorder, run.compliant, run.stops):
        if part is None:
            continue
        for name, value in list(vars(part).items()):
            if value is old:
                setattr(part, name, new)
