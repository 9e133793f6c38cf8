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
    if model.chain.joints[i].kind != "Pb":
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
    N, n = model.n_dof, model.n_links
    K = N + 1
    qs = np.tile(q, K)
    qds = np.concatenate([qdot, np.eye(N).ravel()])
    job = _k.JOB_FRAMES
    F = section(model, run_kernel(model, states(qs, qds), job), K, job, "frames").reshape(K, n + 1, 3, 4, 4)
    T, Td, Tdd0 = F[0, i, 0], F[0, i, 1], F[0, i, 2]
    dT = F[1:, i, 1]                                      # (N, 4, 4): dT_i/dq_c
    r, dr, rdot, rddot0 = _local_derivatives(model, q, qdot, i, float(xa[0]))
    J = (dT @ r)[:, :3].T + (T[:3] @ dr.T)
    a0 = (Tdd0 @ r + 2.0 * Td @ rdot + T @ rddot0)[:3]
    return (T @ r)[:3], J, a0
