"""The stages of the event loop (docs/theory.md §14): start, impact, contact mode, flight, check, dispatch, finish.

Each stage is a function of the run (:class:`Run`: what the run is made of, fixed at the start,
and the loop's state, which the stages advance). The rules they implement are stated in
gibbsimpact.simulation.simulate's module docstring, each with a test.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..contact.impact import HeldContactError
from ..contact.resting import RestingContacts
from ..contact.walls import describe, is_compliant
from ..dynamics.forces import CallbackError
from ..dynamics.gibbs_appell import SingularMassMatrixError, forward_dynamics, mass_matrix
from .accumulation import Accumulation
from .charts import chart, chart_event, charted, start_chart
from .compliant import COMPLIANT_EVENTS, CompliantContacts, compliant_event, compliant_gap_functions
from .contact_filter import FilteredContacts
from .contacts import Contacts, contact_band, event_spec, gap_lipschitz, impact_stage as solve_impact, phase_events
from .equations import Equations
from .flight import integrate_phase
from .joint_limits import EndStops, check_initial, joint_limits
from .outside import outside_walls, point_name
from .recorder import Recorder
from .results import Result
from .status import STATUS_FINISHED, stop
from .stepping import can_step, why_not_stepped
from .validity import ValidityWarning, warn_impact, warn_state

#: Budget of contact-mode events (release, slip, stick, drift, speed) of one run: a contact mode that keeps
#: switching without settling ends the run (status "failed") instead of crawling on.
MAX_MODE_EVENTS = 100_000
#: Consecutive events without progress in time that end a run (status "failed") instead of hanging.
MAX_STALLED = 100
MODE_EVENTS = ("release", "drift", "slip", "stick", "speed")


@dataclass
class Run:
    """One run: its parts (fixed at the start) and the loop's state (advanced by the stages)."""

    model: object
    settings: object
    contacts: Contacts
    limits: list
    stops: EndStops | None
    resting: RestingContacts
    monitor: Accumulation
    recorder: Recorder
    equations: Equations
    clock: object
    lipschitz: float  # L_q [m per unit of q], a bound on |dg/dq|
    t: float
    y: np.ndarray  # (q, qdot[, W_in, W_damp]) (2N or 2N + 2,)
    band: float  # the contact band [m]
    near: np.ndarray  # (W, J) pairs in the contact band since the last impact stage
    phase: int = 0
    status: str | None = None
    message: str = ""
    pending_impact: bool = True  # check the initial state for an impact in progress
    pending_mode: bool = False  # decide the contact mode before the next flight phase
    sink_pair: tuple | None = None  # (wall, joint) whose sink event ended the last phase
    release: np.ndarray | None = None  # (W, J) a released pair, for the next mode decision
    forced: np.ndarray | None = None  # (W, J) the pairs of an accumulation, for the next mode decision
    slipping: dict | None = None  # {(wall, point): direction} of a pair whose "slip" event ended the phase
    settled_at: float | None = None  # time of the last accumulation resolved into resting contact
    stalled: int = 0  # consecutive phases that made no progress in time
    newton_warned: bool = False  # the warning of validity.check_impact was issued (once per run)
    flown: object = None  # the last flight phase's outcome until its samples are recorded
    compliant: CompliantContacts | None = None  # the compliant walls' pairs (simulation.compliant), or None
    charting: bool = False  # the free base is re-charted (simulation.charts); model is then the current chart's
    pending_chart: bool = False  # the last phase ended at the chart event: re-chart before the next one
    stepping: bool = False  # a time-stepping contact phase is under way (simulation.stepping)
    grid: object = None  # the links' grid points of stepped phases (contact.span_grid.SpanGrid), built on first use
    counters: dict = field(default_factory=lambda: {"n_steps": 0, "n_examined": 0, "resting_time": 0.0,
                                                    "mode_events": 0, "contact_steps": 0, "stepped_phases": 0,
                                                    "stepped_contact_work": 0.0})

    @property
    def N(self) -> int:
        return self.model.n_dof

    def end(self, reason: str, **values) -> None:
        """Stop the run for ``reason`` (gibbsimpact.simulation.status.STOPS), the message filled with values."""
        self.status, self.message = stop(reason, **values)


# -- start -------------------------------------------------------------------------------------

