"""Frequencies of a uniform clamped-free beam spinning about its root (formulation.md §15).

Independent of ``gibbsimpact`` and of the Ritz model in ``spinup_reference`` (numpy and
scipy only): the linearised field equation is solved by shooting, with no assumed shape.

Non-dimensional form (xi = x/l, lambda = Omega sqrt(mu l^4/EI), omega_bar = omega sqrt(mu l^4/EI)),
for a beam of length l clamped at the spin axis, axial force N(x) = int_x^l mu Omega^2 xi dxi:

    flapwise (w, out of the plane of rotation):
        w'''' - (n(xi) w')' = omega_bar^2 w,                 n(xi) = lambda^2 (1 - xi^2)/2
    in-plane (v, in the plane of rotation; the centrifugal force also pulls v outward):
        v'''' - (n(xi) v')' - lambda^2 v = omega_bar^2 v
    clamped root: w(0) = w'(0) = 0;  free tip: w''(1) = 0, w'''(1) - n(1) w'(1) = w'''(1) = 0.

Shooting: the two solutions started at xi = 0 with (w, w', w'', w''') = (0, 0, 1, 0) and
(0, 0, 0, 1) are integrated to xi = 1 (DOP853, rtol 1e-13); omega_bar is an eigenvalue
where the 2x2 determinant of their (w'', w''') at the tip vanishes. Roots are bracketed
on a grid of omega_bar and refined by Brent's method to 1e-12.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

__all__ = ["tip_determinant", "rotating_beam_frequencies"]


def tip_determinant(omega_bar, lam, in_plane=False):
    """det [[w''_a(1), w''_b(1)], [w'''_a(1), w'''_b(1)]] of the two root-started solutions.

    omega_bar: non-dimensional frequency, float or array (k,) (one integration for all);
    lam: spin rate (float). Zero exactly at the eigenfrequencies of the flapwise
    (in_plane=False) or in-plane problem above. Returns a float or an array (k,).
    """
    omega_bar = np.asarray(omega_bar, float)
    s = (omega_bar * omega_bar + (lam * lam if in_plane else 0.0)).reshape(-1)
    k = s.size

    def rhs(xi, y):
        # y = (w, w', w'', w''') x (shot a, shot b) x k;  w'''' = n' w' + n w'' + s w.
        n = 0.5 * lam * lam * (1.0 - xi * xi)
        dn = -lam * lam * xi
        w, w1, w2, w3 = y.reshape(4, 2, k)
        return np.concatenate((w1, w2, w3, dn * w1 + n * w2 + s * w)).reshape(-1)

    y0 = np.zeros((4, 2, k))
    y0[2, 0], y0[3, 1] = 1.0, 1.0
    y1 = solve_ivp(rhs, (0.0, 1.0), y0.reshape(-1), method="DOP853", rtol=1e-13,
                   atol=1e-14).y[:, -1].reshape(4, 2, k)
    det = y1[2, 0] * y1[3, 1] - y1[2, 1] * y1[3, 0]
    return det.reshape(omega_bar.shape)


def rotating_beam_frequencies(lam, count=2, in_plane=False, omega_max=80.0, step=0.25):
    """The lowest ``count`` non-dimensional frequencies omega_bar at spin rate ``lam``.

    Multiply by sqrt(EI/(mu l^4)) for rad/s. In-plane modes below lam = omega_bar_flap,1
    (i.e. omega_bar^2 <= 0 with no centrifugal stiffening) are not returned: only real
    omega_bar > 0 are searched, on (0, omega_max] with grid spacing ``step``.
    Returns an array (count,); raises ValueError if fewer roots lie below omega_max.
    """
    grid = np.arange(step, omega_max + step / 2, step)
    det = tip_determinant(grid, lam, in_plane)
    roots = []
    for a, b, fa, fb in zip(grid[:-1], grid[1:], det[:-1], det[1:]):
        if fa == 0.0 or fa * fb < 0.0:
            roots.append(brentq(lambda x: float(tip_determinant(x, lam, in_plane)), a, b,
                                xtol=1e-12, rtol=1e-14))
        if len(roots) == count:
            return np.array(roots)
    raise ValueError(f"only {len(roots)} frequencies below omega_max={omega_max}; raise omega_max")
