"""Impact phase: Newton's restitution law as an impulse problem (docs/theory.md §11).

Symbols: M (N, N) mass matrix, W (N, k) with columns J_j^T n_j (J_j the
(3, N) Jacobian of contact point j, n_j its unit wall normal into the free
region), Lambda (k,) normal impulses [N s], e (k,) coefficients of
restitution, v = W^T qdot (k,) normal velocities [m/s].

Integrating M qddot = ... over the vanishing impact time with q fixed:

    M (qdot+ - qdot-) = W Lambda                                     (1)

With G = W^T M^-1 W (the inverse effective mass, m/(N s)), the post-impact
normal velocities are v+ = v- + G Lambda, and the kinetic energy changes by

    T+ - T- = 1/2 (qdot+ + qdot-)^T M (qdot+ - qdot-)
            = 1/2 sum_j Lambda_j (v+_j + v-_j)                        (2)

Newton's law with the "impulses push" condition, for a set S of contacts, is
the linear complementarity problem

    w = G_SS Lambda_S + b_S >= 0,  Lambda_S >= 0,  w . Lambda_S = 0,
    b_j = v-_j + e_j min(v-_j, 0)                                    (3)

so a contact that carries an impulse leaves with v+_j = -e_j v-_j. By (2) an
impulse on a contact with v-_j <= 0 does work Lambda_j (1 - e_j) v-_j / 2 <= 0,
but one on a contact that moves away (v-_j > 0), stopped at v+_j = 0, does
positive work Lambda_j v-_j / 2: with e = 1 at the others the impact would
create energy. So a contact moving away is never part of S.

An impact is therefore solved in rounds at the same instant: each round
solves (3) for S = the contacts that approach or rest (v_j <= 0, velocities
of this round), contacts moving away keep Lambda_j = 0. If the round pushes
one of them into the wall (v_j < 0), it approaches in the next round and
obeys Newton's law there with that velocity. Each round does work <= 0, so
the kinetic energy never rises, and every contact carrying an impulse in a
round obeys Newton's law for that round. Simultaneous contacts that all
approach stay one round (symmetric impacts stay symmetric); a single contact
gets Lambda = -(1 + e) v- / G. A sequence that has not ended after
max_rounds rounds (a chain jammed between walls with e = 1 can bounce
between them without end) ends with one plastic round over all contacts,

    b_S = v_S  (target v+ >= 0),  T+ - T- = -1/2 Lambda^T G Lambda <= 0   (4)

"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import nnls


class ImpulseSolution(NamedTuple):
    """qdot_after (N,), impulses Lambda (k,) [N s], normal velocities before/after (k,) [m/s], rounds."""

    qdot_after: np.ndarray
    impulses: np.ndarray
    v_before: np.ndarray
    v_after: np.ndarray
    rounds: tuple = ()


def _solve_lcp(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve w = G x + b >= 0, x >= 0, x.w = 0 for symmetric PSD G (k, k).

    First the plain solve with every contact carrying an impulse; if that
    pulls (x_j < 0) the equivalent convex problem
    min 1/2 x^T G x + b^T x, x >= 0, written as non-negative least squares
    min |A x - c|^2 with A^T A = G, A^T c = -b.
    """
    k = b.size
    if np.all(b >= 0):
        return np.zeros(k)
    try:
        x = np.linalg.solve(G, -b)
        if np.all(x >= 0):
            return x
    except np.linalg.LinAlgError:
        pass
    s, U = np.linalg.eigh(G)
    s = np.clip(s, 0.0, None)
    keep = s > 1e-14 * max(s.max(), 1e-300)
    A = np.sqrt(s[keep])[:, None] * U[:, keep].T  # (r, k): A^T A = G
    c = -(U[:, keep].T @ b) / np.sqrt(s[keep])  # A^T c = -b on range(G)
    x, _ = nnls(A, c, maxiter=50 * k)
    # Polish on the active set found by NNLS: G_AA x_A = -b_A exactly.
    act = x > 0
    if np.any(act):
        try:
            xa = np.linalg.solve(G[np.ix_(act, act)], -b[act])
            if np.all(xa >= 0):
                x = np.zeros(k)
                x[act] = xa
        except np.linalg.LinAlgError:
            pass
    return x


class ImpulseRound(NamedTuple):
    """One round of an impact: the contacts it solved and what it did to them.

    contacts : (r,) indices into the impact's k contacts
    impulses : (r,) [N s]; v_before, v_after : (r,) normal velocities of those contacts [m/s]
    """

    contacts: np.ndarray
    impulses: np.ndarray
    v_before: np.ndarray
    v_after: np.ndarray


