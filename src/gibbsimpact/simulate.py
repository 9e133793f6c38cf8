"""The one module that owns the integrate - detect - impact loop (formulation.md section 7).

Flight phases are integrated by ``scipy.integrate.solve_ivp`` with one terminal
event per (joint, wall) pair, ``g_w(O_j(q(t)))``, direction -1. At an event the
impact set is every joint within ``contact_tol`` of a wall; the impulses come
from :func:`gibbsimpact.impact.solve_impulses` and integration restarts.

Event-loop rules (each one has a test in tests/test_simulate.py):

* Simultaneous contacts: all candidates with g <= 2 contact_tol at the event
  time enter one impulse problem (approaching ones with Newton's law, the
  others only with "must not start to penetrate").
* Restart: a candidate with g <= 2 contact_tol at the start of a phase (the
  contact band) is watched by two events instead of g = 0: ``g = min(g_start,
  0) - sink_depth`` with sink_depth = max(1e-6 contact_tol, 64 eps (1 + max|p|))
  (direction -1: it sinks, which is handled as an impact; measured from the
  gap at the phase start so the event function starts positive, above
  round-off, even right after a sink) and
  ``g - 3 contact_tol`` (direction +1: it has left the band; the phase ends
  and the normal event is re-armed). So an impact never re-fires at its own time and
  a point cannot slip through the wall unnoticed. After each phase the gaps
  at all accepted steps are checked; a gap below -penetration_tol stops the
  run with status "penetration".
* Grazing: an event whose candidates have normal velocity
  v_n >= -grazing_velocity carries no impulse; it is not an impact. (A pair
  caught by its sink event is still stopped if v_n < 0.)
* Stall guard: 100 consecutive events without progress in time stop the run
  with status "failed" instead of hanging.
* Accumulation of impacts (Zeno): when ``zeno_count`` consecutive impacts each
  follow the previous one by less than ``zeno_interval`` seconds, the run
  stops with status "zeno" and an estimate of the accumulation time; the
  results so far are kept.
"""

from __future__ import annotations

import time
from numbers import Real

import numpy as np
from scipy.integrate import solve_ivp

from .dynamics import Energy, SingularMassMatrixError, _energy_from, forward_dynamics, mass_matrix
from .impact import solve_impulses
from .kinematics import joint_positions_and_jacobians, transforms
from .results import (
    STATUS_FAILED,
    STATUS_FINISHED,
    STATUS_MAX_IMPACTS,
    STATUS_PENETRATION,
    STATUS_ZENO,
    ImpactRecord,
    Result,
)
from .walls import WALL_TYPES, describe

_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA", "RK23")


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


def _check_inside(model, q, walls, contact_tol):
    """Raise ValueError naming every joint that starts beyond a wall."""
    p = transforms(model, q)[:, :3, 3]
    bad = []
    for w_i, w in enumerate(walls):
        g = w.gap(p)
        for j in np.nonzero(g < -contact_tol)[0]:
            bad.append(
                f"joint O{j + 1} at {np.round(p[j], 6).tolist()} m is {-g[j]:.3g} m outside wall {w_i + 1} ({describe(w)})"
            )
    if bad:
        raise ValueError("initial state q0 puts a joint outside a wall: " + "; ".join(bad) + ". Move the chain inside.")


