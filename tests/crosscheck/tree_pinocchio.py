"""An independent rigid-body reference for rigid chains and trees (issue 28), built with Pinocchio.

It shares no code with gibbsimpact (it never imports it): a plain description of a rigid tree
(:class:`Tree`) becomes a ``pinocchio.Model`` whose configuration and velocity vectors are the
package's ``q`` and ``qdot`` coordinate by coordinate (same signs, same units; one 1-DOF
Pinocchio joint per coordinate, q_pin = v_pin components = the package's entries), so that
Pinocchio's ``crba`` and ``aba`` give the package's ``M(q)`` and ``qddot = -M^-1 (h + dV/dq)``.
Only the ORDER may differ: Pinocchio's crba needs every joint's subtree to be one contiguous block
of its v (joints added depth first), while the package lists links parent first in any order, so
:func:`build_model` adds the joints depth first and :class:`Reference` carries the permutation;
:func:`mass_matrix` and :func:`forward_dynamics` take and return the package's order. (For a
serial chain, and any tree listed depth first, the permutation is the identity.)

The map (docs/theory.md §1.2, §2, §8; formulation.md §17), with ``T_i`` the frame of link i:

* base ``"free"``: ``q = [X1, X2, X3, theta_-1, theta_0, ...]``,
  ``T_root = Trans(X1, X2, X3) Rx(theta_-1) Ry(theta_0) Rz(theta_root)``: three prismatic joints
  along the world axes X1, X2, X3 (at the origin, unrotated), then revolute joints about the
  CURRENT x, then the current y, then the root link's own revolute about the current z. The two
  virtual links between them have no mass. (Not a Pinocchio free-flyer: its quaternion and
  body-frame twist would not be the package's coordinates.)
* base ``"planar"``: ``q = [X1, X2, ...]``, ``T_root = Trans(X1, X2, 0) Rz(theta_root)``.
* base :class:`Fixed` ``(b, beta)``: no base coordinates, every root link hangs on
  ``T_0 = Trans(b) Rz(beta)``: ``T_root = T_0 J_root``.
* every other link i on parent p at the abscissa x_a (None: the parent's tip l_p):
  ``T_i = T_p Trans(x_a, 0, 0) J_i`` with ``J_i = Rot(R_i) Rz(theta_i)`` for a revolute (R_i a
  constant rotation, default I; the coordinate ``theta_i`` [rad], counter-clockwise about the
  link's new z axis) and ``J_i = Rot(R_i) Rz(angle_i)`` for a weld (no coordinate).
* after the base's coordinates come the revolute angles in link order (welds have none). Rigid
  links have no elastic coordinates.

A weld is no Pinocchio joint: the welded link's inertia is added to the body of the nearest
revolute above it (or of the base) (``appendBodyToJoint`` with the composed placement), and its children hang on
that joint with the composed placement too, so Pinocchio sees the same rigid bodies.

Inertia of a link (derived here; the package's §5 tables are not used). A uniform rod of length
l and mass per length mu along its frame's x axis has mass ``m = mu l`` and centre
``c = (l/2, 0, 0)``. Its line of mass has, about c, the second moments
``int_{-l/2}^{l/2} mu s^2 ds = m l^2 / 12`` along x and none across, so its inertia about c is
``diag(0, m l^2/12, m l^2/12)`` (a point on the x axis has no lever about x). The cross-sections
add their rotary inertia per length ``(j_x, j_y, j_z)`` [kg m] over the length,
``l diag(j_x, j_y, j_z)``: each section's inertia about its own centroid, which lies on the axis,
so the parallel-axis shift of the sections is the line term already and the cross terms vanish
(``int z dA = 0``). Total: ``I_c = diag(0, m l^2/12, m l^2/12) + l diag(j)``. An attached rigid
body (mass m_b, centre offset c_b from the axis point at abscissa a, inertia J_b about its centre
in link axes) adds ``Inertia(m_b, (a, 0, 0) + c_b, J_b)``. Gravity is Pinocchio's
``model.gravity`` (a uniform field: V = -sum m g . c).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class Rod:
    """A rigid uniform rod along its frame's x axis.

    length [m], mass_per_length [kg/m], rotary_inertia (j_x, j_y, j_z) [kg m] per length,
    bodies: tuples (mass [kg], centre offset (3,) [m], inertia (3, 3) [kg m^2] about the centre,
    abscissa [m] on the rod), all in the rod's frame.
    """

    length: float
    mass_per_length: float
    rotary_inertia: tuple = (0.0, 0.0, 0.0)
    bodies: tuple = ()


@dataclass(frozen=True)
class Joint:
    """The joint above a link: kind "R" (one coordinate theta [rad]) or "weld" (none).

    J = Rot(rotation) Rz(theta) for "R", Rot(rotation) Rz(angle) for "weld"; rotation (3, 3)
    orthogonal with det +1, None for the identity.
    """

    kind: str = "R"
    angle: float = 0.0
    rotation: np.ndarray | None = None


@dataclass(frozen=True)
class Fixed:
    """A fixed base frame T_0 = Trans(position) Rz(angle): position (3,) [m], angle [rad]."""

    position: tuple = (0.0, 0.0, 0.0)
    angle: float = 0.0


@dataclass(frozen=True)
class Tree:
    """A rigid tree: links, one joint per link, parents (0-based index of an earlier link or -1 for the
    base), attach (abscissa [m] on the parent, None: its tip; None for a root), base ("free",
    "planar" or Fixed), gravity (3,) [m/s^2]."""

    links: tuple
    joints: tuple
    parents: tuple
    attach: tuple
    base: object = "free"
    gravity: tuple = (0.0, -9.81, 0.0)


def rod_inertia(rod: Rod) -> pin.Inertia:
    """The rod's inertia in its frame: m = mu l at (l/2, 0, 0), I_c = diag(0, m l^2/12, m l^2/12) + l diag(j)
    (module docstring), plus its attached bodies."""
    m = rod.mass_per_length * rod.length
    Ic = np.diag([0.0, m * rod.length ** 2 / 12.0, m * rod.length ** 2 / 12.0])
    Ic += rod.length * np.diag(np.asarray(rod.rotary_inertia, dtype=float))
    inertia = pin.Inertia(m, np.array([rod.length / 2.0, 0.0, 0.0]), Ic)
    for mass, centre, J, at in rod.bodies:
        inertia += pin.Inertia(float(mass), np.array([at, 0.0, 0.0]) + np.asarray(centre, dtype=float),
                               np.asarray(J, dtype=float))
    return inertia


def _se3(rotation=None, translation=(0.0, 0.0, 0.0)) -> pin.SE3:
    R = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    return pin.SE3(R, np.asarray(translation, dtype=float))


def rotation(axis: int, angle: float) -> np.ndarray:
    """The rotation (3, 3) by ``angle`` [rad] about the coordinate axis ``axis`` (0: x, 1: y, 2: z),
    counter-clockwise seen from the axis' tip."""
    c, s = np.cos(angle), np.sin(angle)
    R = np.eye(3)
    j, k = (axis + 1) % 3, (axis + 2) % 3
    R[j, j], R[j, k], R[k, j], R[k, k] = c, -s, s, c
    return R


