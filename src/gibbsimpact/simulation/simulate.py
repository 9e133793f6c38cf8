"""The one module that owns the integrate - detect - impact loop (docs/theory.md §14).

``simulate`` is a driver over named stages, one module each:

* :mod:`gibbsimpact.simulation.stages` — the stages below, as functions of one Run;
  :mod:`gibbsimpact.simulation.settings` — every option validated once;
  :mod:`gibbsimpact.simulation.equations` — the right-hand side;
  :mod:`gibbsimpact.simulation.status` — every status and stop message;
* :mod:`gibbsimpact.flight` — a flight phase (scipy's stepping, events seen inside steps);
* :mod:`gibbsimpact.contacts` — gaps of the (wall, contact point) pairs (joints, and the
  closest point of each flexible link: :mod:`gibbsimpact.linkpoints`), the contact band,
  the impact stage and the events of a phase;
* :mod:`gibbsimpact.impact` / :mod:`gibbsimpact.friction` — the impulse problem (Newton's law
  in rounds; Moreau's law with a Coulomb cone on walls with friction);
* :mod:`gibbsimpact.resting` — the contact-mode stage: resting contact (LCP on the Delassus
  matrix), stick and slip, release / slip / stick / drift events;
* :mod:`gibbsimpact.limits` — joint limits of prismatic joints: their events and end-stop impacts;
* :mod:`gibbsimpact.accumulation` — the accumulation monitor (resting contact, or status "zeno");
* :mod:`gibbsimpact.recorder` — samples, impacts, contact forces and the energy balance;
* :mod:`gibbsimpact.progress` — the progress callback or bar.

A run repeats these stages until t_end or a stop:

* **impact** (:func:`impact_stage`), when the last phase ended at a hit or sink
  event (or at the start): every candidate within the contact band at the event
  time is a contact of one impact (resting pairs with e = 0);
* **contact mode** (``mode_stage`` below, :mod:`gibbsimpact.resting`), after an
  impact stage and at a release, slip, stick or drift event: which pairs rest,
  and whether they stick or slip;
* **chart** (:func:`gibbsimpact.simulation.charts.chart`), a spatial free base only: when |theta_0|
  reached 1.2 rad (the chart event of the last phase, or at the start), the base angles are
  measured from the current orientation from now on (formulation §18); the state is unchanged;
* **flight** (:func:`gibbsimpact.flight.integrate_phase`): scipy's ODE solver
  steps the equations of motion (constrained by the resting pairs); one terminal
  event per (contact point, wall) pair, ``g_w(p(q(t)))``, direction -1, located
  at step ends *and inside steps* (a dip of a gap between two accepted steps is
  found from the dense output, see flight.py), plus the events of the resting pairs.

Event-loop rules (each one has a test in tests/test_simulate.py):

* Simultaneous contacts: all candidates within the *contact band* g <= b at
  the event time enter one impulse problem, where the band follows the
  integration error (:func:`contact_band`):

      b = max(2 contact_tol, L_q (atol + rtol max|q|))

  L_q = 1 + 2 sum l_i [m per unit of q] bounds |dg/dq|, and atol + rtol |q|
  is the error the solver allows each coordinate in one step, so L_q (...) is
  the uncertainty of a gap at a located event. Two contacts whose gaps close
  within it are one impact: at rtol = 1e-6 the published simultaneous O1+O3
  impact of case 1 stays one impact (the other gap is 7e-9 m when the first
  closes), instead of splitting into two. At the default tolerances (rtol
  1e-10, atol 1e-12) b = 2 contact_tol for every chain shorter than ~8 m.
* Restart: a candidate with g <= b at the start of a phase (the
  contact band) is watched by two events instead of g = 0: ``g = min(g_start,
  0) - sink_depth`` with sink_depth = max(1e-6 contact_tol, 64 eps (1 + max|p|))
  (direction -1: it sinks, which is handled as an impact; measured from the
  gap at the phase start so the event function starts positive, above
  round-off, even right after a sink) and
  ``g - 1.5 b`` (direction +1: it has left the band; the phase ends
  and the normal event is re-armed). So an impact never re-fires at its own
  time and a point cannot slip through the wall unnoticed. Gaps at every
  accepted step and in-step sample are checked; a gap below -penetration_tol
  stops the run with status "penetration".
* Grazing: an event whose candidates have normal velocity
  v_n >= -grazing_velocity carries no impulse; it is not an impact. (A pair
  caught by its sink event is still stopped if v_n < 0.)
* Stall guard: 100 consecutive events without progress in time stop the run
  with status "failed" instead of hanging.
* Accumulation of impacts (:class:`Accumulation`), status "zeno", results
  so far kept, two rules:
  (a) a contact whose rebounds no longer leave the contact band: zeno_count
      consecutive impacts of one (joint, wall) pair without its "leave"
      event in between. Its rebound height v+^2 / (2 a_n) is then below
      1.5 b (a few nanometres at the default tolerances): the impacts have become resting or
      sliding contact. This rule follows the decay of the rebound velocity,
      so it holds for any interval between the impacts: a geometric
      accumulation (e < 1) reaches it once its bounces are nanometres high,
      a plastic slide (e = 0, chattering at the sink depth) at once;
  (b) zeno_count consecutive impacts each less than zeno_interval after the
      previous one (impacts that alternate between pairs).
  The message gives the estimated accumulation time: geometric extrapolation
  of the intervals when they shrink (ratio < 0.9), else the time the contact
  closed.
* Interrupt: a KeyboardInterrupt raised inside the loop (Ctrl-C, a notebook's
  interrupt, or the command line's SIGTERM handler) stops the run with status
  "interrupted"; the Result holds every sample and impact recorded until
  then, including the accepted steps of the flight phase under way.
* Budget: with max_cpu_time or max_rhs_calls, the right-hand side that finds a limit used up
  raises (gibbsimpact.simulation.budget) and the run stops with status "budget_exceeded",
  keeping its samples as at an interrupt.
"""

