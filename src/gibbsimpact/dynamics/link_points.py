"""Material points of the links: the one p = T r(x), its Jacobian and its acceleration term.

A material point at abscissa x [m] of link i (0-based) is, with T_i (4, 4) the link frame,

    p(q, i, x) = (T_i(q) r_i(x))[:3],   r_i(x) = (x + u_f(x), v_i(x), w_i(x), 1)^T

with v, w the deflections of model.link_deflection (modes or Hermite elements) and u_f the
foreshortening of a stiffened link (model.link_foreshortening, formulation §15; 0 for a link
with geometric_stiffening=False).
Every caller that needs a point of a deformed link (contact candidates, validity checks,
figures) goes through :func:`points_on_link` (frames given) or :func:`material_points`.
"""

from __future__ import annotations

import numpy as np

from .. import kernel as _k
from ..model.elements import hermite_shape
from ..model.shapes import foreshortening_matrix, link_deflection, link_foreshortening, shape_functions
from .kinematics import frames, run_kernel, section, states, transforms


def points_on_link(model, q, T, i: int, x) -> np.ndarray:
    """Points (K, 3) [m] of link i (0-based) at abscissae x (K,) [m], with the frames T (n+1, 4, 4)
    of the state q (N,) given: p = T_i r_i(x), unchecked (the callers check once)."""
    x = np.asarray(x, dtype=float)
    v, w = link_deflection(model, q, i, x)
    r = np.stack([x + link_foreshortening(model, q, i, x)[0], v, w], axis=1)
    return r @ T[i][:3, :3].T + T[i][:3, 3]


def link_points(model, q, n_points: int = 41) -> np.ndarray:
    """Points along every deformed link, shape (n_links, n_points, 3) [m], x = 0 ... l_i evenly."""
    q = np.asarray(q, dtype=float)
    T = transforms(model, q)
    return np.stack([points_on_link(model, q, T, i, np.linspace(0.0, lk.length, n_points))
                     for i, lk in enumerate(model.chain.links)]) if model.n_links else np.zeros((0, n_points, 3))


def _body_local(model, q, i: int, body) -> tuple[np.ndarray, np.ndarray]:
    """r (4,) and dr/dq (N, 4) of the centre of ``body`` on link i (0-based) in the link frame
    (docs/theory.md §6.8): r = (x_a + c_x, v(x_a) + c_x v'(x_a) + c_y, w(x_a) + c_x w'(x_a) + c_z, 1),
    dr/d delta_k = e_(a_k) (psi_k(x_a) + c_x psi_k'(x_a)); at = None is the tip. (No body rides a Pb link:
    Chain refuses it.) On a stiffened link (formulation §15) the centre turns with its section to second
    order: r_x gains -1/2 delta^T H_b delta, H_b = H(x_a) + c_x psi'(x_a) psi'(x_a)^T (same directions),
    and dr_x/d delta = -H_b delta (the points of model.shapes.mass_points foreshorten alike)."""
    c, lk = body.center, model.chain.links[i]
    at = lk.length if body.at is None else body.at
    (v,), (w,) = link_deflection(model, q, i, [at])
    (dv,), (dw,) = link_deflection(model, q, i, [at], derivative=1)
    r = np.array([at + c[0], v + c[0] * dv + c[1], w + c[0] * dw + c[2], 1.0])
    dr = np.zeros((model.n_dof, 4))
    idx = model.delta_index[i]
    if idx.size:
        directions, psi = shape_functions(lk, [at], 0)
        dpsi = shape_functions(lk, [at], 1)[1]
        for k, (col, d) in enumerate(zip(idx, directions)):
            dr[col, 1 if d == "y" else 2] = psi[k, 0] + c[0] * dpsi[k, 0]
        if lk.stiffened:
            same = np.equal.outer(np.array(directions), np.array(directions))
            Hb = foreshortening_matrix(lk, [at])[0] + c[0] * np.outer(dpsi[:, 0], dpsi[:, 0]) * same
            delta = np.asarray(q, dtype=float)[idx]
            r[0] -= 0.5 * delta @ Hb @ delta
            dr[idx, 0] = -Hb @ delta
    return r, dr