def solve_impulses(
    M: np.ndarray, W: np.ndarray, qdot_before: np.ndarray, restitution, max_rounds: int | None = None
) -> ImpulseSolution:
    """Post-impact velocities and impulses from equations (1)-(4).

    Parameters
    ----------
    M : (N, N) mass matrix at the impact configuration.
    W : (N, k) columns J_j^T n_j for the k contacts in the impact.
    qdot_before : (N,) velocities before the impact.
    restitution : float or (k,) coefficients e in [0, 1].
    max_rounds : int or None, bound on the rounds of equation (3); default 10 k + 10.
        Past it one plastic round (4) ends the impact.

    Returns
    -------
    ImpulseSolution: qdot_after (N,), total impulses (k,) [N s], normal
    velocities before and after (k,) [m/s], and the rounds (tuple of ImpulseRound).
    """
    k = W.shape[1]
    e = np.broadcast_to(np.asarray(restitution, dtype=float), (k,))
    L = np.linalg.cholesky(M)
    MinvW = np.linalg.solve(L.T, np.linalg.solve(L, W))  # (N, k)
    G = W.T @ MinvW
    G = 0.5 * (G + G.T)
    v_before = W.T @ qdot_before
    # Velocities within tol_v of zero count as zero: a contact moving away by
    # less than that may carry an impulse, whose work is below tol_v * Lambda.
    tol_v = 1e-13 * max(float(np.max(np.abs(v_before), initial=0.0)), 1e-300)
    if max_rounds is None:
        max_rounds = 10 * k + 10
    v = v_before.copy()
    Lam = np.zeros(k)
    rounds = []
    for r in range(max_rounds + 1):
        if np.all(v >= -tol_v):
            break
        if r < max_rounds:
            # (3): the contacts that approach or rest; those moving away sit this round out.
            S = np.nonzero(v <= tol_v)[0]
            b = v[S] + e[S] * np.minimum(v[S], 0.0)
        else:
            # (4): one plastic round over every contact ends a sequence that did not.
            S = np.arange(k)
            b = v.copy()
        lam = _solve_lcp(G[np.ix_(S, S)], b)
        Lam[S] += lam
        # Velocities from qdot, not accumulated through G, so rounds do not drift.
        v_new = W.T @ (qdot_before + MinvW @ Lam)
        rounds.append(ImpulseRound(S, lam, v[S].copy(), v_new[S].copy()))
        v = v_new
    qdot_after = qdot_before + MinvW @ Lam
    return ImpulseSolution(qdot_after, Lam, v_before, W.T @ qdot_after, tuple(rounds))


class HeldContactError(ValueError):
    """An impact that the free coordinates cannot resolve: a contact moved by prescribed coordinates only."""


def held_impulses(M: np.ndarray, W: np.ndarray, qdot_before: np.ndarray, prescribed: np.ndarray, solve):
    """An impulse problem solved on the free coordinates, the prescribed ones holding their velocity (§16).

    The actuators hold qdot_p, so only the free rows of M (qdot+ - qdot-) = W Lambda + (0, Lambda_p) are
    Newton's problem: M_ff (qdot_f+ - qdot_f-) = W_f Lambda, with the velocities W^T qdot = W_f^T qdot_f +
    W_p^T qdot_p. The solver sees them unchanged through the shifted free velocity qdot_f + u with
    W_f^T u = W_p^T qdot_p (u by least squares; its residual must vanish, else some contact direction
    is moved by prescribed coordinates only and HeldContactError is raised). Its change of velocity
    does not depend on the shift, so qdot_f+ = (its qdot_after) - u.

    Parameters
    ----------
    M : (N, N) mass matrix; W : (N, m) every direction the solver reads a velocity along (normal
    columns J^T n, then tangential ones for friction); qdot_before : (N,); prescribed : (n_p,) int
    solve : solve(M_ff, rows, qdot_shifted) -> a solution with ``qdot_after`` (n_f,): the plain or
        frictional solver given M_ff, the free rows ``rows`` (boolean (N,)) to take of its W's, and
        the shifted velocity (n_f,)

    Returns
    -------
    (solution, qdot_after (N,) with qdot_after[prescribed] = qdot_before[prescribed])
    """
    free = np.ones(qdot_before.size, dtype=bool)
    free[prescribed] = False
    target = W[prescribed].T @ qdot_before[prescribed]  # (m,) [m/s]
    Wf = W[free]
    u = np.linalg.lstsq(Wf.T, target, rcond=None)[0] if free.any() else np.zeros(0)
    if not free.any():
        raise HeldContactError("every coordinate is prescribed: their actuators drive the chain into the wall and "
                               "nothing can take an impulse")
    scale = float(np.abs(W).max(initial=0.0)) * float(np.abs(qdot_before).max(initial=0.0)) + 1e-300
    if not np.all(np.abs(Wf.T @ u - target) <= 1e-10 * scale):
        raise HeldContactError("a contact point is moved by prescribed coordinates only: their actuators drive it "
                               "into the wall and no impulse of the free coordinates can stop it")
    sol = solve(M[np.ix_(free, free)], free, qdot_before[free] + u)
    qdot_after = qdot_before.copy()
    qdot_after[free] = sol.qdot_after - u
    return sol, qdot_after


def actuator_impulses(M: np.ndarray, qdot_before: np.ndarray, qdot_after: np.ndarray, generalized_impulse: np.ndarray,
                      prescribed: np.ndarray) -> np.ndarray:
    """Lambda_p (n_p,) [N m s or N s]: what the prescribed rows of M (qdot+ - qdot-) = W Lambda + (0, Lambda_p) leave
    over, Lambda_p = M_pf (qdot_f+ - qdot_f-) - W_p Lambda (formulation §16); generalized_impulse (N,) = W Lambda
    (with friction, the tangential impulses' too)."""
    return M[prescribed] @ (qdot_after - qdot_before) - generalized_impulse[prescribed]
