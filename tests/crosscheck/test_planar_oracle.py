"""The package's planar R / Pa / Pb dynamics against an independent oracle (docs/design-notes.md, Tests).

``tests/reference/planar_oracle.py`` derives M, h, dV/dq, qddot, the energies and the
joint points of planar chains on a fixed base from the position map p(q, i, x) of
docs/theory.md §7.1, differentiated by forward-mode jets and integrated with an
exact Gauss rule (Gibbs-Appell form, section 12). It shares no code with the package.

1. Oracle self-checks (no package needed): rigid closed forms, the element matrices of
   section 9.2 (also at several d for a Pb link), M symmetric positive definite, h equal
   to Lagrange's velocity terms of M (finite differences), energy conservation of the
   oracle's own equations over 0.3 s (R-Pb with material flowing through the guide, R-Pa
   with a carriage crossing a host node), continuity of M across host nodes.
2. Package vs oracle, R-only chains (FE and rigid links): M, h, dV/dq, qddot, energies,
   joint points at random states, <= 1e-9 relative (measured ~1e-13).
3. Package vs oracle with Pa and Pb joints: all nine two-link combinations of
   {R, Pa, Pb}, a three-link R-Pa-Pb chain, a carriage straddling and crossing host
   nodes (also the moving nodes of a Pb host), a Pb link at many protruding lengths;
   continuity of the package's M across a host node.

Relative error of an array: max|a - b| / max|b| (energies: over |T| + |V_g| + |V_s|).
"""

from __future__ import annotations

import numpy as np
import pytest
from reference.planar_oracle import PlanarChain, link
from scipy.integrate import solve_ivp

import gibbsimpact as gi

TOL = 1e-9
G = 9.81
BASE = (0.2, 0.5, 0.7)
GRAVITY = (0.0, -G)


# --------------------------------------------------------------------------
# Chain specifications shared by the oracle and the package
# --------------------------------------------------------------------------


def spec(*links, base=BASE, gravity=GRAVITY, ranges=None):
    """A chain: the oracle's link dicts plus one joint range per link (None for R)."""
    links = [link(**lk) for lk in links]
    if ranges is None:
        ranges = [default_range(links, i) for i in range(len(links))]
    return dict(links=links, base=base, gravity=gravity, ranges=ranges)


def default_range(links, i):
    lk = links[i]
    if lk["joint"] == "R":
        return None
    if lk["joint"] == "Pb":
        return (0.2 * lk["l"], lk["l"])
    if i == 0:
        return (0.1, 0.9)  # base rail: any range
    c, lh = lk["c"], links[i - 1]["l"]
    return (c + 0.01, lh - c - 0.01)


def oracle(s):
    return PlanarChain(s["links"], base=s["base"], gravity=s["gravity"])


def package(s):
    """The same chain as a gibbsimpact Model (binding API of the Pa/Pb issue)."""
    links, joints = [], []
    for lk, rg in zip(s["links"], s["ranges"]):
        links.append(gi.Link(lk["l"], lk["mu"], lk["EI"], elements=lk["n_e"], geometric_stiffening=False))
        if lk["joint"] == "R":
            joints.append(gi.Revolute())
        elif lk["joint"] == "Pa":
            joints.append(gi.SlidingPrismatic(angle=lk["gamma"], half_length=lk["c"], range=rg))
        else:
            joints.append(gi.FixedPrismatic(angle=lk["gamma"], range=rg))
    b1, b2, beta = s["base"]
    chain = gi.Chain(links, joints=joints, base=gi.FixedBase((b1, b2), beta))
    return gi.Model(chain, gravity=(s["gravity"][0], s["gravity"][1], 0.0))


def r_only_model(s):
    """R-only chains through the API that exists today (no joints argument)."""
    b1, b2, beta = s["base"]
    links = [gi.Link(lk["l"], lk["mu"], lk["EI"], elements=lk["n_e"], geometric_stiffening=False) for lk in s["links"]]
    return gi.Model(gi.Chain(links, base=gi.FixedBase((b1, b2), beta)), gravity=(*s["gravity"], 0.0))


