"""Resting (sustained) contact: the contact-mode stage of the event loop (docs/theory.md §6, §10, §11, §14).

A pair a = (wall w, contact point O_j) is *active* when it is held closed,
g_a(q) = g_w(O_j(q)) = 0, by a normal force lambda_a >= 0 [N]. With the active
set A (k pairs) the equations of motion of a contact phase are

    M qddot = f + W lambda,   f = Q - h - dV/dq,   W = [J_j^T n_a] (N, k)          (1)

and the gaps' second time derivatives along the motion (walls.py: |grad g| = 1)

    gddot_a = n_a . (J_j qddot + Jdot_j qdot) + pdot_j^T H_w pdot_j = W_a^T qddot + c_a,
    c_a = n_a . a0_j + pdot_j^T H_w pdot_j                                            (2)

a0_j = Jdot_j qdot, the acceleration of O_j at qddot = 0, is the translation column
of the kernel's qddot-free frame acceleration Tddot0 (kernel.JOB_FRAMES): frame
origins O_1 .. O_(n+1) rest (the extra tips of prismatic hosts cannot: an
accumulation there still ends the run with status "zeno"), and so do the closest
points of links' spans (link columns; their W_a and c_a: span_resting.py). A contact phase
keeps gddot_A = 0: with the Delassus matrix G = W^T M^-1 W (k, k) [m/(N s^2)],

    G lambda = -(W^T M^-1 f + c),    qddot = M^-1 f + M^-1 W lambda                (3)

(lambda by least squares when G is singular: redundant contacts share the load
with the smallest |lambda|).

Mode decision, at the start of a run, after every impact, at a release and at a
drift event: the candidates C are the pairs in the contact band whose normal
velocity is below the grazing velocity (|v_n| <= grazing_velocity; a pair of an
accumulation is included whatever its rebound, see ``settle``). After the
projection below, every candidate has g = 0 and v_n = 0, and the normal
accelerations a = gddot_C obey the linear complementarity problem

    a = G_CC lambda + b >= 0,  lambda >= 0,  a . lambda = 0,   b = W_C^T M^-1 f + c_C   (4)

(impact._solve_lcp). A = {a in C : lambda_a > 1e-10 max(max lambda, m g)}; the
other candidates separate (a >= 0) and are watched by the sink and leave events
of the flight phase.

Release: the event lambda_a(t, y) = 0 (falling) of an active pair ends the phase;
the pair leaves A, and (4) decides the others again.

Drift: the constraint is kept at acceleration level, so g and v_n of an active
pair drift with the integration error. *Projection*, not stabilisation: every
mode decision first moves the state onto g_C = 0 and v_n,C = 0 along the
metric of M (the smallest change of kinetic metric),

    q  <- q - M^-1 W G^+ g(q)            (Newton iterations, |g| <= 1e-3 contact_tol)
    qdot <- qdot - M^-1 W G^+ W^T qdot    (M-orthogonal: the kinetic energy never rises)   (5)

and the events g_a = +-contact_tol of every active pair end a phase whose drift
reaches contact_tol, which projects again. So no active point is farther than
contact_tol from its wall at any sample.

Impacts while some pairs rest: the impact stage sees the resting pairs in the
contact band and gives them e = 0 (a resting contact can take an impulse but
does not rebound).

Friction (a wall with friction = mu > 0). A resting pair on such a wall *sticks*
or *slips*. Sticking adds the tangential accelerations of its point to the
constraints (tangents t1, t2 of walls.tangent_basis; at zero slip the
tangent's rotation contributes nothing), with free tangential forces
lambda_t; slipping replaces its force column W_a by W_a - mu J_j^T s_a
(Coulomb's force -mu lambda_n s_a). With constraint rows C and force columns B

    (C^T M^-1 B) lambda = -(C^T M^-1 f + c),   qddot = M^-1 f + M^-1 B lambda      (6)

(B != C while something slips: the matrix is not symmetric, and can be singular
for large mu: Painleve's paradox, reported as a failed run). The slip direction
is the tangential velocity v_t of the point, smoothed through zero by the
direction s0 it had when the phase started,

    s_a = (v_t + v_tol s0) / |v_t + v_tol s0|                                    (7)

(v_tol = grazing_velocity). A pair that starts to slip from rest (slower than v_tol at the
mode decision) whose point's tangential acceleration stays below 1e-2 g (a force at the cone's
edge: it slips at ~zero speed) keeps its direction instead,

    s_a = s0                                                                      (7')

(passed to the compiled (7) as s0 scaled by V / v_tol, V = HELD_SLIP_SPEED = 1e3 m/s: s0 to
|v_t| / V <= 2e-9), until its slip speed reaches 2 v_tol (event "speed", a new mode decision:
above v_tol, (7) along its velocity) or its stick event: regularised over v_tol, the direction's feedback
mu lambda_n / (m v_tol) ~ 1e6 1/s on a slip across s0 made the contact ODE stiff, steps of
1e-6 s for a rod slipping at ~zero speed at the friction angle (issue 25 item 9).
Events of a frictional contact phase: "slip" when a
sticking force reaches the cone, mu lambda_n - |lambda_t| = 0; "stick" when a
slip stops (or, in 3D, turns by 90 degrees), v_t . s0 = 0, or v_t . s0 = min(0, v_t0 . s0)
- v_tol / 1000 for a pair that starts to slip from rest (slower than v_tol; v_t0 its slip
after the projection, which cannot remove a slip along a tangent in which the point can hardly
move): its event starts above zero, so that a force sitting exactly at the cone's edge (a rod on an incline with
mu = tan alpha: zero acceleration either way) keeps slipping at zero speed instead of
stopping at once and slipping again without end. At the mode decision
a candidate slower than v_tol sticks (its slip is projected away with the
normal velocity, equation (5) with its tangent rows), the others slip along
their velocity; an active-set iteration then removes the most negative normal
force and turns the sticking force farthest outside the cone into slip against
it, until every normal force is >= 0 and every sticking force inside the cone.
(Frictionless candidates keep the LCP (4).) The friction power sum F_t . pdot is
integrated with the damping's work (Result.work[:, 1]) so that the energy
balance E(t) - E(0) - W(t) still closes.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import kernel as _k
from ..dynamics.gibbs_appell import _raise_singular
from .impact import _solve_lcp
from ..dynamics.kinematics import as_vector, run_kernel, states
from .span_resting import rolls, span_abscissae, span_point_terms, tip_point_terms, tree_tip_columns
from .walls import packed_walls, tangent_basis

_JOB = _k.JOB_SOLVE | _k.JOB_M | _k.JOB_POINTS | _k.JOB_JACOBIANS | _k.JOB_FRAMES
_JOB_POS = _k.JOB_M | _k.JOB_POINTS | _k.JOB_JACOBIANS


#: V [m/s] of equation (7'): a slip direction held at s0 is (v_t + V s0) / |v_t + V s0|.
HELD_SLIP_SPEED = 1e3


class ConstraintData(NamedTuple):
    """Equations (1)-(2) at one state for k pairs.

    qdd_free (N,) = M^-1 f; MinvW (N, k); W (N, k); G (k, k); c (k,) [m/s^2]; g (k,) [m];
    v (k,) normal velocities [m/s].
    """

    qdd_free: np.ndarray
    MinvW: np.ndarray
    W: np.ndarray
    G: np.ndarray
    c: np.ndarray
    g: np.ndarray
    v: np.ndarray
    M: np.ndarray | None = None  # (N, N)
    J: np.ndarray | None = None  # (k, 3, N) point Jacobians
    n: np.ndarray | None = None  # (k, 3) unit normals
    pd: np.ndarray | None = None  # (k, 3) point velocities [m/s]
    a0: np.ndarray | None = None  # (k, 3) Jdot qdot [m/s^2]
    lam: np.ndarray | None = None  # (k,) [N]: equation (3) without friction, G lam = -(W^T qdd_free + c)
    qdd: np.ndarray | None = None  # (N,): its qddot = qdd_free + M^-1 W lam


def _solve_sym(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with G x = b for a symmetric G (k, k): the least-squares solution of smallest |x|, with
    singular values below 1e-10 of the largest cut (lstsq's rcond): redundant contacts (two
    sticking ends of a rigid rod along its axis, three points of a chain on a line) then share
    the load with the smallest |x| instead of an arbitrary split blown up by round-off.
    Compiled (kernel.sym_solve; the right-hand side of a frictionless contact phase solves (3)
    inside kernel.contact_terms with the same code).
    """
    if G.size == 0:
        return np.zeros(0)
    return _k.lazy("sym_solve")(np.array(G, dtype=float, order="C"), np.array(b, dtype=float, order="C"))