def body_tables(model, owner) -> list:
    """(r(0) (4,), dr/dq (N, 4)) of the centre of every (i, body) in ``owner`` (_body_local at q = 0): the centre
    is r(q) = r(0) + q dr/dq in its link's frame, linear in q (only the link's deltas move it)."""
    zero = np.zeros(model.n_dof)
    return [_body_local(model, zero, i, b) for i, b in owner]


def body_centers(model, q, owner=None, tables=None) -> tuple[np.ndarray, tuple]:
    """World positions of the centres of the rigid bodies attached to the links (docs/theory.md §6.8).

    The centre of a body at abscissa x_a with offset c, in its link's frame T_i:
    r = (x_a + c_x, v(x_a) + c_x v'(x_a) + c_y, w(x_a) + c_x w'(x_a) + c_z, 1), p = (T_i r)[:3].

    Parameters
    ----------
    model : Model
    q : (N,) coordinates, or (K, N) states
    owner : pairs (i, body) to place, or None for every body, link by link in the order of ``Link.bodies``
    tables : body_tables(model, owner), or None to compute them (a caller that places the same bodies
        at many states computes them once)

    Returns
    -------
    p : (B, 3) [m], one row per body ((K, B, 3) for q (K, N))
    owner : tuple of B pairs (i, body): the link index (0-based) and the RigidBody
    """
    q = np.asarray(q, dtype=float)
    if owner is None:
        owner = tuple((i, b) for i, lk in enumerate(model.chain.links) for b in lk.bodies)
    qs = q.reshape(-1, model.n_dof)
    K, n = len(qs), model.n_links
    p = np.zeros((K, len(owner), 3))
    if owner:
        # r(q) = r(0) + q dr/dq (body_tables); the frames of all the states in one kernel call.
        job = _k.JOB_FRAMES
        T = section(model, run_kernel(model, states(qs), job), K, job, "frames").reshape(K, n + 1, 3, 4, 4)[:, :, 0]
        for m, ((i, b), (r0, dr)) in enumerate(zip(owner, tables or body_tables(model, owner))):
            r = r0 + qs @ dr
            if model.chain.links[i].stiffened:  # the quadratic foreshortening (_body_local), per state
                r[:, 0] = [_body_local(model, qk, i, b)[0][0] for qk in qs]
            p[:, m] = np.einsum("kab,kb->ka", T[:, i, :3], r)
    return (p if q.ndim == 2 else p[0]), tuple(owner)


def body_jacobian(model, q, i: int, body) -> tuple[np.ndarray, np.ndarray]:
    """Centre p (3,) [m] of ``body`` on link i (0-based) and its Jacobian J = dp/dq (3, N) [m per unit of q_c]:
    J[:, c] = (dT_i/dq_c r + T_i dr/dq_c)[:3] with r, dr of the body's centre (body_centers)."""
    q = model.check_state(q)
    T, _, _, dT = _frame_derivatives(model, q, np.zeros(model.n_dof), _check_link(model, i))
    r, dr = _body_local(model, q, i, body)
    return (T @ r)[:3], (dT @ r)[:, :3].T + (T[:3] @ dr.T)


def _check_link(model, i):
    if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < model.n_links:
        raise ValueError(f"link index i={i!r} must be an integer in [0, {model.n_links - 1}] (0-based)")
    return int(i)


def _check_abscissae(model, i, x):
    x = np.atleast_1d(np.asarray(x, dtype=float))
    l = model.chain.links[i].length
    if x.ndim != 1 or not np.all(np.isfinite(x)) or np.any(x < 0.0) or np.any(x > l):
        raise ValueError(f"abscissae x={x!r} must be finite numbers in [0, {l:g}] m (link {i + 1}'s length)")
    return x


def material_points(model, q, i: int, x) -> np.ndarray:
    """World positions p = (T_i r_i(x))[:3] of link i's material points (docs/theory.md §7.2).

    Parameters
    ----------
    model : Model
    q : (N,) coordinates
    i : int, link index, 0-based
    x : (K,) material abscissae in [0, l_i] [m]

    Returns
    -------
    p : (K, 3) [m]; r_i(x) = (x, v(x), w(x), 1) with v, w from model.link_deflection.
    """
    q = model.check_state(q)
    i = _check_link(model, i)
    x = _check_abscissae(model, i, x)
    return points_on_link(model, q, frames(model, q).T, i, x)


