"""Wall contacts of the event loop: gaps of every (wall, contact point) pair, the contact band,
the impact stage and the events of a flight phase (formulation.md sections 5-7).

The rules are stated in gibbsimpact.simulate's module docstring; simulate.py drives these stages.
"""

from __future__ import annotations

import numpy as np

from .dynamics import energy, mass_matrix
from .flight import EventSpec
from .friction import solve_frictional_impulses
from .impact import solve_impulses
from .kinematics import joint_positions, joint_positions_and_jacobians, joint_positions_batch
from .results import ImpactRecord
from .walls import tangent_basis


class Contacts:
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


def impact_stage(model, contacts, e_wall, t, q, qd, band, grazing_velocity, sink_pair, resting=None):
    """The impact at (t, q, qd), if there is one.

    resting : None or (W, J) bool, the pairs in resting contact: they take e = 0 (gibbsimpact.resting).
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
    if resting is not None:
        e_k = np.where(resting[pairs[:, 0], pairs[:, 1]], 0.0, e_k)
    mu_k = np.array([contacts.walls[w].friction for w in pairs[:, 0]])
    friction = {}
    if np.any(mu_k > 0):
        # Moreau's law with Coulomb's cone (friction.py): tangents t1, t2 of each contact.
        T = tangent_basis(normals)  # (k, 2, 3)
        Wt = np.einsum("kac,kcn->nka", T, Jac[pairs[:, 1]])
        sol = solve_frictional_impulses(M, Wmat, Wt, qd, e_k, mu_k)
        world = lambda a: np.einsum("ka,kac->kc", a, T)  # noqa: E731
        friction = dict(friction_impulses=world(sol.tangential_impulses), slip_before=world(sol.slip_before),
                        slip_after=world(sol.slip_after))
        rounds = sol.rounds
    else:
        sol = solve_impulses(M, Wmat, qd, e_k)
        rounds = len(sol.rounds)
    rec = ImpactRecord(
        time=t, joints=tuple(int(j) + 1 for j in pairs[:, 1]), wall=tuple(int(w) for w in pairs[:, 0]),
        normals=normals, impulses=sol.impulses, v_before=sol.v_before, v_after=sol.v_after,
        restitution=e_k, qdot_before=qd.copy(), qdot_after=sol.qdot_after.copy(),
        energy_before=energy(model, q, qd), energy_after=energy(model, q, sol.qdot_after),
        rounds=rounds, **friction,
    )
    return rec, near


def phase_events(near, g_start, band, sink_depth, row0=0, skip=None):
    """EventSpec of one phase and the kind of each event ("hit", "sink", "leave").

    near : (W, J) pairs in the contact band at the phase start; g_start : (W, J) their gaps [m];
    row0 : the gap-matrix row of near's first row (the joint limits sit below the walls);
    skip : None or (W, J) bool, pairs without these events (resting pairs: see resting.drift_events).
    """
    rows, kinds = [], []
    for w, j in np.ndindex(near.shape):
        w_i = w + row0
        if skip is not None and skip[w, j]:
            continue
        if near[w, j]:
            # Sink level min(g_start, 0) - sink_depth: the event function starts at
            # sink_depth > 0 (above the gap's round-off), so a bounce lower than one
            # solver step that falls back is still a sign change (never tunnels).
            rows.append((w_i, j, sink_depth - min(float(g_start[w, j]), 0.0), -1.0))
            kinds.append(("sink", w_i, j))
            rows.append((w_i, j, -1.5 * band, 1.0))
            kinds.append(("leave", w_i, j))
        else:
            rows.append((w_i, j, 0.0, -1.0))
            kinds.append(("hit", w_i, j))
    a = np.array(rows, dtype=float).reshape(-1, 4)
    return event_spec(a), kinds


def event_spec(a) -> EventSpec:
    """EventSpec from rows (wall row, joint, offset, direction) (K, 4)."""
    a = np.asarray(a, dtype=float).reshape(-1, 4)
    return EventSpec(a[:, 0].astype(int), a[:, 1].astype(int), a[:, 2], a[:, 3])