def _base_joints(model: pin.Model, base) -> tuple[int, pin.SE3]:
    """The base's virtual joints, added to ``model``: (the joint a root hangs on, its placement there)."""
    if isinstance(base, Fixed):
        return 0, _se3(rotation(2, base.angle), base.position)
    if base not in ("free", "planar"):
        raise ValueError(f"base={base!r} must be 'free', 'planar' or Fixed(position, angle)")
    kinds = [(pin.JointModelPX, "X1"), (pin.JointModelPY, "X2")]
    if base == "free":
        kinds += [(pin.JointModelPZ, "X3"), (pin.JointModelRX, "theta_-1"), (pin.JointModelRY, "theta_0")]
    parent = 0
    for kind, name in kinds:  # each virtual joint at the previous one's origin, unrotated
        parent = model.addJoint(parent, kind(), pin.SE3.Identity(), name)
    return parent, pin.SE3.Identity()


def _check(tree: Tree):
    n = len(tree.links)
    if not (len(tree.joints) == len(tree.parents) == len(tree.attach) == n) or n == 0:
        raise ValueError("Tree links, joints, parents and attach must have one entry per link (n >= 1)")
    for i, (p, x) in enumerate(zip(tree.parents, tree.attach)):
        if not -1 <= p < i:
            raise ValueError(f"Tree parents[{i}]={p}: give -1 (the base) or an earlier link's index")
        if p == -1 and x is not None:
            raise ValueError(f"Tree attach[{i}]={x}: a root link hangs on the base frame; give None")
        if tree.joints[i].kind not in ("R", "weld"):
            raise ValueError(f"Tree joints[{i}].kind={tree.joints[i].kind!r} must be 'R' or 'weld'")
    roots = [i for i, p in enumerate(tree.parents) if p == -1]
    if tree.base in ("free", "planar") and (len(roots) != 1 or tree.joints[roots[0]].kind != "R"
                                            or tree.joints[roots[0]].rotation is not None):
        raise ValueError("a floating base floats one root link on a plain revolute Joint('R')")


