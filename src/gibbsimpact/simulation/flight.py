"""One flight phase: scipy's ODE steps with event location that sees inside a step (docs/theory.md §10, §14).

The phase integrates y = (q, qdot), shape (2N,), with a ``scipy.integrate``
``OdeSolver`` (DOP853, RK45, Radau, ...) and stops at the first event. Every
event is a level of the gap matrix g (W, J) [m] of (wall, joint) pairs:

    E_k(y) = g[w_k, j_k](q) + offset_k,    direction d_k in {-1, +1}

An event of direction -1 fires where E_k falls through zero, +1 where it
rises through zero. ``solve_ivp`` looks only at the signs of E_k at the ends
of each accepted step, so a joint that crosses a wall and comes back within
one step is never seen. Here, at every accepted step [t_a, t_b] with
h = t_b - t_a:

1. Sign change of E_k between t_a and t_b (as solve_ivp): the event is in the step.
2. In-step check, for the events of direction -1 without a sign change: E_k
   at s = 1/4, 1/2, 3/4 of the step, from a quintic Hermite interpolant of q
   built on (q, qdot, qddot) at both ends (no extra right-hand side), or from
   the dense output when the step already has one or when the solver steps over fast modes
   (its ``steps_over_fast_modes`` is True: with a cutoff, simulation.compiled_radau and
   cutoff_radau; qddot at the step ends then holds the damped fast mode's acceleration,
   ~omega^2 times an amplitude far below atol, and the quintic built on it dips by microns
   where the motion does not: case 1 with EI = 1e9, a false penetration of 2e-6 m after its
   impact at 0.6704 s). Between samples spaced
   h/4 the piecewise-linear interpolant of E_k misses at most
   max|E''| (h/4)^2 / 8, and max|E''| (h/4)^2 ~ max|second difference D_i|,
   so the dip below the samples is bounded by

       a = max_i |D_i| / 2                        (a safety factor of 4)
         + L_q max|q_quintic - q_cubic|           (interpolation error, cubic as its bound)
         + slack                                  (contact_tol)

   with L_q = 1 + 2 sum l_i [m/unit] a bound on |dg/dq|. Only a step with
   min_i E_k(s_i) - a < 0 (some pair comes within a few interpolation errors
   of its level) is examined further: the solver's dense output (for DOP853
   three more right-hand sides) is sampled at 16 points; unless the same dip
   bound at that spacing keeps every sample interval above zero (e.g. a pair
   leaving the wall after its impact), the smallest sample is refined by a
   bounded Brent minimisation. A minimum below zero is an event.
3. Root: the first crossing is bracketed by the first negative sample (or the
   minimum) and found by brentq on the dense output, xtol = rtol = 4 eps,
   exactly as solve_ivp does. The earliest root over all events ends the
   phase.

Events that are not gap levels (``extra``: the release of a resting contact,
whose force lambda(t, y) falls through zero, its stick / slip events,
gibbsimpact.resting) are sampled at the step ends and at 1/4, 1/2, 3/4 of every
step on the dense output; the first sign change is located by brentq on the
dense output. Their index in PhaseOutcome.event follows the gap events.

The cost when nothing is near a wall is three joint-position evaluations per
step (no right-hand side): on the published cases +0.1-0.3 % right-hand sides
and +9-14 % CPU time with today's numpy kinematics (benchmarks/bench_events.py).
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK23, RK45, Radau
from scipy.optimize import brentq, minimize_scalar

from ..dynamics.forces import CallbackError
from .budget import BudgetExceeded

SOLVERS = {"RK45": RK45, "DOP853": DOP853, "Radau": Radau, "BDF": BDF, "LSODA": LSODA, "RK23": RK23}

_EPS = np.finfo(float).eps
_S_CHECK = np.array([0.25, 0.5, 0.75])  # in-step sample points, fractions of the step
_N_DENSE = 16  # dense-output samples of an examined step


class EventSpec(NamedTuple):
    """K event functions E_k = g[wall_k, joint_k] + offset_k [m] of direction direction_k (+1 / -1)."""

    wall: np.ndarray
    joint: np.ndarray
    offset: np.ndarray
    direction: np.ndarray

    def values(self, g: np.ndarray) -> np.ndarray:
        """E (K,) [m] from a gap matrix g (W, J) [m]."""
        return g[self.wall, self.joint] + self.offset


class PhaseOutcome(NamedTuple):
    """What one flight phase produced.

    t, y : end of the phase [s], state (2N,) there (the event point, or t_end)
    event : index into the EventSpec of the event that ended the phase, or None
    sample_t : (K,) stored sample times after the phase start [s], the last one is t
    sample_y : (K, 2N) states at sample_t
    min_gap : smallest gap over all pairs at step ends and in-step samples [m]
    n_steps : accepted steps; n_examined : steps whose dense output was examined for a dip
    failed : None, or the solver's message when it failed
    interrupted : None, or how a KeyboardInterrupt stopped the phase (its accepted
        steps are in sample_t, sample_y; t, y is the last accepted state)
    stopped_by : None, or what stopped the phase from inside a right-hand side, the accepted
        steps kept as for an interrupt: the CallbackError of a user callback that failed, or
        the BudgetExceeded of a run that used up a limit
    """

    t: float
    y: np.ndarray
    event: int | None
    sample_t: np.ndarray
    sample_y: np.ndarray
    min_gap: float
    n_steps: int
    n_examined: int
    failed: str | None
    interrupted: str | None = None
    stopped_by: Exception | None = None


def hermite_positions(s: np.ndarray, h: float, ya: np.ndarray, fa: np.ndarray, yb: np.ndarray, fb: np.ndarray,
                      N: int | None = None):
    """Quintic and cubic Hermite interpolants of q at fractions s (m,) of a step of length h [s].

    ya, yb : (2N + extra,) states (q, qdot, ...) at the step ends; fa, fb : their
    derivatives (qdot, qddot, ...); N : number of coordinates (default len(ya) // 2).
    Returns (q5, q3), each (m, N): the quintic on (q, qdot, qddot) at both
    ends, and the cubic on (q, qdot) whose difference from q5 bounds q5's error.
    """
    N = ya.shape[0] // 2 if N is None else N
    W5, W3 = _hermite_weights(s)
    # Rows: q_a, h v_a, h^2 a_a, h^2 a_b, h v_b, q_b (the quintic's data; the cubic uses rows 0, 1, 4, 5).
    X = np.stack((ya[:N], h * ya[N:2 * N], h * h * fa[N:2 * N], h * h * fb[N:2 * N], h * yb[N:2 * N], yb[:N]))
    return W5 @ X, W3 @ X[[0, 1, 4, 5]]


def _hermite_weights(s) -> tuple[np.ndarray, np.ndarray]:
    """Quintic (m, 6) and cubic (m, 4) Hermite basis values at the fractions s (m,) of a step (cached)."""
    key = tuple(np.atleast_1d(np.asarray(s, dtype=float)).tolist())
    w = _HERMITE_CACHE.get(key)
    if w is not None:
        return w
    s = np.asarray(key)[:, None]
    s2, s3, s4, s5 = s * s, s**3, s**4, s**5
    # Quintic Hermite basis on [0, 1]: values, first and second derivatives at both ends.
    h0 = 1 - 10 * s3 + 15 * s4 - 6 * s5
    h1 = s - 6 * s3 + 8 * s4 - 3 * s5
    h2 = 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5
    h3 = 0.5 * s3 - s4 + 0.5 * s5
    h4 = -4 * s3 + 7 * s4 - 3 * s5
    h5 = 10 * s3 - 15 * s4 + 6 * s5
    # Cubic Hermite basis.
    c0 = 1 - 3 * s2 + 2 * s3
    c1 = s - 2 * s2 + s3
    c2 = -s2 + s3
    c3 = 3 * s2 - 2 * s3
    w = np.hstack((h0, h1, h2, h3, h4, h5)), np.hstack((c0, c1, c2, c3))
    if len(_HERMITE_CACHE) < 64:
        _HERMITE_CACHE[key] = w
    return w


_HERMITE_CACHE: dict = {}


def dip_allowance(E: np.ndarray) -> np.ndarray:
    """How far E can dip below its samples between them: max |second difference| / 2.

    E : (K, 5) event values at s = 0, 1/4, 1/2, 3/4, 1 of a step [m] -> (K,) [m].
    """
    D = E[:, :-2] - 2.0 * E[:, 1:-1] + E[:, 2:]
    return 0.5 * np.max(np.abs(D), axis=1)


class _Dop853Interpolant:
    """DOP853's dense output on one step, evaluated in one matrix product (scipy's values to round-off).

    scipy's Dop853DenseOutput holds F (7, n) and evaluates, with x = (t - t_old) / h,

        y = ((((((F6 x + F5)(1 - x) + F4) x + F3)(1 - x) + F2) x + F1)(1 - x) + F0) x + y_old

    by 14 in-place array operations (~50 us a call for n = 18). Expanded, with a = x (1 - x):

        y = y_old + w^T F,    w = (x, a, x a, a^2, x a^2, a^3, x a^3)

    Called as scipy's: t a float -> (n,); t (m,) -> (n, m).
    """

    __slots__ = ("t_old", "h", "F", "y_old", "y_col")

    _X_POW = np.array([1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0])[:, None]  # w_i = x^p_i a^r_i
    _A_POW = np.array([0.0, 1.0, 1.0, 2.0, 2.0, 3.0, 3.0])[:, None]

    def __init__(self, dense):
        self.t_old, self.h, self.F, self.y_old = float(dense.t_old), float(dense.h), dense.F, dense.y_old
        self.y_col = dense.y_old[:, None]

    @staticmethod
    def _w(x: float) -> tuple:
        a = x * (1.0 - x)
        a2 = a * a
        return x, a, x * a, a2, x * a2, a2 * a, x * a2 * a

    def __call__(self, t):
        if t.__class__ is float or np.ndim(t) == 0:
            return self.y_old + np.array(self._w((float(t) - self.t_old) / self.h)) @ self.F
        x = (np.asarray(t, dtype=float) - self.t_old) / self.h
        if x.size <= 16:  # a few points (every call of the event loop): float arithmetic is cheaper
            W = np.array([self._w(xi) for xi in x.tolist()]).reshape(x.size, 7).T
        else:
            W = x ** self._X_POW * (x * (1.0 - x)) ** self._A_POW
        return self.y_col + self.F.T @ W


def _interpolant(solver):
    """The solver's dense output on its last step: DOP853's in one matrix product
    (_Dop853Interpolant), any other method's as scipy gives it."""
    dense = solver.dense_output()
    F = getattr(dense, "F", None)
    if type(dense).__name__ == "Dop853DenseOutput" and isinstance(F, np.ndarray) and F.shape[0] == 7 \
            and F.ndim == 2 and hasattr(dense, "h") and hasattr(dense, "y_old"):
        return _Dop853Interpolant(dense)
    return dense