def _accumulation_time(times, intervals):
    """Estimate of the accumulation time of a run of impacts, and the ratio used.

    times : (k,) impact times [s]; intervals : (k,) the interval ending at each.
    Geometric extrapolation t_inf = t_j + d_j r / (1 - r) from the most geometric
    pair (smallest r = d_j / d_(j-1)): the latest intervals can be limited by the
    contact band and tend to a constant.
    """
    d = np.asarray(intervals, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = d[1:] / d[:-1]
    ok = np.isfinite(ratios) & (ratios > 0) & (ratios < 1)
    if not np.any(ok):
        return float(times[-1]), float("nan")
    j = int(np.argmin(np.where(ok, ratios, np.inf)))
    r = float(ratios[j])
    return float(times[j + 1] + d[j + 1] * r / (1 - r)), r


class _Clock:
    """Calls progress(t, n_impacts) at most every `every` seconds of wall time."""

    def __init__(self, progress, every=0.2):
        self.progress, self.every, self.last, self.n_impacts = progress, every, time.monotonic(), 0

    def tick(self, t):
        if self.progress is not None:
            now = time.monotonic()
            if now - self.last >= self.every:
                self.last = now
                self.progress(float(t), self.n_impacts)


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
) -> Result:
    """Simulate flight phases and impacts from (q0, qdot0) over t_span.

    Parameters
    ----------
    model : Model
    q0, qdot0 : (N,) initial coordinates and velocities (order: model.coordinate_names)
    t_span : (t0, t_end) [s]
    walls : sequence of Circle, Sphere, Plane
    restitution : float in [0, 1], used for walls whose own ``restitution`` is None
    rtol, atol : solve_ivp tolerances
    method : solve_ivp method ("DOP853" recommended: explicit, high order)
    output_dt : float [s] or None; None stores every accepted step, a float
        stores uniform samples from the dense output (plus every impact's both sides)
    max_step : float [s], solve_ivp's maximal step
    contact_tol : float [m], gap within which joints belong to one impact
    grazing_velocity : float [m/s], an event with v_n >= -grazing_velocity is no impact
    penetration_tol : float [m], a gap below -penetration_tol between events stops the run
    zeno_interval : float [s], zeno_count : int — the accumulation criterion
    max_impacts : int, impact budget
    progress : callable(t, n_impacts) or None

    Returns
    -------
    Result, with status "finished" or why it stopped early.
    """
    started = time.perf_counter()
    q0, qdot0, (t0, t_end), walls = _validate(
        model, q0, qdot0, t_span, walls, restitution, method,
        rtol=rtol, atol=atol, max_step=max_step, contact_tol=contact_tol,
        grazing_velocity=grazing_velocity, penetration_tol=penetration_tol, zeno_interval=zeno_interval,
    )
    if output_dt is not None:
        output_dt = _positive("output_dt", output_dt)
    for name, v in (("zeno_count", zeno_count), ("max_impacts", max_impacts)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"simulate {name}={v!r} must be an integer >= 1")
    _check_inside(model, q0, walls, contact_tol)
    try:
        mass_matrix(model, q0)
        forward_dynamics(model, q0, qdot0)
    except SingularMassMatrixError as exc:
        raise SingularMassMatrixError(f"initial state q0: {exc}") from None

    N = model.n_dof
    n_joints = model.n_joints
    e_wall = np.array([restitution if w.restitution is None else w.restitution for w in walls])
    settings = dict(
        method=method, rtol=rtol, atol=atol, restitution=float(restitution),
        wall_restitution=[w.restitution for w in walls], output_dt=output_dt, max_step=max_step,
        contact_tol=contact_tol, grazing_velocity=grazing_velocity, penetration_tol=penetration_tol,
        zeno_interval=zeno_interval, zeno_count=int(zeno_count), max_impacts=int(max_impacts),
        t_span=[t0, t_end],
    )
    clock = _Clock(progress)
    counters = {"nfev": 0}

    def rhs(t, y):
        counters["nfev"] += 1
        clock.tick(t)
        return np.concatenate((y[N:], forward_dynamics(model, y[:N], y[N:])))

    # Gaps of all (joint, wall) pairs, cached per state: every event function of
    # one step is evaluated at the same (t, y).
    cache = {"key": None, "g": None}

    def gaps(y):
        key = y.tobytes()
        if cache["key"] != key:
            p = transforms(model, y[:N])[:, :3, 3]
            cache["g"] = np.array([w.gap(p) for w in walls]).reshape(len(walls), n_joints)
            cache["key"] = key
        return cache["g"]

    def make_event(w_i, j, offset, direction):
        def ev(t, y):
            return gaps(y)[w_i, j] + offset

        ev.terminal = True
        ev.direction = direction
        return ev

    def contact_data(q):
        """Gaps (W, J), normals (W, J, 3), Jacobians (J, 3, N) at q."""
        p, Jac = joint_positions_and_jacobians(model, q)
        g = np.array([w.gap(p) for w in walls]).reshape(len(walls), n_joints)
        nrm = np.array([w.normal(p) for w in walls]).reshape(len(walls), n_joints, 3)
        return g, nrm, Jac

    ts, qs, qds, phases = [np.array([t0])], [q0[None, :]], [qdot0[None, :]], [np.array([0])]
    # Energy of every stored sample: needed for the flight-phase drift, then handed
    # to the Result so res.energy() does not evaluate M at every sample again.
    energies = [_energy_from(model, q0, qdot0, mass_matrix(model, q0))]
    impacts: list[ImpactRecord] = []
    energy_error = 0.0
    n_steps = 0
    status, message = STATUS_FINISHED, f"reached t_end = {t_end:g} s"
    t, y, phase = t0, np.concatenate((q0, qdot0)), 0
    near = np.zeros((len(walls), n_joints), dtype=bool)
    pending_impact = True  # check the initial state for an impact in progress
    recent_gaps: list[float] = []
    sink_pair = None  # (wall, joint) whose sink event ended the last phase
    stalled = 0  # consecutive phases that made no progress in time

    while True:
        q, qd = y[:N], y[N:]
        if pending_impact and walls:
            g, nrm, Jac = contact_data(q)
            # Candidates of this impact: every pair within the contact band (a pair
            # caught by its "sink" event sits just below its phase-start gap).
            near = g <= 2.0 * contact_tol
            rec = None
            if np.any(near):
                pairs = np.argwhere(near)  # (k, 2): wall, joint
                normals = nrm[pairs[:, 0], pairs[:, 1]]
                Wmat = np.einsum("kc,kcn->nk", normals, Jac[pairs[:, 1]])
                v_before = Wmat.T @ qd
                # An impact: some candidate approaches faster than grazing, or the
                # pair whose "sink" event fired is still approaching (it must be stopped).
                sinking = sink_pair is not None and np.any(
                    (pairs[:, 0] == sink_pair[0]) & (pairs[:, 1] == sink_pair[1]) & (v_before < 0)
                )
                if np.any(v_before < -grazing_velocity) or sinking:
                    M = mass_matrix(model, q)
                    e_k = e_wall[pairs[:, 0]]
                    sol = solve_impulses(M, Wmat, qd, e_k)
                    E_before = _energy_from(model, q, qd, M)
                    E_after = _energy_from(model, q, sol.qdot_after, M)
                    rec = ImpactRecord(
                        time=t, joints=tuple(int(j) + 1 for j in pairs[:, 1]), wall=tuple(int(w) for w in pairs[:, 0]),
                        normals=normals, impulses=sol.impulses, v_before=sol.v_before, v_after=sol.v_after,
                        restitution=e_k, qdot_before=qd.copy(), qdot_after=sol.qdot_after.copy(),
                        energy_before=E_before, energy_after=E_after,
                    )
            if rec is not None:
                impacts.append(rec)
                clock.n_impacts = len(impacts)
                y = np.concatenate((q, rec.qdot_after))
                phase += 1
                ts.append(np.array([t]))
                qs.append(q[None, :].copy())
                qds.append(rec.qdot_after[None, :].copy())
                phases.append(np.array([phase]))
                energies.append(rec.energy_after)
                if len(impacts) > 1:
                    recent_gaps.append(t - impacts[-2].time)
                    if len(recent_gaps) >= zeno_count and all(d < zeno_interval for d in recent_gaps[-zeno_count:]):
                        win = np.array(recent_gaps[-zeno_count:])
                        t_acc, ratio = _accumulation_time([r_.time for r_ in impacts[-zeno_count:]], win)
                        d1 = float(win[-1])
                        status = STATUS_ZENO
                        message = (
                            f"accumulation of impacts: {zeno_count} consecutive impacts less than "
                            f"{zeno_interval:g} s apart (last interval {d1:.3g} s, interval ratio {ratio:.3g}); "
                            f"estimated accumulation time {t_acc:.9g} s. Sustained contact is not modelled; "
                            "results up to here are kept"
                        )
                        break
                if len(impacts) >= max_impacts:
                    status, message = STATUS_MAX_IMPACTS, f"stopped after max_impacts = {max_impacts} impacts at t = {t:.9g} s"
                    break
        pending_impact = False
        if t >= t_end:
            break

        # Events of this phase: normal ones, or the sink/leave pair for near contacts.
        events, kinds = [], []
        g_start = gaps(y) if walls else None
        sink_depth = max(1e-6 * contact_tol, 64 * np.finfo(float).eps * (1.0 + float(np.abs(y[:3]).max())))
        for w_i in range(len(walls)):
            for j in range(n_joints):
                if near[w_i, j]:
                    # Sink level min(g_start, 0) - sink_depth: the event function starts at
                    # sink_depth > 0 (above the gap's round-off), so a bounce lower than one
                    # solver step that falls back is still a sign change (never tunnels),
                    # and a joint that keeps bouncing sinks by only sink_depth per impact
                    # (the geometric sequence of an accumulation is kept down to ~1e-7 m/s).
                    events.append(make_event(w_i, j, sink_depth - min(float(g_start[w_i, j]), 0.0), -1))
                    kinds.append(("sink", w_i, j))
                    events.append(make_event(w_i, j, -3.0 * contact_tol, 1))
                    kinds.append(("leave", w_i, j))
                else:
                    events.append(make_event(w_i, j, 0.0, -1))
                    kinds.append(("hit", w_i, j))
        E_start = energies[-1]  # the last stored sample is the state y of this phase start
        E_scale = max(abs(E_start.total), abs(E_start.kinetic) + abs(E_start.gravity) + abs(E_start.strain), 1e-300)
        try:
            sol = solve_ivp(
                rhs, (t, t_end), y, method=method, rtol=rtol, atol=atol, max_step=max_step,
                events=events or None, dense_output=output_dt is not None,
            )
        except (SingularMassMatrixError, FloatingPointError, ValueError, np.linalg.LinAlgError) as exc:
            status, message = STATUS_FAILED, f"integration failed after t = {t:.9g} s: {exc}"
            break
        n_steps += len(sol.t) - 1
        if sol.status == -1:
            status, message = STATUS_FAILED, f"solve_ivp failed after t = {t:.9g} s: {sol.message}"
        fired = [k for k, te in enumerate(sol.t_events or []) if len(te)]
        if fired:
            t_new = float(sol.t_events[fired[0]][0])
            y_new = np.asarray(sol.y_events[fired[0]][0], dtype=float)
        else:
            t_new, y_new = float(sol.t[-1]), sol.y[:, -1]
        # Samples of this phase (excluding its start, already stored).
        if output_dt is not None:
            grid = t0 + output_dt * np.arange(np.floor((t - t0) / output_dt) + 1, np.ceil((t_new - t0) / output_dt))
            grid = grid[(grid > t) & (grid < t_new)]
            Y = np.concatenate((sol.sol(grid), y_new[:, None]), axis=1) if grid.size else y_new[:, None]
            T = np.append(grid, t_new)
        else:
            T, Y = sol.t[1:].copy(), sol.y[:, 1:].copy()
            if T.size == 0 or T[-1] != t_new:
                T, Y = np.append(T, t_new), np.concatenate((Y, y_new[:, None]), axis=1)
            else:
                Y[:, -1] = y_new
        ts.append(T)
        qs.append(Y[:N].T)
        qds.append(Y[N:].T)
        phases.append(np.full(T.size, phase))
        # Energy drift over this flight phase, at the stored samples.
        for k in range(T.size):
            Ek = _energy_from(model, Y[:N, k], Y[N:, k], mass_matrix(model, Y[:N, k]))
            energies.append(Ek)
            energy_error = max(energy_error, abs(Ek.total - E_start.total) / E_scale)
        if status == STATUS_FAILED:
            break
        # Between events no joint may be beyond a wall (checked at every accepted step).
        if walls:
            worst = min(float(gaps(sol.y[:, k].copy()).min()) for k in range(sol.y.shape[1]))
            if worst < -penetration_tol:
                status = STATUS_PENETRATION
                message = (
                    f"a joint went {-worst:.3g} m beyond a wall between events in the phase starting at "
                    f"t = {t:.9g} s without an event firing; tighten rtol or set max_step"
                )
                break
        t_prev, (t, y) = t, (t_new, y_new)
        if not np.all(np.isfinite(y)):
            status, message = STATUS_FAILED, f"state became non-finite at t = {t:.9g} s"
            break
        if not fired:
            break
        kind, w_i, j = kinds[fired[0]]
        sink_pair = (w_i, j) if kind == "sink" else None
        if kind == "leave":
            near[w_i, j] = False  # re-arm the normal event of this pair; no impact
        else:
            pending_impact = True
        stalled = stalled + 1 if t_new - t_prev <= 1e-14 * max(1.0, abs(t_new)) else 0
        if stalled >= 100:
            status = STATUS_FAILED
            message = f"event loop stalled at t = {t:.9g} s: 100 consecutive events without progress in time"
            break

    t_all = np.concatenate(ts)
    res = Result(
        model=model, walls=walls, t=t_all, q=np.concatenate(qs), qdot=np.concatenate(qds),
        phase=np.concatenate(phases), impacts=impacts, status=status, message=message, settings=settings,
        nfev=counters["nfev"], n_steps=n_steps, wall_time=time.perf_counter() - started,
        energy_error=float(energy_error),
        _energy_cache=Energy(*(np.array(col) for col in zip(*energies))),
    )
    if progress is not None:
        progress(float(t_all[-1]), len(impacts))
    return res
