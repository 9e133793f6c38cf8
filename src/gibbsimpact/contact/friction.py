"""Frictional impact: Moreau's velocity-average impact law with Coulomb friction (one impact, k contacts).

Symbols (as in impact.py): M (N, N) mass matrix; for contact i, n_i its unit
wall normal, t1_i, t2_i two orthonormal tangents (both orthogonal to n_i),
J_i its (3, N) Jacobian; Wn (N, k) columns J_i^T n_i, Wt (N, k, 2) columns
J_i^T t1_i, J_i^T t2_i; P_n,i >= 0 normal impulse [N s], f_i (2,) tangential
impulse in the (t1_i, t2_i) basis [N s]; mu_i >= 0 Coulomb coefficient;
e in [0, 1] restitution. Contact velocities [m/s] are u = B^T qdot for
generalised force directions B.

Law. Moreau's impact law (J. J. Moreau, "Unilateral contact and dry friction
in finite freedom dynamics", in Nonsmooth Mechanics and Applications, CISM
Courses and Lectures 302, Springer 1988, pp. 1-82), in Glocker's form with a
restitution coefficient (Ch. Glocker, "Set-Valued Force Laws", Lecture Notes
in Applied Mechanics 1, Springer 2001; Ch. Glocker, "Energetic consistency
conditions for standard impacts, Part I", Multibody System Dynamics 29 (2013)
77-117): with the velocity average

    U~ = (u+ + e u-) / (1 + e)                                           (1)

taken for the normal AND the tangential contact velocities, the impulses obey
the normal cone inclusion of Signorini's condition and Coulomb's law in U~:
U~_n >= 0 _|_ P_n >= 0, and f_i in the friction disc |f_i| <= mu_i P_n,i,
maximising the dissipation -f_i . U~_t,i. Coulomb's disc is replaced by the
polyhedral cone of n = n_directions directions (Stewart & Trinkle, "An
implicit time-stepping scheme for rigid body dynamics with inelastic
collisions and Coulomb friction", Int. J. Numer. Meth. Engng 39 (1996)
2673-2691; Anitescu & Potra, "Formulating dynamic multi-rigid-body contact
problems with friction as solvable linear complementarity problems",
Nonlinear Dynamics 14 (1997) 231-247):

    d_ij = cos(phi_i + 2 pi j / n) t1_i + sin(phi_i + 2 pi j / n) t2_i,  j = 0 .. n-1,
    f_i = D_i beta_i,  D_i = [d_i0 .. d_i,n-1] (2, n),  beta_i >= 0 (n,)

phi_i is the angle of the contact's pre-round slip velocity in the (t1, t2)
plane (0 when it does not slip), so d_i0 is along the slip and, with n even,
d_i,n/2 against it: sliding in the plane of the slip is represented exactly.
The complementarity conditions are

    U~_n,i >= 0                       _|_  P_n,i  >= 0
    D_i^T U~_t,i + gamma_i 1 >= 0     _|_  beta_i >= 0                   (2)
    mu_i P_n,i - 1^T beta_i >= 0      _|_  gamma_i >= 0

(gamma_i approximates the magnitude of the average slip). With
B = [Wn  Wt D] (N, k + k n), P = (P_n, beta), A = B^T M^-1 B and
qdot+ = qdot- + M^-1 B P, u+ = u- + A P, so U~ = u- + A x with x = P / (1 + e);
(2) is the linear complementarity problem in z = (x_n, x_beta, gamma)

    w = | A_nn   A_nb   0 |     | u-_n |
        | A_bn   A_bb   E | z + | u-_b |  >= 0,  z >= 0,  z . w = 0      (3)
        | diag(mu) -E^T 0 |     |  0   |

with E (k n, k) the block diagonal of columns of ones.

Energy. T+ - T- = 1/2 (qdot+ + qdot-)^T M (qdot+ - qdot-) = 1/2 P^T (u+ + u-),
and from (1) u+ + u- = 2 U~ - (1 - e)/(1 + e) A P, so

    T+ - T- = P^T U~ - 1/2 (1 - e)/(1 + e) P^T A P.                     (4)

The second term is <= 0 (A is positive semidefinite, 0 <= e <= 1). By (2),
P_n . U~_n = 0, beta_i . D_i^T U~ = -gamma_i 1^T beta_i = -gamma_i mu_i P_n,i, hence

    P^T U~ = -sum_i gamma_i mu_i P_n,i <= 0,   and T+ <= T-.

(4) needs ONE e for all rows of U~: with a different e per contact, u+ + u-
no longer collects into 2 U~ minus a semidefinite term, and the energy can
rise (on random two-contact problems with e = (1, 0) and friction, solutions
of that law gain many times T-; Glocker 2013 derives the consistency
conditions). A round therefore uses the smallest restitution among its
contacts, e = min_i e_i: the most dissipative choice that keeps (4).
A contact with mu_i = 0 gets no beta_i, gamma_i ((2) would force beta_i = 0).

Solvability (why Lemke). The matrix of (3) is copositive:
z^T Mlcp z = x^T A x + sum_i gamma_i mu_i x_n,i >= 0 for z >= 0. If z >= 0,
Mlcp z >= 0, z^T Mlcp z = 0, then x^T A x = 0, so B x = 0 and
z^T q = x^T B^T qdot- = 0. So q lies in the dual of SOL(0, Mlcp) and Lemke's
method cannot end on a secondary ray (Cottle, Pang & Stone, "The Linear
Complementarity Problem", Academic Press 1992, chapter 4; on a secondary ray
z + t z_h, copositivity gives z_h in SOL(0, Mlcp) and z_h^T q <= -z0 1^T z_h < 0,
a contradiction). The lexicographic minimum-ratio rule keeps every basis
lexico-feasible and so prevents cycling under degeneracy (which (3) always
has: its gamma rows have q = 0). A symmetric scaling z = S z' (S diagonal,
positive) keeps both properties. In floating point, q = B^T qdot lies in
range(B^T) only up to round-off, which matters once a late round's
velocities are small next to |qdot| (A is singular when the contacts
outnumber the coordinates): the round's contact velocities are therefore
projected back onto range(B^T) before the solve. Each solution is checked
(complementarity residual) and a failed attempt repeated with other pivot
tolerances (see lemke).

Rounds (as impact.py). Contacts moving away (u_n > tol) sit a round out; each
round solves (3) for the contacts with u_n <= tol with this round's
pre-velocities; a contact pushed into the wall joins the next round. After
max_rounds one plastic round (e = 0) over all contacts ends the impact ((4)
with e = 0 holds whatever the sign of u-). Each round obeys (4), so the kinetic
energy never rises. With all mu_i = 0 the frictionless solver
impact.solve_impulses is called directly (identical results).
"""

