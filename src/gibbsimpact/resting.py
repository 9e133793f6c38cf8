"""Resting (sustained) contact: the contact-mode stage of the event loop (formulation.md sections 4-7).

A pair a = (wall w, contact point O_j) is *active* when it is held closed,
g_a(q) = g_w(O_j(q)) = 0, by a normal force lambda_a >= 0 [N]. With the active
set A (k pairs) the equations of motion of a contact phase are

    M qddot = f + W lambda,   f = Q - h - dV/dq,   W = [J_j^T n_a] (N, k)          (1)

and the gaps' second time derivatives along the motion (walls.py: |grad g| = 1)

    gddot_a = n_a . (J_j qddot + Jdot_j qdot) + pdot_j^T H_w pdot_j = W_a^T qddot + c_a,
    c_a = n_a . a0_j + pdot_j^T H_w pdot_j                                            (2)

a0_j = Jdot_j qdot, the acceleration of O_j at qddot = 0, is the translation column
of the kernel's qddot-free frame acceleration Tddot0 (kernel.JOB_FRAMES), so only
frame origins O_1 .. O_(n+1) can rest (the extra tips of prismatic hosts cannot:
an accumulation there still ends the run with status "zeno", as it does on a
wall with friction: sticking and sliding in resting contact are not modelled). A contact phase
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
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import kernel as _k
from .dynamics import _raise_singular
from .impact import _solve_lcp
from .kinematics import run_kernel, states

_JOB = _k.JOB_SOLVE | _k.JOB_M | _k.JOB_POINTS | _k.JOB_JACOBIANS | _k.JOB_FRAMES
_JOB_POS = _k.JOB_M | _k.JOB_POINTS | _k.JOB_JACOBIANS


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


def _solve_sym(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with G x = b; the least-squares solution of smallest norm when G (k, k) is singular."""
    try:
        x = np.linalg.solve(G, b)
        if np.all(np.isfinite(x)) and np.linalg.cond(G) < 1e12:
            return x
    except np.linalg.LinAlgError:
        pass
    return np.linalg.lstsq(G, b, rcond=1e-12)[0]


def constraint_data(model, walls, q, qd, Q, pairs, velocities=True) -> ConstraintData:
    """Equations (1)-(2) of the pairs (k, 2) (wall, point index) at the state (q, qd) (N,) with forces Q (N,) or None.

    velocities=False: positions only (c and qdd_free are zero; qd is ignored).
    """
    N = model.n_dof
    job = _JOB if velocities else _JOB_POS
    out = run_kernel(model, states(q, qd if velocities else None), job, Q)
    if velocities and out[0] != 0.0:
        _raise_singular(model, q, out[0], out[1], out[2])
    off = _offsets(model, job)
    M = out[off[2]:off[3]].reshape(N, N)
    P = out[off[7]:off[8]].reshape(-1, 3)
    J = out[off[8]:off[9]].reshape(-1, 3, N)
    pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
    k = len(pairs)
    Jp = J[pairs[:, 1]]  # (k, 3, N)
    p = P[pairs[:, 1]]  # (k, 3)
    nrm, g = np.zeros((k, 3)), np.zeros(k)
    c, v = np.zeros(k), np.zeros(k)
    if velocities:
        F = out[off[9]:off[10]].reshape(model.n_links + 1, 3, 4, 4)
        qdd = out[off[1] + N:off[1] + 2 * N].copy()
        pd = Jp @ qd  # (k, 3)
        a0 = F[pairs[:, 1], 2, :3, 3]  # Jdot qdot = Tddot0's translation column
    else:
        qdd = np.zeros(N)
    for w in np.unique(pairs[:, 0]):
        sel = pairs[:, 0] == w
        wall = walls[w]
        nrm[sel] = wall.normal(p[sel])
        g[sel] = wall.gap(p[sel])
        if velocities:
            # (2): c = n . a0 + pdot^T H pdot.
            c[sel] = np.sum(nrm[sel] * a0[sel], axis=1) + wall.curvature(p[sel], pd[sel])
    W = np.einsum("kcn,kc->nk", Jp, nrm)
    if velocities:
        v = np.sum(nrm * pd, axis=1)
    try:
        MinvW = np.linalg.solve(M, W)
    except np.linalg.LinAlgError:
        _raise_singular(model, q, 1, 0.0, 0.0)
    G = W.T @ MinvW
    return ConstraintData(qdd, MinvW, W, 0.5 * (G + G.T), c, g, v)


_OFFSETS: dict = {}


def _offsets(model, job):
    """Section offsets of the kernel output (kernel.layout) for one state, cached per model shape and job."""
    key = (model.n_links, model.n_dof, model.n_joints, job)
    off = _OFFSETS.get(key)
    if off is None:
        off = _OFFSETS[key] = _k.layout(model.n_links, model.n_dof, 1, job, model.n_joints)
    return off