def _earliest_bracket(v, ts, vs, depth: int = 3) -> tuple | None:
    """(t_lo, t_hi) around the earliest fall of v(t) from >= 0 to <= 0 among the uniform samples
    ts (m,) [s] with values vs (m,), or None.

    Between two samples that do not bracket a fall, v can still dip below zero and come back
    when the samples' dip bound allows it (as check 2 of the gaps: v >= min of the two ends
    minus max |second difference| / 2): such an interval is sampled again at _N_DENSE + 1
    points, up to ``depth`` levels (1 / 17^3 of the step). A contact phase whose state does
    not change (a sticking contact) lets the solver take steps far longer than the time scale
    of the applied forces; without this an excursion of a sticking force beyond the friction
    cone between the step's samples went unseen.
    """
    vs = np.asarray(vs, dtype=float)
    allowance = float(dip_allowance(vs[None, :])[0]) if vs.size > 2 else 0.0
    for m in range(ts.size - 1):
        if vs[m] >= 0.0 >= vs[m + 1]:
            return float(ts[m]), float(ts[m + 1])
        if depth > 0 and vs[m] > 0.0 and vs[m + 1] > 0.0 and min(vs[m], vs[m + 1]) - allowance < 0.0:
            sub = np.linspace(ts[m], ts[m + 1], _N_DENSE + 1)
            sv = np.array([vs[m]] + [v(t) for t in sub[1:-1]] + [vs[m + 1]])
            got = _earliest_bracket(v, sub, sv, depth - 1)
            if got is not None:
                return got
    return None