def _check_inside(model, q, walls, contact_tol, link_contacts=True):
    """Raise ValueError naming every joint, and with link contacts every link bent between its
    joints, that starts beyond a wall by more than contact_tol (simulation.outside)."""
    bad = outside_walls(model, q, walls, contact_tol, link_contacts)
    if not bad:
        return
    lines = []
    for o in bad:
        w, at = f"wall {o.wall + 1} ({describe(walls[o.wall])})", np.round(o.point, 6).tolist()
        how = "passes" if walls[o.wall].obstacle else "bends"   # through an obstacle a straight link can pass
        lines.append(f"{point_name(model, o)} at {at} m is {o.depth:.3g} m outside {w}" if o.link is None else
                     f"link {o.link + 1} {how} {o.depth:.3g} m beyond {w} between its joints: its point at "
                     f"x = {o.x:.6g} m (of {model.chain.links[o.link].length:.6g} m) is at {at} m")
    kinds = {"a link" if o.link is not None else ("an attached body" if o.body is not None else "a joint") for o in bad}
    what = " and ".join(sorted(kinds))
    fix = "out of the obstacle" if any(walls[o.wall].obstacle for o in bad) else "inside"
    raise ValueError(f"initial state q0 puts {what} outside a wall: " + "; ".join(lines) + f". Move the chain {fix}.")


def _check_start(model, q0, qdot0, settings, limits, start=None):
    """Refuse an initial state the run cannot start from; warn where it is outside the model's assumptions.
    start: (model, q0, qdot0) in the chart the run starts in (simulation.charts.start_chart), where the
    dynamics are checked."""
    check_initial(limits, q0)
    _check_inside(model, q0, settings.walls, settings.contact_tol, settings.link_contacts)
    try:
        m, q, qd = (model, q0, qdot0) if start is None else start
        mass_matrix(m, q)
        forward_dynamics(m, q, qd)
    except SingularMassMatrixError as exc:
        raise SingularMassMatrixError(f"initial state q0: {exc}") from None
    warn_state(model, q0, qdot0, settings.walls)  # outside the model's assumptions: warned, never changed


def start(model, q0, qdot0, settings, clock) -> Run:
    """Check the initial state and build the run's parts (method="auto" resolved); the loop starts with an
    impact stage."""
    charting = charted(model, _index(settings.prescribed))
    started = start_chart(model, q0, qdot0, charting)
    s, walls = settings.resolve_auto(*started[:2]), settings.walls
    limits = joint_limits(model)
    _check_start(model, q0, qdot0, s, limits, started)
    limits = _watched(limits, s.prescribed)
    contacts = (Contacts(model, walls, s.link_contacts) if s.contact_filter is None else
                FilteredContacts(model, walls, s.link_contacts, s.contact_filter))
    stops = EndStops(limits, len(walls), contacts.n_cols) if limits else None
    lipschitz = gap_lipschitz(model)
    band = contact_band(s.contact_tol, lipschitz, s.rtol, s.atol, q0)
    resting = RestingContacts(model, walls, s.contact_tol, s.grazing_velocity, contacts.n_cols, contacts.cells)
    # Resting pairs are never filtered out, and their link columns stay continuous (Contacts.gaps_batch).
    contacts.resting = lambda: resting.active
    compliant = (CompliantContacts(model, contacts, s.wall_restitution, lipschitz)
                 if any(map(is_compliant, walls)) else None)
    equations = Equations(model, s, q0, qdot0, resting, clock, compliant, stops)
    run = Run(
        model=model, settings=s, contacts=contacts, limits=limits, stops=stops, resting=resting,
        monitor=Accumulation((len(walls), contacts.n_cols), s.zeno_count, s.zeno_interval, band, contacts.names),
        recorder=Recorder(model, s.t0, q0, qdot0, len(walls), _index(s.prescribed), len(limits),
                          contacts.n_cols), equations=equations,
        clock=clock, lipschitz=lipschitz, t=s.t0, y=np.concatenate((q0, qdot0, np.zeros(equations.n_extra))),
        band=band, near=np.zeros((len(walls), contacts.n_cols), dtype=bool), compliant=compliant,
        charting=charting,
    )
    chart(run)  # |theta_0| >= RECHART_ANGLE at t0: the run starts in the chart of q0's orientation
    if s.accumulation == "step" and walls and why_not_stepped(run):
        warnings.warn(f"accumulation='step': this run's contact phases cannot be stepped ({why_not_stepped(run)}; "
                      "docs/theory.md §15.5), so they stay event-driven, as with accumulation='rest'; a flexible "
                      "link settling on a wall may then crawl in micro-impacts (set max_cpu_time)", ValidityWarning,
                      stacklevel=3)
    return run


