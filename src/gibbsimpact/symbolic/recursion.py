"""The chain's frames, velocities and link moments as expressions: the 4x4 recursion of both routes.

The 4x4 recursion (docs/theory.md §6, the moment form of gibbsimpact.dynamics),
link by link, with G_i the local transform of the variables s in
{theta_i, delta_(i-1)}; method="gibbs-appell" uses all of it, "lagrange" only T_i::

    T_i = T_(i-1) G_i
    A_ij = dT_i/dq_j  = A_(i-1)j G_i  (upstream),  T_(i-1) dG_i/ds  (local)
    Td_i   = Td_(i-1) G_i + T_(i-1) Gd_i,                Gd = sum_s dG/ds sdot
    Tdd0_i = Tdd0_(i-1) G_i + 2 Td_(i-1) Gd_i + T_(i-1) Gdd0_i,
                                                          Gdd0 = sum_st d2G/dsdt sdot tdot

Rotary inertia (body angular velocity omega = W qdot, body acceleration
alpha = W qddot + alpha0, recursively with R_G the rotation of G and
omega_G = W_G sdot, W_G = vee(R_G^T dR_G/ds))::

    W_i = R_G^T W_(i-1) (+ W_G columns),
    alpha0_i = R_G^T alpha0_(i-1) - omega_G x (R_G^T omega_(i-1)) + sum_st d(W_G)_s/dt tdot sdot
"""

from __future__ import annotations

import copy

import numpy as np

from ..model.shapes import section_tables
from .algebra import rodrigues_function, rot4


def _end_transform(alg, ld, d, section=None):
    """E(delta) (4, 4) and its rotation kind: None (translation), ('axis', a, angle) or ('general',).

    E = Trans(l e_1 + end_t^T delta) Rot(end_phi^T delta); with section = (x_a, t, phi) (a tree,
    formulation §17) the section at x_a instead: A(x_a) = Trans(x_a e_1 + t^T delta) Rot(phi^T delta).
    """
    if section is None:
        G, et, ep = alg.cmat(ld.E0), alg.cmat(ld.end_t), alg.cmat(ld.end_phi)
    else:
        G = alg.eye(4)
        G[0][3] = alg.const(section[0])
        et, ep = alg.cmat(section[1]), alg.cmat(section[2])
    for a in range(3):
        G[a][3] = alg.add([G[a][3]] + [alg.mul(et[k][a], d[k]) for k in range(len(d))])
    phi = [alg.add([alg.mul(ep[k][a], d[k]) for k in range(len(d))]) for a in range(3)]
    nz = [a for a in range(3) if phi[a] is not alg.Z]
    if not nz:
        return G, None
    if len(nz) == 1:
        # phi = angle e_a: Rot(phi) is the exact rotation about axis a
        R = rot4(alg, nz[0], phi[nz[0]])
        kind = ("axis", nz[0], phi[nz[0]])
    else:
        s = alg.add([alg.mul(p, p) for p in phi])
        a_s, b_s = rodrigues_function("a", 0)(s), rodrigues_function("b", 0)(s)
        K = [[alg.Z, -phi[2], phi[1]], [phi[2], alg.Z, -phi[0]], [-phi[1], phi[0], alg.Z]]
        K2 = alg.mm(K, K)
        R = alg.madd(alg.eye(3), alg.scale(a_s, K), alg.scale(b_s, K2))
        R = [row + [alg.Z] for row in R] + [[alg.Z, alg.Z, alg.Z, alg.O]]
        kind = ("general",)
    return alg.mm(G, R), kind


