"""Rigid chains and trees against Pinocchio's crba and aba (issue 28; formulation.md §17).

The reference, ``tree_pinocchio.py``, builds a ``pinocchio.Model`` from a plain description
(rods, joints, parents, attachment abscissae, base, gravity) whose q and v are the package's q
and qdot; it never imports gibbsimpact. Here each random description is built twice, as a
``gi.Model`` and as that Pinocchio model, and M(q) and qddot(q, qdot) (gravity on, no inputs)
must agree.

Tolerances. M: ``max |M_gi - M_pin| <= 1e-10 max |M_pin|`` (lengths here are 0.3 .. 1.5 m and
masses O(1) kg, so the kg, kg m and kg m^2 blocks are of one size and the largest entry is the
matrix's scale). qddot: both codes solve M qddot = -(h + dV/dq) by different backward-stable
factorisations (Cholesky of the composite M; the articulated-body recursion), whose round-off in
qddot is about ``kappa(M) eps |qddot|`` (kappa the 2-norm condition number). The bound is
``max |qddot_gi - qddot_pin| <= 1e-10 max(1, kappa / 1e5) max |qddot_pin|``: 1e-10 relative up
to kappa = 1e5 (where round-off is ~2e-11, five times below it), and growing with the expected
round-off beyond. The largest kappa, and the errors measured, are in docs/benchmarks.md.

The serial chains (a) need nothing new and prove the coordinate map; the trees (b) need
``gi.Weld`` and ``Chain(parents=, attach=)`` (issue 28, items 1 and 2) and skip until they exist.
A third route, independent of both codes, checks the reference's tree map itself (c): M from
the rods' centre and orientation Jacobians by central differences of a plain numpy position map.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import gibbsimpact as gi

pin = pytest.importorskip("pinocchio", reason="Pinocchio (PyPI 'pin', a test extra) is not installed")
import tree_pinocchio as tp  # noqa: E402  (after the importorskip: it imports pinocchio)

HAS_TREES = hasattr(gi, "Weld") and "parents" in getattr(gi.Chain, "__dataclass_fields__", {})
needs_trees = pytest.mark.skipif(
    not HAS_TREES, reason="trees and welds (gi.Weld, gi.Chain(parents=, attach=)) are not in the package yet "
    "(issue 28 items 1-2, branch tree28); these turn on by themselves when they land")
EPS = np.finfo(float).eps
KAPPA_0 = 1e5  # condition number up to which qddot must agree to 1e-10 relative (module docstring)


# --------------------------------------------------------------------------- random descriptions
def _rotation(rng) -> np.ndarray:
    """A random rotation (3, 3): the Q of a QR factorisation with det +1."""
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    return Q if np.linalg.det(Q) > 0 else -Q


def _body(rng, length: float) -> tuple:
    """A random rigid body (mass, centre offset, inertia J = tr(S) I - S about the centre with S >= 0 the
    second moments, so J is a mass distribution's inertia, abscissa)."""
    A = rng.normal(scale=0.1, size=(3, 3))
    S = A @ A.T
    J = np.trace(S) * np.eye(3) - S
    return (float(rng.uniform(0.1, 1.0)), tuple(rng.uniform(-0.1, 0.1, 3)), J, float(rng.uniform(0.0, length)))


def _rods(rng, n: int, bodies: bool) -> tuple:
    rods = []
    for _ in range(n):
        length = float(rng.uniform(0.3, 1.5))
        carried = (_body(rng, length),) if bodies and rng.random() < 0.3 else ()
        rods.append(tp.Rod(length, float(rng.uniform(0.5, 2.0)), tuple(rng.uniform(1e-3, 1e-2, 3)), carried))
    return tuple(rods)


def _gravity(rng) -> tuple:
    return tuple(rng.normal(size=3) * np.array([1.0, 9.81, 1.0]))


def _fixed_base(rng) -> tp.Fixed:
    return tp.Fixed(tuple(rng.uniform(-0.5, 0.5, 3)), float(rng.uniform(-np.pi, np.pi)))


def serial_chain(rng, n: int, base) -> tp.Tree:
    """A serial rigid chain of n revolute links (each on its parent's tip), with attached bodies."""
    rods = _rods(rng, n, bodies=True)
    return tp.Tree(rods, tuple(tp.Joint() for _ in rods), tuple(range(-1, n - 1)), (None,) * n, base, _gravity(rng))


def random_tree(rng, n: int, base) -> tp.Tree:
    """A random rigid tree of n links: parents uniform among earlier links (a fixed base may carry more
    roots), attachment at the parent's tip, its joint or uniform along it; revolutes (with a random
    axis rotation in half of them) and welds (random angle, random rotation in half of them); a
    floating base's one root on a plain revolute; no rotations on a planar base (a planar tree)."""
    rods = _rods(rng, n, bodies=True)
    parents, attach, joints = [], [], []
    for i in range(n):
        root = i == 0 or (not isinstance(base, str) and rng.random() < 0.15)
        p = -1 if root else int(rng.integers(0, i))
        parents.append(p)
        attach.append(None if root else [None, 0.0, float(rng.uniform(0.0, rods[p].length))][rng.integers(3)])
        rotation = _rotation(rng) if base != "planar" and rng.random() < 0.5 else None
        if (root and isinstance(base, str)) or rng.random() < 0.7:
            joints.append(tp.Joint("R", 0.0, None if root and isinstance(base, str) else rotation))
        else:
            joints.append(tp.Joint("weld", float(rng.uniform(-np.pi, np.pi)), rotation))
    if all(j.kind == "weld" for j in joints):  # at least one coordinate
        joints[-1] = tp.Joint("R")
    return tp.Tree(rods, tuple(joints), tuple(parents), tuple(attach), base, _gravity(rng))


# --------------------------------------------------------------------------- the same tree in gibbsimpact
def to_model(tree: tp.Tree) -> gi.Model:
    """The gi.Model of ``tree``: rigid links with their rotary inertia and bodies; the serial API when the
    tree is a path of plain revolutes on tips, else Chain(parents=, attach=) with gi.Weld and
    gi.Revolute(axis_rotation=)."""
    links = [gi.Link(r.length, mass_per_length=r.mass_per_length, rotary_inertia=r.rotary_inertia,
                     bodies=[gi.RigidBody(m, c, J, at) for m, c, J, at in r.bodies]) for r in tree.links]
    base = tree.base if isinstance(tree.base, str) else gi.FixedBase(tree.base.position, tree.base.angle)
    serial = tree.parents == tuple(range(-1, len(links) - 1)) and all(a is None for a in tree.attach) and all(
        j.kind == "R" and j.rotation is None for j in tree.joints)
    if serial:
        return gi.Model(gi.Chain(links, base=base), gravity=tree.gravity)
    joints = [gi.Revolute() if j.kind == "R" and j.rotation is None else gi.Revolute(axis_rotation=j.rotation)
              if j.kind == "R" else gi.Weld(angle=j.angle, rotation=j.rotation) for j in tree.joints]
    chain = gi.Chain(links, joints=joints, parents=list(tree.parents), attach=list(tree.attach), base=base)
    return gi.Model(chain, gravity=tree.gravity)


def random_state(rng, model: gi.Model) -> tuple[np.ndarray, np.ndarray]:
    """q with positions in +-0.5 m and angles in +-pi (theta_0 in +-1.2 rad, clear of gimbal lock), qdot ~ N(0, 1)."""
    names = model.coordinate_names
    q = np.array([rng.uniform(-0.5, 0.5) if nm.startswith("X") else rng.uniform(-1.2, 1.2) if nm == "theta_0"
                  else rng.uniform(-np.pi, np.pi) for nm in names])
    return q, rng.normal(size=len(names))


def compare(tree: tp.Tree, rng) -> dict:
    """Build ``tree`` both ways at a random state; assert the coordinate map, M and qddot (module docstring);
    return the measured errors and kappa(M)."""
    model, pm = to_model(tree), tp.build_model(tree)
    assert pm.names == model.coordinate_names  # the one-to-one map of q and qdot
    q, qdot = random_state(rng, model)
    M_pin, M_gi = tp.mass_matrix(pm, q), model.mass_matrix(q)
    qdd_pin, qdd_gi = tp.forward_dynamics(pm, q, qdot), model.forward_dynamics(q, qdot)
    kappa = np.linalg.cond(M_pin)
    err_M = np.abs(M_gi - M_pin).max() / np.abs(M_pin).max()
    err_qdd = np.abs(qdd_gi - qdd_pin).max() / np.abs(qdd_pin).max()
    assert err_M <= 1e-10, f"M differs by {err_M:.2e} of its largest entry (N = {len(q)})"
    assert err_qdd <= 1e-10 * max(1.0, kappa / KAPPA_0), f"qddot differs by {err_qdd:.2e} relative, kappa(M) = {kappa:.2e}"
    return {"M": err_M, "qddot": err_qdd, "kappa": kappa}


BASES = {"free": lambda rng: "free", "planar": lambda rng: "planar", "fixed": _fixed_base}


# --------------------------------------------------------------------------- (a) serial chains, now
@pytest.mark.parametrize("base", sorted(BASES))
def test_serial_rigid_chains_match_pinocchio(base):
    """Random serial rigid chains of 2-8 links with attached bodies, random q, qdot and gravity: M and
    qddot equal Pinocchio's; the coordinate names line up one to one."""
    rng = np.random.default_rng({"free": 1, "planar": 2, "fixed": 3}[base])
    for n in (2, 3, 5, 8):
        compare(serial_chain(rng, n, BASES[base](rng)), rng)


# --------------------------------------------------------------------------- (b) trees, when they exist
@needs_trees
@pytest.mark.parametrize("base", ["free", "fixed", "planar"])
def test_rigid_trees_match_pinocchio(base):
    """Random rigid trees of 2-12 links (welds and revolutes with axis rotations, attachment points along
    parents, several roots on a fixed base; planar trees on the planar base): M and qddot equal
    Pinocchio's."""
    rng = np.random.default_rng({"free": 11, "fixed": 12, "planar": 14}[base])
    for n in (2, 3, 4, 6, 9, 12):
        compare(random_tree(rng, n, BASES[base](rng)), rng)


@needs_trees
def test_a_path_tree_equals_the_serial_chain_and_pinocchio():
    """A tree given through parents/attach whose branches form one path (attach=None, plain revolutes) is
    the serial chain: M and qddot of Chain(links) to round-off (a few eps of the largest entry), and
    Pinocchio's."""
    rng = np.random.default_rng(13)
    tree = serial_chain(rng, 4, "free")
    chain = to_model(tree)
    path = gi.Model(gi.Chain(chain.chain.links, parents=[-1, 0, 1, 2], attach=[None] * 4), gravity=tree.gravity)
    q, qdot = random_state(rng, path)
    M = chain.mass_matrix(q)
    assert np.abs(path.mass_matrix(q) - M).max() <= 8 * EPS * np.abs(M).max()
    qdd = chain.forward_dynamics(q, qdot)
    assert np.abs(path.forward_dynamics(q, qdot) - qdd).max() <= 1e-12 * np.abs(qdd).max()
    compare(tree, rng)


# --------------------------------------------------------------------------- (c) the reference's tree map
def _frames(tree: tp.Tree, q: np.ndarray) -> list:
    """(R_i, o_i) of every link by the position map written out (tree_pinocchio's docstring), plain numpy."""
    k, frames = 0, []
    if tree.base == "free":
        R0, o0, k = tp.rotation(0, q[3]) @ tp.rotation(1, q[4]), q[:3].copy(), 5
    elif tree.base == "planar":
        R0, o0, k = np.eye(3), np.array([q[0], q[1], 0.0]), 2
    else:
        R0, o0 = tp.rotation(2, tree.base.angle), np.asarray(tree.base.position, dtype=float)
    for i, (jt, p, x) in enumerate(zip(tree.joints, tree.parents, tree.attach)):
        if p == -1:
            R, o = R0, o0
        else:
            R, o = frames[p]
            o = o + R[:, 0] * (tree.links[p].length if x is None else x)
        R = R @ (np.eye(3) if jt.rotation is None else jt.rotation)
        if jt.kind == "R":
            R, k = R @ tp.rotation(2, q[k]), k + 1
        else:
            R = R @ tp.rotation(2, jt.angle)
        frames.append((R, o))
    return frames


def _finite_difference_mass_matrix(tree: tp.Tree, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """M = sum_i m_i Jc_i^T Jc_i + Jw_i^T R_i I_i R_i^T Jw_i over the links (each rod with its bodies as one
    rigid body: mass m_i, centre c_i and inertia I_i about it in link axes, from tree_pinocchio.rod_inertia),
    with Jc = dc/dq and Jw from skew(dR/dq R^T), both by central differences of _frames."""
    inertias = [tp.rod_inertia(r) for r in tree.links]
    M = np.zeros((q.size, q.size))
    plus, minus = [], []
    for k in range(q.size):
        dq = np.zeros(q.size)
        dq[k] = h
        plus.append(_frames(tree, q + dq))
        minus.append(_frames(tree, q - dq))
    for i, (R, o) in enumerate(_frames(tree, q)):
        Y = inertias[i]
        Jc = np.zeros((3, q.size))
        Jw = np.zeros((3, q.size))
        for k in range(q.size):
            (Rp, op), (Rm, om) = plus[k][i], minus[k][i]
            Jc[:, k] = (op + Rp @ Y.lever - om - Rm @ Y.lever) / (2 * h)
            W = (Rp - Rm) / (2 * h) @ R.T
            Jw[:, k] = (W[2, 1], W[0, 2], W[1, 0])
        M += Y.mass * Jc.T @ Jc + Jw.T @ R @ Y.inertia @ R.T @ Jw
    return M


@pytest.mark.parametrize("base", ["free", "fixed"])
def test_the_reference_tree_map_against_finite_differences(base):
    """The Pinocchio model of random trees (welds, axis rotations, attach points, several roots) has the M of
    the position map written out in numpy, by central differences (error O(h^2) ~ 1e-10 with h = 1e-6,
    plus round-off eps/h ~ 1e-10 on entries of size 1): agreement to 1e-7 of the largest entry."""
    rng = np.random.default_rng({"free": 21, "fixed": 22}[base])
    for n in (3, 7, 12):
        tree = random_tree(rng, n, BASES[base](rng))
        pm = tp.build_model(tree)
        q = rng.uniform(-1.2, 1.2, len(pm.names))
        M = tp.mass_matrix(pm, q)
        assert np.abs(_finite_difference_mass_matrix(tree, q) - M).max() <= 1e-7 * np.abs(M).max()


def test_the_reference_refuses_a_floating_base_with_two_roots():
    """A floating base floats one root (issue 28): two roots raise, naming the rule."""
    rng = np.random.default_rng(0)
    tree = dataclasses.replace(serial_chain(rng, 2, "free"), parents=(-1, -1))
    with pytest.raises(ValueError, match="one root"):
        tp.build_model(tree)