def _index(prescribed):
    """(n_p,) indices of the prescribed coordinates, or None."""
    return None if prescribed is None else prescribed.index


def _watched(limits, prescribed) -> tuple:
    """The joint limits the run watches: all, less those of a prescribed coordinate alone (its profile is the
    user's; checked at t0 by _check_start). A limit that moves free coordinates too is kept."""
    if prescribed is None or not limits:
        return limits
    free = np.ones(limits[0].n.size, dtype=bool)
    free[prescribed.index] = False
    return tuple(lim for lim in limits if np.any(lim.n[free]))


def gap_functions(run):
    """(gap matrix g(q) -> (R, J), batch g(qs) -> (K, R, J)) [m]: the walls' rows (the active compliant pairs'
    shifted: simulation.compliant), and the joint limits' row."""
    g, batch = run.contacts.gaps, run.contacts.gaps_batch
    if run.compliant is not None:
        g, batch = compliant_gap_functions(run.compliant, g, batch)
    if run.stops is None:
        return g, batch
    return run.stops.wrap(g), run.stops.wrap_batch(batch)


# -- impact ------------------------------------------------------------------------------------

def _accumulation(run, accumulation) -> None:
    """An accumulation of impacts: a stepped contact phase when a span point takes part (simulation.stepping),
    else its pairs go on resting, unless that cannot be (status "zeno")."""
    rest = run.settings.accumulation != "stop" and bool(run.settings.walls)
    if rest and run.monitor.recent_pairs()[:, _span_columns(run)].any() and can_step(run):
        _start_stepping(run)
        return
    run.forced = run.monitor.recent_pairs() & run.resting.can_rest
    unresolved = run.monitor.unresolved(run.resting.can_rest) if rest else None
    why = ("accumulation='stop'" if not rest else
           "resting contact is not modelled with prescribed coordinates" if run.settings.prescribed is not None else
           "resting contact is modelled at joints and along links' spans, not at the tip of a prismatic host "
           "(a contact point after the chain's tip) or a body's centre" if not run.forced.any() else
           unresolved if unresolved is not None else
           "resting contact did not resolve it" if run.settled_at == run.t else None)
    if why is not None:
        run.end("zeno", accumulation=accumulation, why=why)
        return
    run.settled_at = run.t
    run.monitor.reset()


def _start_stepping(run) -> None:
    """The next phase is stepped (simulation.stepping), with no resting pair and the accumulation monitor reset."""
    run.stepping, run.pending_mode = True, False
    run.counters["stepped_phases"] += 1
    run.resting.clear()
    run.monitor.reset()


def _span_columns(run) -> slice:
    """The link columns of the gap matrix (0-based): the points of links' spans (contacts.Contacts)."""
    P = run.model.n_joints
    return slice(P, P + len(run.contacts.flex))


def _span_impact(run, rec) -> bool:
    """Whether an impact record's impulses act at a link's span (rec.joints are 1-based columns)."""
    span = _span_columns(run)
    return any(span.start <= j - 1 < span.stop and lam > 0 for j, lam in zip(rec.joints, rec.impulses))


def impact(run) -> None:
    """Stage 1, after a hit or sink event (or at the start): one impact of every candidate in the contact band."""
    s, N = run.settings, run.N
    if run.pending_impact and s.walls:
        q, qd = run.y[:N], run.y[N:2 * N]
        in_band_before = run.near
        run.band = run.monitor.band = contact_band(s.contact_tol, run.lipschitz, s.rtol, s.atol, q)
        try:
            rec, run.near = solve_impact(run.model, run.contacts, s.wall_restitution, run.t, q, qd, run.band,
                                         s.grazing_velocity, run.sink_pair, run.resting.active, _index(s.prescribed),
                                         None if run.compliant is None else run.compliant.rows)
        except HeldContactError as exc:
            run.end("held_contact", t=run.t, error=exc)
            return
        if rec is not None:
            _record_impact(run, rec, q)
            if not run.newton_warned:
                # user -> simulate -> _loop -> impact: stacklevel 4 names the user's line.
                run.newton_warned = bool(warn_impact(run.model, rec, s.walls, s.link_contacts, stacklevel=4))
            accumulation = run.monitor.add(rec, in_band_before)
            if s.accumulation == "step" and accumulation is None and _span_impact(run, rec) and can_step(run):
                _start_stepping(run)   # accumulation="step": the first impact at a span starts a stepped phase
            elif accumulation is not None:
                _accumulation(run, accumulation)
                if run.status is not None:
                    return
            if run.recorder.n_impacts >= s.max_impacts:
                run.end("max_impacts", max_impacts=s.max_impacts, t=run.t)
                return
        run.pending_mode = s.accumulation != "stop" and bool(s.walls) and s.prescribed is None and not run.stepping
    run.pending_impact = False


