"""Resting contact at a material point of a link's span (issue 25 item 1; docs/theory.md §10.3, §14).

A span pair a = (wall w, link column c) is the point of link i = flex[c - P] closest to wall w,
x* = argmin_x phi(q, x), phi(q, x) = g_w(p(q, x)) (contact.closest_points: an interior minimum,
phi_x = 0, phi_xx >= 0). It rests like a joint pair (resting.py, equations (1)-(7)) with the
constraint g_a(q) = phi(q, x*(q)) = 0. The contact point follows the link: it rolls and slides
along the span, deflection included.

Kinematics of the sliding contact point. With phi_x(q, x*(q)) = 0 (envelope theorem)

    g_a'   = phi_q qdot = n^T J(x*) qdot                                                      (1)

so the force column W_a = J(x*)^T n is that of the material point at x*. Differentiating again,
with xdot* from d/dt phi_x(q, x*) = 0, i.e. phi_xq qdot + phi_xx xdot* = 0,

    g_a''  = phi_q qddot + qdot^T phi_qq qdot + (phi_xq qdot) xdot*
           = n^T (J qddot + a0) + pdot^T H_w pdot - (phi_xq qdot)^2 / phi_xx                (2)
    phi_xq qdot = n^T pdot_x + p_x^T H_w pdot,   phi_xx = n^T p_xx + p_x^T H_w p_x

(a0 = Jdot qdot of the material point, pdot = J qdot, p_x = dp/dx, p_xx = d2p/dx2 and pdot_x the
velocity of p_x at fixed x; H_w the Hessian of the wall's gap, |grad g| = 1). The last term
of (2) is the only one a joint pair does not have: the contact point's own motion along the
link, xdot* = -(phi_xq qdot) / phi_xx. For a rigid rod rolling on a cylinder of radius R it is
-R omega^2 (phi_xx = 1 / R, phi_xq qdot = omega); for a rod lying flat on a plane phi_xx = 0 and
x* is not defined (both ends rest instead: a rigid link has no column on a plane).

p_x, p_xx and pdot_x are central differences of the material points and their velocities at
x* +- h_x, h_x = 1e-4 l_i (exact for a rigid link up to round-off ~ eps l / h_x^2; O(h_x^2)
for a flexible one, relative error ~1e-8). The tangential rows of a sticking span point use
a0 of the material point at x*: rolling without slipping keeps its tangential velocity and
acceleration zero.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.link_points import material_jacobians, material_points
from .span_cells import link_minima

#: Step of the central differences along the link, relative to its length.
H_X = 1e-4
#: phi_xx l below which a minimum is held as a fixed material point (no sliding term; module docstring).
MIN_CURVATURE = 0.1


def _bilinear(wall, p, u, v) -> float:
    """u^T H_w v [1/m times the units of u, v] at p (3,) from the wall's quadratic form (polarisation)."""
    P = p[None, :]
    return 0.25 * float(wall.curvature(P, (u + v)[None, :])[0] - wall.curvature(P, (u - v)[None, :])[0])


def span_point_terms(model, wall, q, qd, i: int, x: float, stationary: bool = True):
    """Equations (1)-(2) of the module docstring for the material point x [m] of link i on ``wall``.

    stationary : x is an interior minimum of the link's gap (phi_x = 0: the point slides along the
    link, the term -(phi_xq qd)^2 / phi_xx of (2)), or False: a fixed material point (the end of a
    cell, contact/span_cells.py), whose gap acceleration is that of the material point.
    Returns p (3,) [m], J (3, N), n (3,), pd (3,) [m/s], a0 (3,) [m/s^2] of the material point,
    g [m], the acceleration term c = n.a0 + pd^T H pd - (phi_xq qd)^2 / phi_xx [m/s^2].
    """
    length = model.chain.links[i].length
    h = H_X * length
    q, qd = model.check_state(q, qd)
    if not stationary:  # a fixed material point, anywhere on the link (its ends included)
        return _material_point_terms(model, wall, q, qd, i, x)
    x = float(np.clip(x, h, length - h))
    (p, J, a0), (pm, Jm, _), (pp, Jp, _) = material_jacobians(model, q, qd, i, (x, x - h, x + h))
    n = wall.normal(p[None, :])[0]
    g = float(wall.gap(p[None, :])[0])
    pd = J @ qd
    c = float(n @ a0) + float(wall.curvature(p[None, :], pd[None, :])[0])
    p_x = (pp - pm) / (2.0 * h)
    pd_x = (Jp - Jm) @ qd / (2.0 * h)
    phi_xx = _gap_curvature(wall, p, pm, pp, h)
    if phi_xx * length > MIN_CURVATURE:
        phi_xq = float(n @ pd_x) + _bilinear(wall, p, p_x, pd)
        c -= phi_xq * phi_xq / phi_xx
    return p, J, n, pd, a0, g, c