def _local_derivatives(model, q, qdot, i, x):
    """r (4,), dr/dq (N, 4), rdot (4,), rddot0 (4,) of link i's material point at x (docs/theory.md §7.4).

    Ordinary links: dr/d delta_k = (e_dir psi_k(x), 0), rddot0 = 0; a stiffened link (formulation §15)
    adds u_f = -1/2 delta^T H delta to r, -(H delta)_k to dr/d delta_k and -deltadot^T H deltadot to
    rddot0, along e_x. Pb link (d, stretching
    elements, xi = (x - l + d) / d, Phi_k = d^(a_k) N_k(xi) on xi >= 0, 0 behind the guide):

        dv/d delta_k  = d^(a_k) N_k
        dv/dd         = sum_k delta_k d^(a_k - 1) [a_k N_k + (1 - xi) N_k']
        d2v/dd ddelta_k = d^(a_k - 1) [a_k N_k + (1 - xi) N_k']
        d2v/dd2       = sum_k delta_k d^(a_k - 2) [2 (a_k - 1)(1 - xi) N_k' + (1 - xi)^2 N_k'']
        rddot0 = (0, 2 ddot sum_k d2v/dd ddelta_k deltadot_k + d2v/dd2 ddot^2, 0, 0)
    """
    N = model.n_dof
    lk = model.chain.links[i]
    idx = model.delta_index[i]
    v, w = link_deflection(model, q, i, [x])
    r = np.array([x, v[0], w[0], 1.0])
    dr = np.zeros((N, 4))
    rddot0 = np.zeros(4)
    if idx.size == 0:
        return r, dr, dr.T @ qdot, rddot0
    if not model.chain.joints[i].spec.guide:
        directions, psi = shape_functions(lk, [x], 0)
        for k, (c, s) in enumerate(zip(idx, directions)):
            dr[c, 1 if s == "y" else 2] = psi[k, 0]
        if lk.stiffened:
            H = foreshortening_matrix(lk, [x])[0]
            r[0] += -0.5 * q[idx] @ H @ q[idx]
            dr[idx, 0] = -H @ q[idx]
            rddot0[0] = -qdot[idx] @ H @ qdot[idx]
        return r, dr, dr.T @ qdot, rddot0
    jd = model.theta_index[i]
    d, dd = q[jd], qdot[jd]
    delta, deltadot = q[idx], qdot[idx]
    xi = (x - (lk.length - d)) / d
    if xi < 0.0:
        return r, dr, dr.T @ qdot, rddot0  # behind the guide: v = 0 whatever q
    xi = min(xi, 1.0)
    N0, N1, N2 = (hermite_shape(lk.elements, 1.0, [xi], k)[:, 0] for k in range(3))
    a = np.tile([0.0, 1.0], lk.elements)
    dr[idx, 1] = d ** a * N0
    mixed = d ** (a - 1.0) * (a * N0 + (1.0 - xi) * N1)
    dr[jd, 1] = delta @ mixed
    d2v_dd2 = delta @ (d ** (a - 2.0) * (2.0 * (a - 1.0) * (1.0 - xi) * N1 + (1.0 - xi) ** 2 * N2))
    rddot0[1] = 2.0 * dd * (mixed @ deltadot) + d2v_dd2 * dd * dd
    return r, dr, dr.T @ qdot, rddot0


def _frame_derivatives(model, q, qdot, i: int):
    """T_i, Tdot_i, Tddot0_i (4, 4) and dT_i/dq (N, 4, 4) of link i (0-based) at (q, qdot), exact: the kernel's
    Tdot is linear in qdot, so the frames of the states (q, e_c) give Tdot = dT_i/dq_c (material_jacobian)."""
    N, n = model.n_dof, model.n_links
    K = N + 1
    qs = np.tile(q, K)
    qds = np.concatenate([qdot, np.eye(N).ravel()])
    job = _k.JOB_FRAMES
    F = section(model, run_kernel(model, states(qs, qds), job), K, job, "frames").reshape(K, n + 1, 3, 4, 4)
    return F[0, i, 0], F[0, i, 1], F[0, i, 2], F[1:, i, 1]


