"""The one module that owns the integrate - detect - impact loop (docs/theory.md §14).

``simulate`` is a driver over named stages, one module each:

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

A run repeats three stages until t_end or a stop:

* **impact** (:func:`impact_stage`), when the last phase ended at a hit or sink
  event (or at the start): every candidate within the contact band at the event
  time is a contact of one impact (resting pairs with e = 0);
* **contact mode** (``mode_stage`` below, :mod:`gibbsimpact.resting`), after an
  impact stage and at a release, slip, stick or drift event: which pairs rest,
  and whether they stick or slip;
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
"""

from __future__ import annotations

import time
from numbers import Real

import numpy as np

from .accumulation import Accumulation
from .contacts import Contacts, contact_band, event_spec, impact_stage, phase_events
from ..dynamics.gibbs_appell import SingularMassMatrixError, forward_dynamics, mass_matrix
from .flight import SOLVERS, integrate_phase
from ..dynamics.forces import damping_depends_on_q, damping_matrix, generalized_force
from ..dynamics.kinematics import joint_positions
from .joint_limits import JOINT_LIMIT_MODES, STATUS_JOINT_LIMIT, EndStops, check_initial, joint_limits
from .progress import Clock, progress_reporter
from .recorder import Recorder
from ..contact.resting import RestingContacts
from .results import (
    STATUS_FAILED,
    STATUS_FINISHED,
    STATUS_MAX_IMPACTS,
    STATUS_PENETRATION,
    STATUS_ZENO,
    Result,
)
from .validity import warn_result, warn_state
from ..contact.walls import WALL_TYPES, describe

_METHODS = tuple(SOLVERS)

#: Status of a run stopped by a KeyboardInterrupt (Ctrl-C, SIGTERM in the command line);
#: the Result holds everything computed until then.
STATUS_INTERRUPTED = "interrupted"
#: Budget of contact-mode events (release, slip, stick, drift) of one run: a contact mode that keeps
#: switching without settling ends the run (status "failed") instead of crawling on.
MAX_MODE_EVENTS = 100_000


def _positive(name, v, allow_inf=False):
    if isinstance(v, bool) or not isinstance(v, Real) or not (v > 0) or (not allow_inf and not np.isfinite(v)):
        raise ValueError(f"simulate {name}={v!r} must be a positive number")
    return float(v)


def _validate(model, q0, qdot0, t_span, walls, restitution, method, **tols):
    q0, qdot0 = model.check_state(q0, qdot0, "q0", "qdot0")
    ts = np.asarray(t_span, dtype=float) if not isinstance(t_span, str) else np.array([])
    if ts.shape != (2,) or not np.all(np.isfinite(ts)) or not ts[1] > ts[0]:
        raise ValueError(f"simulate t_span={t_span!r} must be (t0, t_end) in seconds with t_end > t0")
    if isinstance(walls, WALL_TYPES):
        walls = (walls,)
    walls = tuple(walls)
    for k, w in enumerate(walls):
        if not isinstance(w, WALL_TYPES):
            raise ValueError(f"simulate walls[{k}]={w!r} is not a wall; use gi.Circle, gi.Sphere or gi.Plane")
    if isinstance(restitution, bool) or not isinstance(restitution, Real) or not 0.0 <= restitution <= 1.0:
        raise ValueError(f"simulate restitution={restitution!r} must be a number in [0, 1]")
    if method not in _METHODS:
        raise ValueError(f"simulate method={method!r} is not a solve_ivp method; use one of {', '.join(_METHODS)}")
    for name, v in tols.items():
        _positive(name, v, allow_inf=(name == "max_step"))
    return q0, qdot0, (float(ts[0]), float(ts[1])), walls