from __future__ import annotations

from numbers import Integral
from typing import NamedTuple

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.linalg.blas import dger as _dger

from .impact import solve_impulses


class FrictionalImpulseSolution(NamedTuple):
    """Result of one frictional impact of k contacts.

    qdot_after : (N,) generalised velocities after the impact.
    impulses : (k,) normal impulses P_n [N s], summed over the rounds.
    tangential_impulses : (k, 2) tangential impulses f in the caller's (t1, t2) basis [N s].
    v_before, v_after : (k,) normal contact velocities n . J qdot [m/s].
    slip_before, slip_after : (k, 2) tangential velocities (t1, t2) . J qdot [m/s].
    rounds : int, number of complementarity problems solved (0: nothing approached).
    lemke_pivots : int, the largest number of Lemke pivots of any round (0 without friction).
    """

    qdot_after: np.ndarray
    impulses: np.ndarray
    tangential_impulses: np.ndarray
    v_before: np.ndarray
    v_after: np.ndarray
    slip_before: np.ndarray
    slip_after: np.ndarray
    rounds: int
    lemke_pivots: int = 0


class LemkeSolution(NamedTuple):
    """z, w (n,) of w = Mlcp z + q, the pivots of the successful attempt, its scaled residual, attempts made."""

    z: np.ndarray
    w: np.ndarray
    pivots: int
    residual: float
    attempts: int = 1


class _LemkeFailure(RuntimeError):
    """One attempt of Lemke's method failed (ray, pivot limit or residual); carries the reason."""


