"""What each contact point of the event loop is on the chain (docs/theory.md §11.4, §14.7).

The columns of the gap matrix (simulation.contacts.Contacts) are the points O_1 ... O_P
(Model.contact_point_names), with link contacts the closest point of every flexible link, then the
centre of every attached body with a centre offset (contact.candidates.body_candidates).
For each, :func:`contact_points` says which link's shape functions move it relative to that link's
frame and whether another body is attached there. Two rules of the package follow from it:

* **Newton's law is ill-posed** at a point that a link's shape functions move and to which no
  other body is attached (a span point, the free tip of a finite-element or clamped-free link; a
  tip that carries a RigidBody, or a body's centre, is held by that body's mass):
  its instantaneous effective mass ``1 / (n^T J M^-1 J^T n)`` tends to 0 as the link is refined
  (the impulse halves with every doubling of elements), so the impulse has no limit.
  (simulation.validity warns at the first impact there.)
* **The dwell of a collision episode** (simulation.episodes): a point that a link's shape functions
  move can be brought back to the wall by that link's vibration, within one period of its slowest
  mode ``T_1 = 2 pi / omega_1`` (:func:`rebound_period`); a point they do not move (a joint of
  clamped-clamped links, a rigid link's point) comes back only with the motion of its link frame.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..model.shapes import section_tables
from ..contact.candidates import body_candidates
from .contacts import link_column_cells, link_column_name

__all__ = ["ContactPoint", "contact_points", "describe_point", "rebound_period"]


class ContactPoint(NamedTuple):
    """One column of the gap matrix.

    name : "O2" (contact point O_j) or "link 1" (the closest point of flexible link 1), as Contacts.names
    description : what it is on the chain, e.g. "tip of link 1", "joint 2", "span of link 1"
    link : 0-based index of the link whose shape functions move the point relative to that link's
        frame (a span point, an end of a link whose end moves: finite elements, clamped-free modes,
        a carriage on a flexible host), or None (nothing but the frames moves it)
    free : True when no other body is attached at the point (a chain's tip, a host's tip beside a
        carriage, a span point); False at a joint, a carriage or a guide
    """

    name: str
    description: str
    link: int | None
    free: bool

    @property
    def newton_ill_posed(self) -> bool:
        """Newton's law here has no limit under refinement: a shape function moves the point and nothing
        is attached to it (module docstring)."""
        return self.link is not None and self.free


def describe_point(model, j: int) -> str:
    """What contact point O_j (1-based, Model.n_joints) is on the chain: 'joint 2' (a revolute joint),
    'carriage of joint 2' (SlidingPrismatic), 'rear end of link 2, behind its guide' (FixedPrismatic),
    'tip of link 3' (the last link), and for the points after O_(n+1) 'tip of link 1, guide of joint 2'
    or 'tip of link 1, host of carriage 2'."""
    n = model.n_links
    if not model.chain.serial:
        return _describe_tree_point(model, j)
    specs = model.joint_specs
    if j <= n:
        spec = specs[j - 1]
        if spec.carriage:
            return f"carriage of joint {j}"
        if spec.guide:
            return f"rear end of link {j}, behind its guide"
        return f"{'joint' if spec.has_coordinate else 'weld'} {j}"
    if j == n + 1:
        return f"tip of link {n}"
    joint = _tip_joint(model, j)
    what = "guide" if specs[joint - 1].guide else "host of carriage"
    return f"tip of link {joint - 1}, {what} {'of joint ' if what == 'guide' else ''}{joint}"


def _describe_tree_point(model, j: int) -> str:
    """describe_point for a tree (formulation §17; no prismatic joints): 'joint 3 on link 1 at
    x = 0.4 m', 'weld 2 at the tip of link 1', 'tip of link 4' (a link end that carries no child)."""
    n, chain = model.n_links, model.chain
    if j > n:
        return f"tip of link {n if j == n + 1 else model.extra_tips[j - n - 2] + 1}"
    i = j - 1
    what = "weld" if chain.joints[i].kind == "W" else "joint"
    p, xa = chain.parents[i], chain.attach[i]
    if p < 0:
        return f"{what} {j} on the base"
    return f"{what} {j} " + (f"at the tip of link {p + 1}" if xa is None else f"on link {p + 1} at x = {xa:g} m")