def _first_crossing(fun, sol, t_a: float, t_b: float, E_a: float, E_b: float, fun_batch) -> float | None:
    """First t in [t_a, t_b] where fun(t, sol(t)) falls through zero, or None.

    E_a = fun at t_a (> 0); E_b at t_b; fun_batch(Y) -> (m,), fun at the states Y (n, m) (the
    same values, one kernel call). Samples the dense output; without a sample <= 0 and unless
    the samples' dip bound rules a crossing out, refines the smallest sample by a bounded
    minimisation; then brentq on the first bracket.
    """
    ts = np.linspace(t_a, t_b, _N_DENSE + 2)
    Es = np.empty(ts.size)
    Es[0], Es[-1] = E_a, E_b
    Es[1:-1] = fun_batch(sol(ts[1:-1]))
    neg = np.nonzero(Es <= 0)[0]
    if neg.size:
        i = int(neg[0])
        if i == ts.size - 1 and neg.size == 1:
            lo, hi = t_a, t_b  # a plain sign change: the bracket solve_ivp uses
        else:
            lo, hi = ts[i - 1], ts[i]
    else:
        # Check 2's dip bound at the samples' spacing: with |E''| delta^2 <= 4 max|D_i| (the same
        # safety factor 4), on a sample interval with end values e0, e1 > 0
        #     E >= (1 - u) e0 + u e1 - 2 max|D| u (1 - u) >= u (1 - u) ((sqrt e0 + sqrt e1)^2 - 2 max|D|)
        # (Cauchy-Schwarz, as in contacts.py's skip rule): no interval can reach zero when every
        # bracket is positive; typically a pair leaving the wall right after its impact.
        root = np.sqrt(Es)
        if np.all((root[:-1] + root[1:]) ** 2 > 4.0 * float(dip_allowance(Es[None, :])[0])):  # 2 max|D|
            return None
        i = int(np.argmin(Es))
        lo_b, hi_b = ts[max(i - 1, 0)], ts[min(i + 1, ts.size - 1)]
        res = minimize_scalar(lambda t: fun(t, sol(t)), bounds=(lo_b, hi_b), method="bounded",
                              options={"xatol": 1e-3 * (hi_b - lo_b) * _EPS ** 0.5})
        if not res.fun <= 0:
            return None
        lo, hi = lo_b, float(res.x)  # fun(lo) > 0: lo is a sample before the first negative value
    return brentq(lambda t: fun(t, sol(t)), lo, hi, xtol=4 * _EPS, rtol=4 * _EPS)