class _LemkeTableau:
    """The basis of one Lemke attempt on the scaled LCP (Ms (n, n), qs (n,)), with pivot and tie tolerance tol.

    Variables 0..n-1 are w, n..2n-1 are z, 2n is z0. ``basis`` (n,) holds the basic variables,
    ``Binv`` the inverse B^-1 (n, n) of their columns of C = [I, -Ms, -1] (n, 2n + 1), and
    ``xB`` = B^-1 q' (n,) their values; both start from B = I.
    """

    def __init__(self, Ms: np.ndarray, qs: np.ndarray, tol: float):
        self.Ms, self.qs, self.tol = Ms, qs, tol
        self.n = n = qs.size
        self.z0 = 2 * n
        self.basis = np.arange(n)
        self.Binv = np.asfortranarray(np.eye(n))
        self.xB = qs.copy()
        self._C = None

    def columns(self) -> np.ndarray:
        """C = [I, -Ms, -1] (n, 2n + 1), built once."""
        if self._C is None:
            n = self.n
            self._C = np.hstack([np.eye(n), -self.Ms, -np.ones((n, 1))])
        return self._C

    def column(self, j: int) -> np.ndarray:
        """B^-1 times column j of [I, -Ms, -1] (n,)."""
        n, Binv = self.n, self.Binv
        if j < n:
            return Binv[:, j].copy()
        if j < self.z0:
            return -(Binv @ self.Ms[:, j - n])
        return -Binv.sum(axis=1)

    def ratio_test(self, y: np.ndarray, ptol: float) -> int:
        """The leaving row for the entering column y (n,): -1 when no row blocks (a ray).

        Lexicographic minimum of the rows (x_B, B^-1) / y over the rows with y > ptol: the
        minimum-ratio test, ties (within tol) broken by the columns of B^-1; z0 leaves
        whenever it ties.
        """
        xB, Binv, basis, tol = self.xB, self.Binv, self.basis, self.tol
        rows = np.flatnonzero(y > ptol)
        if rows.size <= 1:
            return int(rows[0]) if rows.size else -1
        ratio = xB[rows] / y[rows]
        m = ratio.min()
        rows = rows[ratio <= m + tol * max(1.0, abs(m))]
        if rows.size == 1:
            return int(rows[0])
        at_z0 = basis[rows] == self.z0
        if at_z0.any():
            return int(rows[at_z0][0])
        for j in range(self.n):
            ratio = Binv[rows, j] / y[rows]
            m = ratio.min()
            rows = rows[ratio <= m + tol * max(1.0, abs(m))]
            if rows.size == 1:
                break
        return int(rows[0])

    def pivot(self, r: int, c: int, y: np.ndarray) -> int:
        """Variable c (entering column y = B^-1 C_c (n,)) replaces the basic variable of row r; returns that one."""
        Binv, xB, basis = self.Binv, self.xB, self.basis
        # Gauss-Jordan step on row r: B^-1 <- B^-1 - y (B^-1_r / y_r), row r <- B^-1_r / y_r.
        row = Binv[r] / y[r]
        xr = xB[r] / y[r]
        _dger(-1.0, y, row, a=Binv, overwrite_a=1)  # in place (Binv is Fortran-ordered)
        xB[:] -= y * xr
        Binv[r], xB[r] = row, xr
        left = int(basis[r])
        basis[r] = c
        return left

    def refactorise(self, pivots: int):
        """B^-1 and x_B afresh from the basis columns (round-off of the updates does not build up)."""
        try:
            self.Binv[:] = np.linalg.inv(self.columns()[:, self.basis])
        except np.linalg.LinAlgError:
            raise _LemkeFailure(f"singular basis after {pivots} pivots") from None
        self.xB[:] = self.Binv @ self.qs

    def residual(self, xb: np.ndarray):
        """(z' (n,), scaled residual) of the basic solution x_B = xb: max(|min(z', w')|, -z', -w') / max(1, |z'|_inf)."""
        n = self.n
        x = np.zeros(2 * n + 1)
        x[self.basis] = xb
        zs = x[n:self.z0]
        ws = self.Ms @ zs + self.qs
        res = max(float(np.abs(np.minimum(zs, ws)).max()), float(-zs.min()), float(-ws.min()))
        return zs, res / max(1.0, float(np.abs(zs).max()))

    def solution(self):
        """(z' (n,), residual) of the final basis: from x_B, or re-solved directly when that is better."""
        # The complementarity residual of the basic solution; if round-off shows, the final
        # basis is re-solved directly (C_B x_B = q') and the better of the two kept.
        zs, residual = self.residual(self.xB)
        if residual > 1e-14:
            try:
                zs2, residual2 = self.residual(np.linalg.solve(self.columns()[:, self.basis], self.qs))
                if residual2 < residual:
                    zs, residual = zs2, residual2
            except np.linalg.LinAlgError:
                pass
        return zs, residual