from __future__ import annotations

import time

import numpy as np

from ..dynamics.forces import CallbackError
from .budget import BudgetExceeded
from .progress import Clock, progress_reporter
from .results import Result
from .settings import Settings
from .stepping import contact_phase
from .stages import chart, check, dispatch, finish, flight, impact, interrupted, mode, start, stopped_inside
from .validity import warn_result


def simulate(model, q0, qdot0, t_span, walls=(), restitution: float = 1.0, rtol: float = 1e-10,
             atol: float = 1e-12, method: str = "DOP853", output_dt: float | None = None, max_step: float = np.inf,
             contact_tol: float = 1e-9, grazing_velocity: float = 1e-6, penetration_tol: float = 1e-6,
             zeno_interval: float = 1e-6, zeno_count: int = 10, max_impacts: int = 10000, progress=None,
             inputs=None, joint_limit: str = "stop", joint_restitution: float = 0.5, accumulation: str = "rest",
             link_contacts: bool = True, max_cpu_time: float | None = None, max_rhs_calls: int | None = None,
             prescribed: dict | None = None, contact_filter=None, cutoff_frequency: float | None = None,
             contact_step: float = 1e-4, _in_step_check: bool = True) -> Result:
    """Simulate flight phases, impacts and resting contact from (q0, qdot0) over t_span (module docstring).

    Each option in full, with its units and rules: gibbsimpact.simulation.settings.Settings.

    Parameters
    ----------
    model : Model; q0, qdot0 : (N,) initial coordinates and velocities (order: model.coordinate_names)
    t_span : (t0, t_end) [s]; walls : sequence of Circle, Sphere, Plane
    restitution : e in [0, 1] of the walls whose own ``restitution`` is None
    rtol, atol, method : the solver's tolerances and method (solve_ivp's meaning), or "auto" (DOP853 or Radau)
    output_dt : [s] or None (every accepted step); max_step : [s] the solver's largest step
    contact_tol [m], grazing_velocity [m/s], penetration_tol [m] : the contact band, no impact above
        v_n = -grazing_velocity, the stop below a gap of -penetration_tol
    zeno_interval [s], zeno_count : the accumulation criteria; max_impacts : the impact budget
    progress : None, True (a tqdm bar on stderr) or progress(t, n_impacts)
    inputs : applied generalised forces Q_in: Q(t, q, qdot) -> (N,), a constant (N,), or {name: value or f}
    joint_limit : "stop" or "impact" (with joint_restitution in [0, 1]) at a prismatic joint's end of range
    accumulation : "rest" (go on in resting contact; stepped at a link's span), "step" (step from the first impact
        at a link's span) or "stop" (status "zeno")
    link_contacts : True (the closest point of each flexible link is a candidate too) or False (joints only)
    prescribed : None or {joint coordinate: f(t) -> (q, qdot, qddot)}, motions imposed by actuators
    contact_filter : None or contact_filter(q) -> (C,) bool: where contacts may begin
    max_cpu_time [s], max_rhs_calls : None or the budget after which the run stops ("budget_exceeded")
    cutoff_frequency : None or [rad/s]: Radau leaves the modes above it out of its error estimate
    contact_step : [s] the step of the time-stepping contact phases (an accumulation at a link's span)
    _in_step_check : private; False leaves solve_ivp's sign test at step ends only (benchmarks, tests)

    Returns
    -------
    Result, with status "finished" or why the run stopped early (gibbsimpact.simulation.status),
    and everything computed until then. A KeyboardInterrupt (Ctrl-C, a notebook's interrupt)
    stops the run with status "interrupted"; a user callback (an input, progress) that raises or
    returns a non-finite value, with "callback_failed" and a message naming it, its coordinate
    and the time; a run over a limit, with "budget_exceeded". Bad arguments raise ValueError
    before the first step, as does an input that fails at the initial state.
    """
    started = time.perf_counter()
    q0, qdot0 = model.check_state(q0, qdot0, "q0", "qdot0")
    settings = Settings.from_arguments(
        t_span, walls, restitution, method, output_dt, progress, inputs, zeno_count, max_impacts, joint_limit,
        joint_restitution, accumulation, link_contacts, rtol=rtol, atol=atol, max_step=max_step,
        contact_tol=contact_tol, grazing_velocity=grazing_velocity, penetration_tol=penetration_tol,
        zeno_interval=zeno_interval, in_step_check=_in_step_check, max_cpu_time=max_cpu_time,
        max_rhs_calls=max_rhs_calls, prescribed=prescribed, cutoff_frequency=cutoff_frequency,
        state=(model, q0, qdot0), contact_filter=contact_filter, contact_step=contact_step)
    with progress_reporter(settings.progress, settings.t0, settings.t_end) as report:
        run = start(model, q0, qdot0, settings, Clock(report))
        try:
            _loop(run)
        except KeyboardInterrupt as exc:
            interrupted(run, str(exc) or "KeyboardInterrupt (Ctrl-C)")
        except CallbackError as exc:
            stopped_inside(run, "callback", exc)
        except BudgetExceeded as exc:
            stopped_inside(run, "budget", exc)
        res = finish(run, started)
        _final_report(report, res)
    warn_result(res)
    return res


def _loop(run) -> None:
    """The stages (module docstring) until the run stops: impact, contact mode, chart, flight, check, dispatch;
    a stepped contact phase (simulation.stepping) in place of the last four while run.stepping."""
    while run.status is None:
        impact(run)
        if run.status is not None:
            break
        if run.stepping:  # an accumulation at a link's span: a time-stepping contact phase
            contact_phase(run)
            continue
        mode(run)
        if run.t >= run.settings.t_end:
            run.end("t_end", t_end=run.settings.t_end)
            break
        chart(run)
        outcome = flight(run)
        if outcome is not None and check(run, outcome[0]):
            dispatch(run, *outcome)


def _final_report(report, res) -> None:
    """The progress callback's last call, at the end of the run; an interrupt now must not lose the Result."""
    if report is None:
        return
    try:
        report(float(res.t[-1]), len(res.impacts))
    except KeyboardInterrupt:
        pass