def _check_inside(model, q, walls, contact_tol, contacts=None):
    """Raise ValueError naming every joint (and link, with link contacts) that starts beyond a wall."""
    p = joint_positions(model, q)
    bad = []
    for w_i, w in enumerate(walls):
        g = w.gap(p)
        for j in np.nonzero(g < -contact_tol)[0]:
            bad.append(
                f"joint O{j + 1} at {np.round(p[j], 6).tolist()} m is {-g[j]:.3g} m outside wall {w_i + 1} ({describe(w)})"
            )
    if contacts is not None and contacts.flex and not bad:
        g = contacts.gaps(q)[:, contacts.n_joints:]
        for w_i, f in np.argwhere(g < -contact_tol):
            bad.append(f"link {contacts.flex[f] + 1} bends {-g[w_i, f]:.3g} m beyond wall {w_i + 1} ({describe(walls[w_i])}) "
                       "between its joints")
    if bad:
        what = "a joint" if "joint" in bad[0] else "a link"
        raise ValueError(f"initial state q0 puts {what} outside a wall: " + "; ".join(bad) + ". Move the chain inside.")


def simulate(
    model,
    q0,
    qdot0,
    t_span,
    walls=(),
    restitution: float = 1.0,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    method: str = "DOP853",
    output_dt: float | None = None,
    max_step: float = np.inf,
    contact_tol: float = 1e-9,
    grazing_velocity: float = 1e-6,
    penetration_tol: float = 1e-6,
    zeno_interval: float = 1e-6,
    zeno_count: int = 10,
    max_impacts: int = 10000,
    progress=None,
    inputs=None,
    joint_limit: str = "stop",
    joint_restitution: float = 0.5,
    accumulation: str = "rest",
    link_contacts: bool = True,
    _in_step_check: bool = True,
) -> Result:
    """Simulate flight phases and impacts from (q0, qdot0) over t_span.

    Parameters
    ----------
    model : Model
    q0, qdot0 : (N,) initial coordinates and velocities (order: model.coordinate_names)
    t_span : (t0, t_end) [s]
    walls : sequence of Circle, Sphere, Plane
    restitution : float in [0, 1], used for walls whose own ``restitution`` is None
    rtol : solver relative tolerance (solve_ivp's meaning)
    atol : solver absolute tolerance (solve_ivp's meaning)
    method : scipy ODE solver ("DOP853" recommended: explicit, high order)
    output_dt : float [s] or None; None stores every accepted step, a float
        stores uniform samples from the dense output (plus every impact's both sides)
    max_step : float [s], the solver's maximal step
    contact_tol : float [m], gap within which joints belong to one impact: the contact band is
        max(2 contact_tol, L_q (atol + rtol max|q|)), L_q = 1 + 2 sum l_i (module docstring)
    grazing_velocity : float [m/s], an event with v_n >= -grazing_velocity is no impact
    penetration_tol : float [m], a gap below -penetration_tol between events stops the run
    zeno_interval : float [s] — with zeno_count, the accumulation criteria
    zeno_count : int — with zeno_interval, the accumulation criteria
    max_impacts : int, impact budget
    progress : None (default), True, or a callable progress(t, n_impacts). True shows a
        progress bar (tqdm) over simulated time on stderr; a callable is called with the
        simulated time [s] and the number of impacts so far. Either is updated at most
        5 times a second of wall time, and once at the end.
    inputs : applied generalised forces Q_in (gibbsimpact.forces): None, a callable
        Q(t, q, qdot) -> (N,), a constant (N,) vector, or {coordinate name: number or
        f(t, q, qdot)} (a torque [N m] on an angle, a force [N] on a translation).
        With inputs or damped links (``Link.damping``) the run also integrates their
        work W (Result.work) and energy_error measures E(t) - E(start) - (W(t) - W(start)).
    joint_limit : "stop" (default) or "impact", what happens when a prismatic joint reaches
        an end of its range (gibbsimpact.limits): "stop" ends the run with status
        "joint_limit" (results kept); "impact" applies an end-stop impact with
        ``joint_restitution`` (an ImpactRecord with wall -1) and goes on.
    joint_restitution : float in [0, 1], e_stop of the end-stop impacts (joint_limit="impact")
    accumulation : "rest" (default) or "stop", what an accumulation of impacts (and a plastic
        impact) leads to: "rest" goes on in resting contact (gibbsimpact.resting: contact forces
        from an LCP, release events; Result.contact_forces); "stop" ends the run with status
        "zeno" at the accumulation and never enters resting contact (the behaviour before
        resting contact existed).
    link_contacts : bool, default True: the closest point of every flexible link to every
        wall is a contact candidate too (a link bulging into a wall between its joints;
        gibbsimpact.contacts.Contacts); False: joints only, as in the published case studies.
    _in_step_check : private; False turns off the search for gap dips inside steps
        (flight.py), leaving solve_ivp's sign test at step ends: for benchmarks and tests only.

    Returns
    -------
    Result, with status "finished" or why it stopped early. A KeyboardInterrupt
    during the run (Ctrl-C in a terminal, "interrupt kernel" in a notebook) does
    not propagate: the run stops with status "interrupted" and the Result holds
    everything computed until then (every accepted step of the phase under way
    included). An interrupt during the input checks, before the first step,
    propagates as usual.
    """
    started = time.perf_counter()
    q0, qdot0, (t0, t_end), walls = _validate(
        model, q0, qdot0, t_span, walls, restitution, method,
        rtol=rtol, atol=atol, max_step=max_step, contact_tol=contact_tol,
        grazing_velocity=grazing_velocity, penetration_tol=penetration_tol, zeno_interval=zeno_interval,
    )
    if output_dt is not None:
        output_dt = _positive("output_dt", output_dt)
    if not (progress is None or isinstance(progress, bool) or callable(progress)):
        raise ValueError(f"simulate progress={progress!r} must be None, True (a progress bar on stderr) "
                         "or a callable progress(t, n_impacts)")
    for name, v in (("zeno_count", zeno_count), ("max_impacts", max_impacts)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"simulate {name}={v!r} must be an integer >= 1")
    if joint_limit not in JOINT_LIMIT_MODES:
        raise ValueError(f"simulate joint_limit={joint_limit!r} must be 'stop' (end the run at a joint limit) "
                         "or 'impact' (an end-stop impact with joint_restitution)")
    if isinstance(joint_restitution, bool) or not isinstance(joint_restitution, Real) or not 0.0 <= joint_restitution <= 1.0:
        raise ValueError(f"simulate joint_restitution={joint_restitution!r} must be a number in [0, 1]")
    if not isinstance(link_contacts, (bool, np.bool_)):
        raise ValueError(f"simulate link_contacts={link_contacts!r} must be True (links' closest points are contact "
                         "candidates too) or False (joints only)")
    if accumulation not in ("rest", "stop"):
        raise ValueError(f"simulate accumulation={accumulation!r} must be 'rest' (go on in resting contact) "
                         "or 'stop' (end the run with status 'zeno')")
    limits = joint_limits(model)
    check_initial(limits, q0)
    contacts = Contacts(model, walls, bool(link_contacts))
    _check_inside(model, q0, walls, contact_tol, contacts)
    try:
        mass_matrix(model, q0)
        forward_dynamics(model, q0, qdot0)
    except SingularMassMatrixError as exc:
        raise SingularMassMatrixError(f"initial state q0: {exc}") from None
    warn_state(model, q0, qdot0, walls)  # outside the model's assumptions: warned, never changed

    N, P = model.n_dof, model.n_joints
    Q_in = generalized_force(model, inputs, t0, q0, qdot0)
    C_varies = damping_depends_on_q(model)  # a damped Pb link: C = C(d)
    C_damp = damping_matrix(model, q0)
    damped = bool(np.any(C_damp))
    # Friction in resting contact does work too: a frictional wall makes the run keep its work.
    driven = Q_in is not None or damped or any(w.friction > 0 for w in walls)
    e_wall = np.array([restitution if w.restitution is None else w.restitution for w in walls])
    settings = dict(
        method=method, rtol=rtol, atol=atol, restitution=float(restitution),
        wall_restitution=[w.restitution for w in walls], output_dt=output_dt, max_step=max_step,
        contact_tol=contact_tol, grazing_velocity=grazing_velocity, penetration_tol=penetration_tol,
        zeno_interval=zeno_interval, zeno_count=int(zeno_count), max_impacts=int(max_impacts),
        t_span=[t0, t_end], joint_limit=joint_limit, joint_restitution=float(joint_restitution),
        accumulation=accumulation, link_contacts=bool(link_contacts),
    )
    counters = {"nfev": 0, "n_steps": 0, "n_examined": 0, "resting_time": 0.0, "mode_events": 0}

    singular = {"message": None}  # diagnosis of the last trial state with a singular M

    def forces_in(t, q, qd):
        """(Q_in, Q_damp) (N,) each, or None for an undriven, undamped run."""
        if not driven:
            return None
        # (1) of forces.py: M qddot = Q_in + Q_damp - h - dV/dq, and the work rates qdot.Q.
        Qi = Q_in(t, q, qd) if Q_in is not None else np.zeros(N)
        Qd = -((damping_matrix(model, q) if C_varies else C_damp) @ qd) if damped else np.zeros(N)
        return Qi, Qd

    def applied(t, q, qd):
        """Q (N,) of the equations of motion, or None (resting.py)."""
        f = forces_in(t, q, qd)
        return None if f is None else f[0] + f[1]

    # Whether the current phase has pairs in resting contact: fixed during a phase (its
    # events end it), set before each flight stage.
    in_phase = {"resting": False}

    def rhs(t, y):
        counters["nfev"] += 1
        clock.tick(t)
        try:
            q, qd = y[:N], y[N:2 * N]
            if in_phase["resting"]:
                # A contact phase: equations (3), (6) of resting.py; friction's power joins the damping's.
                f = forces_in(t, q, qd)
                qdd, _, _, power, *_ = resting.acceleration(q, qd, None if f is None else f[0] + f[1])
                return np.concatenate((qd, qdd) if f is None else (qd, qdd, [qd @ f[0], qd @ f[1] + power.sum()]))
            if not driven:
                return np.concatenate((qd, forward_dynamics(model, q, qd)))
            Qi, Qd = forces_in(t, q, qd)
            qdd = forward_dynamics(model, q, qd, Qi + Qd)
            return np.concatenate((qd, qdd, [qd @ Qi, qd @ Qd]))
        except SingularMassMatrixError as exc:
            # A trial stage of a too-long step can land on a meaningless state (e.g. right
            # after an impact that excites high modes): NaN makes the solver reject the
            # step and shrink it. Only if it cannot go on is the diagnosis reported.
            singular["message"] = f"at t = {t:.9g} s: {exc}"
            return np.full(y.shape, np.nan)

    # Joint limits, when the chain has prismatic joints: one more row of the gap matrix (row W).
    gap_matrix, gap_batch = contacts.gaps, contacts.gaps_batch
    stops = EndStops(limits, len(walls), contacts.n_cols) if limits else None
    if stops is not None:
        gap_matrix, gap_batch = stops.wrap(contacts.gaps), stops.wrap_batch(contacts.gaps_batch)
    # |dg/dq| <= 1 + 2 sum l: a translation moves a joint 1:1, a rotation by at most its lever arm.
    lipschitz = 1.0 + 2.0 * sum(ld.length for ld in model.link_data)
    recorder = Recorder(model, t0, q0, qdot0, len(walls))
    band = contact_band(contact_tol, lipschitz, rtol, atol, q0)
    monitor = Accumulation((len(walls), contacts.n_cols), int(zeno_count), zeno_interval, band, contacts.names)
    resting = RestingContacts(model, walls, contact_tol, grazing_velocity, contacts.n_cols)
    rest = accumulation == "rest" and bool(walls)
    release = forced = None  # (W, J) masks for the next mode decision: a released pair, an accumulation
    slipping = None  # {(wall, point): direction} of a pair whose "slip" event ended the phase
    settled_at = None  # time of the last accumulation resolved into resting contact
    status, message = STATUS_FINISHED, f"reached t_end = {t_end:g} s"
    t, y, phase = t0, np.concatenate((q0, qdot0, np.zeros(2 if driven else 0))), 0
    near = np.zeros((len(walls), contacts.n_cols), dtype=bool)
    pending_impact = True  # check the initial state for an impact in progress
    pending_mode = False  # decide the contact mode (resting.py) before the next flight phase
    sink_pair = None  # (wall, joint) whose sink event ended the last phase
    stalled = 0  # consecutive phases that made no progress in time
    flown = None  # outcome of the last flight phase until its samples are recorded

    def mode_stage(t, y, phase):
        """Contact-mode decision at (t, y) (resting.py); returns the (projected) state."""
        q, qd = y[:N], y[N:2 * N]
        g, nrm, Jac, _, _ = contacts.full(q)
        v = np.einsum("wjc,wjcn,n->wj", nrm, Jac, qd)
        cand = resting.candidates(g, v, band, grazing_velocity, release, forced)
        if len(cand) == 0 and not resting.any():
            return y
        q, qd = resting.decide(q, qd, applied(t, q, qd), cand, slipping)
        monitor.streak[resting.active] = 0
        y = np.concatenate((q, qd, y[2 * N:]))
        recorder.mode(t, q, qd, phase, *(f[:, :P] for f in resting.force_matrix(q, qd, applied(t, q, qd))))
        return y

    def contact_forces(T, Y):
        """Normal (K, W, P) and tangential (K, W, P, 3) [N] resting-contact forces at the samples of a phase."""
        F = [resting.force_matrix(yk[:N], yk[N:2 * N], applied(tk, yk[:N], yk[N:2 * N])) for tk, yk in zip(T, Y)]
        return np.stack([f[0][:, :P] for f in F]), np.stack([f[1][:, :P] for f in F])

    with progress_reporter(progress, t0, t_end) as report:
        clock = Clock(report)
        try:
            while True:
                # Stage 1: impact, when the last phase ended at an event (or at the start).
                if pending_impact and walls:
                    q, qd = y[:N], y[N:2 * N]
                    in_band_before = near
                    band = monitor.band = contact_band(contact_tol, lipschitz, rtol, atol, q)
                    rec, near = impact_stage(model, contacts, e_wall, t, q, qd, band, grazing_velocity,
                                              sink_pair, resting.active)
                    if rec is not None:
                        y = np.concatenate((q, rec.qdot_after, y[2 * N:]))
                        phase += 1
                        recorder.impact(rec, q, phase)
                        clock.n_impacts = recorder.n_impacts
                        stop = monitor.add(rec, in_band_before)
                        if stop is not None:
                            # An accumulation: resting contact of its pairs, unless that cannot be.
                            forced = monitor.recent_pairs() & resting.can_rest
                            why = ("accumulation='stop'" if not rest else
                                   "resting contact is modelled for joints only, not for a link's span or the "
                                   "tip of a prismatic host" if not forced.any() else
                                   "resting contact did not resolve it" if settled_at == t else None)
                            if why is not None:
                                status, message = STATUS_ZENO, f"{stop}; stopped ({why}); results up to here are kept"
                                break
                            settled_at = t
                            monitor.reset()
                        if recorder.n_impacts >= max_impacts:
                            status = STATUS_MAX_IMPACTS
                            message = f"stopped after max_impacts = {max_impacts} impacts at t = {t:.9g} s"
                            break
                    pending_mode = rest
                pending_impact = False
                # Stage 2: contact mode (resting.py), after an impact stage, a release or a drift event.
                if pending_mode:
                    y = mode_stage(t, y, phase)
                    release = forced = slipping = None
                    pending_mode = False
                if t >= t_end:
                    break

                # Stage 3: flight until the first event or t_end.
                g_start = contacts.gaps(y[:N])
                sink_depth = max(1e-6 * contact_tol, 64 * np.finfo(float).eps * (1.0 + float(np.abs(y[:3]).max())))
                events, kinds = phase_events(near, g_start, band, sink_depth, skip=resting.active)
                extra = None
                if resting.any():
                    rows, drift_kinds = resting.drift_events()
                    drift = event_spec(rows)
                    events = type(events)(*(np.concatenate((a, b)) for a, b in zip(events, drift)))
                    kinds = kinds + drift_kinds
                if stops is not None:
                    events, kinds = stops.events(events, kinds, y[:N], contact_tol, sink_depth)
                if resting.any():
                    extra, release_kinds = resting.release_events(applied)
                    kinds = kinds + release_kinds
                in_phase["resting"] = resting.any()
                try:
                    flown = out = integrate_phase(
                        rhs, t, y, t_end, events, gap_matrix, method=method, rtol=rtol, atol=atol,
                        max_step=max_step, output_dt=output_dt, t_origin=t0, lipschitz=lipschitz, slack=contact_tol,
                        n_q=N, check_in_step=_in_step_check, gap_batch=gap_batch, extra=extra,
                        gap_single=lambda q, w, c: contacts.gap_single(q, w, c, gap_matrix),
                    )
                except (SingularMassMatrixError, FloatingPointError, ValueError, np.linalg.LinAlgError) as exc:
                    status, message = STATUS_FAILED, f"integration failed after t = {t:.9g} s: {exc}"
                    break
                counters["n_steps"] += out.n_steps
                counters["n_examined"] += out.n_examined
                if out.sample_t.size:
                    recorder.flight(out.sample_t, out.sample_y, phase,
                                    *(contact_forces(out.sample_t, out.sample_y) if resting.any() else (None, None)))
                flown = None
                if out.interrupted is not None:
                    raise KeyboardInterrupt(out.interrupted)  # its samples are recorded: stop below
                if out.failed is not None:
                    status, message = STATUS_FAILED, f"the ODE solver failed after t = {t:.9g} s: {out.failed}"
                    if singular["message"] is not None:
                        message += f"; the mass matrix was singular at a trial state {singular['message']}"
                    break
                singular["message"] = None
                # Between events no joint may be beyond a wall (step ends and in-step samples).
                if out.min_gap < -penetration_tol:
                    status = STATUS_PENETRATION
                    what = "a wall or a joint limit" if stops is not None else "a wall"
                    message = (
                        f"a contact point went {-out.min_gap:.3g} m beyond {what} between events in the phase starting at "
                        f"t = {t:.9g} s without an event firing; tighten rtol or set max_step"
                    )
                    break
                if resting.any():
                    counters["resting_time"] += out.t - t
                t_prev, (t, y) = t, (out.t, out.y)
                if not np.all(np.isfinite(y)):
                    status, message = STATUS_FAILED, f"state became non-finite at t = {t:.9g} s"
                    break
                if out.event is None:
                    break
                stalled = stalled + 1 if t - t_prev <= 1e-14 * max(1.0, abs(t)) else 0
                if stalled >= 100:
                    status = STATUS_FAILED
                    message = f"event loop stalled at t = {t:.9g} s: 100 consecutive events without progress in time"
                    break
                kind, w_i, j = kinds[out.event]
                if kind in ("release", "drift", "slip", "stick"):
                    counters["mode_events"] += 1
                    if counters["mode_events"] > MAX_MODE_EVENTS:
                        status = STATUS_FAILED
                        message = (f"stopped after {MAX_MODE_EVENTS} contact-mode events (release, slip, stick, drift) "
                                   f"at t = {t:.9g} s: the resting contacts do not settle")
                        break
                    # A resting pair's force reached zero (it leaves the active set), its drift
                    # reached contact_tol (projection), its friction reached the cone (it slips)
                    # or its slip stopped (it may stick): decide the contact mode again.
                    if kind == "release":
                        release = np.zeros(resting.active.shape, dtype=bool)
                        release[w_i, j] = True
                    elif kind == "slip":
                        qe, qde = y[:N], y[N:2 * N]
                        slipping = {(w_i, j): resting.slip_direction(qe, qde, applied(t, qe, qde), (w_i, j))}
                    pending_mode = True
                    continue
                if w_i == len(walls):
                    # A joint limit (row W of the gap matrix).
                    if kind == "leave":
                        stops.near[j] = False
                    elif joint_limit == "stop":
                        status = STATUS_JOINT_LIMIT
                        message = (f"joint {limits[j].joint} reached its limit {limits[j].name} at t = {t:.9g} s; "
                                   "results up to there are kept (simulate(..., joint_limit='impact') bounces instead)")
                        break
                    else:
                        rec = stops.impact(model, t, y[:N], y[N:2 * N], j, joint_restitution, grazing_velocity,
                                           kind == "sink")
                        if rec is not None:
                            y = np.concatenate((y[:N], rec.qdot_after, y[2 * N:]))
                            phase += 1
                            recorder.impact(rec, y[:N], phase)
                            clock.n_impacts = recorder.n_impacts
                            stop = stops.accumulation(rec.time, j, int(zeno_count), zeno_interval)
                            if stop is not None:
                                status, message = STATUS_JOINT_LIMIT, stop
                                break
                            # Resting pairs may have been pushed by the end-stop impulse.
                            pending_impact = resting.any()
                    continue
                sink_pair = (w_i, j) if kind == "sink" else None
                if kind == "leave":
                    near[w_i, j] = False  # re-arm the normal event of this pair; no impact
                    monitor.left_band(w_i, j)
                else:
                    pending_impact = True
        except KeyboardInterrupt as exc:
            # Keep what was computed: the accepted steps of the phase under way, or a
            # finished phase whose samples were not recorded yet.
            # (integrate_phase returns the steps it accepted before an interrupt, recorded above.)
            if flown is not None and flown.sample_t.size and not recorder.ends_with(flown.sample_t):
                recorder.flight(flown.sample_t, flown.sample_y, phase)
            t_last = float(recorder.chunks[-1].t[-1])
            status = STATUS_INTERRUPTED
            message = (f"stopped by {str(exc) or 'KeyboardInterrupt (Ctrl-C)'} at t = {t_last:.9g} s of "
                       f"t_end = {t_end:g} s; the results up to there are kept")

        t_all, q_all, qdot_all, phase_all, work_all, E_all, F_all, Ft_all = recorder.arrays()
        impacts = recorder.impacts
        res = Result(
            model=model, walls=walls, t=t_all, q=q_all, qdot=qdot_all, phase=phase_all, impacts=impacts,
            status=status, message=message, settings=settings,
            nfev=counters["nfev"], n_steps=counters["n_steps"], n_examined=counters["n_examined"],
            wall_time=time.perf_counter() - started, energy_error=recorder.energy_error,
            energy_error_whole_run_J=recorder.balance_J,
            _energy_cache=E_all, work=work_all if driven else None, contact_forces=F_all,
            friction_forces=Ft_all if any(w.friction > 0 for w in walls) else None,
            resting_time=counters["resting_time"],
        )
        if report is not None:
            try:
                report(float(t_all[-1]), len(impacts))
            except KeyboardInterrupt:
                pass  # the run is over and its Result complete: an interrupt now must not lose it
    warn_result(res)
    return res