@dataclass(frozen=True)
class Reference:
    """A tree's Pinocchio model and the permutation to the package's coordinates.

    model : pinocchio.Model, its joints added depth first (module docstring);
    order : (N,) int, ``order[k]`` = the package's index of Pinocchio's coordinate k;
    names : the package's coordinate names, in the package's order.
    """

    model: pin.Model
    order: np.ndarray
    names: tuple


def _depth_first(parents: tuple) -> list:
    """The links in depth-first order (children in link order): Pinocchio's crba fills each joint's
    subtree as one contiguous block of v, so its joints must be added in this order."""
    children = {i: [k for k, p in enumerate(parents) if p == i] for i in range(-1, len(parents))}
    order, stack = [], list(reversed(children[-1]))
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(reversed(children[i]))
    return order


def build_model(tree: Tree) -> Reference:
    """The Pinocchio model of ``tree`` whose coordinates are the package's q and qdot up to the
    permutation ``order`` (module docstring); names ``X1 ... theta_0`` then ``theta_i`` (i 1-based)
    for every revolute link, in link order."""
    _check(tree)
    model = pin.Model()
    model.gravity = pin.Motion(np.asarray(tree.gravity, dtype=float), np.zeros(3))
    base_joint, base_pose = _base_joints(model, tree.base)
    n = len(tree.links)
    joint_of, pose_of = [0] * n, [None] * n  # per link: the Pinocchio joint it moves with, its frame in that joint's frame
    for i in _depth_first(tree.parents):
        rod, jt, p, x = tree.links[i], tree.joints[i], tree.parents[i], tree.attach[i]
        if p == -1:
            parent, above = base_joint, base_pose
        else:
            xa = tree.links[p].length if x is None else float(x)
            parent, above = joint_of[p], pose_of[p] * _se3(translation=(xa, 0.0, 0.0))
        above = above * _se3(jt.rotation)  # Rot(R_i)
        if jt.kind == "R":
            joint_of[i], pose_of[i] = model.addJoint(parent, pin.JointModelRZ(), above, f"theta_{i + 1}"), pin.SE3.Identity()
        else:
            joint_of[i], pose_of[i] = parent, above * _se3(rotation(2, jt.angle))
        model.appendBodyToJoint(joint_of[i], rod_inertia(rod), pose_of[i])
    base = list(model.names[1:model.njoints - sum(j.kind == "R" for j in tree.joints)])
    names = tuple(base + [f"theta_{i + 1}" for i, j in enumerate(tree.joints) if j.kind == "R"])
    return Reference(model, np.array([names.index(nm) for nm in model.names[1:]]), names)


def mass_matrix(ref: Reference, q: np.ndarray) -> np.ndarray:
    """M(q) (N, N) in the package's order, by Pinocchio's crba (it fills the upper triangle), symmetrised."""
    q = np.asarray(q, dtype=float)
    Mp = pin.crba(ref.model, ref.model.createData(), q[ref.order])
    M = np.empty_like(Mp)
    M[np.ix_(ref.order, ref.order)] = np.triu(Mp) + np.triu(Mp, 1).T
    return M


def forward_dynamics(ref: Reference, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """qddot (N,) in the package's order, by Pinocchio's aba with zero joint torques and the model's
    gravity: M qddot = -(h + dV/dq)."""
    q, qdot = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    model = ref.model
    qdd = np.empty(model.nv)
    qdd[ref.order] = pin.aba(model, model.createData(), q[ref.order], qdot[ref.order], np.zeros(model.nv))
    return qdd