def _record_impact(run, rec, q) -> None:
    """The state after an impact (the record's qdot_after), recorded as the start of a new phase."""
    run.phase += 1
    run.recorder.impact(rec, q, run.phase)
    # The work states go on from the recorded ones: the actuators' impulses did work (Recorder.impact).
    # The compliant contacts' states (after the work states) go on unchanged.
    N, nw = run.N, run.equations.n_work
    run.y = np.concatenate((q, rec.qdot_after, run.recorder.chunks[-1].work[-1] if run.equations.driven else [],
                            run.y[2 * N + nw:]))
    run.clock.n_impacts = run.recorder.n_impacts


# -- contact mode ------------------------------------------------------------------------------

def mode(run) -> None:
    """Stage 2, after an impact stage, a release, slip, stick or drift event: which pairs rest (resting.py)
    and which end stops hold their joints (joint_limits.py)."""
    if not run.pending_mode:
        return
    s, N, resting, stops = run.settings, run.N, run.resting, run.stops
    t = run.t
    held_before = stops is not None and stops.held.any()
    if stops is not None:
        # The stop candidates first onto g = 0, n.qdot = 0, so that the walls' projection starts there.
        q, qd = run.y[:N], run.y[N:2 * N]
        q, qd = stops.project(mass_matrix(run.model, q), q, qd, stops.candidates(q, qd, 2 * s.contact_tol,
                                                                                 s.grazing_velocity))
        run.y = np.concatenate((q, qd, run.y[2 * N:]))
    changed = _decide_walls(run) if s.walls else False
    if stops is not None:
        q, qd = run.y[:N], run.y[N:2 * N]
        q, qd = stops.decide(lambda q, qd: run.equations.stop_forces(t, q, qd), mass_matrix(run.model, q), q, qd,
                             2 * s.contact_tol, s.grazing_velocity, resting.force_scale)
        stops.forced[:] = stops.released[:] = False
        run.y = np.concatenate((q, qd, run.y[2 * N:]))
        changed = changed or held_before or stops.held.any()
    if changed:
        q, qd = run.y[:N], run.y[N:2 * N]
        F, Ft, S, X = _forces_at(run, [t], run.y[None, :])
        run.recorder.mode(t, q, qd, run.phase, F[0], Ft[0], None if S is None else S[0], None if X is None else X[0])
    run.release = run.forced = run.slipping = None
    run.pending_mode = False


def _decide_walls(run) -> bool:
    """The walls' contact mode (resting.py), with the held stops' forces in Q; True when some pair was
    a candidate or rests."""
    s, N, resting = run.settings, run.N, run.resting
    t, q, qd = run.t, run.y[:N], run.y[N:2 * N]
    g, nrm, Jac, _, _ = run.contacts.full(q)
    v = np.einsum("wjc,wjcn,n->wj", nrm, Jac, qd)
    if run.compliant is not None:  # no resting mode on a compliant wall: its contact is a force
        g = np.where(run.compliant.rows[:, None], np.inf, g)
    sunk = _sunk(run, g)
    forced = sunk if run.forced is None else run.forced | sunk
    cand = resting.candidates(g, v, run.band, s.grazing_velocity, run.release, forced)
    if not (len(cand) or resting.any()):
        return False
    # The applied forces at the projected state: damping (-beta K delta_dot) changes with the projected velocities.
    Q, start = (lambda q, qd: run.equations.applied(t, q, qd)), (q, qd)
    for _ in range(g.size):
        q, qd = resting.decide(*start, Q, cand, run.slipping)
        # The projection onto the candidates moves the others too: one pushed beyond the wall joins them.
        pushed = _sunk(run, run.contacts.full(q)[0]) & ~forced
        if not pushed.any():
            break
        forced |= pushed
        cand = np.unique(np.vstack((cand.reshape(-1, 2), np.argwhere(pushed))), axis=0)
    run.monitor.streak[resting.active] = 0
    run.y = np.concatenate((q, qd, run.y[2 * N:]))
    return True