class _Recursion:
    """State of the 4x4 recursion along the chain (docs/theory.md §6).

    T (4, 4); A: dict q-index -> dT/dq_j (4, 4) (nonzero ones only); Td, Tdd0 (4, 4);
    with rotary: W dict q-index -> (3,) body angular-velocity column, alpha0 (3,).
    """

    def __init__(self, alg, q, qd, velocities: bool, rotary: bool):
        self.alg, self.q, self.qd = alg, q, qd
        self.vel, self.rotary = velocities, rotary
        self.T = alg.eye(4)
        self.A = {}
        self.Td = alg.zeros(4, 4)
        self.Tdd0 = alg.zeros(4, 4)
        self.W = {}
        self.alpha0 = [alg.Z] * 3

    def step(self, G, local, kind):
        """T <- T G with G depending on the q-indices ``local``; kind: rotation of G (see _end_transform)."""
        alg, q, qd = self.alg, self.q, self.qd
        dG = {s: alg.diff(G, q[s]) for s in local}
        A = {j: alg.mm(Aj, G) for j, Aj in self.A.items()}
        for s in local:
            A[s] = alg.mm(self.T, dG[s])
        A = {j: Aj for j, Aj in A.items() if not alg.is_zero(Aj)}
        if self.vel:
            Gd = alg.madd(*[alg.scale(qd[s], dG[s]) for s in local]) if local else alg.zeros(4, 4)
            terms = [alg.scale(alg.mul(qd[s], qd[t]), alg.diff(dG[s], q[t])) for s in local for t in local]
            Gdd0 = alg.madd(*terms) if terms else alg.zeros(4, 4)
            Td = alg.madd(alg.mm(self.Td, G), alg.mm(self.T, Gd))
            Tdd0 = alg.madd(alg.mm(self.Tdd0, G), alg.scale(alg.two, alg.mm(self.Td, Gd)), alg.mm(self.T, Gdd0))
            self.Td, self.Tdd0 = Td, Tdd0
        if self.rotary and kind is not None:
            self._rotate(G, dG, local, kind)
        self.T = alg.mm(self.T, G)
        self.A = A

    def _rotate(self, G, dG, local, kind):
        alg, qd = self.alg, self.qd
        R = [row[:3] for row in G[:3]]
        Rt = alg.T(R)
        if kind[0] == "axis":
            # R_G = Rot_a(angle), angle linear in the local q: W_G,s = e_a d(angle)/dq_s, constant
            WG = {s: [kind[2].diff(self.q[s]) if c == kind[1] else alg.Z for c in range(3)] for s in local}
            wGd0 = [alg.Z] * 3
        else:
            WG = {s: alg.vee_skew(alg.mm(Rt, [row[:3] for row in dG[s][:3]])) for s in local}
            wGd0 = [alg.add([alg.mul(alg.mul(qd[s], qd[t]), WG[s][c].diff(self.q[t]))
                             for s in local for t in local]) for c in range(3)]
        w_prev = [alg.add([alg.mul(Wj[c], qd[j]) for j, Wj in self.W.items()]) for c in range(3)]
        wG = [alg.add([alg.mul(WG[s][c], qd[s]) for s in local]) for c in range(3)]
        Rw = alg.mv(Rt, w_prev)
        # alpha0_i = R_G^T alpha0 - omega_G x (R_G^T omega) + d(W_G)/dt sdot
        self.alpha0 = [alg.add([x, -y, z]) for x, y, z in zip(alg.mv(Rt, self.alpha0), alg.cross(wG, Rw), wGd0)]
        W = {j: alg.mv(Rt, Wj) for j, Wj in self.W.items()}
        for s in local:
            W[s] = [alg.add([a, b]) for a, b in zip(W.get(s, [alg.Z] * 3), WG[s])]
        self.W = {j: Wj for j, Wj in W.items() if any(w is not alg.Z for w in Wj)}

    def omega(self):
        alg = self.alg
        return [alg.add([alg.mul(Wj[c], self.qd[j]) for j, Wj in self.W.items()]) for c in range(3)]


def _base_state(model, alg, q, qd, velocities, rotary):
    """The recursion state at the base: after Trans(X) Rx Ry of a free base, or at the fixed base's T0."""
    rec = _Recursion(alg, q, qd, velocities, rotary)
    if model.free_base:
        G = alg.eye(4)
        for a in range(3):
            G[a][3] = q[a]
        rec.step(G, [0, 1, 2], None)
        rec.step(rot4(alg, 0, q[3]), [3], ("axis", 0, q[3]))
        rec.step(rot4(alg, 1, q[4]), [4], ("axis", 1, q[4]))
    else:
        rec.T = alg.cmat(model.base_transform)  # constant: no derivatives, zero angular velocity
    return rec


def _joint_step(alg, rec, joint, k, q):
    """rec <- rec J_i: J = Rot(R) Rz(theta_k) of a revolute (R its axis_rotation), Rot(R) Rz(angle) of a weld."""
    R = getattr(joint, "axis_rotation", None) if joint.spec.turns else joint.rotation
    if R is not None:  # a constant rotation: no local coordinate, but it turns the angular velocity columns
        G = [[alg.const(v) for v in row] + [alg.Z] for row in np.asarray(R, dtype=float)] + [[alg.Z] * 3 + [alg.O]]
        rec.step(G, [], ("general",))
    if not joint.spec.has_coordinate:
        if joint.angle != 0.0:
            rec.step(rot4(alg, 2, alg.const(joint.angle)), [], ("general",))
    else:
        rec.step(rot4(alg, 2, q[k]), [k], ("axis", 2, q[k]))