def integrate_phase(
    rhs: Callable,
    t0: float,
    y0: np.ndarray,
    t_end: float,
    events: EventSpec,
    gap_matrix: Callable,
    *,
    method: str,
    rtol: float,
    atol: float,
    max_step: float,
    output_dt: float | None,
    t_origin: float,
    lipschitz: float,
    slack: float,
    n_q: int | None = None,
    check_in_step: bool = True,
    gap_batch: Callable | None = None,
    extra: tuple | None = None,
    gap_single: Callable | None = None,
    jac: Callable | None = None,
    solver: Callable | None = None,
) -> PhaseOutcome:
    """Integrate from (t0, y0) to the first event or t_end.

    Parameters
    ----------
    rhs : f(t, y) -> (2N,), the first-order form of the equations of motion
    t0, t_end : [s]; y0 : (2N,)
    events : EventSpec of the K event functions of this phase
    gap_matrix : g(q) -> (W, J) gaps [m] of every (wall, joint) pair
    method, rtol, atol, max_step : the solver and its tolerances (solve_ivp's meaning)
    output_dt : [s] or None. None stores every accepted step; a float stores
        the points of the grid t_origin + k output_dt inside the phase
    lipschitz : L_q, bound on |dg/dq| [m per unit of q]
    slack : [m], extra margin of the in-step check (contact_tol)
    n_q : N, the number of coordinates: y = (q, qdot, extra states); default len(y0) // 2
    check_in_step : False skips check 2 (only solve_ivp's sign test at step ends): for
        benchmarks and for tests that show what the check finds
    gap_batch : g(qs (K, N)) -> (K, W, J), the gaps of several states at once
        (default: gap_matrix state by state)
    extra : None, or (fun(t, y) -> (m,), direction (m,) of +1 / -1[, inside (m,) bool]): m more event
        functions (module docstring), event index K + i; inside (default all True) says which are also
        sampled inside the steps; the others (a smooth function of the state, e.g. the chart event of
        simulation.charts) by their sign change at the step ends only, which needs no dense output
    gap_single : g(q, row, column) -> float [m], one entry of the gap matrix (default: from
        gap_matrix); the root search of one event calls it many times
    jac : None, or J(t, y) -> (2N, 2N) the Jacobian of rhs, for an implicit method (Radau, BDF,
        LSODA; gibbsimpact.simulation.implicit); None: the solver's own finite differences
    solver : None (scipy's solver of ``method``), or a factory with an OdeSolver's arguments to use instead
        (the compiled Radau, gibbsimpact.simulation.compiled_radau)

    Returns
    -------
    PhaseOutcome
    """
    phase = _Phase(rhs, t0, y0, t_end, events, gap_matrix, method=method, rtol=rtol, atol=atol,
                   max_step=max_step, output_dt=output_dt, t_origin=t_origin, lipschitz=lipschitz, slack=slack,
                   n_q=n_q, check_in_step=check_in_step, gap_batch=gap_batch, extra=extra, gap_single=gap_single,
                   jac=jac, solver=solver)
    try:
        while phase.solver.status == "running":
            out = phase.step()
            if out is not None:
                return out
    except KeyboardInterrupt as exc:
        # Ctrl-C (or the CLI's SIGTERM): keep the accepted steps.
        phase.interrupted = str(exc) or "KeyboardInterrupt (Ctrl-C)"
        phase.keep_accepted()
    except (CallbackError, BudgetExceeded) as exc:
        # A user callback failed, or the run used up a limit, inside a right-hand side: keep the
        # accepted steps, as for an interrupt.
        phase.stopped_by = exc
        phase.keep_accepted()
    return phase.outcome()