def _sunk(run, g) -> np.ndarray:
    """(W, C) bool: the pairs that can rest and lie beyond the wall by more than contact_tol / 2 (g (W, C) [m]):
    candidates of a mode decision whatever their velocity, like the pairs of an accumulation (the projection (5)
    of contact/resting.py stops them plastically: the kinetic energy never rises). No event of the next phase
    could catch them: a "hit" fires where g falls through 0 and a "sink" below the phase-start gap, so a
    pair that starts under the wall and is not held sinks without an event (docs/theory.md §15.3: a seated span
    point's drifted minimum, with a normal velocity of ~1e-3 m/s above grazing_velocity; a link's end that
    takes over a cell's drifted minimum; a point pushed under by the projection onto the other candidates)."""
    sunk = (g < -0.5 * run.settings.contact_tol) & run.resting.can_rest
    if run.release is not None:
        sunk &= ~run.release
    if run.compliant is not None:
        sunk &= ~run.compliant.rows[:, None]
    return sunk


# -- flight ------------------------------------------------------------------------------------

def _phase_events(run):
    """(EventSpec, kinds, extra) of the phase starting at run.y: hit / sink / leave of every pair, the resting
    pairs' drift events, the joint limits', and the resting pairs' release (and slip / stick) events."""
    s, N, resting = run.settings, run.N, run.resting
    g_start = run.contacts.gaps(run.y[:N])
    sink_depth = max(1e-6 * s.contact_tol, 64 * np.finfo(float).eps * (1.0 + float(np.abs(run.y[:3]).max())))
    compliant = run.compliant
    skip = resting.active if compliant is None else resting.active | compliant.rows[:, None]
    watched = _end_held(run) & ~skip
    events, kinds = phase_events(run.near, g_start, run.band, sink_depth, skip=skip | watched)
    if watched.any():  # a cell next to a resting end: its dip is caught at -contact_tol (Contacts.end_held)
        rows = [(w, j, s.contact_tol, -1.0) for w, j in np.argwhere(watched)]
        events = type(events)(*(np.concatenate((a, b)) for a, b in zip(events, event_spec(rows))))
        kinds = kinds + [("hit", int(w), int(j)) for w, j, _, _ in rows]
    if compliant is not None:
        rows, compliant_kinds = compliant.events(g_start)
        events = type(events)(*(np.concatenate((a, b)) for a, b in zip(events, event_spec(rows))))
        kinds = kinds + compliant_kinds
    extra = None
    if resting.any():
        rows, drift_kinds = resting.drift_events()
        drift = event_spec(rows)
        events = type(events)(*(np.concatenate((a, b)) for a, b in zip(events, drift)))
        kinds = kinds + drift_kinds
    if run.stops is not None:
        events, kinds = run.stops.events(events, kinds, run.y[:N], s.contact_tol, sink_depth)
    extras = []
    if resting.any():
        extra, release_kinds = resting.release_events(run.equations.applied)
        extras.append(extra)
        kinds = kinds + release_kinds
    if run.stops is not None and run.stops.held.any():
        extra, release_kinds = run.stops.release_events(
            lambda t, y: run.equations.stop_forces(t, y[:N], y[N:2 * N]))
        extras.append(extra)
        kinds = kinds + release_kinds
    if run.charting:
        extras.append(chart_event(run.model))
        kinds = kinds + [("chart", -1, -1)]
    return events, kinds, _joined(extras)


def _end_held(run) -> np.ndarray:
    """(W, C) bool: the link columns of Contacts.end_held (a cell next to a resting end) as gap-matrix pairs."""
    c = run.contacts
    out = np.zeros(run.resting.active.shape, dtype=bool)
    if c.flex:
        out[:, c.n_joints:c.n_joints + len(c.flex)] = c.end_held()
    return out