def random_state(s, rng, w=0.02, t=0.05, speed=1.0):
    """q inside the joint ranges (carriages at least 0.05 m inside their host), small deflections, qdot ~ N(0, speed)."""
    links = s["links"]
    n = len(links)
    q = []
    for i, (lk, rg) in enumerate(zip(links, s["ranges"])):
        if lk["joint"] == "R":
            q.append(rng.uniform(-np.pi, np.pi))
        elif lk["joint"] == "Pb":
            lo = max(rg[0], 0.2 * lk["l"]) + 0.01
            if i + 1 < n and links[i + 1]["joint"] == "Pa":  # room for the carriage on the protruding part
                lo = max(lo, 2 * links[i + 1]["c"] + 0.15)
            q.append(rng.uniform(lo, rg[1] - 0.01))
        elif i == 0:
            q.append(rng.uniform(rg[0], rg[1]))
        else:
            c, host = lk["c"], links[i - 1]
            lo, hi = c + 0.05, host["l"] - c - 0.05
            if host["joint"] == "Pb":  # the carriage stays on the protruding part
                lo = max(lo, host["l"] - q[i - 1] + c + 0.05)
            lo, hi = max(lo, rg[0]), min(hi, rg[1])
            assert lo < hi, (lo, hi)
            q.append(rng.uniform(lo, hi))
    for lk in links:
        for _ in range(lk["n_e"]):
            q += [rng.uniform(-w, w), rng.uniform(-t, t)]
    q = np.array(q)
    assert q.size == n + sum(2 * lk["n_e"] for lk in links)
    return q, rng.normal(scale=speed, size=q.size)


def rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def compare(model, orc, q, qd, tol=TOL, skip=()):
    """Every quantity of the package against the oracle at (q, qdot) except ``skip``; returns the errors."""
    r = orc.evaluate(q, qd)
    qdd = np.linalg.solve(r["M"], -r["h"] - r["dV"])
    e = model.energy(q, qd)
    scale = abs(r["kinetic"]) + abs(r["gravity"]) + abs(r["strain"])
    err = dict(
        M=rel(model.mass_matrix(q), r["M"]),
        h=rel(model.bias_forces(q, qd), r["h"]),
        dV=rel(model.potential_forces(q), r["dV"]),
        qddot=rel(model.forward_dynamics(q, qd), qdd),
        energy=max(abs(e.kinetic - r["kinetic"]), abs(e.gravity - r["gravity"]), abs(e.strain - r["strain"]),
                   abs(e.total - r["total"])) / scale,
        joints=rel(model.joint_positions(q), orc.joint_positions(q)),
    )
    bad = {k: v for k, v in err.items() if not v <= tol and k not in skip}
    assert not bad, f"package != oracle at q={q.tolist()}, qdot={qd.tolist()}: {bad} (all: {err})"
    return err


def check_states(s, seed, n_states=5, model=None):
    orc = oracle(s)
    model = package(s) if model is None else model
    assert model.coordinate_names == orc.coordinate_names
    rng = np.random.default_rng(seed)
    return [compare(model, orc, *random_state(s, rng)) for _ in range(n_states)]


# Link parameters of the two-link combinations: host 3 elements, arm 2 elements.
HOST = dict(l=1.0, mu=1.2, EI=20.0, n_e=3)
ARM = dict(l=0.7, mu=0.6, EI=6.0, n_e=2)
JOINT = {"R": dict(joint="R"), "Pa": dict(joint="Pa", gamma=0.4, c=0.06), "Pb": dict(joint="Pb", gamma=-0.3)}
COMBOS = [(a, b) for a in ("R", "Pa", "Pb") for b in ("R", "Pa", "Pb")]


def two_link(a, b, host=HOST, arm=ARM):
    return spec({**JOINT[a], **host}, {**JOINT[b], **arm})