class RestingContacts:
    """The active set of resting pairs (W, P) bool and equations (3)-(5) (module docstring).

    model, walls : the run's; contact_tol [m]: drift bound; force_scale [N]: m |g~|, the
    scale of the activity threshold (1 N without gravity).
    """

    def __init__(self, model, walls, contact_tol):
        self.model, self.walls, self.contact_tol = model, walls, contact_tol
        P = model.n_joints
        self.active = np.zeros((len(walls), P), dtype=bool)
        # Frame origins can rest (a0 from the kernel's frames); O_1 of a fixed base never moves.
        restable = np.arange(P) <= model.n_links
        if not isinstance(model.chain.base, str):
            restable[0] = False
        self.restable = restable
        # Resting contact with friction (stick / slip) is not modelled: frictional walls hold no pair.
        self.can_rest = restable[None, :] & np.array([w.friction == 0 for w in walls], dtype=bool)[:, None]
        grav = float(np.linalg.norm(getattr(model, "gravity", (0.0, 0.0, 0.0))))
        self.force_scale = model.total_mass * grav if grav > 0 else 1.0
        self._cache = (None, None)

    @property
    def pairs(self) -> np.ndarray:
        """(k, 2) active (wall, point) pairs, row-major order."""
        return np.argwhere(self.active)

    def any(self) -> bool:
        return bool(self.active.any())

    def clear(self):
        self.active[:] = False

    # -- equations (1)-(3) ------------------------------------------------------------
    def acceleration(self, q, qd, Q=None):
        """(qddot (N,), lambda (k,) [N]) of equation (3) for the active pairs at (q, qd)."""
        key = (q.tobytes(), qd.tobytes(), None if Q is None else Q.tobytes())
        if self._cache[0] == key:
            return self._cache[1]
        d = constraint_data(self.model, self.walls, q, qd, Q, self.pairs)
        lam = _solve_sym(d.G, -(d.W.T @ d.qdd_free + d.c))
        res = (d.qdd_free + d.MinvW @ lam, lam)
        self._cache = (key, res)
        return res

    def force_matrix(self, q, qd, Q=None) -> np.ndarray:
        """Normal forces (W, P) [N] of the active pairs at (q, qd), zeros elsewhere."""
        F = np.zeros(self.active.shape)
        if self.any():
            F[self.active] = self.acceleration(q, qd, Q)[1]
        return F

    # -- equation (5) -----------------------------------------------------------------
    def project(self, q, qd, pairs, max_iter=20):
        """(q, qd) moved onto g = 0, v_n = 0 of the pairs (k, 2) along the metric of M (equation (5))."""
        q, qd = q.copy(), qd.copy()
        if len(pairs) == 0:
            return q, qd
        tol = 1e-3 * self.contact_tol
        for _ in range(max_iter):
            d = constraint_data(self.model, self.walls, q, None, None, pairs, velocities=False)
            if np.max(np.abs(d.g)) <= tol:
                break
            q = q - d.MinvW @ _solve_sym(d.G, d.g)
        else:
            raise np.linalg.LinAlgError(
                f"resting contact: the projection onto the walls did not converge (max |g| = "
                f"{np.max(np.abs(d.g)):.3g} m after {max_iter} Newton steps)")
        qd = qd - d.MinvW @ _solve_sym(d.G, d.W.T @ qd)
        return q, qd

    # -- equation (4) -----------------------------------------------------------------
    def decide(self, q, qd, Q, candidates):
        """Project onto the candidates (k, 2), solve (4), set the active set; returns the projected (q, qd)."""
        self.clear()
        self._cache = (None, None)
        if len(candidates) == 0:
            return q, qd
        q, qd = self.project(q, qd, candidates)
        d = constraint_data(self.model, self.walls, q, qd, Q, candidates)
        lam = _solve_lcp(d.G, d.W.T @ d.qdd_free + d.c)
        on = lam > 1e-10 * max(float(lam.max(initial=0.0)), self.force_scale)
        for (w, j), a in zip(candidates, on):
            self.active[w, j] = a
        return q, qd

    # -- the events and the candidates of a contact phase -----------------------------
    def drift_events(self):
        """Rows (wall, point, offset [m], direction) and kinds of the drift events g_a = +-contact_tol."""
        rows, kinds = [], []
        for w, j in self.pairs:
            rows += [(w, j, -self.contact_tol, 1.0), (w, j, self.contact_tol, -1.0)]
            kinds += [("drift", int(w), int(j))] * 2
        return rows, kinds

    def release_events(self, applied):
        """(fun(t, y) -> lambda (k,) [N], directions (k,) = -1) and kinds of the release events.

        applied(t, q, qd) -> (N,) or None: the generalised forces Q of equation (1).
        """
        N = self.model.n_dof

        def fun(t, y):
            q, qd = y[:N], y[N:2 * N]
            return self.acceleration(q, qd, applied(t, q, qd))[1]

        pairs = self.pairs
        return (fun, -np.ones(len(pairs))), [("release", int(w), int(j)) for w, j in pairs]

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