def _tree_frames(model, alg, q, qd, velocities, rotary):
    """Yield (i, recursion state at T_i) of a tree (formulation §17): T_i = T_p A_p(x_a) J_i, each link
    starting from a copy of its parent's state (the recursion's steps build new matrices, so a shallow copy
    is a snapshot)."""
    chain, states = model.chain, []
    for i in range(model.n_links):
        p, xa = chain.parents[i], chain.attach[i]
        rec = copy.copy(_base_state(model, alg, q, qd, velocities, rotary) if p < 0 else states[p])
        if p >= 0:
            ld = model.link_data[p]
            idx = [int(k) for k in model.delta_index[p]]
            if xa is None and ld.end_is_rigid:
                rec.step(alg.cmat(ld.E0), [], None)
            else:
                sec = None if xa is None else (xa, *section_tables(chain.links[p], xa))
                E, kind = _end_transform(alg, ld, [q[k] for k in idx], sec)
                rec.step(E, idx, kind)
        _joint_step(alg, rec, chain.joints[i], int(model.theta_index[i]), q)
        states.append(rec)
        yield i, rec


def _link_frames(model, alg, q, qd, velocities, rotary):
    """Yield (i, recursion state at T_i) for i = 0 .. n-1 (state valid only during the yield)."""
    if not model.chain.serial or any(getattr(j, "axis_rotation", None) is not None or not j.spec.has_coordinate
                                     for j in model.chain.joints):
        yield from _tree_frames(model, alg, q, qd, velocities, rotary)
        return
    rec = _base_state(model, alg, q, qd, velocities, rotary)
    theta = model.theta_index
    rec.step(rot4(alg, 2, q[theta[0]]), [theta[0]], ("axis", 2, q[theta[0]]))
    n = model.n_links
    for i in range(n):
        yield i, rec
        if i + 1 < n:
            ld = model.link_data[i]
            idx = [int(k) for k in model.delta_index[i]]
            if ld.end_is_rigid:
                rec.step(alg.cmat(ld.E0), [], None)
            else:
                E, kind = _end_transform(alg, ld, [q[k] for k in idx])
                rec.step(E, idx, kind)
            rec.step(rot4(alg, 2, q[theta[i + 1]]), [theta[i + 1]], ("axis", 2, q[theta[i + 1]]))


def _link_moments(alg, ld, d, dd):
    """P (4,4), Q_l (m,4,4), m_r (4,), Pv (4,4), Qd_l (m,4,4), M_dd (m,m) as expressions."""
    m = len(d)
    P0, C, D = alg.cmat(ld.P0), [alg.cmat(c) for c in ld.C], [[alg.cmat(x) for x in row] for row in ld.D]
    Q = [alg.madd(C[l], *[alg.scale(d[k], D[k][l]) for k in range(m)]) for l in range(m)]
    # P = P0 + sum_k d_k (C_k + C_k^T) + sum_kl d_k d_l D_kl
    P = alg.madd(P0, *[alg.scale(d[k], alg.madd(C[k], alg.T(C[k]))) for k in range(m)],
                 *[alg.scale(alg.mul(d[k], d[l]), D[k][l]) for k in range(m) for l in range(m)])
    m_r = [alg.add([alg.const(ld.m_r0[a])] + [alg.mul(alg.const(ld.m_psi[k][a]), d[k]) for k in range(m)])
           for a in range(4)]
    Pv = alg.madd(*[alg.scale(dd[l], Q[l]) for l in range(m)]) if m else alg.zeros(4, 4)
    Qd = [alg.madd(*[alg.scale(dd[k], D[k][l]) for k in range(m)]) for l in range(m)]
    return P, Q, m_r, Pv, Qd, alg.cmat(ld.M_dd)


def each_link(model, alg, q, qd, velocities, rotary, stage):
    """Per link: (i, recursion state, link data, its delta indices, delta, deltadot, _link_moments(...))."""
    for i, rec in _link_frames(model, alg, q, qd, velocities, rotary):
        alg.tick(stage, i + 1, model.n_links)
        ld = model.link_data[i]
        idx = [int(k) for k in model.delta_index[i]]
        d, dd = [q[k] for k in idx], [qd[k] for k in idx]
        yield i, rec, ld, idx, d, dd, _link_moments(alg, ld, d, dd)