def _lemke_attempt(Ms: np.ndarray, qs: np.ndarray, tol: float, max_pivots: int, residual_tol: float):
    """Lemke's method on the scaled LCP (Ms, qs), |qs|_inf = 1, with pivot and tie tolerance ``tol``.

    Variables 0..n-1 are w, n..2n-1 are z, 2n is z0; the basis inverse B^-1 of the
    columns of [I, -Ms, -1] and x_B = B^-1 q' are updated by each pivot (_LemkeTableau) and
    refactorised every 20 pivots. Returns (z' (n,), pivots, residual).
    """
    tab = _LemkeTableau(Ms, qs, tol)
    n, z0 = tab.n, tab.z0
    # First pivot: z0 enters at the row of the lexicographically smallest (q'_i, e_i): the most
    # negative q', the last such row among ties; every row of (x_B, B^-1) is then lexico-positive.
    entering = n + tab.pivot(tab.ratio_test(np.ones(n), 0.0), z0, tab.column(z0))
    pivots = 1
    while True:
        if pivots >= max_pivots:
            raise _LemkeFailure(f"no solution after max_pivots={max_pivots} pivots")
        if pivots % 20 == 0:
            tab.refactorise(pivots)
        y = tab.column(entering)
        r = tab.ratio_test(y, tol * max(1.0, float(y.max()), -float(y.min())))
        if r < 0:
            raise _LemkeFailure(f"secondary ray after {pivots} pivots")
        left = tab.pivot(r, entering, y)
        pivots += 1
        if left == z0:
            break
        # The complement of the variable that left enters next.
        entering = left + n if left < n else left - n
    zs, residual = tab.solution()
    if not residual <= residual_tol:
        raise _LemkeFailure(f"complementarity residual {residual:.3g} > {residual_tol:g} after {pivots} pivots")
    return zs, pivots, residual