# --------------------------------------------------------------------------
# 1. The oracle on its own
# --------------------------------------------------------------------------


def test_jet_arithmetic():
    # f(s) = sin(a) cos(b) a^3 / (1 + b^2) - 2/a with a = 0.7 + 2 s, b = -0.4 + s: value, f', f'' at 0
    # against Richardson-extrapolated central differences of the same function on floats.
    from reference.planar_oracle import Jet, jcos, jsin

    def f(a, b, sin=np.sin, cos=np.cos):
        return sin(a) * cos(b) * a**3 / (1.0 + b * b) - 2.0 / a + (a - b) * 3.0

    a = Jet(0.7, np.array([[[2.0]], [[0.0]]]))
    b = Jet(-0.4, np.array([[[1.0]], [[0.0]]]))
    r = f(a, b, jsin, jcos)
    def g(s):
        return f(0.7 + 2 * s, -0.4 + s)

    def d1(e):
        return (g(e) - g(-e)) / (2 * e)

    def d2(e):
        return (g(e) - 2 * g(0.0) + g(-e)) / e**2

    e = 1e-3  # Richardson: O(e^4)
    assert abs(r.v - g(0.0)) < 1e-15
    assert abs(r.D[0, 0, 0] - (4 * d1(e / 2) - d1(e)) / 3) < 1e-9 * abs(r.D[0, 0, 0])
    assert abs(r.D[1, 0, 0] - (4 * d2(e / 2) - d2(e)) / 3) < 1e-6 * abs(r.D[1, 0, 0])


def test_oracle_two_deflection_paths_agree():
    # v, v' of an R/Pa link: the tabulated basis (fixed abscissae) and the jet path (moving abscissae).
    o = PlanarChain([link("R", 1.0, 1.0, 5.0, 3), link("Pa", 0.5, 1.0, 1.0, 1, c=0.05)])
    rng = np.random.default_rng(2)
    q = np.r_[0.3, 0.4, rng.uniform(-0.05, 0.05, 8)]
    V = np.vstack([np.eye(q.size), rng.normal(size=q.size)])
    joint, nodes = o._jets(q, V)
    f = o._fixed[0]
    v_tab = nodes[0][2].linear(f["B0"])
    v_jet, = o._deflection(0, f["x"], joint, nodes, V.shape[0], derivs=0)
    assert np.abs(v_tab.v - v_jet.v).max() < 1e-15
    assert np.abs(v_tab.D - v_jet.D).max() < 1e-15
    e0, e1 = nodes[0][2].linear(f["end0"]), nodes[0][2].linear(f["end1"])
    j0, j1 = o._deflection(0, 1.0, joint, nodes, V.shape[0])
    assert abs(e0.v - q[6]) < 1e-16 and abs(e1.v - q[7]) < 1e-15  # v(l) = w_3, v'(l) = t_3
    assert abs(j0.v - e0.v) < 1e-15 and abs(j1.v - e1.v) < 1e-14


