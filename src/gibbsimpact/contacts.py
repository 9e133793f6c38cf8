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


def flexible_links(model) -> list:
    """0-based indices of the links with elastic coordinates: the link columns of Contacts, in order."""
    return [i for i in range(model.n_links) if model.delta_index[i].size]


#: Gap [m] of a link candidate whose closest point is at an end of the link (its end joint stands for it).
NOT_INTERIOR = 1e300


class Contacts:
    """Gaps, normals and Jacobians of every (wall, contact point) pair (formulation.md 5; issue 9 item 2).

    Columns c = 0 .. C-1 of the (W, C) gap matrix: the P joint points (model.contact_point_names),
    then one column per flexible link i (``flex``): the material point of link i closest to
    wall w (gibbsimpact.linkpoints), deflection included. A link column holds that point's gap
    when it is *interior* (farther than 1e-6 l_i from the link's ends), else NOT_INTERIOR: at
    an end, the end joint's own column is the candidate, so nothing is counted twice. Its
    event fires where a link bulges into a wall between its joints. Rigid links have no column
    (their closest point is always an end). Link columns cannot rest (resting.py).

    link_contacts=False: joints only (C = P), the model of the published case studies.

    Cost: a link is searched only where it can be near a wall. Along the undeformed axis of
    link i the gap is linear (plane) or concave (circle, sphere), so it is at least the
    smaller gap of the axis' ends; the deflection moves a point by at most
    D_i = sum_k max_x|psi_k(x)| |delta_k| (|grad g| = 1), and the end joints lie within D_i
    of the axis' ends, so

        g(p_i(x)) >= min(g(end joints of i)) - 2 D_i  =: bound_i                         (1)

    A link with bound_i > refine_below on every wall gets NOT_INTERIOR without a search (it
    cannot touch: its gap is above refine_below > 0 wherever the search is skipped, so the
    switch between the two never fakes a sign change).
    """

    def __init__(self, model, walls, link_contacts=True):
        self.model, self.walls = model, walls
        self.N, self.n_joints = model.n_dof, model.n_joints
        self.flex = flexible_links(model) if (walls and link_contacts) else []
        self.n_cols = self.n_joints + len(self.flex)
        # Link minima farther than this from a wall are not refined (a sample's gap: sign exact).
        self.refine_below = 0.01 * (1.0 + sum(ld.length for ld in model.link_data))
        self._key, self._g = None, None
        self._pkey, self._p = None, None
        if self.flex:
            from .linkpoints import end_joints
            from .model import link_deflection

            # (1): max_x |psi_k(x)| per elastic coordinate (10 % over a 401-point grid), and the end joints.
            self._psi_max = np.zeros((len(self.flex), self.N))
            for f, i in enumerate(self.flex):
                lk = model.chain.links[i]
                x = np.linspace(0.0, lk.length, 401)
                q = np.zeros(self.N)
                if model.chain.joints[i].kind == "Pb":
                    q[model.theta_index[i]] = lk.length  # stretching shapes are largest fully out
                for c in model.delta_index[i]:
                    q[c] = 1.0
                    v, w = link_deflection(model, q, i, x)
                    self._psi_max[f, c] = 1.1 * float(np.max(np.hypot(v, w)))
                    q[c] = 0.0
            ends = end_joints(model)[self.flex]
            self._ends = ends
            self._always = np.any(ends < 0, axis=1)  # a Pb link on the base guide: no end point, always searched

    def gap_single(self, q: np.ndarray, w: int, c: int, full=None) -> float:
        """g[w, c] at q [m]; a joint column costs one joint-position call (cached per q), not a link search.

        full : the gap-matrix function to use for other entries (default self.gaps).
        """
        if w < len(self.walls) and c < self.n_joints:
            key = q.tobytes()
            if key != self._pkey:
                self._p, self._pkey = joint_positions(self.model, q), key
            return float(self.walls[w].gap(self._p[c:c + 1])[0])
        return float((self.gaps if full is None else full)(q)[w, c])

    @property
    def names(self) -> list:
        """Names of the C columns: the joint points, then "link i" for the closest point of link i."""
        return [f"O{j + 1}" for j in range(self.n_joints)] + [f"link {i + 1}" for i in self.flex]

    def _link_gaps(self, qs, g_joints=None):
        """Link columns (K, W, F) [m], the closest points' abscissae x (K, W, F) [m], their normals
        (K, W, F, 3) and whether they are interior (K, W, F), for the states qs (K, N).

        g_joints : (K, W, P) [m] the joint gaps of the same states, for the bound (1); None searches every link.
        """
        from .linkpoints import closest_points, interior

        K, W, F = len(qs), len(self.walls), len(self.flex)
        g = np.full((K, W, F), NOT_INTERIOR)
        x, nrm, inside = np.zeros((K, W, F)), np.zeros((K, W, F, 3)), np.zeros((K, W, F), dtype=bool)
        if g_joints is None:
            need = np.ones(K, dtype=bool)
        else:
            D = np.abs(qs) @ self._psi_max.T  # (K, F)
            ends = np.where(self._ends < 0, 0, self._ends)
            bound = np.minimum(g_joints[:, :, ends[:, 0]], g_joints[:, :, ends[:, 1]]) - 2.0 * D[:, None, :]
            need = np.any((bound <= self.refine_below) | self._always[None, None, :], axis=(1, 2))
        if np.any(need):
            cp = closest_points(self.model, qs[need], self.walls, refine_below=self.refine_below)
            ins = interior(self.model, qs[need], cp.x)[..., self.flex]
            g[need] = np.where(ins, cp.gap[..., self.flex], NOT_INTERIOR)
            x[need], nrm[need], inside[need] = cp.x[..., self.flex], cp.normal[..., self.flex, :], ins
        return g, x, nrm, inside

    def gaps(self, q: np.ndarray) -> np.ndarray:
        """g (W, C) [m]; cached per q (every event function of a step sees the same q)."""
        key = q.tobytes()
        if key != self._key:
            p = joint_positions(self.model, q)
            g = np.array([w.gap(p) for w in self.walls]).reshape(len(self.walls), self.n_joints)
            if self.flex:
                g = np.concatenate((g, self._link_gaps(q[None, :], g[None])[0][0]), axis=1)
            self._g = g
            self._key = key
        return self._g

    def gaps_batch(self, qs: np.ndarray) -> np.ndarray:
        """g (K, W, C) [m] of the states qs (K, N): one kernel call for all of them."""
        if not self.walls:
            return np.zeros((len(qs), 0, self.n_cols))
        P = joint_positions_batch(self.model, qs)  # (K, J, 3)
        g = np.stack([w.gap(P) for w in self.walls], axis=1).reshape(len(qs), len(self.walls), self.n_joints)
        if self.flex:
            g = np.concatenate((g, self._link_gaps(qs, g)[0]), axis=2)
        return g

    def full(self, q: np.ndarray):
        """g (W, C) [m], unit normals (W, C, 3), Jacobians (W, C, 3, N), points (W, C, 3) [m] and
        valid (W, C) bool: the columns that can be candidates of an impact (joints; interior link points)."""
        p, Jac = joint_positions_and_jacobians(self.model, q)
        W, P = len(self.walls), self.n_joints
        g = np.array([w.gap(p) for w in self.walls]).reshape(W, P)
        nrm = np.array([w.normal(p) for w in self.walls]).reshape(W, P, 3)
        J = np.broadcast_to(Jac, (W,) + Jac.shape)
        pts = np.broadcast_to(p, (W,) + p.shape)
        valid = np.ones((W, P), dtype=bool)
        if self.flex:
            from .linkpoints import material_jacobian

            gl, x, nl, inside = (a[0] for a in self._link_gaps(q[None, :], g[None]))
            F = len(self.flex)
            Jl, pl = np.zeros((W, F, 3, self.N)), np.full((W, F, 3), np.nan)
            for w, f in np.argwhere(inside):
                pl[w, f], Jl[w, f], _ = material_jacobian(self.model, q, np.zeros(self.N), self.flex[f], x[w, f])
            g, nrm = np.concatenate((g, gl), axis=1), np.concatenate((nrm, nl), axis=1)
            J, pts = np.concatenate((J, Jl), axis=1), np.concatenate((pts, pl), axis=1)
            valid = np.concatenate((valid, inside), axis=1)
        return g, nrm, J, pts, valid


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
    g, nrm, Jac, pts, valid = contacts.full(q)
    # Candidates: every pair within the contact band (a pair caught by its "sink"
    # event sits just below its phase-start gap); a link column only with an interior point.
    near = g <= band
    if not np.any(near & valid):
        return None, near
    pairs = np.argwhere(near & valid)  # (k, 2): wall, column
    normals = nrm[pairs[:, 0], pairs[:, 1]]
    Jk = Jac[pairs[:, 0], pairs[:, 1]]  # (k, 3, N)
    Wmat = np.einsum("kc,kcn->nk", normals, Jk)
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
        Wt = np.einsum("kac,kcn->nka", T, Jk)
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
        rounds=rounds, points=pts[pairs[:, 0], pairs[:, 1]].copy(), **friction,
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