def _slip_against(n: np.ndarray, lam_t: np.ndarray) -> np.ndarray:
    """The impending slip direction (3,) of a sticking point with unit normal n (3,) and tangential
    force lam_t (2,) [N] in its tangent basis (walls.tangent_basis): against that force."""
    ft = lam_t @ tangent_basis(n[None, :])[0]
    return -ft / np.linalg.norm(ft)


def _tangential(d: ConstraintData) -> np.ndarray:
    """v_t (k, 3) [m/s]: the tangential velocities pdot - (pdot . n) n of the pairs of d."""
    return d.pd - np.sum(d.pd * d.n, axis=1)[:, None] * d.n


class _Plan(NamedTuple):
    """What the compiled contact terms need besides the state, fixed for a set of pairs:
    pairs (k, 2) int64, packed walls (wk (W,), wp (W, 6)), the kernel job and its output's
    offsets, contact_terms' vel (0 positions, 2 velocities and equation (3)) and its section
    offsets o (12,) as a list."""

    pairs: np.ndarray
    wk: np.ndarray
    wp: np.ndarray
    job: int
    off: np.ndarray
    vel: int
    o: list


def _plan(model, walls, pairs, velocities=True) -> _Plan:
    job = _JOB if velocities else _JOB_POS
    pairs = np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2)
    wk, wp = packed_walls(walls)
    o = _k.contact_layout(model.n_dof, len(pairs)).tolist()  # section starts, then the end
    return _Plan(pairs, wk, wp, job, _offsets(model, job), 2 if velocities else 0, o)