def lemke(Mlcp: np.ndarray, q: np.ndarray, scale: np.ndarray | None = None, max_pivots: int | None = None,
          tolerances: tuple = (1e-12, 1e-10, 1e-9, 1e-11, 1e-13), residual_tol: float = 1e-10) -> LemkeSolution:
    """Solve the LCP w = Mlcp z + q >= 0, z >= 0, z . w = 0 by Lemke's complementary pivoting.

    The augmented system w - Mlcp' z - d z0 = q' (covering vector d = 1) on the
    symmetrically scaled problem Mlcp' = S Mlcp S, q' = S q / |S q|_inf (so
    z = S z' |S q|_inf) starts from z0 = -min q'; each pivot brings in the
    complement of the variable that left; the leaving row is the
    lexicographic minimum of the rows (x_B, B^-1) / y (minimum ratio, ties
    broken by B^-1; z0 leaves whenever it ties), which keeps every basis
    lexico-feasible and so rules out cycling (Cottle, Pang & Stone 1992,
    chapter 4). The final basis is re-solved directly and the
    complementarity residual checked. Pivots and ties are decided with a
    relative tolerance; in floating point a tolerance can misjudge a nearly
    degenerate pivot, so a failed attempt (ray, pivot limit, residual) is
    repeated with the next of ``tolerances``: any result returned passed the
    residual check. Lemke's method solves the LCP when Mlcp is copositive and
    q is in the dual of SOL(0, Mlcp) (module docstring), in particular for
    P-matrices and for positive semidefinite Mlcp with a feasible q.

    Parameters
    ----------
    Mlcp : (n, n) matrix.
    q : (n,) vector.
    scale : (n,) positive diagonal of S; None: 1/sqrt(Mlcp_ii) where Mlcp_ii > 0, else 1.
    max_pivots : bound on the pivots of one attempt, default max(1000, 50 n).
    tolerances : relative pivot and tie tolerances, tried in turn.
    residual_tol : largest accepted max(|min(z', w')|, -z', -w') / max(1, |z'|_inf).

    Returns
    -------
    LemkeSolution(z (n,), w (n,), pivots of the successful attempt, residual).

    Raises
    ------
    RuntimeError when every attempt fails (each attempt's reason in the message).
    """
    Mlcp = np.asarray(Mlcp, dtype=float)
    q = np.asarray(q, dtype=float)
    n = q.size
    if q.ndim != 1 or Mlcp.shape != (n, n):
        raise ValueError(f"Mlcp has shape {Mlcp.shape} and q {q.shape}; they must be (n, n) and (n,)")
    if not (np.all(np.isfinite(Mlcp)) and np.all(np.isfinite(q))):
        raise ValueError("Mlcp and q must be finite")
    if n == 0 or np.all(q >= 0):
        return LemkeSolution(np.zeros(n), q.copy(), 0, 0.0, 0)
    if scale is None:
        d = np.diag(Mlcp)
        scale = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 1.0)
    s = np.asarray(scale, dtype=float)
    if s.shape != (n,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise ValueError(f"scale must be {n} positive finite numbers (the diagonal of S)")
    if max_pivots is None:
        max_pivots = max(1000, 50 * n)
    Ms = s[:, None] * Mlcp * s[None, :]
    qs = s * q
    qnorm = float(np.abs(qs).max())
    qs = qs / qnorm
    reasons = []
    for tol in tolerances:
        try:
            zs, pivots, residual = _lemke_attempt(Ms, qs, tol, max_pivots, residual_tol)
        except _LemkeFailure as err:
            reasons.append(f"tolerance {tol:g}: {err}")
            continue
        z = s * np.clip(zs, 0.0, None) * qnorm
        return LemkeSolution(z, Mlcp @ z + q, pivots, residual, len(reasons) + 1)
    raise RuntimeError(f"Lemke's method found no solution of the LCP of size {n} ({'; '.join(reasons)}); "
                       "the matrix may not be copositive or q may be infeasible")


def _check_inputs(M, Wn, Wt, qdot_before, restitution, friction, n_directions, max_rounds):
    M = np.asarray(M, dtype=float)
    if M.ndim != 2 or M.shape[0] != M.shape[1] or M.shape[0] == 0:
        raise ValueError(f"M has shape {M.shape}; it must be a square (N, N) mass matrix")
    N = M.shape[0]
    if not np.all(np.isfinite(M)):
        raise ValueError("M has non-finite entries; give the finite mass matrix at the impact configuration")
    if not np.allclose(M, M.T, rtol=1e-10, atol=1e-12 * np.abs(M).max()):
        raise ValueError("M is not symmetric; give the symmetric mass matrix (or (M + M.T) / 2)")
    Wn = np.asarray(Wn, dtype=float)
    if Wn.ndim != 2 or Wn.shape[0] != N:
        raise ValueError(f"Wn has shape {Wn.shape}; it must be ({N}, k): one column J_i^T n_i per contact")
    k = Wn.shape[1]
    Wt = np.asarray(Wt, dtype=float)
    if Wt.shape != (N, k, 2):
        raise ValueError(f"Wt has shape {Wt.shape}; it must be ({N}, {k}, 2): columns J_i^T t1_i, J_i^T t2_i "
                         "for each of the k contacts of Wn")
    qd = np.asarray(qdot_before, dtype=float)
    if qd.shape != (N,):
        raise ValueError(f"qdot_before has shape {qd.shape}; it must be ({N},) to match M")
    for name, a in (("Wn", Wn), ("Wt", Wt), ("qdot_before", qd)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} has non-finite entries; give finite numbers")
    e = np.asarray(restitution, dtype=float)
    if e.ndim > 1 or (e.ndim == 1 and e.shape != (k,)):
        raise ValueError(f"restitution has shape {e.shape}; give one number or one per contact, shape ({k},)")
    e = np.array(np.broadcast_to(e, (k,)))
    if not np.all((e >= 0) & (e <= 1)):
        raise ValueError(f"restitution={np.asarray(restitution).tolist()!r} must lie in [0, 1] "
                         "(0 plastic, 1 elastic); clip it to that range")
    mu = np.asarray(friction, dtype=float)
    if mu.ndim > 1 or (mu.ndim == 1 and mu.shape != (k,)):
        raise ValueError(f"friction has shape {mu.shape}; give one Coulomb coefficient per contact, shape ({k},)")
    mu = np.array(np.broadcast_to(mu, (k,)))
    if not np.all(np.isfinite(mu) & (mu >= 0)):
        raise ValueError(f"friction={np.asarray(friction).tolist()!r} must be finite and >= 0 "
                         "(Coulomb coefficients mu_i); use 0 for a frictionless contact")
    if isinstance(n_directions, bool) or not isinstance(n_directions, Integral) or n_directions < 4 \
            or n_directions % 2:
        raise ValueError(f"n_directions={n_directions!r} must be an even integer >= 4 so that the friction "
                         "cone holds the directions along and against the slip; e.g. 8")
    if max_rounds is not None and (isinstance(max_rounds, bool) or not isinstance(max_rounds, Integral)
                                   or max_rounds < 0):
        raise ValueError(f"max_rounds={max_rounds!r} must be a non-negative integer or None (10 k + 10)")
    try:
        L = cho_factor(0.5 * (M + M.T))
    except np.linalg.LinAlgError:
        raise ValueError("M is not positive definite; give the mass matrix of a configuration where "
                         "it is regular") from None
    return L, Wn, Wt, qd, e, mu, int(n_directions)


def _frictional_rounds(L, Wn, Wt, qdot_before, e, mu, n_dir, max_rounds):
    """Rounds of (3); returns (P_n (k,), f (k, 2), qdot_after (N,), rounds, max pivots)."""
    k = Wn.shape[1]
    # All contact directions of the impact, W3 = [Wn, Wt1, Wt2] (N, 3k), their inverse effective
    # mass G3 = W3^T M^-1 W3 (3k, 3k) and velocities c = W3^T qdot: a round's A and u are
    # G3 and c seen through its friction directions, c+ = c- + G3 P3 (velocities from the
    # summed impulses, not accumulated per round, as impact.py).
    W3 = np.hstack([Wn, Wt[:, :, 0], Wt[:, :, 1]])
    MinvW3 = cho_solve(L, W3)
    G3 = W3.T @ MinvW3
    G3 = 0.5 * (G3 + G3.T)
    c0 = W3.T @ qdot_before
    v_before = c0[:k]
    # As impact.py: |u_n| <= tol_v counts as resting; a contact moving away slower may carry an impulse.
    tol_v = 1e-13 * max(float(np.max(np.abs(v_before), initial=0.0)), 1e-300)
    tol_s = 1e-12 * max(float(np.max(np.abs(c0), initial=0.0)), 1e-300)
    if max_rounds is None:
        max_rounds = 10 * k + 10
    angles = 2 * np.pi * np.arange(n_dir) / n_dir
    P3 = np.zeros(3 * k)  # (P_n, f_t1, f_t2), summed over the rounds
    c = c0.copy()
    rounds = max_piv = 0
    for r in range(max_rounds + 1):
        v = c[:k]
        if np.all(v >= -tol_v):
            break
        if r < max_rounds:
            S = np.flatnonzero(v <= tol_v)
            e_r = float(e[S].min())  # one e per round: (4) needs it
        else:
            S = np.arange(k)
            e_r = 0.0  # the closing plastic round
        m = S.size
        idx = np.concatenate([S, k + S, 2 * k + S])
        # Only contacts with mu > 0 get friction directions and a gamma (with mu = 0, (2) forces beta = 0).
        fr = np.flatnonzero(mu[S] > 0)
        mf = fr.size
        slip = c[idx[m:]].reshape(2, m)[:, fr]
        phi = np.where(np.hypot(slip[0], slip[1]) > tol_s, np.arctan2(slip[1], slip[0]), 0.0)
        cos, sin = np.cos(phi[:, None] + angles), np.sin(phi[:, None] + angles)  # (mf, n)
        # R (3m, m + mf n) maps (P_n, beta) to (P_n, f_t1, f_t2): B = W3_S R, A = R^T G3_SS R,
        # d_ij = cos t1 + sin t2, contact-major.
        nb = m + mf * n_dir
        R = np.zeros((3 * m, nb))
        R[:m, :m] = np.eye(m)
        owner = np.repeat(np.arange(mf), n_dir)  # the gamma of each beta
        cols = m + np.arange(mf * n_dir)
        R[m + fr[owner], cols] = cos.ravel()
        R[2 * m + fr[owner], cols] = sin.ravel()
        A = R.T @ G3[np.ix_(idx, idx)] @ R
        A = 0.5 * (A + A.T)
        Mlcp = np.zeros((nb + mf, nb + mf))
        Mlcp[:nb, :nb] = A
        Mlcp[cols, nb + owner] = 1.0  # E
        Mlcp[nb + np.arange(mf), fr] = mu[S][fr]
        Mlcp[nb + owner, cols] = -1.0  # -E^T
        # c_S = W3_S^T qdot exactly lies in range(W3_S^T); once the round's velocities are
        # small next to |qdot| its round-off does not, and then z^T q >= 0 on SOL(0, Mlcp)
        # (module docstring) can fail: project c_S back onto range(W3_S^T) first.
        y = np.linalg.lstsq(W3[:, idx].T, c[idx], rcond=None)[0]
        q = np.concatenate([R.T @ (W3[:, idx].T @ y), np.zeros(mf)])
        # Symmetric scaling: unit diagonal for the impulse rows, O(1) entries in the E blocks.
        dA = np.diag(A)
        big = max(float(dA.max()), 1e-300)
        s_imp = 1.0 / np.sqrt(np.where(dA > 1e-12 * big, dA, big))
        dT = dA[m:].reshape(mf, n_dir).mean(axis=1)
        s_gam = np.sqrt(np.where(dT > 1e-12 * big, dT, big))
        sol = lemke(Mlcp, q, scale=np.concatenate([s_imp, s_gam]))
        max_piv = max(max_piv, sol.pivots)
        # x = P / (1 + e): the impulses of this round in (n, t1, t2) components.
        P3[idx] += R @ ((1.0 + e_r) * sol.z[:nb])
        rounds += 1
        c = c0 + G3 @ P3
    qdot_after = qdot_before + MinvW3 @ P3
    return P3[:k], P3[k:].reshape(2, k).T.copy(), qdot_after, rounds, max_piv


def solve_frictional_impulses(M: np.ndarray, Wn: np.ndarray, Wt: np.ndarray, qdot_before: np.ndarray,
                              restitution, friction, n_directions: int = 8,
                              max_rounds: int | None = None) -> FrictionalImpulseSolution:
    """Post-impact velocities and impulses of k simultaneous frictional contacts, equations (1)-(4).

    Parameters
    ----------
    M : (N, N) symmetric positive definite mass matrix at the impact configuration.
    Wn : (N, k) columns J_i^T n_i (unit wall normals n_i into the free region).
    Wt : (N, k, 2) columns J_i^T t1_i, J_i^T t2_i (orthonormal tangents, orthogonal to n_i).
    qdot_before : (N,) generalised velocities before the impact.
    restitution : float or (k,) coefficients e_i in [0, 1]; a frictional round uses the smallest of
        its contacts'. With all mu_i = 0 impact.solve_impulses is called, which applies each e_i
        to its own contact (Newton's law; energy-safe without friction).
    friction : float or (k,) Coulomb coefficients mu_i >= 0.
    n_directions : even integer >= 4, directions of the polyhedral friction cone.
    max_rounds : int or None, bound on the rounds of (3); default 10 k + 10. Past it one
        plastic round over all contacts ends the impact.

    Returns
    -------
    FrictionalImpulseSolution: qdot_after (N,), impulses (k,) [N s], tangential_impulses
    (k, 2) [N s] in the caller's (t1, t2) basis, v_before, v_after (k,) [m/s], slip_before,
    slip_after (k, 2) [m/s], rounds, lemke_pivots.

    Raises
    ------
    ValueError for inputs of the wrong shape or range; RuntimeError if Lemke's method fails.
    """
    L, Wn, Wt, qd0, e, mu, n_dir = _check_inputs(M, Wn, Wt, qdot_before, restitution, friction, n_directions,
                                                 max_rounds)
    k = Wn.shape[1]
    if np.all(mu == 0):
        sol = solve_impulses(np.asarray(M, dtype=float), Wn, qd0, e, max_rounds=max_rounds)
        Pn, f, qd, rounds, piv = sol.impulses, np.zeros((k, 2)), sol.qdot_after, len(sol.rounds), 0
    else:
        Pn, f, qd, rounds, piv = _frictional_rounds(L, Wn, Wt, qd0, e, mu, n_dir, max_rounds)

    def slip(x):
        return np.einsum("nkc,n->kc", Wt, x)

    return FrictionalImpulseSolution(qd, Pn, f, Wn.T @ qd0, Wn.T @ qd, slip(qd0), slip(qd), rounds, piv)