def test_oracle_rigid_closed_forms():
    rng = np.random.default_rng(1)
    beta = BASE[2]
    # A rigid rod of mass m in a fixed Pb guide on the base: M = m, dd = g . axis.
    for gamma in (0.0, 0.9, -2.0):
        o = PlanarChain([link("Pb", 0.8, 1.5, 1.0, 0, gamma=gamma)], base=BASE)
        for d in (0.2, 0.55, 0.8):
            r = o.evaluate([d], [rng.normal()])
            assert rel(r["M"], [[1.2]]) < 1e-14
            assert abs(r["h"][0]) < 1e-14
            acc = o.forward_dynamics([d], [0.3])[0]
            assert abs(acc - (-G) * np.sin(beta + gamma)) < 1e-13
            tip = o.joint_positions([d])[-1]
            axis = np.array([np.cos(beta + gamma), np.sin(beta + gamma)])
            assert np.allclose(tip[:2], np.array(BASE[:2]) + d * axis, atol=1e-15)
    # A rigid link on the base rail (Pa): M = m, dd = g . rail axis.
    o = PlanarChain([link("Pa", 0.6, 2.0, 1.0, 0, gamma=0.5, c=0.05)], base=BASE)
    assert rel(o.mass_matrix([0.3]), [[1.2]]) < 1e-14
    assert abs(o.forward_dynamics([0.3], [0.7])[0] + G * np.sin(beta)) < 1e-13
    # Rigid R-R double pendulum (uniform rods), theta_2 relative.
    l1, l2, m1, m2 = 1.0, 0.7, 2.0, 1.4
    o = PlanarChain([link("R", l1, m1 / l1, 1.0, 0), link("R", l2, m2 / l2, 1.0, 0)], base=BASE)
    for _ in range(5):
        q, qd = rng.uniform(-3, 3, 2), rng.normal(size=2)
        c2, s2 = np.cos(q[1]), np.sin(q[1])
        k = m2 * l1 * l2 / 2
        b = m2 * l2**2 / 3 + k * c2
        M = [[m1 * l1**2 / 3 + m2 * l1**2 + m2 * l2**2 / 3 + 2 * k * c2, b], [b, m2 * l2**2 / 3]]
        h = [-k * s2 * (2 * qd[0] * qd[1] + qd[1] ** 2), k * s2 * qd[0] ** 2]
        p1, p2 = beta + q[0], beta + q[0] + q[1]
        dV = [G * (m1 * l1 / 2 * np.cos(p1) + m2 * (l1 * np.cos(p1) + l2 / 2 * np.cos(p2))), G * m2 * l2 / 2 * np.cos(p2)]
        r = o.evaluate(q, qd)
        assert rel(r["M"], M) < 1e-14 and rel(r["dV"], dV) < 1e-14
        assert np.abs(r["h"] - h).max() < 1e-14 * max(1.0, np.abs(h).max())