def _terms(model, q, qd, Q, plan: _Plan):
    """(kernel output, kernel.contact_terms output) at the state (q, qd) (N,) with forces Q or None."""
    vel = plan.vel
    out = run_kernel(model, states(q, qd if vel else None), plan.job, Q)
    if vel and out[0] != 0.0:
        _raise_singular(model, q, out[0], out[1], out[2])
    r = _k.lazy("contact_terms")(out, plan.off, as_vector(qd) if vel else model.kernel_data[2], plan.pairs,
                                 plan.wk, plan.wp, vel)
    if r[0] != 0.0:
        _raise_singular(model, q, 1, 0.0, 0.0)
    return out, r


def constraint_data(model, walls, q, qd, Q, pairs, velocities=True) -> ConstraintData:
    """Equations (1)-(2) of the pairs (k, 2) (wall, point index) at the state (q, qd) (N,) with forces Q (N,) or None:
    one kernel call, then the compiled kernel.contact_terms on its output (equation (3) without
    friction included: lam, qdd).

    velocities=False: positions only (c and qdd_free are zero; qd is ignored; lam, qdd None).
    """
    plan = _plan(model, walls, pairs, velocities)
    out, r = _terms(model, q, qd, Q, plan)
    return _constraint_data(model, out, r, plan)


def mixed_constraint_data(model, walls, q, qd, Q, pairs, n_joints: int, flex, velocities=True, seats=None):
    """resting.ConstraintData of pairs (k, 2) some of which are span pairs (column >= n_joints):
    the joint pairs from the compiled contact terms (resting.constraint_data), the span pairs from
    span_resting.span_point_terms at x* (or at their seats (k,) [m], NaN: none; RestingContacts.seat), then W (N, k), M^-1 W, G = W^T M^-1 W and, with
    velocities, equation (3) of resting.py (lam, qdd). Shapes and units as ConstraintData."""
    pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
    k, N = len(pairs), model.n_dof
    tip = np.isin(pairs[:, 1], tree_tip_columns(model))
    span = (pairs[:, 1] >= n_joints) | tip
    d0 = constraint_data(model, walls, q, qd, Q, pairs[~span], velocities)
    qd_use = qd if velocities else np.zeros(N)
    W, J = np.zeros((N, k)), np.zeros((k, 3, N))
    nrm, pd, a0, c, g = np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3)), np.zeros(k), np.zeros(k)
    joint = np.flatnonzero(~span)
    W[:, joint], J[joint], nrm[joint], g[joint] = d0.W, d0.J, d0.n, d0.g
    if velocities:
        pd[joint], a0[joint], c[joint] = d0.pd, d0.a0, d0.c
    sp = np.flatnonzero(span & ~tip)
    for a, (i, x, stat) in zip(sp, span_abscissae(model, walls, q, pairs[sp], n_joints, flex,
                                                  None if seats is None else seats[sp])):
        _, J[a], nrm[a], pd[a], a0[a], g[a], c[a] = span_point_terms(model, walls[pairs[a, 0]], q, qd_use, i, x,
                                                                     stat)
        W[:, a] = J[a].T @ nrm[a]
    for a in np.flatnonzero(tip):  # a tree's free tip: a fixed material point at x = l
        i = model.extra_tips[pairs[a, 1] - model.n_links - 1]
        _, J[a], nrm[a], pd[a], a0[a], g[a], c[a] = tip_point_terms(model, walls[pairs[a, 0]], q, qd_use, i)
        W[:, a] = J[a].T @ nrm[a]
    if not velocities:
        pd = a0 = None
        c = np.zeros(k)
    M = d0.M
    MinvW = np.linalg.solve(M, W)
    G = W.T @ MinvW
    G = 0.5 * (G + G.T)
    v = W.T @ qd_use
    lam = qdd = None
    if velocities:
        lam = _solve_sym(G, -(W.T @ d0.qdd_free + c))
        qdd = d0.qdd_free + MinvW @ lam
    return ConstraintData(d0.qdd_free, MinvW, W, G, c, g, v, M, J, nrm, pd, a0, lam, qdd)