def _tree_joint_point(model, j: int) -> ContactPoint:
    """_joint_point for a tree: a joint on the base is fixed to its frame; a joint at x_a on its
    parent p moves with p's shape functions where they move the section x_a (or the tip); a link end
    that carries no child is free unless a body sits there."""
    n, chain = model.n_links, model.chain
    name, text = f"O{j}", describe_point(model, j)
    if j > n:
        h = n - 1 if j == n + 1 else model.extra_tips[j - n - 2]
        return ContactPoint(name, text, h if _end_moves(model, h) else None, not _tip_body(model, h))
    p, xa = chain.parents[j - 1], chain.attach[j - 1]
    if p < 0:
        return ContactPoint(name, text, None, False)
    moves = _end_moves(model, p) if xa is None else bool(np.any(section_tables(chain.links[p], xa)[0]))
    return ContactPoint(name, text, p if moves else None, False)


def _tip_joint(model, j: int) -> int:
    """The prismatic joint i >= 2 (1-based) whose host's tip is contact point O_j, j > n + 1."""
    return [i for i, spec in enumerate(model.joint_specs, start=1) if i > 1 and spec.prismatic][j - model.n_links - 2]


def _end_moves(model, i: int) -> bool:
    """Whether link i's (0-based) shape functions move its end x = l_i (LinkData.end_t, exact zeros kept)."""
    return bool(np.any(model.link_data[i].end_t))


def _tip_body(model, i: int) -> bool:
    """Whether a RigidBody is attached to link i (0-based) at its tip x = l_i."""
    lk = model.chain.links[i]
    return any(b.at == lk.length for b in lk.bodies)


def _joint_point(model, j: int) -> ContactPoint:
    """ContactPoint of O_j (1-based)."""
    n, specs = model.n_links, model.joint_specs
    if not model.chain.serial:
        return _tree_joint_point(model, j)
    name, text = f"O{j}", describe_point(model, j)
    if j == n + 1:  # the chain's tip (held by a body attached there)
        return ContactPoint(name, text, n - 1 if _end_moves(model, n - 1) else None, not _tip_body(model, n - 1))
    if j > n + 1:  # a host's tip: a guide holds the next link there (Pb), a carriage rides elsewhere (Pa)
        host = _tip_joint(model, j) - 2
        return ContactPoint(name, text, host if _end_moves(model, host) else None,
                            specs[host + 1].carriage and not _tip_body(model, host))
    if j == 1 or specs[j - 1].guide:  # the base, or a Pb link's rear end: its own frame's origin
        return ContactPoint(name, text, None, False)
    host = j - 2
    if specs[j - 1].carriage:  # the carriage centre, on the host's centreline at x = d
        return ContactPoint(name, text, host if model.delta_index[host].size else None, False)
    return ContactPoint(name, text, host if _end_moves(model, host) else None, False)


def contact_points(model, link_contacts: bool = True, walls=()) -> list[ContactPoint]:
    """The ContactPoint of every gap-matrix column: O_1 ... O_P, then (link_contacts) one per link with a
    link column (Contacts.flex: contacts.link_columns of ``walls``), then one per body candidate
    (Contacts.bodies: "body k", held by its own mass), as in simulation.contacts.Contacts."""
    points = [_joint_point(model, j) for j in range(1, model.n_joints + 1)]
    if link_contacts:
        # A rigid link's span point (obstacles) moves with the frame only: Newton's law is well posed there.
        points += [ContactPoint(link_column_name(i, c, m), f"span of link {i + 1}", i if model.delta_index[i].size
                                else None, True) for i, c, m in link_column_cells(model, walls)]
    for k, (i, b) in enumerate(body_candidates(model), start=1):
        where = "its tip" if b.at == model.chain.links[i].length else f"x = {b.at:g} m"
        points.append(ContactPoint(f"body {k}", f"centre of a body on link {i + 1} at {where}",
                                   i if model.delta_index[i].size else None, False))
    return points


def rebound_period(model, i: int) -> float:
    """T_1 = 2 pi / omega_1 [s] of link i (0-based) clamped at its frame, 0 for a rigid link.

    omega_1 = LinkData.first_frequency, the smallest eigenvalue of K phi = omega^2 M_dd phi (the link's
    elastic stiffness and mass blocks): the slowest vibration of the link relative to its frame (a
    cantilever for finite elements and clamped-free modes: 2 pi l^2 / (1.8751^2 sqrt(EI / mu)), 0.0565 s
    for l = 1 m, mu = 1 kg/m, EI = 1e3 N m^2).
    """
    ld = model.link_data[i]
    return 0.0 if ld.K.size == 0 else 2.0 * np.pi / ld.first_frequency
