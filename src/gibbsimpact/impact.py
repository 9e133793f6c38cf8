"""Impact phase: Newton's restitution law as an impulse problem (formulation.md section 6).

Symbols: M (N, N) mass matrix, W (N, k) with columns J_j^T n_j (J_j the
(3, N) Jacobian of contact point j, n_j its unit wall normal into the free
region), Lambda (k,) normal impulses [N s], e (k,) coefficients of
restitution, v = W^T qdot (k,) normal velocities [m/s].

Integrating M qddot = ... over the vanishing impact time with q fixed:

    M (qdot+ - qdot-) = W Lambda                                     (1)

With G = W^T M^-1 W (the inverse effective mass, m/(N s)), the post-impact
normal velocities are v+ = v- + G Lambda. Newton's law with the "impulses
push" condition is the linear complementarity problem

    w = G Lambda + b >= 0,  Lambda >= 0,  w . Lambda = 0,
    b_j = v-_j + e_j min(v-_j, 0)                                    (2)

so an approaching contact (v-_j < 0) gets v+_j = -e_j v-_j when it carries an
impulse, and a contact that was not approaching only must not start to
penetrate. For one contact this is Lambda = -(1 + e) v- / G.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import nnls


class ImpulseSolution(NamedTuple):
    """qdot_after (N,), impulses Lambda (k,) [N s], normal velocities before/after (k,) [m/s]."""

    qdot_after: np.ndarray
    impulses: np.ndarray
    v_before: np.ndarray
    v_after: np.ndarray


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


def solve_impulses(M: np.ndarray, W: np.ndarray, qdot_before: np.ndarray, restitution) -> ImpulseSolution:
    """Post-impact velocities and impulses from equations (1)-(2).

    Parameters
    ----------
    M : (N, N) mass matrix at the impact configuration.
    W : (N, k) columns J_j^T n_j for the k contacts in the impact.
    qdot_before : (N,) velocities before the impact.
    restitution : float or (k,) coefficients e in [0, 1].

    Returns
    -------
    ImpulseSolution
    """
    k = W.shape[1]
    e = np.broadcast_to(np.asarray(restitution, dtype=float), (k,))
    L = np.linalg.cholesky(M)
    MinvW = np.linalg.solve(L.T, np.linalg.solve(L, W))  # (N, k)
    G = W.T @ MinvW
    G = 0.5 * (G + G.T)
    v_before = W.T @ qdot_before
    b = v_before + e * np.minimum(v_before, 0.0)
    Lam = _solve_lcp(G, b)
    qdot_after = qdot_before + MinvW @ Lam
    return ImpulseSolution(qdot_after, Lam, v_before, W.T @ qdot_after)