class _Phase:
    """The state of one flight phase between accepted steps (integrate_phase's arguments, the solver,
    the event values at the last step end, the stored samples)."""

    def __init__(self, rhs, t0, y0, t_end, events, gap_matrix, *, method, rtol, atol, max_step, output_dt,
                 t_origin, lipschitz, slack, n_q, check_in_step, gap_batch, extra, gap_single, jac=None, solver=None):
        self.rhs, self.t0, self.y0, self.events, self.gap_matrix = rhs, t0, y0, events, gap_matrix
        self.output_dt, self.t_origin, self.lipschitz, self.slack = output_dt, t_origin, lipschitz, slack
        self.check_in_step, self.gap_single = check_in_step, gap_single
        self.N = N = y0.shape[0] // 2 if n_q is None else n_q
        if gap_batch is None:
            def gap_batch(qs):
                return np.stack([gap_matrix(qi) for qi in qs])
        self.gap_batch = gap_batch
        options = {} if jac is None else {"jac": jac}
        self.solver = (solver or SOLVERS[method])(rhs, t0, y0, t_end, rtol=rtol, atol=atol, max_step=max_step,
                                                  **options)
        # In-step samples from the dense output rather than the quintic (module docstring, check 2).
        self.dense_samples = bool(getattr(self.solver, "steps_over_fast_modes", False))
        self.down, self.up = events.direction < 0, events.direction > 0
        g0 = gap_matrix(y0[:N])
        self.E_prev = events.values(g0)
        self.n_gap = len(events.direction)
        self.extra = extra
        if extra is not None:
            self.x_fun, self.x_dir = extra[0], np.asarray(extra[1], dtype=float)
            self.x_inside = np.asarray(extra[2], dtype=bool) if len(extra) > 2 else np.ones(self.x_dir.size, bool)
            self.X_prev = np.asarray(self.x_fun(t0, y0), dtype=float)
        self.min_gap = float(g0.min()) if g0.size else np.inf
        self.t_a, self.y_a, self.f_a = t0, y0.copy(), self.derivative(t0, y0)
        self.sample_t, self.sample_y = [], []
        self.n_steps = self.n_examined = 0
        self.failed = self.interrupted = self.stopped_by = None

    def derivative(self, t, y):
        f = getattr(self.solver, "f", None)
        return f if f is not None else self.rhs(t, y)

    def E_single(self, k):
        """E_k(t, y) -> float of one event (for its root search)."""
        ev, N = self.events, self.N
        if self.gap_single is not None:
            row, col, off = int(ev.wall[k]), int(ev.joint[k]), float(ev.offset[k])
            return lambda t, y: float(self.gap_single(y[:N], row, col)) + off
        return lambda t, y: float(ev.values(self.gap_matrix(y[:N]))[k])

    def E_batch(self, k):
        """E_k at the states Y (2N, m) -> (m,), one batch of gaps."""
        ev, N = self.events, self.N
        row, col, off = int(ev.wall[k]), int(ev.joint[k]), float(ev.offset[k])
        return lambda Y: self.gap_batch(np.ascontiguousarray(Y[:N].T))[:, row, col] + off

    def step(self) -> PhaseOutcome | None:
        """One accepted step [t_a, t_b]: its events (checks 1-3 of the module docstring) and samples.
        Returns the phase's outcome when an event ends it, else None (the phase goes on or is over)."""
        solver = self.solver
        message = solver.step()
        if solver.status == "failed":
            self.failed = message
            return None
        self.n_steps += 1
        t_b, y_b = solver.t, solver.y.copy()
        f_b = self.derivative(t_b, y_b)
        h = t_b - self.t_a
        grid = self._grid(t_b)
        dense = _interpolant(solver) if grid.size or self.dense_samples else None
        g_b, G_in, err, in_step = self._step_gaps(h, y_b, f_b, dense)
        E_b = self.events.values(g_b)
        step_min = float(g_b.min()) if g_b.size else np.inf
        # 1. Sign changes at the step ends (solve_ivp's rule).
        down, up, E_prev = self.down, self.up, self.E_prev
        crossed = (down & (E_prev >= 0) & (E_b <= 0)) | (up & (E_prev <= 0) & (E_b >= 0))
        examine, step_min = self._dips(crossed, E_b, G_in, err, in_step, step_min)
        roots = {}
        if self.extra is not None:
            X_b = np.asarray(self.x_fun(t_b, y_b), dtype=float)
            v_a, v_b = -self.x_dir * self.X_prev, -self.x_dir * X_b  # v = sgn X falls through 0 at an event
            if self.x_inside.any() or np.any((v_a >= 0.0) & (v_b <= 0.0)):
                if dense is None:
                    dense = _interpolant(solver)
                roots.update(self._extra_roots(h, t_b, X_b, dense))
        if np.any(crossed) or np.any(examine):
            if dense is None:
                dense = _interpolant(solver)
            roots.update(self._gap_roots(crossed, examine, t_b, E_b, dense))
        if roots:
            return self._event_outcome(roots, grid, dense)
        self.min_gap = min(self.min_gap, step_min)  # the step of an event counts only up to the event
        self._store(grid, dense, t_b, y_b)
        self.t_a, self.y_a, self.f_a, self.E_prev = t_b, y_b, f_b, E_b
        if self.extra is not None:
            self.X_prev = X_b
        return None

    def _grid(self, t_b) -> np.ndarray:
        """Output grid points t_origin + k output_dt in (t_a, t_b] (the phase end itself is stored once)."""
        if self.output_dt is None:
            return np.empty(0)
        t_a, dt, t_o = self.t_a, self.output_dt, self.t_origin
        k = np.arange(np.floor((t_a - t_o) / dt), np.floor((t_b - t_o) / dt) + 2)
        grid = t_o + dt * k
        return grid[(grid > t_a) & ((grid <= t_b) if self.solver.status == "running" else (grid < t_b))]

    def _step_gaps(self, h, y_b, f_b, dense):
        """(g_b (W, J) at the step end, G_in (3, W, J) in-step gaps, err [m] interpolation bound, in_step)."""
        N = self.N
        in_step = self.check_in_step and self.down.any()
        if not in_step:
            return self.gap_matrix(y_b[:N]), None, 0.0, False
        # The in-step samples of check 2 and the step end: one kinematics call for the four.
        if dense is not None:
            q_in = dense(self.t_a + _S_CHECK * h)[:N].T
            err = 0.0
        else:
            q_in, q3 = hermite_positions(_S_CHECK, h, self.y_a, self.f_a, y_b, f_b, N)
            err = self.lipschitz * float(np.max(np.abs(q_in - q3)))
        G4 = self.gap_batch(np.vstack((q_in, y_b[None, :N])))  # (4, W, J)
        return G4[-1], G4[:-1], err, True

    def _dips(self, crossed, E_b, G_in, err, in_step, step_min):
        """Check 2: the direction -1 events without a sign change whose in-step samples come within the
        dip bound of zero, to be examined on the dense output. Returns (examine (K,) bool, step_min [m])."""
        down, E_prev, ev = self.down, self.E_prev, self.events
        candidates = np.nonzero(down & ~crossed & (E_prev > 0) & (E_b > 0))[0] if in_step else np.empty(0, int)
        examine = np.zeros(E_b.shape, dtype=bool)
        if candidates.size:
            if G_in.size:
                step_min = min(step_min, float(G_in.min()))
            E_in = G_in[:, ev.wall, ev.joint].T + ev.offset[:, None]  # (K, 3)
            E5 = np.concatenate((E_prev[:, None], E_in, E_b[:, None]), axis=1)[candidates]
            low = E5.min(axis=1) - dip_allowance(E5) - err - self.slack
            examine[candidates[low < 0]] = True
        return examine, step_min

    def _extra_roots(self, h, t_b, X_b, dense) -> dict:
        """Roots of the non-gap events: sign changes between the step ends and the dense output at 1/4, 1/2,
        3/4 of the step (a state that does not change, e.g. a sticking contact, lets the solver take
        long steps over which a force can reach the cone and come back)."""
        t_a, x_fun, roots = self.t_a, self.x_fun, {}
        ts = np.concatenate(([t_a], t_a + _S_CHECK * h, [t_b])) if self.x_inside.any() else np.array([t_a, t_b])
        Xs = [self.X_prev] + [np.asarray(x_fun(tk, dense(tk)), dtype=float) for tk in ts[1:-1]] + [X_b]
        for i in range(len(self.x_dir)):
            def x_i(t, i=i):
                return float(x_fun(t, dense(t))[i])

            sgn = -float(self.x_dir[i])  # v = sgn X_i falls from >= 0 to <= 0 at a crossing
            at = slice(None) if self.x_inside[i] else [0, -1]  # an end-only event: its values at the step ends
            bracket = _earliest_bracket(lambda t: sgn * x_i(t), ts[at], [sgn * X[i] for X in np.array(Xs)[at]],
                                        depth=3 if self.x_inside[i] else 0)
            if bracket is not None:
                roots[self.n_gap + i] = brentq(x_i, *bracket, xtol=4 * _EPS, rtol=4 * _EPS)
        return roots

    def _gap_roots(self, crossed, examine, t_b, E_b, dense) -> dict:
        """Check 3: the first crossing of every crossed or examined gap event in [t_a, t_b]."""
        t_a, E_prev, roots = self.t_a, self.E_prev, {}
        for k in np.nonzero(crossed)[0]:
            if self.up[k]:
                roots[int(k)] = brentq(lambda t: self.E_single(k)(t, dense(t)), t_a, t_b,
                                       xtol=4 * _EPS, rtol=4 * _EPS)
            else:
                roots[int(k)] = _first_crossing(self.E_single(k), dense, t_a, t_b, E_prev[k], E_b[k],
                                                self.E_batch(k))
        if np.any(examine):
            self.n_examined += 1
            for k in np.nonzero(examine)[0]:
                tk = _first_crossing(self.E_single(k), dense, t_a, t_b, E_prev[k], E_b[k], self.E_batch(k))
                if tk is not None:
                    roots[int(k)] = tk
        return roots

    def _event_outcome(self, roots, grid, dense) -> PhaseOutcome:
        """The phase ends at the earliest root: grid samples before it, then the event point."""
        event = min(roots, key=roots.get)
        t_ev = roots[event]
        y_ev = dense(t_ev)
        if grid.size:
            grid = grid[grid < t_ev]
        if grid.size:
            self.sample_t.append(grid)
            self.sample_y.append(dense(grid).T)
        # Gaps over the step up to the event (in-step samples beyond it are not part of the phase).
        self.sample_t.append(np.array([t_ev]))
        self.sample_y.append(y_ev[None, :])
        return PhaseOutcome(t_ev, y_ev, event, np.concatenate(self.sample_t), np.concatenate(self.sample_y),
                            self.min_gap, self.n_steps, self.n_examined, None)

    def _store(self, grid, dense, t_b, y_b) -> None:
        """The samples of an accepted step without an event: the step end, or the output grid in it."""
        if self.output_dt is None:
            self.sample_t.append(np.array([t_b]))
            self.sample_y.append(y_b[None, :])
            return
        if grid.size:
            self.sample_t.append(grid)
            self.sample_y.append(dense(grid).T)
        if self.solver.status == "finished":
            self.sample_t.append(np.array([t_b]))
            self.sample_y.append(y_b[None, :])

    def keep_accepted(self) -> None:
        """After an interrupt or a failed callback: the samples of the accepted steps, ending at the last one.
        One stopped between the two appends of one step leaves one list longer: cut it."""
        k = min(len(self.sample_t), len(self.sample_y))
        self.sample_t, self.sample_y = self.sample_t[:k], self.sample_y[:k]
        if self.t_a > (self.sample_t[-1][-1] if self.sample_t else self.t0):
            self.sample_t.append(np.array([self.t_a]))
            self.sample_y.append(self.y_a[None, :])

    def outcome(self) -> PhaseOutcome:
        """The phase's outcome without an event: at t_end, or cut short (failed solver, interrupt, callback, limit)."""
        t_last = self.sample_t[-1][-1] if self.sample_t else self.t0
        y_last = self.sample_y[-1][-1] if self.sample_y else self.y0
        cut = self.failed is not None or self.interrupted is not None or self.stopped_by is not None
        if cut and not self.sample_t:
            self.sample_t, self.sample_y = [np.empty(0)], [np.empty((0, self.y0.shape[0]))]
        return PhaseOutcome(float(t_last), np.asarray(y_last), None, np.concatenate(self.sample_t),
                            np.concatenate(self.sample_y), self.min_gap, self.n_steps, self.n_examined, self.failed,
                            self.interrupted, self.stopped_by)
