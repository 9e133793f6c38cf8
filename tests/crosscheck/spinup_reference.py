"""Independent Ritz reference for the spin-up benchmark (issue 24; formulation.md §15).

What it is
----------
A planar cantilever of length ``L`` clamped at the centre of a hub whose angle
``theta(t)`` is prescribed (Kane, Ryan & Banerjee 1987; Simo & Vu-Quoc 1986). It shares
**no code** with ``gibbsimpact`` (numpy and scipy only) so that it can check the package's
foreshortening (formulation.md §15) and prescribed motion (§16).

Model (the kinematics of §15, written here in the rotating hub frame)
---------------------------------------------------------------------
Material point of undeformed abscissa x (0 <= x <= L), inextensible centreline:

    X(x, t) = x + u_f(x, t),   Y(x, t) = v(x, t),
    v(x, t) = sum_k phi_k(x) q_k(t),                       (Ritz, n terms)
    u_f(x, t) = -1/2 int_0^x v'^2 dxi = -1/2 q^T H(x) q,    H_kl(x) = int_0^x phi_k' phi_l' dxi

Inertial acceleration of the point, components in the hub frame (theta_dot = w):

    a_X = Xdd - 2 w Yd - wd Y - w^2 X
    a_Y = Ydd + 2 w Xd + wd X - w^2 Y,     Xd = -(H q).qd,  Xdd = -qd^T H qd - (H q).qdd

Energies: T = 1/2 int mu [(Xd - w Y)^2 + (Yd + w X)^2] dx,  V = 1/2 int EI v''^2 dx = 1/2 q^T K q.
Nothing is dropped from T: it is exact for these kinematics (up to fourth order in q),
so the model is the exact holonomic system of §15 (the same one the package must
reproduce), not an approximation of it. What the model itself neglects with respect to
a geometrically exact beam: extensibility, shear, rotary inertia, and the exact curvature
(V uses v'' instead of v''/sqrt(1 - v'^2); u_f is the quadratic approximation of
int (sqrt(1 - v'^2) - 1)). These are O(v'^2) relative corrections: the largest slopes
of the benchmark are 0.054, 0.078, 0.115 for Omega_s = 4, 6, 10 rad/s (v'^2 <= 1.3e-2), so
the model stays within about 1 % of a geometrically exact beam. The package implements
the same §15 model, so it must agree with this reference far more closely than that.

Equations of motion (d'Alembert = Lagrange for this holonomic system, theta prescribed):

    sum over the beam of  mu a . dp/dq_k  +  (K q)_k = 0,    dp/dq_k = (-(H q)_k, phi_k)

    [int mu (G G^T + phi phi^T)] qdd = int mu (G a_X0 - phi a_Y0) - K q        (G = H q)

with a_X0, a_Y0 the accelerations without their qdd parts. Linearised about a steady spin
Omega this gives K + Omega^2 K_G - Omega^2 M0 with K_G = int mu x H(x) dx (§15's K_G).
The hub torque that realises theta(t) (it is the only force doing work, the root does not
move) is

    tau = int mu (X a_Y - Y a_X) dx,     d(T + V)/dt = tau w                      (power)

``foreshortening=False`` sets H = 0 (u_f = 0): the linear beam of the package's Parts I-II,
whose in-plane stiffness K - Omega^2 M0 turns negative above the first bending frequency.

Ritz basis and quadrature
-------------------------
phi_k = polynomial combinations of (x/L)^(j+1), j = 1..n (clamped: phi(0) = phi'(0) = 0),
made M0-orthonormal by the eigenvectors of the linear non-rotating beam (only to condition
the coordinates; any invertible combination spans the same space). A basis unlike the
package's (clamped-free eigenfunctions, Hermite elements), so that the check is a second
route. All integrands are polynomials: H(x) by an (n+1)-point Gauss rule on [0, x] and
every integral over the beam by a (2n+4)-point Gauss rule on [0, L] are exact (the highest
degree, in int mu (H q)(H q)^T, is 4n+2).

Checking the package with it
----------------------------
Run the package on the same link and profile (``spin_up_profile`` gives (q, qdot, qddot) of
the hub angle), take link 0's deflection at x = L from every sample (the link frame of a
fixed-base R joint at the root is the hub frame), and call
``spinup_reference(..., t_eval=result.t)``: both are then sampled at the same instants, and
``max |v_package - v_reference| / max |v_reference|`` is the number issue 24 bounds by 1 %
(the reference's own error at n = 4 is 1.6e-4 of the peak for Omega_s = 6).

Units: SI (m, kg/m, N m^2, s, rad).
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial.legendre import leggauss
from scipy.integrate import solve_ivp
from scipy.linalg import eigh
from scipy.linalg.lapack import dposv

__all__ = [
    "spin_up_profile",
    "RitzBeam",
    "accelerations",
    "energy",
    "spinup_reference",
    "spinup_summary",
]


def spin_up_profile(t, Omega_s, T_s):
    """Hub angle of the benchmark and its two derivatives [rad, rad/s, rad/s^2].

        theta = (Omega_s/T_s) (t^2/2 + (T_s/2pi)^2 (cos(2pi t/T_s) - 1)),   t < T_s
              = Omega_s (t - T_s/2),                                        t >= T_s

    so theta_dot rises smoothly from 0 to Omega_s and theta_ddot = (Omega_s/T_s)(1 - cos(2pi t/T_s))
    vanishes at both ends. t: float [s].
    """
    if t >= T_s:
        return Omega_s * (t - T_s / 2.0), Omega_s, 0.0
    a = 2.0 * np.pi / T_s
    c = Omega_s / T_s
    theta = c * (t * t / 2.0 + (np.cos(a * t) - 1.0) / (a * a))
    return theta, c * (t - np.sin(a * t) / a), c * (1.0 - np.cos(a * t))


def _gauss(m, a, b):
    """m-point Gauss-Legendre nodes and weights on [a, b] (exact to degree 2m - 1)."""
    s, w = leggauss(m)
    return 0.5 * (b - a) * s + 0.5 * (b + a), 0.5 * (b - a) * w


def _monomials(x, n, L):
    """(x/L)^(j+1), j = 1..n, and their first two x-derivatives; each (len(x), n)."""
    j = np.arange(1, n + 1)
    s = np.asarray(x, float)[:, None] / L
    phi = s ** (j + 1)
    dphi = (j + 1) * s**j / L
    ddphi = (j + 1) * j * s ** (j - 1) / L**2
    return phi, dphi, ddphi


class RitzBeam:
    """Tabulated Ritz basis of a uniform clamped-free beam (read-only after construction).

    The coordinates are M0-orthonormal: q [sqrt(kg) m], phi [1/sqrt(kg)], v = phi q [m].
    Attributes (m = 2n + 4 Gauss points on [0, L]):
      x (m,) [m]; mw (m,) = mu * Gauss weight [kg]; phi (m, n), dphi (m, n) = phi' [1/(sqrt(kg) m)];
      mwphi = mw phi (m, n); phi_tip (n,) = phi(L);
      H (m, n, n) = int_0^x phi' phi'^T dxi [1/(kg m)] (u_f = -1/2 q^T H q [m]); H_tip = H(L);
      M0 (n, n) = int mu phi phi^T = I [-]; K (n, n) = int EI phi'' phi''^T [1/s^2]
      (its eigenvalues are omega^2 of the non-rotating beam); K_G (n, n) = int mu x H(x) dx [-].
    """

    def __init__(self, n, L, mu, EI):
        if int(n) != n or n < 1:
            raise ValueError(f"n must be a positive integer (number of Ritz terms), got {n!r}")
        for name, value in (("L", L), ("mu", mu), ("EI", EI)):
            if not value > 0:
                raise ValueError(f"{name} must be > 0, got {value!r}")
        n = int(n)
        self.n, self.L, self.mu, self.EI = n, float(L), float(mu), float(EI)
        x, w = _gauss(2 * n + 4, 0.0, L)
        phi, dphi, ddphi = _monomials(x, n, L)
        mw = mu * w
        M0 = phi.T @ (mw[:, None] * phi)
        K = ddphi.T @ ((EI * w)[:, None] * ddphi)
        # M0-orthonormal combinations: conditions q (monomials alone have cond(M0) ~ 10^n).
        _, C = eigh(K, M0)
        self.x, self.mw = x, mw
        self.phi, self.dphi = phi @ C, dphi @ C
        self.phi_tip = (_monomials([L], n, L)[0] @ C)[0]
        self.H = np.array([self._H(xi, C) for xi in x])
        self.H_tip = self._H(L, C)
        self.mwphi = mw[:, None] * self.phi
        self.M0 = self.phi.T @ self.mwphi
        self.K = C.T @ K @ C
        self.K_G = np.einsum("i,i,ikl->kl", mw, x, self.H)

    def _H(self, x, C):
        """H(x) = int_0^x phi' phi'^T dxi, exact ((n+1)-point Gauss on a degree-2n integrand)."""
        xi, w = _gauss(self.n + 1, 0.0, x)
        d = _monomials(xi, self.n, self.L)[1] @ C
        return d.T @ (w[:, None] * d)

    def rotating_matrices(self, Omega, in_plane=True):
        """(M0, K_eff) linearised about a steady spin Omega [rad/s] (§15).

        K_eff = K + Omega^2 K_G - Omega^2 M0 (in-plane) or K + Omega^2 K_G (flapwise);
        without foreshortening K_G is absent. Both (n, n).
        """
        K_eff = self.K + Omega**2 * self.K_G
        if in_plane:
            K_eff = K_eff - Omega**2 * self.M0
        return self.M0, K_eff


def _field(beam, q, qd, foreshortening):
    """Hub-frame position and velocity at the Gauss points: X, Y, Xd, Yd, G = H q (m,n)."""
    Y, Yd = beam.phi @ q, beam.phi @ qd
    if not foreshortening:
        zero = np.zeros_like(beam.x)
        return beam.x, Y, zero, Yd, np.zeros_like(beam.phi)
    G = beam.H @ q
    return beam.x - 0.5 * (G @ q), Y, -(G @ qd), Yd, G


def accelerations(beam, q, qd, w, wd, foreshortening=True):
    """qdd (n,) and the hub torque tau [N m] at hub speed w [rad/s] and acceleration wd [rad/s^2].

        [int mu (G G^T + phi phi^T)] qdd = int mu (G a_X0 - phi a_Y0) - K q,
        tau = int mu (X a_Y - Y a_X)
    """
    X, Y, Xd, Yd, G = _field(beam, q, qd, foreshortening)
    qHq = (beam.H @ qd) @ qd if foreshortening else 0.0
    aX0 = -qHq - 2.0 * w * Yd - wd * Y - w * w * X
    aY0 = 2.0 * w * Xd + wd * X - w * w * Y
    mwG = beam.mw[:, None] * G
    M = beam.M0 + G.T @ mwG
    rhs = mwG.T @ aX0 - beam.mwphi.T @ aY0 - beam.K @ q
    qdd = _solve_spd(M, rhs)
    aX = aX0 - G @ qdd
    aY = aY0 + beam.phi @ qdd
    tau = beam.mw @ (X * aY - Y * aX)
    return qdd, tau


def _solve_spd(M, b):
    """M^-1 b for a symmetric positive definite M (LAPACK dposv: numpy's solve costs 10x more)."""
    _, x, info = dposv(M, b)
    if info != 0:
        raise np.linalg.LinAlgError(f"mass matrix not positive definite (dposv info {info})")
    return x


def energy(beam, q, qd, w, foreshortening=True):
    """T + V [J]: T = 1/2 int mu [(Xd - w Y)^2 + (Yd + w X)^2], V = 1/2 q^T K q."""
    X, Y, Xd, Yd, _ = _field(beam, q, qd, foreshortening)
    T = 0.5 * beam.mw @ ((Xd - w * Y) ** 2 + (Yd + w * X) ** 2)
    return T + 0.5 * q @ beam.K @ q


def spinup_reference(Omega_s=6.0, T_s=15.0, t_end=30.0, n=4, t_eval=None, L=10.0, mu=1.2,
                     EI=14000.0, rtol=1e-10, foreshortening=True, blow_up=None):
    """Spin-up benchmark by the Ritz model above, from rest (q = qd = 0 at t = 0).

    Omega_s [rad/s], T_s [s], t_end [s]; n Ritz terms; t_eval (k,) [s] output times
    (default 0.01 s spacing); L [m], mu [kg/m], EI [N m^2]; rtol of DOP853 (atol = rtol).
    ``foreshortening=False`` is the linear beam. The run stops early (status 1) once
    |v(L)| exceeds ``blow_up`` [m] (default 100 L): only a linear beam gets there.

    Returns a dict of arrays over the output times reached, shape (k,):
      t [s]; tip_deflection v(L, t) [m], the transverse tip displacement in the hub frame;
      tip_shortening -u_f(L, t) = 1/2 q^T H(L) q [m] (0 for the linear beam);
      energy T + V [J]; work int tau theta_dot dt [J] of the hub torque; torque tau [N m];
      theta_dot [rad/s]; and q, qd (k, n); plus status (0 finished, 1 blown up).
    """
    if not (T_s > 0 and t_end > 0):
        raise ValueError(f"T_s and t_end must be > 0 [s], got T_s={T_s!r}, t_end={t_end!r}")
    beam = RitzBeam(n, L, mu, EI)
    if t_eval is None:
        t_eval = np.linspace(0.0, t_end, int(round(t_end * 100)) + 1)
    t_eval = np.asarray(t_eval, float)
    blow_up = 100.0 * L if blow_up is None else blow_up
    n = beam.n

    def rhs(t, y):
        _, w, wd = spin_up_profile(t, Omega_s, T_s)
        qdd, tau = accelerations(beam, y[:n], y[n:2 * n], w, wd, foreshortening)
        return np.concatenate((y[n:2 * n], qdd, [tau * w]))

    def escaped(t, y):
        return blow_up - abs(beam.phi_tip @ y[:n])
    escaped.terminal = True

    # Two legs: the profile's fourth derivative jumps at T_s; no step straddles it.
    y, ts, ys, status = np.zeros(2 * n + 1), [], [], 0
    for t0, t1 in ((0.0, min(T_s, t_end)), (T_s, t_end)):
        if t1 <= t0:
            continue
        wanted = t_eval[(t_eval >= t0) & (t_eval <= t1) & ((t_eval > t0) | (t0 == 0.0))]
        # atol = rtol: q, qd are O(1) (sqrt(kg) m, M0 = I: |q|^2 = int mu v^2 ~ 12 kg * v^2).
        sol = solve_ivp(rhs, (t0, t1), y, method="DOP853", rtol=rtol, atol=rtol,
                        t_eval=np.union1d(wanted, [t1]), events=escaped)
        keep = np.isin(sol.t, wanted)
        ts.append(sol.t[keep])
        ys.append(sol.y[:, keep])
        if sol.status == 1:
            status = 1
            break
        y = sol.y[:, -1]
    return _collect(beam, np.concatenate(ts), np.concatenate(ys, axis=1), Omega_s, T_s,
                    foreshortening, status)


def _collect(beam, t, y, Omega_s, T_s, foreshortening, status):
    """The output dict of ``spinup_reference`` from the states y (2n+1, k) at times t (k,)."""
    n = beam.n
    q, qd, work = y[:n].T, y[n:2 * n].T, y[2 * n]
    w = np.array([spin_up_profile(ti, Omega_s, T_s)[1] for ti in t])
    wd = np.array([spin_up_profile(ti, Omega_s, T_s)[2] for ti in t])
    E = np.array([energy(beam, a, b, c, foreshortening) for a, b, c in zip(q, qd, w)])
    tau = np.array([accelerations(beam, a, b, c, d, foreshortening)[1]
                    for a, b, c, d in zip(q, qd, w, wd)])
    shortening = 0.5 * np.einsum("ik,kl,il->i", q, beam.H_tip, q) if foreshortening \
        else np.zeros_like(t)
    return {"t": t, "tip_deflection": q @ beam.phi_tip, "tip_shortening": shortening,
            "energy": E, "work": work, "torque": tau, "theta_dot": w, "q": q, "qd": qd,
            "status": status}


def spinup_summary(result, T_s=15.0):
    """The benchmark's two numbers from a ``spinup_reference`` result [m].

    peak: max |v(L)| for t <= T_s (during the spin-up); after: max |v(L)| for t > T_s
    (the residual vibration about the straight steady state, whose v(L) = 0);
    shortening: max -u_f(L).
    """
    t, v = result["t"], result["tip_deflection"]
    return {"peak": float(np.max(np.abs(v[t <= T_s]))),
            "after": float(np.max(np.abs(v[t > T_s]), initial=0.0)),
            "shortening": float(np.max(result["tip_shortening"]))}