def _joined(extras):
    """One (fun(t, y) -> (m,), directions (m,), inside (m,)) of several (fun, directions[, inside]), their values
    in order (inside: flight.integrate_phase's extra, default True); None for none."""
    if len(extras) < 2:
        return extras[0] if extras else None
    funs = [e[0] for e in extras]
    return (lambda t, y: np.concatenate([f(t, y) for f in funs]),
            np.concatenate([np.asarray(e[1], dtype=float) for e in extras]),
            np.concatenate([np.asarray(e[2] if len(e) > 2 else np.ones(len(e[1])), dtype=bool) for e in extras]))


def _forces_at(run, T, Y):
    """Normal (K, W, C) and tangential (K, W, C, 3) [N] resting-contact forces (C: the joint points, then the
    span points of the link columns), the end-stop forces (K, L) [N or N m] (None without joint limits) and
    the abscissae (K, W, C) [m] of the resting span points (RestingContacts.abscissa_matrix; None when no span
    point rests), at the samples T (K,), Y (K, 2N [+ 2])."""
    N, applied, stops = run.N, run.equations.applied, run.stops
    F = [run.resting.force_matrix(yk[:N], yk[N:2 * N], applied(tk, yk[:N], yk[N:2 * N])) for tk, yk in zip(T, Y)]
    S = None
    if stops is not None:
        S = np.zeros((len(T), len(stops.limits)))
        if stops.held.any():
            S[:, stops.held] = [run.equations.stop_forces(tk, yk[:N], yk[N:2 * N]) for tk, yk in zip(T, Y)]
    X = None
    if run.resting.active[:, run.resting.n_joints:].any():   # some span point rests
        X = np.stack([run.resting.abscissa_matrix(yk[:N]) for yk in Y])
    return np.stack([f[0] for f in F]), np.stack([f[1] for f in F]), S, X


def flight(run):
    """Stage 3: integrate until the first event or t_end; record the samples. Returns (outcome, kinds) or None
    when the integration failed (the run is then stopped)."""
    s, N = run.settings, run.N
    events, kinds, extra = _phase_events(run)
    held = run.stops is not None and run.stops.held.any()
    run.equations.resting_phase = run.resting.any() or held
    gap_matrix, gap_batch = gap_functions(run)
    try:
        run.flown = out = integrate_phase(
            run.equations, run.t, run.y, s.t_end, events, gap_matrix, method=s.method, rtol=s.rtol, atol=s.atol,
            max_step=s.max_step, output_dt=s.output_dt, t_origin=s.t0, lipschitz=run.lipschitz,
            slack=s.contact_tol, n_q=N, check_in_step=s.in_step_check, gap_batch=gap_batch, extra=extra,
            gap_single=lambda q, w, c: run.contacts.gap_single(q, w, c, gap_matrix) + (
                0.0 if run.compliant is None else run.compliant.joint_shift(w, c)),
            jac=run.equations.phase_jacobian(s.method), solver=run.equations.phase_solver(s.method),
        )
    except (SingularMassMatrixError, FloatingPointError, ValueError, np.linalg.LinAlgError) as exc:
        run.end("integration", t=run.t, error=exc)
        return None
    if s.prescribed is not None:  # the prescribed slots rode along as quadratures of f: reset them to f(t)
        s.prescribed.fill(out.sample_t, out.sample_y, N)
        s.prescribed.fill(np.array([out.t]), out.y[None, :], N)
    run.counters["n_steps"] += out.n_steps
    run.counters["n_examined"] += out.n_examined
    if out.sample_t.size:
        forces = _forces_at(run, out.sample_t, out.sample_y) if run.resting.any() or held else (None,) * 4
        compliant = None if run.compliant is None else run.compliant.sample_forces(out.sample_y)
        run.recorder.flight(out.sample_t, out.sample_y, run.phase, *forces[:2], compliant=compliant, stops=forces[2],
                            where=forces[3])
    run.flown = None
    if out.interrupted is not None:
        raise KeyboardInterrupt(out.interrupted)  # its samples are recorded: the driver stops the run
    if out.stopped_by is not None:
        raise out.stopped_by  # likewise
    return out, kinds


# -- check -------------------------------------------------------------------------------------

