"""The one module that owns the integrate - detect - impact loop (formulation.md section 7).

A run alternates two stages until t_end or a stop:

* **flight** (:func:`gibbsimpact.flight.integrate_phase`): scipy's ODE solver
  steps the equations of motion; one terminal event per (joint, wall) pair,
  ``g_w(O_j(q(t)))``, direction -1, located at step ends *and inside steps*
  (a dip of a gap between two accepted steps is found from the dense output,
  see flight.py);
* **impact** (:func:`_impact_stage`): every joint within the contact band
  ``g <= 2 contact_tol`` at the event time is a contact of one impact; the
  impulses come from :func:`gibbsimpact.impact.solve_impulses` (rounds of
  Newton's law, never raising the kinetic energy).

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
* Accumulation of impacts (:class:`_Accumulation`), status "zeno", results
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
from contextlib import contextmanager
from numbers import Real
from typing import NamedTuple

import numpy as np

from .dynamics import Energy, SingularMassMatrixError, energies, energy, forward_dynamics, mass_matrix
from .flight import SOLVERS, EventSpec, integrate_phase
from .forces import damping_depends_on_q, damping_matrix, generalized_force
from .impact import solve_impulses
from .kinematics import joint_positions, joint_positions_and_jacobians, joint_positions_batch
from .limits import JOINT_LIMIT_MODES, STATUS_JOINT_LIMIT, check_initial, joint_limits, limit_gaps
from .results import (
    STATUS_FAILED,
    STATUS_FINISHED,
    STATUS_MAX_IMPACTS,
    STATUS_PENETRATION,
    STATUS_ZENO,
    ImpactRecord,
    Result,
)
from .validity import warn_result, warn_state
from .walls import WALL_TYPES, describe

_METHODS = tuple(SOLVERS)

#: Status of a run stopped by a KeyboardInterrupt (Ctrl-C, SIGTERM in the command line);
#: the Result holds everything computed until then.
STATUS_INTERRUPTED = "interrupted"


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
    p = joint_positions(model, q)
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
    """Calls progress(t, n_impacts) at most every `every` seconds of wall time (5 times a second)."""

    def __init__(self, progress, every=0.2):
        self.progress, self.every, self.last, self.n_impacts = progress, every, time.monotonic(), 0

    def tick(self, t):
        if self.progress is not None:
            now = time.monotonic()
            if now - self.last >= self.every:
                self.last = now
                self.progress(float(t), self.n_impacts)


class _ProgressBar:
    """``progress=True``: a tqdm bar over simulated time t - t0 [s] on stderr, fed by _Clock.

    tqdm is imported here, when a bar is asked for. The solver calls the
    right-hand side at trial times that can step back, so the bar only moves forward.
    """

    def __init__(self, t0: float, t_end: float):
        from tqdm.auto import tqdm

        self.t0 = t0
        self.bar = tqdm(total=t_end - t0, desc="simulate", unit="s", leave=True,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g} / {total:.4g} s "
                                   "[{elapsed}<{remaining}{postfix}]")
        self.bar.set_postfix_str("impacts: 0", refresh=False)

    def __call__(self, t: float, n_impacts: int):
        self.bar.set_postfix_str(f"impacts: {n_impacts}", refresh=False)
        step = min(t - self.t0, self.bar.total) - self.bar.n
        if step > 0:
            self.bar.update(step)
        else:
            self.bar.refresh()

    def close(self):
        self.bar.close()


@contextmanager
def _progress_reporter(progress, t0: float, t_end: float):
    """The callable progress(t, n_impacts) for simulate's ``progress`` argument, or None; closes a bar at the end.

    progress : None or False (nothing), True (a tqdm bar on stderr), or a callable.
    """
    if progress is None or progress is False:
        yield None
    elif progress is True:
        bar = _ProgressBar(t0, t_end)
        try:
            yield bar
        finally:
            bar.close()
    elif callable(progress):
        yield progress
    else:
        raise ValueError(f"simulate progress={progress!r} must be None, True (a progress bar on stderr) "
                         "or a callable progress(t, n_impacts)")


class _Contacts:
    """Gaps, normals and Jacobians of every (wall, joint) pair: g (W, J) [m], n (W, J, 3), J (J, 3, N)."""

    def __init__(self, model, walls):
        self.model, self.walls = model, walls
        self.N, self.n_joints = model.n_dof, model.n_joints
        self._key, self._g = None, None

    def gaps(self, q: np.ndarray) -> np.ndarray:
        """g (W, J) [m]; cached per q (every event function of a step sees the same q)."""
        key = q.tobytes()
        if key != self._key:
            p = joint_positions(self.model, q)
            self._g = np.array([w.gap(p) for w in self.walls]).reshape(len(self.walls), self.n_joints)
            self._key = key
        return self._g

    def gaps_batch(self, qs: np.ndarray) -> np.ndarray:
        """g (K, W, J) [m] of the states qs (K, N): one kernel call for all of them."""
        if not self.walls:
            return np.zeros((len(qs), 0, self.n_joints))
        P = joint_positions_batch(self.model, qs)  # (K, J, 3)
        return np.stack([w.gap(P) for w in self.walls], axis=1).reshape(len(qs), len(self.walls), self.n_joints)

    def full(self, q: np.ndarray):
        p, Jac = joint_positions_and_jacobians(self.model, q)
        g = np.array([w.gap(p) for w in self.walls]).reshape(len(self.walls), self.n_joints)
        nrm = np.array([w.normal(p) for w in self.walls]).reshape(len(self.walls), self.n_joints, 3)
        return g, nrm, Jac


def contact_band(contact_tol: float, lipschitz: float, rtol: float, atol: float, q: np.ndarray) -> float:
    """The contact band b [m] at q (N,): gaps within it belong to one impact (module docstring).

    b = max(2 contact_tol, L_q (atol + rtol max|q|)), L_q [m per unit of q] a bound on |dg/dq|.
    """
    return max(2.0 * contact_tol, lipschitz * (atol + rtol * float(np.abs(q).max(initial=0.0))))


def _impact_stage(model, contacts, e_wall, t, q, qd, band, grazing_velocity, sink_pair):
    """The impact at (t, q, qd), if there is one.

    Returns (record or None, near (W, J) bool: the pairs in the contact band g <= band [m]).
    """
    g, nrm, Jac = contacts.full(q)
    # Candidates: every pair within the contact band (a pair caught by its "sink"
    # event sits just below its phase-start gap).
    near = g <= band
    if not np.any(near):
        return None, near
    pairs = np.argwhere(near)  # (k, 2): wall, joint
    normals = nrm[pairs[:, 0], pairs[:, 1]]
    Wmat = np.einsum("kc,kcn->nk", normals, Jac[pairs[:, 1]])
    v_before = Wmat.T @ qd
    # An impact: some candidate approaches faster than grazing, or the pair whose
    # "sink" event fired is still approaching (it must be stopped).
    sinking = sink_pair is not None and np.any(
        (pairs[:, 0] == sink_pair[0]) & (pairs[:, 1] == sink_pair[1]) & (v_before < 0)
    )
    if not (np.any(v_before < -grazing_velocity) or sinking):
        return None, near
    M = mass_matrix(model, q)
    e_k = e_wall[pairs[:, 0]]
    sol = solve_impulses(M, Wmat, qd, e_k)
    rec = ImpactRecord(
        time=t, joints=tuple(int(j) + 1 for j in pairs[:, 1]), wall=tuple(int(w) for w in pairs[:, 0]),
        normals=normals, impulses=sol.impulses, v_before=sol.v_before, v_after=sol.v_after,
        restitution=e_k, qdot_before=qd.copy(), qdot_after=sol.qdot_after.copy(),
        energy_before=energy(model, q, qd), energy_after=energy(model, q, sol.qdot_after),
        rounds=len(sol.rounds),
    )
    return rec, near


def _phase_events(near, g_start, band, sink_depth):
    """EventSpec of one phase and the kind of each event ("hit", "sink", "leave").

    near : (W, J) pairs in the contact band at the phase start; g_start : (W, J) their gaps [m].
    """
    rows, kinds = [], []
    for w_i, j in np.ndindex(near.shape):
        if near[w_i, j]:
            # Sink level min(g_start, 0) - sink_depth: the event function starts at
            # sink_depth > 0 (above the gap's round-off), so a bounce lower than one
            # solver step that falls back is still a sign change (never tunnels).
            rows.append((w_i, j, sink_depth - min(float(g_start[w_i, j]), 0.0), -1.0))
            kinds.append(("sink", w_i, j))
            rows.append((w_i, j, -1.5 * band, 1.0))
            kinds.append(("leave", w_i, j))
        else:
            rows.append((w_i, j, 0.0, -1.0))
            kinds.append(("hit", w_i, j))
    a = np.array(rows, dtype=float).reshape(-1, 4)
    return EventSpec(a[:, 0].astype(int), a[:, 1].astype(int), a[:, 2], a[:, 3]), kinds


class _Accumulation:
    """Detects an accumulation of impacts (rules (a) and (b) of the module docstring)."""

    def __init__(self, shape, zeno_count, zeno_interval, band):
        self.count, self.interval, self.band = zeno_count, zeno_interval, band
        self.streak = np.zeros(shape, dtype=int)  # consecutive in-band impacts per (wall, joint)
        self.times: list[float] = []

    def left_band(self, w_i, j):
        self.streak[w_i, j] = 0

    def add(self, rec, in_band_before) -> str | None:
        """Register an impact; in_band_before (W, J): pairs that stayed in the band since the last impact.

        Returns the stop message, or None.
        """
        self.times.append(rec.time)
        for w_i, j, lam in zip(rec.wall, rec.joints, rec.impulses):
            if lam > 0:
                self.streak[w_i, j - 1] = self.streak[w_i, j - 1] + 1 if in_band_before[w_i, j - 1] else 0
        k = self.count
        times = np.array(self.times[-(k + 1):])
        d = np.diff(times)
        if np.max(self.streak) >= k:
            w_i, j = np.unravel_index(int(np.argmax(self.streak)), self.streak.shape)
            why = (f"joint O{j + 1} stayed within {1.5 * self.band:.3g} m of wall {w_i + 1} through {k} consecutive "
                   "impacts (its rebounds no longer leave the contact band)")
        elif d.size >= k and np.all(d[-k:] < self.interval):
            why = f"{k} consecutive impacts less than {self.interval:g} s apart"
        else:
            return None
        d = d[-k:]
        t_acc, ratio = _accumulation_time(times[-d.size:], d)
        if not ratio < 0.9:
            # Intervals that do not shrink: the contact is closed (resting or sliding) since then.
            t_acc, ratio = float(times[-d.size - 1] if times.size > d.size else times[0]), ratio
        return (f"accumulation of impacts: {why}; last interval {d[-1]:.3g} s, interval ratio {ratio:.3g}; "
                f"estimated accumulation time {t_acc:.9g} s: resting contact from t = {t_acc:.9g} s, which is not "
                "modelled yet; results up to here are kept")


class _Chunk(NamedTuple):
    """Samples recorded at once: an impact (one sample, its record) or a flight phase (k samples)."""

    t: np.ndarray  # (k,) [s]
    q: np.ndarray  # (k, N)
    qdot: np.ndarray  # (k, N)
    phase: np.ndarray  # (k,) int
    work: np.ndarray  # (k, 2) [J]
    energy: Energy  # each field (k,) [J]
    error: float  # energy balance error of these samples (relative)
    impact: ImpactRecord | None


def _one(E: Energy) -> Energy:
    """Energy of one state as arrays of one sample."""
    return Energy(*(np.array([float(v)]) for v in E))


class _Recorder:
    """Stored samples (t, q, qdot, phase, work), their energies, the impacts, and the flight-phase energy balance.

    work : (K, 2) [J] the work of the inputs and of the damping since t0 (zeros
    for an undriven, undamped run). In a flight phase E(t) - E(start) equals
    W(t) - W(start) up to the integration error, which is what energy_error measures.

    Everything is kept as a list of _Chunk, each added by one ``list.append``:
    a KeyboardInterrupt anywhere leaves whole chunks only, so the Result built
    from them after an interrupt is consistent (every sample with its energy,
    every impact with the sample after it).
    """

    def __init__(self, model, t0, q0, qdot0):
        self.model = model
        # Energy of every stored sample: needed for the flight-phase drift, then handed
        # to the Result so res.energy() does not evaluate M at every sample again.
        self.chunks = [_Chunk(np.array([t0]), q0[None, :], qdot0[None, :], np.array([0]), np.zeros((1, 2)),
                              _one(energy(model, q0, qdot0)), 0.0, None)]
        self.n_impacts = 0

    def impact(self, rec, q, phase):
        last = self.chunks[-1]
        self.chunks.append(_Chunk(np.array([rec.time]), q[None, :].copy(), rec.qdot_after[None, :].copy(),
                                  np.array([phase]), last.work[-1:].copy(), _one(rec.energy_after), 0.0, rec))
        self.n_impacts += 1

    def flight(self, T, Y, phase):
        """Samples T (K,), Y (K, 2N [+ 2]) of a flight phase that started at the last stored sample."""
        N = self.model.n_dof
        last = self.chunks[-1]
        E_start = Energy(*(float(a[-1]) for a in last.energy))
        W_start = last.work[-1].sum()
        W = Y[:, 2 * N:2 * N + 2] if Y.shape[1] > 2 * N else np.zeros((T.size, 2))
        scale = max(abs(E_start.total), abs(E_start.kinetic) + abs(E_start.gravity) + abs(E_start.strain),
                    float(np.max(np.abs(W.sum(axis=1) - W_start), initial=0.0)), 1e-300)
        # All samples in one kernel call; the balance E(t) - E(0) - W(t) per sample.
        E = energies(self.model, Y[:, :N], Y[:, N:2 * N])
        err = float(np.abs(E.total - E_start.total - (W.sum(axis=1) - W_start)).max() / scale) if T.size else 0.0
        self.chunks.append(_Chunk(T, Y[:, :N], Y[:, N:2 * N], np.full(T.size, phase), W, E, err, None))

    def ends_with(self, T) -> bool:
        """Whether the last chunk holds the samples T (the same array)."""
        return self.chunks[-1].t is T

    @property
    def energy_error(self) -> float:
        return max(c.error for c in self.chunks)

    @property
    def impacts(self) -> list:
        return [c.impact for c in self.chunks if c.impact is not None]

    def arrays(self):
        """t (K,), q (K, N), qdot (K, N), phase (K,), work (K, 2), Energy of (K,) arrays."""
        cs = self.chunks
        cat = np.concatenate
        return (cat([c.t for c in cs]), cat([c.q for c in cs]), cat([c.qdot for c in cs]),
                cat([c.phase for c in cs]), cat([c.work for c in cs]),
                Energy(*(cat([getattr(c.energy, f) for c in cs]) for f in Energy._fields)))


class _EndStops:
    """The joint limits as row W of the gap matrix, their events and end-stop impacts (gibbsimpact.limits)."""

    def __init__(self, limits, n_walls, n_joints):
        self.limits, self.W, self.J = limits, n_walls, n_joints
        self.cols = max(n_joints, len(limits))
        self.n = np.array([lim.n for lim in limits])  # (L, N)
        self.offset = np.array([lim.offset for lim in limits])
        self.near = np.zeros(len(limits), dtype=bool)  # limits in their contact band (after an end-stop impact)
        self.streak = np.zeros(len(limits), dtype=int)
        self.times: list[float] = []

    def _full(self, g_walls, qs):
        """(K, W + 1, cols): wall gaps, then the limit gaps; +inf pads unused entries."""
        K = qs.shape[0]
        G = np.full((K, self.W + 1, self.cols), np.inf)
        G[:, :self.W, :self.J] = g_walls.reshape(K, self.W, self.J)
        G[:, self.W, :len(self.limits)] = qs @ self.n.T + self.offset
        return G

    def wrap(self, gaps):
        return lambda q: self._full(gaps(q), q[None, :])[0]

    def wrap_batch(self, gaps_batch):
        return lambda qs: self._full(gaps_batch(qs), qs)

    def events(self, events, kinds, q, contact_tol, sink_depth):
        """Append one event per limit (or its sink / leave pair when it is in the band) to the wall events."""
        g = limit_gaps(self.limits, q)
        self.near &= g <= 2.0 * contact_tol
        rows, kinds = [tuple(r) for r in zip(events.wall, events.joint, events.offset, events.direction)], list(kinds)
        for k, gk in enumerate(g):
            if self.near[k]:
                rows.append((self.W, k, sink_depth - min(float(gk), 0.0), -1.0))
                kinds.append(("sink", self.W, k))
                rows.append((self.W, k, -3.0 * contact_tol, 1.0))
                kinds.append(("leave", self.W, k))
            else:
                rows.append((self.W, k, 0.0, -1.0))
                kinds.append(("hit", self.W, k))
        a = np.array(rows, dtype=float).reshape(-1, 4)
        return EventSpec(a[:, 0].astype(int), a[:, 1].astype(int), a[:, 2], a[:, 3]), kinds

    def impact(self, model, t, q, qd, k, e_stop, grazing_velocity, sinking):
        """End-stop impact of limit k (Newton's law with W = n), or None when it does not approach."""
        n = self.limits[k].n
        # consecutive impacts of this stop without a "leave" event in between
        self.streak[k] = self.streak[k] + 1 if self.near[k] else 1
        self.near[k] = True
        v = float(n @ qd)
        if not (v < -grazing_velocity or (sinking and v < 0)):
            return None
        sol = solve_impulses(mass_matrix(model, q), n[:, None], qd, np.array([e_stop]))
        return ImpactRecord(
            time=t, joints=(self.limits[k].joint,), wall=(-1,), normals=np.zeros((1, 3)),
            impulses=sol.impulses, v_before=sol.v_before, v_after=sol.v_after, restitution=np.array([e_stop]),
            qdot_before=qd.copy(), qdot_after=sol.qdot_after.copy(),
            energy_before=energy(model, q, qd), energy_after=energy(model, q, sol.qdot_after),
            rounds=len(sol.rounds),
        )

    def accumulation(self, t, k, count, interval):
        """Stop message when the joint has come to rest at end stop k: ``count`` impacts of
        limit k in a row without its "leave" event in between (rule (a) of the module
        docstring), or ``count`` impacts in a row less than ``interval`` apart (rule (b))."""
        self.times.append(t)
        dts = np.diff(self.times[-(count + 1):])
        if self.streak[k] < count and not (dts.size >= count and np.all(dts < interval)):
            return None
        return (f"joint {self.limits[k].joint} came to rest at its end stop ({self.limits[k].name}) at "
                f"t = {t:.9g} s: {count} end-stop impacts without leaving the stop; resting contact "
                "at an end stop is not modelled: results up to here are kept")


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
    limits = joint_limits(model)
    check_initial(limits, q0)
    _check_inside(model, q0, walls, contact_tol)
    try:
        mass_matrix(model, q0)
        forward_dynamics(model, q0, qdot0)
    except SingularMassMatrixError as exc:
        raise SingularMassMatrixError(f"initial state q0: {exc}") from None
    warn_state(model, q0, qdot0, walls)  # outside the model's assumptions: warned, never changed

    N = model.n_dof
    Q_in = generalized_force(model, inputs, t0, q0, qdot0)
    C_varies = damping_depends_on_q(model)  # a damped Pb link: C = C(d)
    C_damp = damping_matrix(model, q0)
    damped = bool(np.any(C_damp))
    driven = Q_in is not None or damped
    e_wall = np.array([restitution if w.restitution is None else w.restitution for w in walls])
    settings = dict(
        method=method, rtol=rtol, atol=atol, restitution=float(restitution),
        wall_restitution=[w.restitution for w in walls], output_dt=output_dt, max_step=max_step,
        contact_tol=contact_tol, grazing_velocity=grazing_velocity, penetration_tol=penetration_tol,
        zeno_interval=zeno_interval, zeno_count=int(zeno_count), max_impacts=int(max_impacts),
        t_span=[t0, t_end], joint_limit=joint_limit, joint_restitution=float(joint_restitution),
    )
    counters = {"nfev": 0, "n_steps": 0, "n_examined": 0}

    singular = {"message": None}  # diagnosis of the last trial state with a singular M

    def rhs(t, y):
        counters["nfev"] += 1
        clock.tick(t)
        q, qd = y[:N], y[N:2 * N]
        try:
            if not driven:
                return np.concatenate((qd, forward_dynamics(model, q, qd)))
            # (1) of forces.py: M qddot = Q_in + Q_damp - h - dV/dq, and the work rates qdot.Q.
            Qi = Q_in(t, q, qd) if Q_in is not None else np.zeros(N)
            Qd = -((damping_matrix(model, q) if C_varies else C_damp) @ qd) if damped else np.zeros(N)
            qdd = forward_dynamics(model, q, qd, Qi + Qd)
            return np.concatenate((qd, qdd, [qd @ Qi, qd @ Qd]))
        except SingularMassMatrixError as exc:
            # A trial stage of a too-long step can land on a meaningless state (e.g. right
            # after an impact that excites high modes): NaN makes the solver reject the
            # step and shrink it. Only if it cannot go on is the diagnosis reported.
            singular["message"] = f"at t = {t:.9g} s: {exc}"
            return np.full(y.shape, np.nan)

    contacts = _Contacts(model, walls)
    # Joint limits, when the chain has prismatic joints: one more row of the gap matrix (row W).
    gap_matrix, gap_batch = contacts.gaps, contacts.gaps_batch
    stops = _EndStops(limits, len(walls), model.n_joints) if limits else None
    if stops is not None:
        gap_matrix, gap_batch = stops.wrap(contacts.gaps), stops.wrap_batch(contacts.gaps_batch)
    # |dg/dq| <= 1 + 2 sum l: a translation moves a joint 1:1, a rotation by at most its lever arm.
    lipschitz = 1.0 + 2.0 * sum(ld.length for ld in model.link_data)
    recorder = _Recorder(model, t0, q0, qdot0)
    band = contact_band(contact_tol, lipschitz, rtol, atol, q0)
    accumulation = _Accumulation((len(walls), model.n_joints), int(zeno_count), zeno_interval, band)
    status, message = STATUS_FINISHED, f"reached t_end = {t_end:g} s"
    t, y, phase = t0, np.concatenate((q0, qdot0, np.zeros(2 if driven else 0))), 0
    near = np.zeros((len(walls), model.n_joints), dtype=bool)
    pending_impact = True  # check the initial state for an impact in progress
    sink_pair = None  # (wall, joint) whose sink event ended the last phase
    stalled = 0  # consecutive phases that made no progress in time
    flown = None  # outcome of the last flight phase until its samples are recorded

    with _progress_reporter(progress, t0, t_end) as report:
        clock = _Clock(report)
        try:
            while True:
                # Stage 1: impact, when the last phase ended at an event (or at the start).
                if pending_impact and walls:
                    q, qd = y[:N], y[N:2 * N]
                    in_band_before = near
                    band = accumulation.band = contact_band(contact_tol, lipschitz, rtol, atol, q)
                    rec, near = _impact_stage(model, contacts, e_wall, t, q, qd, band, grazing_velocity,
                                              sink_pair)
                    if rec is not None:
                        y = np.concatenate((q, rec.qdot_after, y[2 * N:]))
                        phase += 1
                        recorder.impact(rec, q, phase)
                        clock.n_impacts = recorder.n_impacts
                        stop = accumulation.add(rec, in_band_before)
                        if stop is not None:
                            status, message = STATUS_ZENO, stop
                            break
                        if recorder.n_impacts >= max_impacts:
                            status = STATUS_MAX_IMPACTS
                            message = f"stopped after max_impacts = {max_impacts} impacts at t = {t:.9g} s"
                            break
                pending_impact = False
                if t >= t_end:
                    break

                # Stage 2: flight until the first event or t_end.
                g_start = contacts.gaps(y[:N])
                sink_depth = max(1e-6 * contact_tol, 64 * np.finfo(float).eps * (1.0 + float(np.abs(y[:3]).max())))
                events, kinds = _phase_events(near, g_start, band, sink_depth)
                if stops is not None:
                    events, kinds = stops.events(events, kinds, y[:N], contact_tol, sink_depth)
                try:
                    flown = out = integrate_phase(
                        rhs, t, y, t_end, events, gap_matrix, method=method, rtol=rtol, atol=atol,
                        max_step=max_step, output_dt=output_dt, t_origin=t0, lipschitz=lipschitz, slack=contact_tol,
                        n_q=N, check_in_step=_in_step_check, gap_batch=gap_batch,
                    )
                except (SingularMassMatrixError, FloatingPointError, ValueError, np.linalg.LinAlgError) as exc:
                    status, message = STATUS_FAILED, f"integration failed after t = {t:.9g} s: {exc}"
                    break
                counters["n_steps"] += out.n_steps
                counters["n_examined"] += out.n_examined
                if out.sample_t.size:
                    recorder.flight(out.sample_t, out.sample_y, phase)
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
                        f"a joint went {-out.min_gap:.3g} m beyond {what} between events in the phase starting at "
                        f"t = {t:.9g} s without an event firing; tighten rtol or set max_step"
                    )
                    break
                t_prev, (t, y) = t, (out.t, out.y)
                if not np.all(np.isfinite(y)):
                    status, message = STATUS_FAILED, f"state became non-finite at t = {t:.9g} s"
                    break
                if out.event is None:
                    break
                kind, w_i, j = kinds[out.event]
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
                    stalled = stalled + 1 if t - t_prev <= 1e-14 * max(1.0, abs(t)) else 0
                    if stalled >= 100:
                        status = STATUS_FAILED
                        message = f"event loop stalled at t = {t:.9g} s: 100 consecutive events without progress in time"
                        break
                    continue
                sink_pair = (w_i, j) if kind == "sink" else None
                if kind == "leave":
                    near[w_i, j] = False  # re-arm the normal event of this pair; no impact
                    accumulation.left_band(w_i, j)
                else:
                    pending_impact = True
                stalled = stalled + 1 if t - t_prev <= 1e-14 * max(1.0, abs(t)) else 0
                if stalled >= 100:
                    status = STATUS_FAILED
                    message = f"event loop stalled at t = {t:.9g} s: 100 consecutive events without progress in time"
                    break
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

        t_all, q_all, qdot_all, phase_all, work_all, E_all = recorder.arrays()
        impacts = recorder.impacts
        res = Result(
            model=model, walls=walls, t=t_all, q=q_all, qdot=qdot_all, phase=phase_all, impacts=impacts,
            status=status, message=message, settings=settings,
            nfev=counters["nfev"], n_steps=counters["n_steps"], n_examined=counters["n_examined"],
            wall_time=time.perf_counter() - started, energy_error=recorder.energy_error,
            _energy_cache=E_all, work=work_all if driven else None,
        )
        if report is not None:
            try:
                report(float(t_all[-1]), len(impacts))
            except KeyboardInterrupt:
                pass  # the run is over and its Result complete: an interrupt now must not lose it
    warn_result(res)
    return res
