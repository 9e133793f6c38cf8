"""Time-stepping contact phases: Moreau-Jean's scheme where links' spans lie on walls (docs/theory.md §15.5).

Why. Newton's impact law at the points of a discretised flexible span makes a vibrating beam that
settles on a wall take micro-impacts at a rate that grows as the mesh is refined (the effective mass of
a span point falls with the element size, theory §11.4): an event-driven run must locate each one and
crawls (issue 25). A time-stepping scheme takes the impulses of a whole step at once, at the pace the
step sets, and a beam at rest on its grid (contact/span_grid.py) is well posed. So an accumulation of
impacts that involves a span point (simulation.stages._accumulation) hands the run to this stage; it
steps until every contact has opened, then the event-driven loop goes on.

Scheme (Jean 1999; Acary & Brogliato 2008, ch. 10), theta = 1/2, step h from (q_k, v_k) at t_k:

    M (v_(k+1) - v_k) = h f_(k+theta) + W P                                                   (1)
    q_(k+1) = q_k + h ((1 - theta) v_k + theta v_(k+1))                                       (2)

with M qddot = f(t, q, qdot) the equations of motion (applied forces, elastic, damping, velocity terms)
linearised once per step, a = M^-1 f, A = da/dq, B = da/dqdot at the step's start
(simulation.implicit.rhs_jacobian: kernel and applied forces), so that with dq = q_(k+1) - q_k,
dv = v_(k+1) - v_k, a_(k+theta) ~ a + theta (A dq + B dv) and dq = h (v_k + theta dv):

    Mh dv = M (h a + h^2 theta A v_k) + W P,   Mh = sym(M (I - h theta B - h^2 theta^2 A))     (3)

(sym: the symmetric part; the skew part of M B, M A is gyroscopic, O(h) in Mh). The contact columns
W = [J_a^T n_a] (N, k) at q_k are the joint points, the links' grid points (contact/span_grid.py) and
the cells' lowest points (contact/span_cells.py) that can rest (contact/resting.py). A column is
active when its gap predicted by (2) with the free velocity (P = 0) closes,

    g_a(q_k) + h ((1 - theta) U_a,k + theta U_a,free) <= b,    U = W^T v                      (4)

(b the contact band, 2 contact_tol at the default tolerances: the points of a beam at rest sit within
~1e-6 m of the wall, and with b = 0 a shorter step, the last before t_end, found those that sit
higher than h^2 g / 2 free and let the beam sag into them.)

and the active columns obey Newton's law at the step's level (an LCP on the Delassus matrix
D = W^T Mh^-1 W, contact.impact._solve_lcp):

    0 <= U_(k+1) - tau  _|_  P >= 0,   tau = min(-e_a U_k, -(g_a^+ + h (1 - theta) U_k) / (h theta)),
    e_a = e if U_k <= 0, else 1                                                                 (5)

(the second target lets a contact that is still g_a^+ = max(g_a, 0) above its wall close that gap within
the step, g_(k+1) ~ g_k + h ((1 - theta) U_k + theta U_(k+1)) = 0, before Newton's law stops it: without
it, a contact predicted to close by (4) was stopped where it stood, and a beam came to rest on points
held up to 6e-6 m above the floor, which a shorter step then let go),
so a contact that approaches leaves with -e times its velocity and one that rests stays at rest
(U = 0, P = the step's impulse of its force: the recorded force is P / h, for a grid point added to its cell's
column, at the force-weighted mean of their abscissae). With theta = 1/2 the energy
of the (linear) scheme changes by the contact work P . (U_k + U_(k+1)) / 2 (the trapezoidal rule:
dq = h (v_k + v_(k+1)) / 2), which (5) makes <= P (1 - e_a) U_k / 2 <= 0 for each active contact (the
closing target is lower than Newton's only where it gives U_k + U_(k+1) = -2 g_a^+ / h <= 0). A
contact that moves away at the step's start (U_k > 0) but that the forces turn back within the step
is held at U_(k+1) >= -U_k, with no work: Newton's -e U_k would do the positive work P (1 - e) U_k / 2
(1e-4 J in one step on the dropped beam of issue 25 at h = 1e-3 s), and leaving it free made a resting
beam bounce for ever in a 2-step cycle (up at e g h, down at g h, lifted back by (6)). It approaches
at the next step and is stopped there with e: a resting contact's velocity decays as e^(k/2) to rest.
Drift: after the step, if some column lies below its wall by more than contact_tol / 2, the positions
(not the velocities) are projected onto the walls along M (the direct projection of Moreau-Jean,
Acary 2013):

    q <- q + M^-1 W_S mu,   0 <= g_S + W_S^T M^-1 W_S mu  _|_  mu >= 0                          (6)

over the columns S below their walls (Newton iterations until every gap is >= -1e-3 contact_tol).
The change of energy of (6), with the contact work of (5), is the phase's contact dissipation: the
recorded energy balance E - E_0 - W_applied - W_contact measures the scheme's own error.

Step control (controlled_step): a step is halved (at most MAX_HALVINGS times) while a column would end more
than contact_tol below its wall, or while its energy balance E_(k+1) - E_k - W_applied - W_contact misses by
more than ENERGY_TOL times the phase's energy scale (the trapezoidal rule keeps the energy of a linear system,
so the miss is the error of the once-linearised step); after GROW_AFTER steps at one size it doubles again, up
to h = contact_step. So the projection (6) moves no point by more than contact_tol, and the scheme's own error
is ENERGY_TOL scale per step whatever contact_step.

The phase ends (the event-driven loop resumes) after OPEN_STEPS steps in which no column was active, when
every column's gap exceeds the contact band; or at t_end. (Ending at the first such step handed a beam
that bounces off in micro-bounces back to events and accumulations every few steps.) Walls with friction,
compliant walls, joint limits, prescribed coordinates and a re-charted free base keep the event-driven
contact phases (can_step).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg

from ..contact.candidates import end_joints
from ..contact.impact import _solve_lcp
from ..contact.link_tables import _tables
from ..contact.span_grid import grid_terms, span_grid
from ..dynamics.gibbs_appell import energy, mass_matrix
from .implicit import rhs_jacobian
from .results import energy_scale

#: theta of equations (1)-(2): the trapezoidal rule (no numerical damping of the flight's motion).
THETA = 0.5
#: Depth below a wall, relative to contact_tol, beyond which the positions are projected (equation (6)).
PROJECT_BELOW = 0.5
#: Gaps at which the projection (6) stops, relative to contact_tol.
PROJECT_TO = 1e-3
#: Halvings of a step at most (controlled_step): down to contact_step / 1024.
MAX_HALVINGS = 10
#: The largest miss of a step's energy balance, relative to the phase's energy scale (controlled_step).
ENERGY_TOL = 1e-6
#: Steps accepted at one step size after which it doubles again (up to contact_step).
GROW_AFTER = 4
#: Consecutive steps without an impulse after which a stepped phase whose gaps all exceed the contact band ends.
OPEN_STEPS = 20
#: Steps recorded at once (a chunk of samples; an interrupt keeps whole chunks).
CHUNK = 200


class Columns(NamedTuple):
    """The contact columns at one state: g (k,) [m], W (N, k), wall (k,) int, column (k,) int (of the gap matrix,
    where its force is recorded), x (k,) [m] abscissa on its link (NaN: a joint point)."""

    g: np.ndarray
    W: np.ndarray
    wall: np.ndarray
    column: np.ndarray
    x: np.ndarray


def can_step(run) -> bool:
    """Whether this run's contact phases can be stepped (module docstring: frictionless, rigid walls, no joint
    limits, no prescribed coordinates, no re-charted free base)."""
    return bool(run.settings.walls) and run.settings.accumulation != "stop" and not why_not_stepped(run)


def why_not_stepped(run) -> str:
    """"" when this run's contact phases can be stepped, else what keeps them event-driven (a warning's words)."""
    s = run.settings
    why = [what for what, no in (("a wall with friction", any(w.friction > 0 for w in s.walls)),
                                 ("a compliant wall", run.compliant is not None), ("joint limits", run.stops is not None),
                                 ("prescribed coordinates", s.prescribed is not None),
                                 ("a free base re-charted in 3D", run.charting)) if no]
    return ", ".join(why)


def columns(run, q, reach: float = np.inf) -> Columns:
    """Columns at q (N,): the joint points and the cells' lowest points that can rest (Contacts.full), then the grid
    points on every wall whose cell (its lowest point and its link's end joints) is within reach [m] of that wall
    (a grid point's gap is never below its cell's); columns whose W is zero (a fixed base's O_1) are left out.
    (The cells' lowest points are columns of the step too: without them a dip of a vibrating element between
    grid points was caught by the projection (6) only, 4x the steps and up to 3.6e-5 J per projection on the
    dropped beam of issue 25, against 3.2e-6 J with them.)"""
    if run.grid is None:
        run.grid = span_grid(run.model, run.contacts.cells, run.contacts.n_joints, _tables(run.model).pb)
    grid = run.grid
    g, nrm, J, _, valid, xs = run.contacts.full(q, abscissae=True)
    w_i, c_i = np.nonzero(valid & run.resting.can_rest)
    parts = [(g[w_i, c_i], np.einsum("kdn,kd->nk", J[w_i, c_i], nrm[w_i, c_i]), w_i, c_i, xs[w_i, c_i])]
    if grid.x.size:
        near = _cell_gaps(run, q) <= reach                                          # (W, G)
        sel = near.any(axis=0)
        if sel.any():
            gg, gn, gJ = grid_terms(run.model, run.settings.walls, q, grid, sel)
            for w in np.flatnonzero(near.any(axis=1)):
                m = near[w, sel]
                parts.append((gg[w, m], np.einsum("gdn,gd->ng", gJ[m], gn[w, m]), np.full(m.sum(), w),
                              grid.column[sel][m], grid.x[sel][m]))
    g, W, wall, col, x = (np.concatenate([p[k] for p in parts], axis=-1) for k in range(5))
    keep = np.abs(W).max(axis=0) > 0.0
    return Columns(g[keep], W[:, keep], wall[keep].astype(int), col[keep].astype(int), x[keep])


def _cell_gaps(run, q) -> np.ndarray:
    """(W, G) [m] a lower bound of each grid point's gap at q: the least of its cell's column and its link's end
    joints (Contacts.gaps: a cell's lowest point, or NOT_INTERIOR when that is an end of the link)."""
    g = run.contacts.gaps(q)
    ends = end_joints(run.model)[run.grid.link]                                   # (G, 2), -1: none
    at_end = np.where(ends >= 0, g[:, np.maximum(ends, 0)], np.inf).min(axis=2)  # (W, G)
    return np.minimum(g[:, run.grid.column], at_end)


def lowest(run, q) -> float:
    """The least gap [m] at q (N,) of the columns that can rest: joints and cells' lowest points (Contacts.gaps), which
    bound every grid point's from below."""
    g = run.contacts.gaps(q)
    return float(g[run.resting.can_rest].min(initial=np.inf))


def _solver(Mh):
    """A solve of Mh x = b (Cholesky where Mh is positive definite, else LU)."""
    try:
        c = scipy.linalg.cho_factor(Mh)
        return lambda b: scipy.linalg.cho_solve(c, b)
    except np.linalg.LinAlgError:
        lu = scipy.linalg.lu_factor(Mh)
        return lambda b: scipy.linalg.lu_solve(lu, b)


class StepOut(NamedTuple):
    """One step of (1)-(6): y (2N [+ 2],) at t + h, the impulses P (k,) [N s] of the columns at the step's start,
    the columns, the contact work [J] (equation (5) and the projection (6))."""

    y: np.ndarray
    P: np.ndarray
    cols: Columns
    work: float


def linearised(run, t, y):
    """(a (N,) [m/s^2 or rad/s^2], A = da/dq (N, N), B = da/dqdot (N, N), M (N, N)) at (t, y): what equation (3)
    takes from the step's start (simulation.implicit.rhs_jacobian; one evaluation for every halving of a step)."""
    N = run.N
    a = run.equations(t, y)[N:2 * N]        # counts as a right-hand side (budget, progress)
    jac = rhs_jacobian(run.equations, t, y[:2 * N])
    return a, jac[N:2 * N, :N], jac[N:2 * N, N:2 * N], mass_matrix(run.model, y[:N])


def step(run, t, y, h, e, lin) -> StepOut:
    """Equations (1)-(5) from (t, y) over h [s]; e (W,) the walls' restitution; lin: linearised(run, t, y)."""
    N, th = run.N, THETA
    q, v = y[:N], y[N:2 * N]
    a, A, B, M = lin
    Mh = M @ (np.eye(N) - h * th * B - h * h * th * th * A)
    solve = _solver(0.5 * (Mh + Mh.T))
    v_free = v + solve(M @ (h * a + h * h * th * (A @ v)))                      # (3) with P = 0
    reach = run.band + h * run.lipschitz * (np.abs(v).max() + np.abs(v_free).max())   # |dg/dq| <= L_q
    cols = columns(run, q, reach)
    U0, Uf = cols.W.T @ v, cols.W.T @ v_free
    act = cols.g + h * ((1.0 - th) * U0 + th * Uf) <= run.band                  # (4)
    P, v1 = np.zeros(cols.g.size), v_free
    if act.any():
        MinvW = solve(cols.W[:, act])
        D = cols.W[:, act].T @ MinvW
        u0 = U0[act]
        newton = -np.where(u0 > 0.0, 1.0, e[cols.wall[act]]) * u0
        closing = -(np.maximum(cols.g[act], 0.0) + h * (1.0 - th) * u0) / (h * th)
        P[act] = _solve_lcp(0.5 * (D + D.T), Uf[act] - np.minimum(newton, closing))                  # (5)
        v1 = v_free + MinvW @ P[act]
    y1 = y.copy()
    y1[:N], y1[N:2 * N] = q + h * ((1.0 - th) * v + th * v1), v1              # (2)
    work = float(P @ (U0 + cols.W.T @ v1)) / 2.0
    if y.size > 2 * N:   # the applied forces' work at the step's middle (trapezoidal, like (2))
        mid = run.equations(t + 0.5 * h, 0.5 * (y + y1))
        y1[2 * N:] = y[2 * N:] + h * mid[2 * N:]
    return StepOut(y1, P, cols, work)


def controlled_step(run, t, y, h, e, scale: float):
    """(StepOut projected by (6), h used [s]): the step (1)-(6) from (t, y) over h [s], halved (down to
    h / 2^MAX_HALVINGS) while a column would end more than contact_tol below its wall (the projection (6) then moves
    the state by at most contact_tol), while the step's energy balance E_(k+1) - E_k - W_applied - W_contact misses
    by more than ENERGY_TOL scale (the error of the step's linearisation: the trapezoidal rule keeps the energy of a
    linear system; up to 8.8e-5 J in one step of 1e-3 s of the vibrating beam of issue 25, 5.6e-8 J at 1e-4 s).
    scale [J]: the phase's energy scale (results.energy_scale)."""
    N, tol, model = run.N, run.settings.contact_tol, run.model
    E0 = energy(model, y[:N], y[N:2 * N]).total - y[2 * N:2 * N + 2].sum()
    lin = linearised(run, t, y)
    for k in range(MAX_HALVINGS + 1):
        out = step(run, t, y, h, e, lin)
        q1, v1 = out.y[:N], out.y[N:2 * N]
        W1 = out.y[2 * N:2 * N + 2].sum()
        E1 = energy(model, q1, v1).total - W1
        if k == MAX_HALVINGS or (lowest(run, q1) >= -tol and abs(E1 - E0 - out.work) <= ENERGY_TOL * scale):
            break
        h *= 0.5
    q2, moved = project(run, q1, v1)
    if not moved:
        return out, h
    y2 = out.y.copy()
    y2[:N] = q2
    return out._replace(y=y2, work=out.work + float(energy(model, q2, v1).total - W1 - E1)), h


def project(run, q, v, max_iter: int = 10):
    """Equation (6) at q (N,) (v (N,) unchanged): (q, True) after a projection, (q, False) when no column is below
    its wall by more than PROJECT_BELOW contact_tol."""
    tol = run.settings.contact_tol
    if lowest(run, q) >= -PROJECT_BELOW * tol:
        return q, False
    cols = columns(run, q, 0.0)
    for _ in range(max_iter):
        S = cols.g < 0.0
        MinvW = np.linalg.solve(mass_matrix(run.model, q), cols.W[:, S])
        G = cols.W[:, S].T @ MinvW
        q = q + MinvW @ _solve_lcp(0.5 * (G + G.T), cols.g[S])
        cols = columns(run, q, 0.0)
        if cols.g.min() >= -PROJECT_TO * tol:
            break
    return q, True


def contact_phase(run) -> None:
    """Stage 3' (instead of flight, check and dispatch while run.stepping): steps of h = settings.contact_step
    until every contact has opened (run.stepping then False: the event-driven loop resumes) or t_end; the
    samples (every step, or every output_dt), their contact forces P / h at the gap matrix's columns (the grid
    points' summed into their cell's column, at the force-weighted mean abscissa) and energy balance recorded
    in chunks of CHUNK steps."""
    s, N = run.settings, run.N
    e = np.asarray(s.wall_restitution, dtype=float)
    h_max, shape = s.contact_step, run.resting.active.shape
    run.equations.resting_phase = False
    rec, quiet, calm, h = _Samples(shape), 0, 0, h_max
    scale = energy_scale(run.model, energy(run.model, run.y[:N], run.y[N:2 * N]))
    try:
        while run.status is None:
            if run.t >= s.t_end:
                run.end("t_end", t_end=s.t_end)
                break
            t0 = run.t
            h = min(h, h_max)
            last = s.t_end - t0 - h <= 1e-6 * h      # no sliver of a step before t_end: take the rest now
            out, h_done = controlled_step(run, t0, run.y, s.t_end - t0 if last else h, e, scale)
            t1 = s.t_end if last and h_done == s.t_end - t0 else t0 + h_done
            calm = calm + 1 if h_done == h else 0       # steps accepted without a halving
            run.t, run.y, h = t1, out.y, min(h, h_done)
            if calm >= GROW_AFTER:                       # try twice as long (up to h_max, above)
                h, calm = 2.0 * h, 0
            run.counters["n_steps"] += 1
            run.counters["contact_steps"] += 1
            run.counters["stepped_contact_work"] += out.work
            if out.P.any():   # some contact carried a force over this step (Result.resting_time)
                run.counters["resting_time"] += t1 - t0
            rec.add(run, out, t1 - t0)
            if not np.all(np.isfinite(run.y)):
                run.end("non_finite", t=run.t)
                break
            quiet = 0 if out.P.any() else quiet + 1
            if quiet >= OPEN_STEPS and lowest(run, run.y[:N]) > run.band:
                run.stepping = False        # every contact open: the event-driven loop resumes
                run.near[:] = False
                break
            if rec.full():
                rec.flush(run)
    finally:
        rec.flush(run)


class _Samples:
    """The samples of a stepped phase not yet recorded (contact_phase), with their forces and contact work."""

    def __init__(self, shape):
        self.shape = shape
        self.T, self.Y, self.F, self.X, self.Wc = [], [], [], [], []
        self.work = 0.0  # contact work since the chunk's start [J]

    def add(self, run, out, h) -> None:
        F, X = np.zeros(self.shape), np.full(self.shape, np.nan)
        c = out.cols
        on = out.P > 0.0
        np.add.at(F, (c.wall[on], c.column[on]), out.P[on] / h)
        moment = np.zeros(self.shape)
        np.add.at(moment, (c.wall[on], c.column[on]), np.nan_to_num(c.x[on]) * out.P[on] / h)
        span = (F > 0) & (np.arange(self.shape[1]) >= run.contacts.n_joints)[None, :]
        X[span] = moment[span] / F[span]
        self.work += out.work
        self.T.append(run.t)
        self.Y.append(run.y.copy())
        self.F.append(F)
        self.X.append(X)
        self.Wc.append(self.work)

    def full(self) -> bool:
        return len(self.T) >= CHUNK

    def flush(self, run) -> None:
        if not self.T:
            return
        T, Y = np.array(self.T), np.array(self.Y)
        keep = _output(run, T)
        X = np.array(self.X)[keep]
        run.recorder.flight(T[keep], Y[keep], run.phase, np.array(self.F)[keep], None,
                            where=X if np.isfinite(X).any() else None, contact_work=np.array(self.Wc)[keep])
        self.T, self.Y, self.F, self.X, self.Wc = [], [], [], [], []
        self.work = 0.0


def _output(run, T) -> np.ndarray:
    """(K,) bool: the steps T (K,) [s] recorded: every step, or with output_dt the first step at or after each
    multiple of output_dt from t0 (and the last)."""
    dt = run.settings.output_dt
    if dt is None:
        return np.ones(T.size, dtype=bool)
    k = np.floor((T - run.settings.t0) / dt + 1e-9)
    keep = np.r_[True, k[1:] > k[:-1]]
    keep[-1] = True
    return keep