def assembled(ne, h, mu, EI):
    """Assembled Hermite element matrices of formulation 9.2, node 0 removed."""
    Me = mu * h / 420 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                  [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
    Ke = EI / h**3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                               [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
    M, K = np.zeros((2 * ne + 2, 2 * ne + 2)), np.zeros((2 * ne + 2, 2 * ne + 2))
    for e in range(ne):
        M[2 * e:2 * e + 4, 2 * e:2 * e + 4] += Me
        K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += Ke
    return M[2:, 2:], K[2:, 2:]


@pytest.mark.parametrize("joint, d", [("R", None), ("Pa", None), ("Pb", 0.35), ("Pb", 0.61), ("Pb", 0.8)])
def test_oracle_element_matrices(joint, d):
    # The last link's delta-delta block of M is int mu psi psi^T; dV/d delta = K delta without gravity.
    ne, l, mu, EI = 3, 0.8, 1.3, 7.0
    o = PlanarChain([link("R", 1.0, 1.0, 5.0, 2), link(joint, l, mu, EI, ne, gamma=0.2, c=0.05)],
                    base=BASE, gravity=(0.0, 0.0))
    rng = np.random.default_rng(3)
    q = np.concatenate([[0.4, 0.5 if joint != "Pb" else d], rng.uniform(-0.02, 0.02, 4 + 2 * ne)])
    Mh, Kh = assembled(ne, (d if joint == "Pb" else l) / ne, mu, EI)
    r = o.evaluate(q)
    idx = o.delta_index[1]
    assert rel(r["M"][np.ix_(idx, idx)], Mh) < 1e-14
    # dV/d delta_2 = K delta_2 (no gravity): column k from delta_2 = e_k, the rest of q kept.
    K = []
    for k in idx:
        qk = q.copy()
        qk[idx] = 0.0
        qk[k] = 1.0
        K.append(o.potential_forces(qk)[idx])
    assert rel(np.array(K).T, Kh) < 1e-12
    Kh1 = assembled(2, 0.5, 1.0, 5.0)[1]
    strain = 0.5 * q[idx] @ Kh @ q[idx] + 0.5 * q[2:6] @ Kh1 @ q[2:6]
    assert abs(r["strain"] - strain) < 1e-14 * strain


@pytest.mark.parametrize("combo", COMBOS, ids=["-".join(c) for c in COMBOS])
def test_oracle_mass_matrix_symmetric_positive_definite(combo):
    s = two_link(*combo)
    o = oracle(s)
    rng = np.random.default_rng(11)
    for _ in range(3):
        q, _ = random_state(s, rng)
        M = o.mass_matrix(q)
        assert rel(M, M.T) < 1e-15
        assert np.linalg.eigvalsh(M).min() > 0


@pytest.mark.parametrize("combo", COMBOS, ids=["-".join(c) for c in COMBOS])
def test_oracle_bias_forces_are_lagrange_velocity_terms(combo):
    # h = Mdot qdot - d/dq (1/2 qdot^T M qdot), both by central differences of the oracle's M.
    s = two_link(*combo)
    o = oracle(s)
    rng = np.random.default_rng(12)
    q, qd = random_state(s, rng)
    eps = 1e-5
    Mdot = (o.mass_matrix(q + eps * qd) - o.mass_matrix(q - eps * qd)) / (2 * eps)
    dT = np.array([(qd @ o.mass_matrix(q + eps * e) @ qd - qd @ o.mass_matrix(q - eps * e) @ qd) / (4 * eps)
                   for e in np.eye(q.size)])
    h = o.bias_forces(q, qd)
    assert rel(h, Mdot @ qd - dT) < 1e-7
    # and dV/dq against differences of V
    def V(x):
        r = o.evaluate(x)
        return r["gravity"] + r["strain"]

    dV = np.array([(V(q + eps * e) - V(q - eps * e)) / (2 * eps) for e in np.eye(q.size)])
    assert rel(o.potential_forces(q), dV) < 1e-7


def _energy_drift(s, q0, qd0, t_end=0.3):
    o = oracle(s)
    N = o.n_dof
    sol = solve_ivp(o.rhs, (0.0, t_end), np.concatenate([q0, qd0]), method="DOP853", rtol=1e-11, atol=1e-11)
    assert sol.status == 0, sol.message
    E = [o.energy(y[:N], y[N:]) for y in sol.y.T]
    scale = abs(E[0]["kinetic"]) + abs(E[0]["gravity"]) + abs(E[0]["strain"])
    return max(abs(e["total"] - E[0]["total"]) for e in E) / scale, sol


def test_oracle_conserves_energy_r_pb_material_through_guide():
    # A hanging arm: gravity mostly along the links keeps the bending small with soft links (low
    # FE frequencies, hence few steps: ~1200 right-hand sides). The rod is thrown up through the
    # guide, stops and falls back (d 0.80 -> 0.75 -> 0.95), its two moving elements stretching.
    s = spec(dict(joint="R", l=1.0, mu=1.0, EI=2.0, n_e=1), dict(joint="Pb", l=1.0, mu=1.0, EI=0.05, n_e=2, gamma=0.05),
             base=(0.1, 0.2, 0.0))
    rng = np.random.default_rng(5)
    q0 = np.concatenate([[-np.pi / 2, 0.8], rng.uniform(-0.005, 0.005, 6)])
    qd0 = np.concatenate([[0.3, -1.0], 0.02 * rng.normal(size=6)])
    drift, sol = _energy_drift(s, q0, qd0)
    assert sol.y[1].max() - sol.y[1].min() > 0.15  # material flowed through the guide
    assert drift <= 1e-8, drift


def test_oracle_conserves_energy_r_pa_carriage_across_host_node():
    # The carriage slides down a hanging 2-element host (d 0.3 -> 0.74): both contact points
    # d +- c cross the node at 0.6 m, where h jumps. Soft links for few steps (~1800 right-hand
    # sides); the moving carriage bends the soft host visibly, which does not matter here.
    s = spec(dict(joint="R", l=1.2, mu=1.0, EI=0.5, n_e=2), dict(joint="Pa", l=0.5, mu=1.0, EI=0.05, n_e=1, gamma=0.1, c=0.06),
             base=(0.1, 0.2, 0.0))
    rng = np.random.default_rng(6)
    q0 = np.concatenate([[-np.pi / 2, 0.3], rng.uniform(-0.005, 0.005, 6)])
    qd0 = np.concatenate([[0.02, 0.3], 0.02 * rng.normal(size=6)])
    drift, sol = _energy_drift(s, q0, qd0)
    assert sol.y[1].min() + 0.06 < 0.6 < sol.y[1].max() - 0.06  # both contact points crossed the node
    assert drift <= 1e-8, drift


# --------------------------------------------------------------------------
# Carriage across host nodes: continuity of M (oracle and package)
# --------------------------------------------------------------------------

NODE_CASES = {
    # (chain, joint index of the carriage)
    "R-Pa": (two_link("R", "Pa"), 1),
    "Pb-Pa": (two_link("Pb", "Pa"), 1),  # moving nodes of a Pb host: l - d_1 + j d_1/n_e
}


def _host_nodes(s, q, i):
    host = s["links"][i - 1]
    ne = host["n_e"]
    if host["joint"] == "Pb":
        d = q[i - 1]
        return [host["l"] - d + j * d / ne for j in range(ne + 1)]
    return [j * host["l"] / ne for j in range(ne + 1)]


def _node_crossings(s, i, seed):
    """States (q, qdot, d_node, x_node): a contact point d_node +- c exactly at the inner host node x_node."""
    rng = np.random.default_rng(seed)
    c = s["links"][i]["c"]
    out = []
    while len(out) < 4:
        q, qd = random_state(s, rng)
        nodes = _host_nodes(s, q, i)
        lo = nodes[0] + c + 0.01
        hi = s["links"][i - 1]["l"] - c - 0.01
        for x in nodes[1:-1]:
            for dn in (x - c, x + c):
                if lo < dn < hi:
                    out.append((q.copy(), qd, dn, x))
    return out[:4]


def _continuity(model_or_orc, i, q, d_node, eps=1e-9):
    """max|M(d_node + eps) - M(d_node - eps)| / max|M| for the carriage variable q[i]."""
    qm, qp = q.copy(), q.copy()
    qm[i], qp[i] = d_node - eps, d_node + eps
    Mm, Mp = model_or_orc.mass_matrix(qm), model_or_orc.mass_matrix(qp)
    return rel(Mp, Mm)


@pytest.mark.parametrize("case", list(NODE_CASES))
def test_oracle_mass_matrix_continuous_across_host_nodes(case):
    s, i = NODE_CASES[case]
    o = oracle(s)
    for q, qd, dn, _ in _node_crossings(s, i, seed=21):
        assert _continuity(o, i, q, dn) <= 1e-6
        # h is not continuous there (v'' jumps at the node): the crossing is real.
        qm, qp = q.copy(), q.copy()
        qm[i], qp[i] = dn - 1e-9, dn + 1e-9
        assert rel(o.bias_forces(qp, qd), o.bias_forces(qm, qd)) > 1e-7


@pytest.mark.parametrize("case", list(NODE_CASES))
def test_package_mass_matrix_continuous_across_host_nodes(case):
    s, i = NODE_CASES[case]
    model = package(s)
    for q, qd, dn, _ in _node_crossings(s, i, seed=21):
        assert _continuity(model, i, q, dn) <= 1e-6


# --------------------------------------------------------------------------
# 2. Package vs oracle, R-only chains (the API of today)
# --------------------------------------------------------------------------

R_ONLY = {
    "flex-flex": spec(dict(joint="R", l=1.0, mu=1.0, EI=25.0, n_e=3), dict(joint="R", l=0.6, mu=0.5, EI=8.0, n_e=2)),
    "rigid-flex": spec(dict(joint="R", l=0.8, mu=2.0, EI=1.0, n_e=0), dict(joint="R", l=0.6, mu=0.5, EI=8.0, n_e=2)),
    "flex-rigid-flex": spec(dict(joint="R", l=1.0, mu=1.0, EI=25.0, n_e=3), dict(joint="R", l=0.5, mu=1.5, EI=1.0, n_e=0),
                            dict(joint="R", l=0.6, mu=0.5, EI=8.0, n_e=4)),
}


@pytest.mark.parametrize("name", list(R_ONLY))
def test_r_only_package_matches_oracle(name):
    s = R_ONLY[name]
    errs = check_states(s, seed=7, model=r_only_model(s))
    worst = {k: max(e[k] for e in errs) for k in errs[0]}
    assert max(worst.values()) <= TOL, worst


# --------------------------------------------------------------------------
# 3. Package vs oracle with Pa and Pb joints
# --------------------------------------------------------------------------


@pytest.mark.parametrize("combo", COMBOS, ids=["-".join(c) for c in COMBOS])
def test_two_link_combinations_match_oracle(combo):
    check_states(two_link(*combo), seed=100 + COMBOS.index(combo))


def test_two_link_rigid_arm_and_rigid_host_match_oracle():
    # Rigid links in every position: a Pa carriage on a rigid host, a rigid Pb rod.
    rigid = dict(l=0.9, mu=1.1, EI=1.0, n_e=0)
    check_states(spec({**JOINT["R"], **rigid}, {**JOINT["Pa"], **ARM}), seed=31)
    check_states(spec({**JOINT["Pa"], **HOST}, {**JOINT["Pb"], **rigid}), seed=32)


def test_three_link_r_pa_pb_matches_oracle():
    s = spec(dict(joint="R", l=1.0, mu=1.0, EI=25.0, n_e=3),
             dict(joint="Pa", l=0.6, mu=0.8, EI=10.0, n_e=2, gamma=0.5, c=0.05),
             dict(joint="Pb", l=0.5, mu=0.4, EI=4.0, n_e=2, gamma=-0.4))
    check_states(s, seed=41)


@pytest.mark.parametrize("case", list(NODE_CASES))
def test_carriage_at_and_across_host_nodes_matches_oracle(case):
    # A contact point just either side of a host node and exactly at it; the carriage straddling it.
    # Exactly at the node h and qddot are two-valued (v''(d +- c) jumps there): compared are only
    # the continuous quantities M, dV/dq, the energies and the joint points.
    s, i = NODE_CASES[case]
    orc, model = oracle(s), package(s)
    c = s["links"][i]["c"]
    straddled = 0
    for q, qd, dn, x in _node_crossings(s, i, seed=22):
        lo = _host_nodes(s, q, i)[0] + c + 0.01
        straddle = [x] if lo < x < s["links"][i - 1]["l"] - c - 0.01 else []  # d - c < x < d + c
        straddled += len(straddle)
        for d in [dn - 1e-3, dn - 1e-9, dn + 1e-9, dn + 1e-3] + straddle:
            q[i] = d
            compare(model, orc, q, qd)
        q[i] = dn
        compare(model, orc, q, qd, skip=("h", "qddot"))
    assert straddled


def test_pb_link_at_many_protruding_lengths_matches_oracle():
    # Material flows through the guide: d from 0.2 l to l (the rear end at the guide), moving nodes
    # passing fixed material points.
    s = two_link("R", "Pb")
    orc, model = oracle(s), package(s)
    rng = np.random.default_rng(51)
    l = s["links"][1]["l"]
    q, qd = random_state(s, rng)
    for d in np.r_[np.linspace(0.2, 1.0, 9) * l, 0.5 * l + 1e-9, 0.999999 * l]:
        q[1] = d
        compare(model, orc, q, qd)
