"""Compliant contact in the event loop: the Hunt-Crossley force of the walls with a stiffness, its episode
state and its events (docs/theory.md §11.5; the law: gibbsimpact.contact.compliant).

A (wall, contact point) pair of a compliant wall is *active* from its start event to its end event:

* start: ``g = 0``, direction -1 (located inside a step as every gap event, flight.py). The approach
  speed there, v_0 = max(-gdot, MIN_APPROACH_SPEED) [m/s], is the episode's state: kept in ``v0`` (W, C)
  until the end event, across every solver step and phase of the contact;
* end: ``g = 0``, direction +1 (the point is back on the free side; where the clamp F_n >= 0 has
  already set the force to zero the point flies free inside the wall until then).

An inactive pair exerts no force, whatever its gap; an active one exerts, at contact point j of wall w,
the generalised force J_j^T (n F_n + F_t) (contact.compliant.normal_force, friction_force), added to the
applied forces of the right-hand side. The pairs' columns are those of Newton contact (joints, closest
points of flexible links: simulation.contacts.Contacts), with the same Jacobians.

Extra states (``n_extra`` = 3 + N, after (q, qdot, W_in, W_damp)), their rates summed over active pairs:

    D_damp' = F_d gdot [W],  D_fric' = F_t . v_t [W],  I_n' = F_n [N],  P' = sum J^T (n F_n + F_t) (N,)

D_damp, D_fric [J] the work of the contact damping and friction (<= 0), I_n [N s] the normal impulse,
P the generalised impulse; W_damp' also receives qdot . P' (the whole contact work, so that the run's
energy balance E - W holds: the contact's elastic energy is not part of E).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..contact.compliant import MIN_APPROACH_SPEED, damping_factor, friction_force, normal_force
from ..contact.walls import is_compliant
from ..dynamics.kinematics import joint_positions_and_jacobians

#: Event kinds of compliant pairs (stages.dispatch).
COMPLIANT_EVENTS = ("contact_start", "contact_end")


class CompliantContact(NamedTuple):
    """One contact of a pair on a compliant wall, from its start event to its end event (Result.compliant_contacts).

    wall : 0-based index into Result.walls; point : 1-based contact column (ImpactRecord.joints numbering)
    start, end : [s] the start and end events (end NaN: still in contact when the run ended)
    approach_speed : v_0 [m/s], -gdot at the start event (before the floor MIN_APPROACH_SPEED)
    """

    wall: int
    point: int
    start: float
    end: float
    approach_speed: float


class CompliantContacts:
    """The compliant walls of a run, the active pairs and their v_0, and the force of the right-hand side.

    contacts : the run's Contacts (gaps, normals, Jacobians of every column); e_wall : (W,) restitution of
    each wall; shift : [m] added to the gaps of active pairs in the gap functions of a phase, so that the
    penetration check (flight.PhaseOutcome.min_gap) sees them as free (a compliant contact penetrates).
    """

    def __init__(self, model, contacts, e_wall, shift: float):
        walls = contacts.walls
        self.model, self.contacts, self.N = model, contacts, model.n_dof
        self.rows = np.array([is_compliant(w) for w in walls], dtype=bool)  # (W,)
        W, C = len(walls), contacts.n_cols
        nan = np.full(W, np.nan)
        self.k, self.p, self.chi, self.mu = nan.copy(), nan.copy(), nan.copy(), np.zeros(W)
        for w in np.flatnonzero(self.rows):
            wall = walls[w]
            self.k[w], self.p[w], self.mu[w] = wall.stiffness, wall.exponent, wall.friction
            self.chi[w] = damping_factor(float(e_wall[w]), wall.damping)
        self.active = np.zeros((W, C), dtype=bool)
        self.v0 = np.full((W, C), np.nan)
        self.shift = float(shift)
        self.n_extra = 3 + self.N
        self._pairs = np.zeros((0, 2), dtype=int)
        self._zero_rates = np.zeros(self.n_extra)
        self.log: list[CompliantContact] = []
        self._open: dict = {}  # (w, c) -> index into log of the pair's contact under way
        self._one_wall = None  # the wall of every active pair when there is one such wall
        self._frictional = False  # whether an active pair is on a wall with friction

    # -- episode state ----------------------------------------------------------------------------

    def start(self, w: int, c: int, t: float, q, qd) -> None:
        """Activate pair (w, c) at its start event at t [s]: v_0 = max(-gdot, MIN_APPROACH_SPEED) [m/s]."""
        _, nrm, J, _, _ = self.contacts.full(q)
        approach = -float(nrm[w, c] @ J[w, c] @ qd)
        self.v0[w, c] = max(approach, MIN_APPROACH_SPEED)
        self.active[w, c] = True
        self._changed()
        self._open[(w, c)] = len(self.log)
        self.log.append(CompliantContact(int(w), int(c) + 1, float(t), float("nan"), approach))

    def _changed(self) -> None:
        """The active pairs changed: their list and what the force's fast paths read from it."""
        self._pairs = np.argwhere(self.active)
        walls = np.unique(self._pairs[:, 0])
        self._one_wall = int(walls[0]) if walls.size == 1 else None
        self._frictional = bool(np.any(self.mu[walls] > 0))

    def end(self, w: int, c: int, t: float) -> None:
        """Deactivate pair (w, c) at its end event at t [s]."""
        self.active[w, c] = False
        self.v0[w, c] = np.nan
        self._changed()
        i = self._open.pop((w, c))
        self.log[i] = self.log[i]._replace(end=float(t))

    # -- forces -----------------------------------------------------------------------------------

    def _geometry(self, q):
        """Gaps (k,) [m], normals (k, 3), Jacobians (k, 3, N) and positions (k, 3) [m] of the active pairs'
        points at q (N,)."""
        pairs = self._pairs
        w, c = pairs[:, 0], pairs[:, 1]
        if np.any(c >= self.model.n_joints):  # a link column: the closest point's search (Contacts.full)
            g, nrm, J, pts, _ = self.contacts.full(q)
            return g[w, c], nrm[w, c], J[w, c], pts[w, c]
        p, Jac = joint_positions_and_jacobians(self.model, q)
        if self._one_wall is not None:  # every active pair on one wall: one geometry call
            g, nrm, _ = self.contacts.walls[self._one_wall].geometry(p[c])
            return g, nrm, Jac[c], p[c]
        g, nrm = np.empty(len(pairs)), np.empty((len(pairs), 3))
        for i, (wi, ci) in enumerate(pairs):
            gi, ni, _ = self.contacts.walls[wi].geometry(p[ci][None, :])
            g[i], nrm[i] = gi[0], ni[0]
        return g, nrm, Jac[c], p[c]

    def pair_forces(self, q, qd):
        """Normal forces F_n (k,) [N], their damping parts F_d (k,) [N], friction forces F_t (k, 3) [N],
        normal rates gdot (k,) [m/s], tangential velocities v_t (k, 3) [m/s], J^T-mapped generalised
        forces (k, N) and the points' positions (k, 3) [m] of the k active pairs at (q, qd) (N,) each."""
        w, c = self._pairs[:, 0], self._pairs[:, 1]
        g, nrm, J, pts = self._geometry(q)
        v = J @ qd  # point velocities (k, 3) [m/s]
        gdot = (nrm * v).sum(axis=1)  # |grad g| = 1: gdot = n . pdot
        Fn, Fd = normal_force(-g, -gdot, self.k[w], self.p[w], self.chi[w], self.v0[w, c])
        v_t = v - gdot[:, None] * nrm
        if self._frictional:
            Ft = friction_force(Fn, v_t, self.mu[w])
            f = nrm * Fn[:, None] + Ft
        else:
            Ft, f = np.zeros_like(v_t), nrm * Fn[:, None]
        Qk = (f[:, None, :] @ J)[:, 0, :]  # J^T f per pair (k, N)
        return Fn, Fd, Ft, gdot, v_t, Qk, pts

    def generalized_force(self, q, qd):
        """(Q (N,) [N, N m], rates (3 + N,) of the extra states: module docstring) at (q, qd) (N,) each."""
        if not len(self._pairs):
            return np.zeros(self.N), self._zero_rates
        Fn, Fd, Ft, gdot, v_t, Qk, _ = self.pair_forces(q, qd)
        Q = Qk.sum(axis=0)
        rates = np.concatenate(([Fd @ gdot, float((Ft * v_t).sum()), Fn.sum()], Q))
        return Q, rates

    def force_matrix(self, q, qd) -> tuple:
        """F_n (W, C) [N] of every pair at (q, qd), zero for the inactive ones, and where each active pair's
        point is, (W, C, 3) [m] (NaN for the inactive ones): for the recorded samples."""
        F, X = np.zeros(self.active.shape), np.full(self.active.shape + (3,), np.nan)
        if len(self._pairs):
            w, c = self._pairs[:, 0], self._pairs[:, 1]
            out = self.pair_forces(q, qd)
            F[w, c], X[w, c] = out[0], out[-1]
        return F, X

    def sample_forces(self, Y) -> tuple:
        """F_n (K, W, C) [N] and the points (K, W, C, 3) [m] (force_matrix) at the states Y (K, 2N [+ extra]) of
        one phase (its active set)."""
        N, shape = self.N, self.active.shape
        if not len(Y):
            return np.zeros((0,) + shape), np.zeros((0,) + shape + (3,))
        F, X = zip(*(self.force_matrix(y[:N], y[N:2 * N]) for y in Y))
        return np.stack(F), np.stack(X)

    def joint_shift(self, w: int, c: int) -> float:
        """The shift [m] of entry (w, c) that Contacts.gap_single leaves out: it reads a joint column's gap
        itself (0 for the other entries, which it takes from the shifted gap matrix)."""
        return self.shift if w < len(self.rows) and c < self.model.n_joints and self.active[w, c] else 0.0

    # -- events -----------------------------------------------------------------------------------

    def shifted(self, g: np.ndarray) -> np.ndarray:
        """The gap matrix (W, C) [m] (or (K, W, C)) with ``shift`` added to the active pairs (class docstring)."""
        return g + self.shift * self.active if self.active.any() else g

    def events(self, g_start):
        """(rows (k, 4): wall, column, offset, direction; kinds) of the compliant pairs' events at the phase start,
        whose gaps are g_start (W, C) [m] (unshifted):

        * inactive: start, E = g - min(g_start, 0), direction -1 (E starts at >= 0 even a round-off below);
        * active: end, E = g - max(g_start, 0), direction +1 (E starts at <= 0), on the shifted gap.
        """
        rows, kinds = [], []
        for w in np.flatnonzero(self.rows):
            for c in range(self.active.shape[1]):
                g0 = float(g_start[w, c])
                if self.active[w, c]:
                    rows.append((w, c, -self.shift - max(g0, 0.0), 1.0))
                    kinds.append(("contact_end", w, c))
                else:
                    rows.append((w, c, -min(g0, 0.0), -1.0))
                    kinds.append(("contact_start", w, c))
        return np.array(rows, dtype=float).reshape(-1, 4), kinds


def compliant_gap_functions(compliant, gap_matrix, gap_batch):
    """The gap functions of a phase with ``shift`` added to the active compliant pairs (class docstring):
    gap_matrix g(q) -> (W, C), gap_batch g(qs) -> (K, W, C) [m]."""
    return (lambda q: compliant.shifted(gap_matrix(q))), (lambda qs: compliant.shifted(gap_batch(qs)))

def compliant_event(run, kind: str, w: int, c: int) -> None:
    """A compliant pair's start or end event (stages.dispatch): its episode state changes, no impact."""
    N = run.N
    if kind == "contact_start":
        run.compliant.start(w, c, run.t, run.y[:N], run.y[N:2 * N])
    else:
        run.compliant.end(w, c, run.t)