def check(run, out) -> bool:
    """After a phase: stop the run on a solver failure, a penetration, a non-finite state, t_end or a stalled
    loop; otherwise advance run.t, run.y to the phase end. True when an event is left to dispatch."""
    s, t = run.settings, run.t
    if out.failed is not None:
        singular = run.equations.singular
        run.end("solver", t=t, error=out.failed,
                singular="" if singular is None else f"; the mass matrix was singular at a trial state {singular}")
        return False
    run.equations.singular = None
    # Between events no contact point may be beyond a wall (step ends and in-step samples).
    if out.min_gap < -s.penetration_tol:
        what = "a wall or a joint limit" if run.stops is not None else "a wall"
        run.end("penetration", depth=-out.min_gap, what=what, t=t)
        return False
    if run.resting.any():
        run.counters["resting_time"] += out.t - t
    run.t, run.y = out.t, out.y
    if not np.all(np.isfinite(run.y)):
        run.end("non_finite", t=run.t)
        return False
    if out.event is None:
        run.end("t_end", t_end=s.t_end)
        return False
    run.stalled = run.stalled + 1 if run.t - t <= 1e-14 * max(1.0, abs(run.t)) else 0
    if run.stalled >= MAX_STALLED:
        run.end("stalled", t=run.t, count=MAX_STALLED)
        return False
    return True


# -- dispatch ----------------------------------------------------------------------------------

def _mode_event(run, kind, w_i, j) -> None:
    """A resting pair's force reached zero (it leaves the active set), its drift reached contact_tol
    (projection), its friction reached the cone (it slips) or its slip stopped (it may stick)."""
    run.counters["mode_events"] += 1
    if run.counters["mode_events"] > MAX_MODE_EVENTS:
        run.end("mode_events", count=MAX_MODE_EVENTS, t=run.t)
        return
    if w_i == len(run.settings.walls):
        if kind == "release":  # an end stop's force reached zero (a drift event only projects again)
            run.stops.released[j] = True
    elif kind == "release":
        run.release = np.zeros(run.resting.active.shape, dtype=bool)
        run.release[w_i, j] = True
    elif kind == "slip":
        N, t = run.N, run.t
        q, qd = run.y[:N], run.y[N:2 * N]
        run.slipping = {(w_i, j): run.resting.slip_direction(q, qd, run.equations.applied(t, q, qd), (w_i, j))}
    run.pending_mode = True


def _limit_event(run, kind, j) -> None:
    """A joint limit's event (the gap matrix's last row): leave its band, stop, or an end-stop impact."""
    s, N, stops = run.settings, run.N, run.stops
    if kind == "leave":
        stops.near[j] = False
    elif s.joint_limit == "stop":
        run.end("joint_limit", joint=run.limits[j].joint, limit=run.limits[j].name, t=run.t)
    else:
        try:
            rec = stops.impact(run.model, run.t, run.y[:N], run.y[N:2 * N], j, s.joint_restitution,
                               s.grazing_velocity, kind == "sink", _index(s.prescribed))
        except HeldContactError as exc:
            run.end("held_contact", t=run.t, error=exc)
            return
        if rec is not None:
            _record_impact(run, rec, run.y[:N])
            # (held stops are not modelled with prescribed coordinates: there the old stop stays)
            rest = s.accumulation != "stop" and s.prescribed is None
            accumulation = stops.accumulation(rec.time, j, s.zeno_count, s.zeno_interval, rest=rest)
            if accumulation is not None:
                run.end("end_stop_accumulation", accumulation=accumulation)
                return
            # Resting pairs may have been pushed by the end-stop impulse; a stop that no longer
            # rebounds (e_stop = 0, or an accumulation) is held from the mode decision on.
            run.pending_impact = run.resting.any()
            run.pending_mode = rest


def dispatch(run, out, kinds) -> None:
    """What the event that ended the phase leads to: a mode decision, a joint limit's rule, an impact stage,
    or re-arming a pair that left the contact band."""
    kind, w_i, j = kinds[out.event]
    if kind == "chart":
        run.pending_chart = True  # the chart stage re-charts before the next phase (simulation.charts)
    elif kind in MODE_EVENTS:
        _mode_event(run, kind, w_i, j)
    elif kind in COMPLIANT_EVENTS:
        compliant_event(run, kind, w_i, j)
    elif w_i == len(run.settings.walls):
        _limit_event(run, kind, j)
    else:
        run.sink_pair = (w_i, j) if kind == "sink" else None
        if kind == "leave":
            run.near[w_i, j] = False  # re-arm the normal event of this pair; no impact
            run.monitor.left_band(w_i, j)
        else:
            run.pending_impact = True