def material_point_jacobians(model, q, i: int, xs):
    """Positions p (K, 3) [m] and Jacobians J = dp/dq (K, 3, N) of link i's material points at xs (K,) [m],
    vectorised over the points (the time-stepping grid, contact.span_grid): J[:, :, c] = (dT_i/dq_c r +
    T_i dr/dq_c)[:3] as in material_jacobian, with r = (x, v, w, 1) and dr/d delta_k = e_dir psi_k(x) (a
    stiffened link: u_f = -1/2 delta^T H delta added to r_x, -(H delta)_k to dr_x/d delta_k). Not for a link
    sliding through a guide (Pb): ValueError. q (N,) is taken as checked."""
    lk, N = model.chain.links[i], model.n_dof
    if model.chain.joints[i].spec.guide:
        raise ValueError(f"link {i + 1} slides through a guide: use material_jacobians for its points")
    xs = np.asarray(xs, dtype=float)
    T, _, _, dT = _frame_derivatives(model, q, np.zeros(N), i)
    v, w = link_deflection(model, q, i, xs)
    r = np.stack([xs, v, w, np.ones_like(xs)], axis=1)                  # (K, 4)
    dr = np.zeros((xs.size, N, 4))
    idx = model.delta_index[i]
    if idx.size:
        directions, psi = shape_functions(lk, xs, 0)                     # psi (m, K)
        for k, (c, d) in enumerate(zip(idx, directions)):
            dr[:, c, 1 if d == "y" else 2] = psi[k]
        if lk.stiffened:
            Hd = foreshortening_matrix(lk, xs) @ q[idx]                  # (K, m)
            r[:, 0] -= 0.5 * (Hd @ q[idx])
            dr[:, idx, 0] = -Hd
    p = (r @ T.T)[:, :3]
    J = np.einsum("cab,kb->kac", dT[:, :3], r) + np.einsum("ab,kcb->kac", T[:3], dr)
    return p, J


def material_jacobian(model, q, qdot, i: int, x: float):
    """Position, Jacobian and velocity-product acceleration of link i's material point at x.

    p = (T_i r)[:3],  J = dp/dq:  J[:, c] = (dT_i/dq_c r + T_i dr/dq_c)[:3],
    a0 = Jdot qdot = (Tddot0_i r + 2 Tdot_i rdot + T_i rddot0)[:3]     (docs/theory.md §6)

    so that pddot = J qddot + a0. dT_i/dq_c is exact, not a finite difference: the kernel's
    Tdot is linear in qdot, so the frames of the states (q, e_c) give Tdot = dT_i/dq_c; one
    kernel call evaluates them with (q, qdot) (T, Tdot, Tddot0) as K = N + 1 states.

    Parameters
    ----------
    model : Model
    q, qdot : (N,) coordinates and velocities
    i : int, link index, 0-based
    x : float, material abscissa in [0, l_i] [m]

    Returns
    -------
    p : (3,) [m]; J : (3, N) [m per unit of q_c]; a0 : (3,) [m/s^2]
    """
    q, qdot = model.check_state(q, qdot)
    i = _check_link(model, i)
    xa = _check_abscissae(model, i, x)
    if xa.size != 1:
        raise ValueError(f"x={x!r} must be one abscissa [m]; call material_jacobian once per point")
    return material_jacobians(model, q, qdot, i, xa)[0]


def material_jacobians(model, q, qdot, i: int, xs):
    """material_jacobian at several abscissae xs (K,) [m] of link i with one kernel call (the frame
    and its q-derivatives are shared): a list of K (p (3,) [m], J (3, N), a0 (3,) [m/s^2]).
    q, qdot (N,) are taken as checked (material_jacobian checks them)."""
    T, Td, Tdd0, dT = _frame_derivatives(model, q, qdot, i)
    out = []
    for x in xs:
        r, dr, rdot, rddot0 = _local_derivatives(model, q, qdot, i, float(x))
        J = (dT @ r)[:, :3].T + (T[:3] @ dr.T)
        a0 = (Tdd0 @ r + 2.0 * Td @ rdot + T @ rddot0)[:3]
        out.append(((T @ r)[:3], J, a0))
    return out