def _constraint_data(model, out, r, plan: _Plan) -> ConstraintData:
    """ConstraintData as views of the two outputs of _terms."""
    N, k, o, off = model.n_dof, len(plan.pairs), plan.o, plan.off
    W, MinvW = r[o[0]:o[1]].reshape(N, k), r[o[1]:o[2]].reshape(N, k)
    G, c, g, v = r[o[2]:o[3]].reshape(k, k), r[o[3]:o[4]], r[o[4]:o[5]], r[o[5]:o[6]]
    nrm, pd, a0 = r[o[6]:o[7]].reshape(k, 3), r[o[7]:o[8]].reshape(k, 3), r[o[8]:o[9]].reshape(k, 3)
    M = out[off[2]:off[3]].reshape(N, N)
    Jp = out[off[8]:off[9]].reshape(-1, 3, N)[plan.pairs[:, 1]]  # (k, 3, N)
    if plan.vel:
        qdd, lam, qdd3 = out[off[1] + N:off[1] + 2 * N].copy(), r[o[9]:o[10]], r[o[10]:o[11]]
    else:
        qdd, lam, qdd3, pd, a0 = np.zeros(N), None, None, None, None
    return ConstraintData(qdd, MinvW, W, G, c, g, v, M, Jp, nrm, pd, a0, lam, qdd3)


_OFFSETS: dict = {}


def _offsets(model, job):
    """Section offsets of the kernel output (kernel.layout) for one state, cached per model shape and job."""
    key = (model.n_links, model.n_dof, model.n_joints, job)
    off = _OFFSETS.get(key)
    if off is None:
        off = _OFFSETS[key] = _k.layout(model.n_links, model.n_dof, 1, job, model.n_joints)
    return off


