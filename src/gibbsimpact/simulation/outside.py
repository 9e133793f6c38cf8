"""Contact points beyond a wall at one state: the start check of simulate and of the case loader.

A state q is inside when every contact point has a gap g >= -tol to every wall (g > 0 inside,
gibbsimpact.walls). The contact points are those of the event loop (simulation.contacts.Contacts):

* the joints O_1 ... O_P (kinematics.joint_positions, Model.contact_point_names);
* with link contacts, the material point p(q, i, x*) of every flexible link i closest to wall w,
  x* = argmin over x of g_w(p(q, i, x)) (contact.candidates.closest_points), when x* lies between
  the link's ends (candidates.interior): a bent link can cross a wall with both of its joints
  inside. A rigid link cannot (every wall's gap is concave along a straight line), nor can the
  closest point at an end, which is a joint;
* the centre of every attached body with a centre offset (contact.candidates.body_candidates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contact.candidates import body_candidates, closest_points, interior
from ..dynamics.kinematics import joint_positions
from ..dynamics.link_points import body_centers, material_points
from .contacts import link_columns

__all__ = ["Outside", "outside_walls", "point_name"]


@dataclass(frozen=True)
class Outside:
    """One contact point beyond a wall.

    wall : index of the wall in ``walls`` (0-based)
    depth : -g > tol [m], how far the point is beyond the wall
    point : (3,) its position [m]
    joint : index of the contact point (0-based, Model.contact_point_names) for a joint, else None
    link : index of the link (0-based) for a link's interior point, else None
    x : the point's abscissa on that link [m] (0 <= x <= l_i), else None
    body : for a body's centre, its number (0-based) among contact.candidates.body_candidates, else None
    """

    wall: int
    depth: float
    point: tuple
    joint: int | None = None
    link: int | None = None
    x: float | None = None
    body: int | None = None


def outside_walls(model, q, walls, tol: float, link_contacts: bool = True) -> list[Outside]:
    """Every contact point of the state q (N,) with gap g < -tol [m] to one of ``walls``: the joints
    first, wall by wall, then the centres of the body candidates, then (with ``link_contacts``) the
    interior closest points of links (contacts.link_columns)."""
    walls = tuple(walls)
    p = joint_positions(model, q)
    pb = body_centers(model, q, body_candidates(model))[0]
    out = []
    for k, w in enumerate(walls):
        g = w.gap(p)
        out += [Outside(k, float(-g[j]), tuple(float(c) for c in p[j]), joint=int(j))
                for j in np.nonzero(g < -tol)[0]]
        gb = w.gap(pb)
        out += [Outside(k, float(-gb[b]), tuple(float(c) for c in pb[b]), body=int(b)) for b in np.nonzero(gb < -tol)[0]]
    flex = link_columns(model, walls) if link_contacts else []
    if not (flex and walls):
        return out
    cp = closest_points(model, q, walls)
    beyond = (cp.gap < -tol) & interior(model, q, cp.x)
    for k, i in zip(*np.nonzero(beyond)):
        if i in flex:
            x = float(cp.x[k, i])
            point = material_points(model, q, int(i), [x])[0]
            out.append(Outside(int(k), float(-cp.gap[k, i]), tuple(float(c) for c in point), link=int(i), x=x))
    return out


def point_name(model, o: Outside) -> str:
    """What is outside, in words: 'joint O2', 'the tip of link 1' (a host's tip at a prismatic
    joint), 'link 2 at x = 0.3 m of its 0.6 m' or 'the centre of body 1 (on link 2 at x = 0.4 m)'."""
    if o.link is not None:
        return f"link {o.link + 1} at x = {o.x:.6g} m of its {model.chain.links[o.link].length:.6g} m"
    if o.body is not None:
        i, b = body_candidates(model)[o.body]
        return f"the centre of body {o.body + 1} (on link {i + 1} at x = {b.at:.6g} m)"
    if o.joint <= model.n_links:
        return f"joint O{o.joint + 1}"
    return f"the {model.contact_point_names[o.joint]}"