def _gap_curvature(wall, p, pm, pp, h: float) -> float:
    """phi_xx = n^T p_xx + p_x^T H_w p_x [1/m] of equation (2) from the material points p, pm, pp (3,) [m] at
    x, x - h, x + h (central differences)."""
    n = wall.normal(p[None, :])[0]
    p_x, p_xx = (pp - pm) / (2.0 * h), (pp - 2.0 * p + pm) / (h * h)
    return float(n @ p_xx) + float(wall.curvature(p[None, :], p_x[None, :])[0])


def rolls(model, wall, q, i: int, x: float) -> bool:
    """Whether the interior minimum x [m] of link i's gap on ``wall`` at q (N,) rests as a rolling point (equation
    (2) with its sliding term: phi_xx l > MIN_CURVATURE) rather than as a fixed material point."""
    length = model.chain.links[i].length
    h = H_X * length
    x = float(np.clip(x, h, length - h))
    p, pm, pp = material_points(model, q, i, np.array([x, x - h, x + h]))
    return _gap_curvature(wall, p, pm, pp, h) * length > MIN_CURVATURE


def tip_point_terms(model, wall, q, qd, i: int):
    """Equations (1)-(2) for the tip x = l_i of link i on ``wall``: a link end that carries no child
    in a tree (formulation §17), whose acceleration term the kernel's frames do not hold. As
    span_point_terms, but at a fixed material point (no sliding-minimum term): c = n.a0 + pd^T H pd.
    Returns p (3,) [m], J (3, N), n (3,), pd (3,) [m/s], a0 (3,) [m/s^2], g [m], c [m/s^2]."""
    q, qd = model.check_state(q, qd)
    return _material_point_terms(model, wall, q, qd, i, model.chain.links[i].length)


def _material_point_terms(model, wall, q, qd, i: int, x: float):
    """Equation (2) without its sliding term at the fixed material point x [m] of link i (q, qd checked):
    p (3,) [m], J (3, N), n (3,), pd (3,) [m/s], a0 (3,) [m/s^2], g [m], c = n.a0 + pd^T H pd [m/s^2]."""
    ((p, J, a0),) = material_jacobians(model, q, qd, i, (float(x),))
    n = wall.normal(p[None, :])[0]
    pd = J @ qd
    c = float(n @ a0) + float(wall.curvature(p[None, :], pd[None, :])[0])
    return p, J, n, pd, a0, float(wall.gap(p[None, :])[0]), c


def tree_tip_columns(model) -> np.ndarray:
    """Columns (point indices) of a tree's free tips among the contact points (Model.extra_tips;
    none for a serial chain, whose extra tips are prismatic hosts' and do not rest)."""
    if model.chain.serial:
        return np.zeros(0, dtype=int)
    return np.arange(model.n_links + 1, model.n_joints)


def span_abscissae(model, walls, q, pairs, n_joints: int, cells, seats=None) -> list:
    """(link, x* [m], stationary) of every span pair (wall, column >= n_joints) of ``pairs`` (k, 2); the
    columns after the joints are ``cells`` ((i, c, m), contact.span_cells.link_cells): link_minima.
    seats : None or (k,) [m], NaN or the abscissa of a pair seated at a fixed material point (resting.py's
    seats: held there, stationary False, until the next mode decision)."""
    cols = [cells[c - n_joints] for c in pairs[:, 1]]
    if seats is not None and np.all(np.isfinite(seats)):
        return [(col[0], float(x), False) for col, x in zip(cols, seats)]
    cm = link_minima(model, q, walls, cols)
    if seats is not None:
        return [(cols[a][0], float(seats[a]), False) if np.isfinite(seats[a]) else
                (cols[a][0], float(cm.x[w, a]), bool(cm.stationary[w, a] and cm.inside[w, a]))
                for a, (w, _) in enumerate(pairs)]
    # A minimum within CELL_END_TOL l of the link's end is held as the material point there (the end joint's
    # own point at the end): the rolling contact hands over to the corner without a jump (Contacts.hold).
    return [(cols[a][0], float(cm.x[w, a]), bool(cm.stationary[w, a] and cm.inside[w, a]))
            for a, (w, _) in enumerate(pairs)]