class RestingContacts:
    """The active set of resting pairs and equations (3)-(7) (module docstring).

    active (W, P) bool: resting pairs; stick (W, P) bool: the active pairs on a frictional
    wall that stick (the others on such a wall slip along slip_dir (W, P, 3)).
    model, walls : the run's; contact_tol [m]: drift bound; v_tol [m/s]: the slip speed below
    which a contact may stick (grazing_velocity); n_cols: columns of the gap matrix (default
    the P joint points); force_scale [N]: m |g~| (1 N without gravity).
    """

    def __init__(self, model, walls, contact_tol, v_tol=1e-6, n_cols=None, flex=()):
        self.model, self.walls, self.contact_tol, self.v_tol = model, walls, contact_tol, v_tol
        # Link columns (n_cols > P): cell flex[c - P] = (link, cell, cells) (contact.span_cells.link_cells), a
        # span pair (span_resting.py).
        self.n_joints, self.flex = model.n_joints, list(flex)
        P = model.n_joints if n_cols is None else n_cols  # columns of the gap matrix (contacts.Contacts)
        self.active = np.zeros((len(walls), P), dtype=bool)
        self.stick = np.zeros((len(walls), P), dtype=bool)
        self.slip_dir = np.zeros((len(walls), P, 3))
        # v_t . s0 at which a slipping pair's "stick" event fires, minus sign [m/s]: 0, or
        # v_tol / 1000 for a pair that started to slip from rest (module docstring).
        self.slip_offset = np.zeros((len(walls), P))
        # Slipping pairs that started from rest: their slip direction is held at s0 (equation (7')).
        self.slow = np.zeros((len(walls), P), dtype=bool)
        # The abscissa [m] at which a resting span pair is held as a fixed material point until the next mode
        # decision (NaN: it follows its cell's minimum; _seat_flat_minima).
        self.seat = np.full((len(walls), P), np.nan)
        self.mu = np.array([w.friction for w in walls], dtype=float)
        # Frame origins can rest (a0 from the kernel's frames); O_1 of a fixed base never moves when
        # joint 1 is revolute or a weld (J = 0 there), but it does as a carriage on the base rail (Pa) or as the
        # rear end of a link sliding through the base guide (Pb): then it rests like any joint.
        # Frame origins and span points (link columns, span_resting.py) rest; the extra tips of prismatic hosts do not, nor
        # the centres of attached bodies (the columns after the link columns, contacts.Contacts).
        col = np.arange(P)
        restable = (col <= model.n_links) | ((col >= model.n_joints) & (col < model.n_joints + len(self.flex)))
        self._tips = tree_tip_columns(model)
        restable[self._tips] = True  # a tree's free tips rest (span_resting.tip_point_terms)
        if not isinstance(model.chain.base, str) and not model.joint_specs[0].prismatic:
            restable[0] = False
        self.can_rest = np.broadcast_to(restable[None, :], self.active.shape)  # (W, P): the same for every wall
        grav = float(np.linalg.norm(getattr(model, "gravity", (0.0, 0.0, 0.0))))
        self.force_scale = model.total_mass * grav if grav > 0 else 1.0
        self._cache = (None, None)
        self._mode = (None, None)  # (key of active, stick, slip_dir; their pairs and selections)

    @property
    def pairs(self) -> np.ndarray:
        """(k, 2) active (wall, point) pairs, row-major order."""
        return np.argwhere(self.active)

    def any(self) -> bool:
        return bool(self.active.any())

    @property
    def frictional(self) -> bool:
        """Whether some active pair is on a wall with friction."""
        return bool(np.any(self.active & (self.mu[:, None] > 0)))

    def clear(self):
        self.active[:] = False
        self.stick[:] = False
        self.slip_dir[:] = 0.0
        self.slip_offset[:] = 0.0
        self.slow[:] = False
        self.seat[:] = np.nan
        self._cache = (None, None)

    # -- equations (1)-(3), (6) ------------------------------------------------------
    def _in_python(self, pairs) -> bool:
        """True when some pair (k, 2) is a span pair or a tree's free tip: their acceleration terms come
        from span_resting (mixed_constraint_data), not from the compiled contact terms."""
        return bool(np.any(pairs[:, 1] >= self.n_joints) or (self._tips.size and np.any(np.isin(pairs[:, 1], self._tips))))

    def _data(self, q, qd, Q, pairs, velocities=True) -> ConstraintData:
        """constraint_data of the pairs (k, 2), span pairs included (span_resting.mixed_constraint_data)."""
        pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
        if self._in_python(pairs):
            return mixed_constraint_data(self.model, self.walls, q, qd, Q, pairs, self.n_joints, self.flex,
                                         velocities, self.seat[pairs[:, 0], pairs[:, 1]])
        return constraint_data(self.model, self.walls, q, qd, Q, pairs, velocities)

    def _solve(self, d, pairs, stick, sdir, slow=None):
        """Equations (3)/(6) for the pairs (k, 2) with constraint data d; stick (k,) bool, sdir (k, 3);
        slow (k,) bool or None: slipping pairs whose direction is held at sdir (7').

        Returns (qddot (N,), lambda_n (k,), F_t (k, 3) tangential forces [N], lambda_t (k, 2) of
        sticking pairs in their tangent basis, slip power (k,) [W]).
        """
        k = len(pairs)
        mu = self.mu[pairs[:, 0]] if k else np.zeros(0)
        if not (mu > 0).any():
            # (3), solved by the compiled contact terms (constraint_data).
            return d.qdd.copy(), d.lam.copy(), np.zeros((k, 3)), np.zeros((k, 2)), np.zeros(k)
        # (6)-(7): constraint rows C (normal gaps; tangential accelerations of sticking points) and
        # force columns B (normal; slip friction -mu n_s along the slip; sticking tangents), compiled.
        if slow is not None and np.any(slow):
            # (7'): s = (v_t + V s0) / |v_t + V s0| with V = HELD_SLIP_SPEED: s0 to |v_t| / V <= 2e-9.
            sdir = sdir * np.where(slow, HELD_SLIP_SPEED / self.v_tol, 1.0)[:, None]
        r = _k.lazy("friction_solve")(d.M, d.W, d.J, d.n, d.pd, d.a0, d.c, d.qdd_free, mu,
                                      np.ascontiguousarray(stick, dtype=np.int64), np.ascontiguousarray(sdir, dtype=float),
                                      float(self.v_tol))
        N = d.qdd_free.size
        return (r[:N], r[N:N + k], r[N + k:N + 4 * k].reshape(k, 3), r[N + 4 * k:N + 6 * k].reshape(k, 2),
                r[N + 6 * k:])

    def acceleration(self, q, qd, Q=None):
        """Equations (3)/(6) for the active pairs at (q, qd) with forces Q (N,) or None, cached per state:
        (qddot (N,), lambda_n (k,) [N], F_t (k, 3) [N], friction power (k,) [W], lambda_t (k, 2) [N]
        of sticking pairs in their tangent basis, the ConstraintData (None when no active pair
        has friction: that right-hand side is one kernel and one contact_terms call, no views))."""
        key = (q.tobytes(), qd.tobytes(), None if Q is None else Q.tobytes())
        if self._cache[0] == key:
            return self._cache[1]
        # The active set and its stick / slip data change only at mode decisions: read once per set.
        mode = (self.active.tobytes(), self.stick.tobytes(), self.slip_dir.tobytes(), self.slow.tobytes(),
                self.seat.tobytes())
        if self._mode[0] != mode:
            pairs = self.pairs
            k = len(pairs)
            plan = _plan(self.model, self.walls, pairs)
            frictionless = not np.any(self.mu[pairs[:, 0]] > 0)
            zeros = tuple(np.zeros(shape) for shape in ((k, 3), (k,), (k, 2)))
            for z in zeros:
                z.flags.writeable = False  # shared by every right-hand side of the set
            self._mode = (mode, (pairs, self.stick[self.active], self.slip_dir[self.active], plan, frictionless,
                                 zeros, self.slow[self.active]))
        pairs, stick, sdir, plan, frictionless, zeros, slow = self._mode[1]
        if self._in_python(pairs):  # span pairs, a tree's free tips: equations (3)/(6) in Python
            d = self._data(q, qd, Q, pairs)
            qdd, lam, F_t, lam_t, power = self._solve(d, pairs, stick, sdir, slow)
            res = (qdd, lam, F_t, power, lam_t, d)
            self._cache = (key, res)
            return res
        if frictionless:
            # Equation (3) from the compiled contact terms' lambda and qddot sections.
            r = _terms(self.model, q, qd, Q, plan)[1]
            o = plan.o
            res = (r[o[10]:o[11]], r[o[9]:o[10]], zeros[0], zeros[1], zeros[2], None)
            self._cache = (key, res)
            return res
        d = _constraint_data(self.model, *_terms(self.model, q, qd, Q, plan), plan)
        qdd, lam, F_t, lam_t, power = self._solve(d, pairs, stick, sdir, slow)
        res = (qdd, lam, F_t, power, lam_t, d)
        self._cache = (key, res)
        return res

    def force_matrix(self, q, qd, Q=None):
        """Normal forces (W, P) [N] and tangential forces (W, P, 3) [N] of the active pairs at (q, qd)."""
        F = np.zeros(self.active.shape)
        Ft = np.zeros(self.active.shape + (3,))
        if self.any():
            _, lam, F_t, *_ = self.acceleration(q, qd, Q)
            F[self.active] = lam
            Ft[self.active] = F_t
        return F, Ft

    def abscissa_matrix(self, q) -> np.ndarray:
        """x (W, P) [m] along its link of every resting span pair's contact point at q (N,): its seat (a fixed
        material point) or its cell's minimum (a rolling point; span_abscissae); NaN for the joint points and
        for pairs that do not rest. With the link from Contacts' columns this says where a span force acts."""
        X = np.full(self.active.shape, np.nan)
        span = self._span_pairs()
        if len(span):
            X[span[:, 0], span[:, 1]] = [x for _, x, _ in span_abscissae(
                self.model, self.walls, q, span, self.n_joints, self.flex, self.seat[span[:, 0], span[:, 1]])]
        return X

    def _span_pairs(self) -> np.ndarray:
        """(k, 2) the active span pairs (columns after the joint points), row-major order."""
        return np.argwhere(self.active & (np.arange(self.active.shape[1]) >= self.n_joints)[None, :])

    # -- equation (5) -----------------------------------------------------------------
    def project(self, q, qd, pairs, stick=None, max_iter=20):
        """(q, qd) moved onto g = 0, v_n = 0 of the pairs (k, 2) along the metric of M (equation (5));
        stick (k,) bool: those pairs' tangential velocities are projected to zero too."""
        q, qd = q.copy(), qd.copy()
        if len(pairs) == 0:
            return q, qd
        tol = 1e-3 * self.contact_tol
        for _ in range(max_iter):
            d = self._data(q, None, None, pairs, velocities=False)
            if np.max(np.abs(d.g)) <= tol:
                break
            q = q - d.MinvW @ _solve_sym(d.G, d.g)
        else:
            raise np.linalg.LinAlgError(
                f"resting contact: the projection onto the walls did not converge (max |g| = "
                f"{np.max(np.abs(d.g)):.3g} m after {max_iter} Newton steps)")
        W = d.W
        if stick is not None and np.any(stick):
            T = tangent_basis(d.n[stick])
            W = np.hstack((W, np.einsum("sac,scn->nsa", T, d.J[stick]).reshape(W.shape[0], -1)))
        MinvW = np.linalg.solve(d.M, W)
        G = W.T @ MinvW
        qd = qd - MinvW @ _solve_sym(0.5 * (G + G.T), W.T @ qd)
        return q, qd

    # -- equation (4) and its frictional form -----------------------------------------
    def decide(self, q, qd, Q, candidates, slipping=None):
        """Project onto the candidates (k, 2), choose the active set (and stick / slip), set it;
        returns the projected (q, qd).

        slipping : None or {(wall, point): s (3,)}: pairs whose sticking force just reached the
        cone (a "slip" event): they slip along s whatever their speed, so that a force exactly
        at the cone's edge does not stick and slip again at the same instant.
        Q : (N,) the applied generalised forces, or a callable (q, qd) -> (N,): then evaluated at the
        projected state (velocity-dependent forces such as structural damping change with the projection: taken
        before it, a pressed FE arm's tip was set resting with lambda = 1.40 N that the phase then found to be
        -1.42 N, and it stayed pulling on the floor to the end).
        """
        self.clear()
        if len(candidates) == 0:
            return q, qd
        candidates = np.asarray(candidates, dtype=int).reshape(-1, 2)
        mu = self.mu[candidates[:, 0]]
        applied = Q if callable(Q) else (lambda q, qd: Q)
        if not np.any(mu > 0):
            q, qd = self.project(q, qd, candidates)
            Q = applied(q, qd)
            d = self._data(q, qd, Q, candidates)
            lam = _solve_lcp(d.G, d.W.T @ d.qdd_free + d.c)
            on = lam > 1e-10 * max(float(lam.max(initial=0.0)), self.force_scale)
            self.active[candidates[on, 0], candidates[on, 1]] = True
            self._seat_flat_minima(q)
            return q, qd
        # With friction: contacts slower than v_tol stick (their slip is projected away), the
        # others slip along their velocity. Then an active-set iteration: a negative normal force
        # leaves (the most negative first); a sticking force outside the cone |F_t| < mu N (or on
        # its edge) turns into slip against it (the largest excess first).
        vt = _tangential(self._data(q, qd, applied(q, qd), candidates))
        speed = np.linalg.norm(vt, axis=1)
        stick = (mu > 0) & (speed <= self.v_tol)
        sdir = np.where(speed[:, None] > 0, vt / np.maximum(speed, 1e-300)[:, None], 0.0)
        for a, (w, j) in enumerate(candidates):
            s = (slipping or {}).get((int(w), int(j)))
            if s is not None and mu[a] > 0:
                stick[a] = False
                sdir[a] = s if speed[a] <= self.v_tol else sdir[a]
        q, qd = self.project(q, qd, candidates, stick)
        Q = applied(q, qd)
        from_rest = (mu > 0) & (speed <= self.v_tol)  # a slip among these starts from rest
        on = self._active_set(q, qd, Q, candidates, stick, sdir, from_rest)
        slow = self._slow_slips(q, qd, Q, candidates, on, stick, sdir, from_rest)
        # The projection cannot remove a slip along a direction in which the point can hardly move
        # (a tangent of near-zero mobility: G's cut singular values), so a pair that starts to slip
        # from rest may still move against s0: its stick event starts at v_t . s0 < 0 (issue 25 item 7).
        # The event's level is then below that velocity by v_tol / 1000.
        along = np.sum(_tangential(self._data(q, qd, Q, candidates)) * sdir, axis=1)
        for a in np.nonzero(on)[0]:
            w, j = candidates[a]
            self.active[w, j] = True
            self.stick[w, j] = stick[a]
            slips = mu[a] > 0 and not stick[a]
            self.slip_dir[w, j] = sdir[a] if slips else 0.0
            self.slow[w, j] = slips and slow[a]
            self.slip_offset[w, j] = 1e-3 * self.v_tol - min(0.0, along[a]) if slips and from_rest[a] else 0.0
        self._seat_flat_minima(q)
        return q, qd

    def _seat_flat_minima(self, q) -> None:
        """Seat every active span pair that does not roll (span_resting.rolls: a cell's end, or a minimum flatter
        than MIN_CURVATURE) at its present abscissa x* [m]: a fixed material point until the next mode decision.
        Its gap acceleration is then exact (no sliding term); the true minimum of its cell sinks below it by
        ~ phi_xx (x* - x_seat)^2 / 2 at most, which the drift event on the cell's column (g = -contact_tol)
        catches, and the next decision seats it anew."""
        span = self._span_pairs()
        if not len(span):
            return
        for (w, j), (i, x, stat) in zip(span, span_abscissae(self.model, self.walls, q, span, self.n_joints, self.flex)):
            if not (stat and rolls(self.model, self.walls[w], q, i, x)):
                self.seat[w, j] = x

    def _active_set(self, q, qd, Q, candidates, stick, sdir, slow) -> np.ndarray:
        """The active-set iteration of decide (its comments): which candidates (k, 2) rest, (k,) bool;
        stick (k,) bool and sdir (k, 3) are updated in place; slow (k,) bool: the slips from rest (there
        v_t ~ 0, so (7) and (7') give the same forces; (7') keeps |v_t| <= v_tol out of it)."""
        mu = self.mu[candidates[:, 0]]
        on = np.ones(len(candidates), dtype=bool)
        for _ in range(4 * len(candidates) + 4):
            pairs = candidates[on]
            d = self._data(q, qd, Q, pairs)
            _, lam, _, lam_t, _ = self._solve(d, pairs, stick[on], sdir[on], (~stick & slow)[on])
            scale = max(float(np.abs(lam).max(initial=0.0)), self.force_scale)
            if np.any(lam < -1e-10 * scale):
                i = int(np.argmin(lam))
                a = np.nonzero(on)[0][i]
                if stick[a] and np.any(lam_t[i]):
                    # Sticking would pull the point off the wall (a flexible link's tip pressed on
                    # a rough floor): try it slipping before letting it separate (issue 25 item 9).
                    stick[a], sdir[a] = False, _slip_against(d.n[i], lam_t[i])
                    continue
                on[a] = False
                if not on.any():
                    break
                continue
            # A pair sticks only strictly inside the cone (by 1e-9 of the force scale): at its edge
            # it slips, so that a sticking phase starts with its slip event above zero.
            excess = np.linalg.norm(lam_t, axis=1) - mu[on] * lam
            excess[~stick[on]] = -np.inf
            if np.any(excess > -1e-9 * scale):
                i = int(np.argmax(excess))
                a = np.nonzero(on)[0][i]
                stick[a], sdir[a] = False, _slip_against(d.n[i], lam_t[i])
                continue
            on[np.nonzero(on)[0][lam <= 1e-10 * scale]] = False
            break
        return on

    def _slow_slips(self, q, qd, Q, candidates, on, stick, sdir, slow) -> np.ndarray:
        """(K,) bool: the candidates (K, 2) that slip from rest (slow & ~stick & on, each (K,) bool)
        and whose points' tangential accelerations |a_t| [m/s^2] stay below 1e-2 g: they keep their
        direction s0 (sdir (K, 3)), equation (7'). A slip that accelerates faster leaves the slow
        regime |v_t| <= v_tol within v_tol / |a_t| (~100 steps of the regularised (7) at most), and
        keeps (7): from rest a slip starts along a_t, which the active set's s0 (against a sticking
        force of a statically indeterminate set) need not be, and (7) turns onto it."""
        held = slow & ~stick & on
        if not held.any():
            return held
        pairs, rows = candidates[on], np.flatnonzero(held[on])
        d = self._data(q, qd, Q, pairs)
        qdd = self._solve(d, pairs, stick[on], sdir[on], held[on])[0]
        acc = np.einsum("kcn,n->kc", d.J[rows], qdd) + d.a0[rows]
        a_t = acc - np.sum(acc * d.n[rows], axis=1)[:, None] * d.n[rows]
        held[np.flatnonzero(held)] = np.linalg.norm(a_t, axis=1) <= 1e-2 * self.force_scale / self.model.total_mass
        return held

    # -- the events and the candidates of a contact phase -----------------------------
    def drift_events(self):
        """Rows (wall, point, offset [m], direction) and kinds of the drift events g_a = +-contact_tol."""
        rows, kinds = [], []
        for w, j in self.pairs:
            rows += [(w, j, -self.contact_tol, 1.0), (w, j, self.contact_tol, -1.0)]
            kinds += [("drift", int(w), int(j))] * 2
        return rows, kinds

    def release_events(self, applied):
        """(fun(t, y) -> values (m,), directions (m,) = -1) and kinds of the events of a contact phase:
        "release" lambda_n = 0; "slip" mu lambda_n - |F_t| = 0 of a sticking pair; "stick"
        v_t . s = 0 of a slipping pair (its slip stops or turns by 90 degrees; below zero for a
        pair that started to slip from rest, slip_offset); "speed" 2 v_tol - |v_t| = 0 of a pair
        whose direction is held at s0 (7'): its slip has become fast enough for (7).

        applied(t, q, qd) -> (N,) or None: the generalised forces Q of equation (1).
        """
        N = self.model.n_dof
        pairs = self.pairs
        mu = self.mu[pairs[:, 0]]
        stick = self.stick[self.active] & (mu > 0)
        slip = ~self.stick[self.active] & (mu > 0)
        sdir = self.slip_dir[self.active]
        offset = self.slip_offset[self.active]
        slow = self.slow[self.active] & slip

        def fun(t, y):
            q, qd = y[:N], y[N:2 * N]
            _, lam, F_t, _, _, d = self.acceleration(q, qd, applied(t, q, qd))
            out = [lam]
            if stick.any():
                out.append(mu[stick] * lam[stick] - np.linalg.norm(F_t[stick], axis=1))
            if slip.any():
                out.append(np.sum(d.pd[slip] * sdir[slip], axis=1) + offset[slip])
            if slow.any():
                out.append(2.0 * self.v_tol - np.linalg.norm(_tangential(d)[slow], axis=1))
            return np.concatenate(out)

        kinds = [("release", int(w), int(j)) for w, j in pairs]
        kinds += [("slip", int(w), int(j)) for w, j in pairs[stick]]
        kinds += [("stick", int(w), int(j)) for w, j in pairs[slip]]
        kinds += [("speed", int(w), int(j)) for w, j in pairs[slow]]
        return (fun, -np.ones(len(kinds))), kinds

    def slip_direction(self, q, qd, Q, pair) -> np.ndarray:
        """The direction (3,) in which a sticking pair (wall, point) starts to slip: against its
        tangential force at (q, qd), the force that can no longer hold it."""
        _, _, F_t, *_ = self.acceleration(q, qd, Q)
        k = int(np.nonzero((self.pairs == np.asarray(pair)).all(axis=1))[0][0])
        f = F_t[k]
        return -f / np.linalg.norm(f) if np.linalg.norm(f) > 0 else f

    def candidates(self, g, v, band, grazing_velocity, exclude=None, forced=None) -> np.ndarray:
        """(k, 2) candidate pairs of a mode decision (module docstring).

        g, v : (W, P) gaps [m] and normal velocities [m/s]; band [m]: the contact band;
        exclude : (W, P) bool or None, pairs left out (a pair just released);
        forced : (W, P) bool or None, pairs of an accumulation, candidates whatever their velocity.
        """
        c = (g <= band) & (np.abs(v) <= grazing_velocity)
        if forced is not None:
            c |= forced & (g <= band)
        c &= self.can_rest
        if exclude is not None:
            c &= ~exclude
        return np.argwhere(c)