# -- finish ------------------------------------------------------------------------------------

def interrupted(run, what: str) -> None:
    """A KeyboardInterrupt stopped the run: keep the accepted steps of a phase whose samples were not recorded."""
    flown = run.flown
    if flown is not None and flown.sample_t.size and not run.recorder.ends_with(flown.sample_t):
        run.recorder.flight(flown.sample_t, flown.sample_y, run.phase)
    t_last = float(run.recorder.chunks[-1].t[-1])
    run.end("interrupted", what=what, t=t_last, t_end=run.settings.t_end)


def stopped_inside(run, reason: str, error) -> None:
    """A right-hand side stopped the run (reason "callback": a user callback's CallbackError; "budget": the
    BudgetExceeded of a used-up limit): stop, keeping what was recorded."""
    run.end(reason, error=error, t=float(run.recorder.chunks[-1].t[-1]), t_end=run.settings.t_end)


def finish(run, started: float) -> Result:
    """The Result of the run: every recorded sample, impact and force, its status and counters."""
    if run.status is None:
        run.status = STATUS_FINISHED
    t_all, q_all, qdot_all, phase_all, work_all, E_all, F_all, Ft_all, S_all = run.recorder.arrays()
    P = run.model.n_joints
    X_all = run.recorder.abscissae()
    if not np.any(F_all[:, :, P:]):  # no span point rested: the joint points' columns only, as before
        F_all, Ft_all, X_all = F_all[:, :, :P], Ft_all[:, :, :P], None
    walls = run.settings.walls
    return Result(
        model=run.model.chart_root, walls=walls, t=t_all, q=q_all, qdot=qdot_all, phase=phase_all,
        impacts=run.recorder.impacts, status=run.status, message=run.message,
        settings={**run.settings.record(), **run.equations.radau_record(), **_stepped(run)},
        nfev=run.equations.nfev, n_steps=run.counters["n_steps"], n_examined=run.counters["n_examined"],
        wall_time=time.perf_counter() - started, energy_error=run.recorder.energy_error,
        energy_error_whole_run_J=run.recorder.balance_J,
        _energy_cache=E_all, work=work_all if run.equations.driven else None, contact_forces=F_all,
        contact_abscissae=X_all, friction_forces=Ft_all if any(w.friction > 0 for w in walls) else None,
        resting_time=run.counters["resting_time"], stop_forces=S_all, **_efforts(run, t_all, q_all, qdot_all),
        base_chart=run.recorder.base_charts(), charts=run.recorder.chart_changes,
        **({} if run.compliant is None else dict(zip(
            ("compliant_forces", "compliant_points", "compliant_integrals"),
            run.recorder.compliant_arrays(run.compliant.active.shape)),
            compliant_contacts=list(run.compliant.log))),
    )


def _stepped(run) -> dict:
    """For Result.settings: {"stepped_phases": k, "contact_steps": n, "stepped_contact_work_J": W [J]} of a run with
    time-stepping contact phases (simulation.stepping; W the work of their contact impulses and projections, which
    Result.energy_audit lists); {} else."""
    c = run.counters
    return {"stepped_phases": c["stepped_phases"], "contact_steps": c["contact_steps"],
            "stepped_contact_work_J": float(c["stepped_contact_work"])} if c["stepped_phases"] else {}


def _efforts(run, t, q, qdot) -> dict:
    """Result's prescribed (names) and effort (K, n_p) [N m or N] at every sample ({} without prescribed
    coordinates). One chart serves every sample: a run with prescribed coordinates has no resting or compliant
    contact force, and the joint efforts of a free-floating chain do not change under a rotation of the whole
    (uniform gravity included), which is all a change of the free base's chart is (simulation.charts)."""
    P = run.settings.prescribed
    if P is None:
        return {}
    try:
        effort = run.equations.efforts(t, q, qdot)
    except (SingularMassMatrixError, CallbackError):  # a run that stopped on such a state: NaN there
        effort = np.array([_effort_or_nan(run, *a) for a in zip(t, q, qdot)]).reshape(len(t), len(P.index))
    return dict(prescribed=P.names, effort=effort)


def _effort_or_nan(run, t, q, qd) -> np.ndarray:
    try:
        return run.equations.partitioned(t, q, qd)[4]
    except (SingularMassMatrixError, CallbackError):
        return np.full(len(run.settings.prescribed.index), np.nan)
