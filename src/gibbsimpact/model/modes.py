"""Assumed-mode shape functions of Euler-Bernoulli beams.

Symbols (docs/theory.md §3): ``x`` abscissa along the link [m], ``l``
link length [m], ``beta`` wavenumber [1/m], ``psi(x)`` mode shape
(dimensionless, normalised so that ``max |psi| = 1`` on ``[0, l]`` and
positive where that maximum is reached (where it is reached at several places,
as in antisymmetric modes, at the one with the smallest x), so a modal coordinate ``delta`` is a
peak deflection in metres).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import brentq

#: Boundary conditions that have closed-form eigenfunctions here.
MODE_KINDS = ("clamped-clamped", "clamped-free", "pinned-pinned")
#: Deflection directions of a mode in the link frame: bending along y (v) or z (w).
MODE_DIRECTIONS = ("y", "z")


@dataclass(frozen=True)
class Mode:
    """One assumed mode of a link.

    Parameters
    ----------
    kind : str
        Boundary conditions of the link frame: ``"clamped-clamped"``,
        ``"clamped-free"`` or ``"pinned-pinned"``.
    direction : str
        ``"y"``: bending deflection ``v`` along the link's y axis (in the plane
        of a planar chain, stiffness ``EI_z``); ``"z"``: deflection ``w`` along
        z (stiffness ``EI_y``).
    number : int
        Which eigenfunction, 1 for the fundamental.
    """

    kind: str
    direction: str = "y"
    number: int = 1

    def __post_init__(self):
        if self.kind not in MODE_KINDS:
            raise ValueError(
                f"Mode kind={self.kind!r} is unknown; use one of {', '.join(MODE_KINDS)}"
            )
        if self.direction not in MODE_DIRECTIONS:
            raise ValueError(
                f"Mode direction={self.direction!r} is unknown; use 'y' (in-plane bending v) "
                "or 'z' (out-of-plane bending w)"
            )
        if isinstance(self.number, bool) or not isinstance(self.number, (int, np.integer)) or self.number < 1:
            raise ValueError(f"Mode number={self.number!r} must be an integer >= 1 (1 = fundamental)")

    @property
    def beta_l(self) -> float:
        """Dimensionless root ``beta*l`` of the frequency equation."""
        return frequency_root(self.kind, int(self.number))


def _characteristic(kind: str):
    # Frequency equations divided by cosh(z) so that they stay O(1):
    #   clamped-clamped: cos z cosh z = 1   ->  cos z - 1/cosh z = 0
    #   clamped-free:    cos z cosh z = -1  ->  cos z + 1/cosh z = 0
    if kind == "clamped-clamped":
        return lambda z: np.cos(z) - 1.0 / np.cosh(z)
    if kind == "clamped-free":
        return lambda z: np.cos(z) + 1.0 / np.cosh(z)
    raise ValueError(kind)


@lru_cache(maxsize=None)
def frequency_root(kind: str, number: int) -> float:
    """k-th positive root ``beta_k l`` of the frequency equation of ``kind``.

    clamped-clamped: 4.730040744862704, 7.853204624095838, ...;
    clamped-free: 1.875104068711961, 4.694091132974175, ...;
    pinned-pinned: k*pi.
    """
    if kind == "pinned-pinned":
        return number * np.pi
    f = _characteristic(kind)
    # Roots are separated by ~pi; a grid of pi/64 brackets each one once.
    z = np.arange(0.5, (number + 2) * np.pi, np.pi / 64)
    fz = f(z)
    idx = np.nonzero(np.sign(fz[:-1]) * np.sign(fz[1:]) < 0)[0]
    return float(brentq(f, z[idx[number - 1]], z[idx[number - 1] + 1], xtol=1e-15, rtol=1e-15))


def _sigma_terms(kind: str, z: float) -> tuple[float, float, float]:
    """Return (sigma, 1 - sigma, 1 + sigma) for root z without cancellation."""
    sh, ch, s, c = np.sinh(z), np.cosh(z), np.sin(z), np.cos(z)
    em = np.exp(-z)
    if kind == "clamped-clamped":
        # sigma = (cosh z - cos z)/(sinh z - sin z); cosh - sinh = e^-z
        den = sh - s
        sigma = (ch - c) / den
        one_minus = (-em - s + c) / den
    else:  # clamped-free
        den = sh + s
        sigma = (ch + c) / den
        one_minus = (-em + s - c) / den
    return sigma, one_minus, 1.0 + sigma


def _raw_shape(kind: str, beta: float, z_l: float, x: np.ndarray, derivative: int) -> np.ndarray:
    """Unnormalised eigenfunction phi(x) and its derivatives.

    phi = cosh bx - cos bx - sigma (sinh bx - sin bx)
        = (1-sigma)/2 e^{bx} + (1+sigma)/2 e^{-bx} - cos bx + sigma sin bx
    The exponential form keeps the hyperbolic part from cancelling for large bx.
    """
    x = np.asarray(x, dtype=float)
    if kind == "pinned-pinned":
        bx = beta * x
        return [np.sin(bx), beta * np.cos(bx), -beta**2 * np.sin(bx), -beta**3 * np.cos(bx)][derivative]
    sigma, one_minus, one_plus = _sigma_terms(kind, z_l)
    bx = beta * x
    # e^{bx} (1-sigma)/2: (1-sigma) ~ e^{-z_l}, so evaluate as exp(bx + log) when tiny.
    ep = 0.5 * one_minus * np.exp(bx)
    em = 0.5 * one_plus * np.exp(-bx)
    c, s = np.cos(bx), np.sin(bx)
    if derivative == 0:
        return ep + em - c + sigma * s
    if derivative == 1:
        return beta * (ep - em + s + sigma * c)
    if derivative == 2:
        return beta**2 * (ep + em + c - sigma * s)
    if derivative == 3:
        return beta**3 * (ep - em - s - sigma * c)
    raise ValueError("derivative must be 0..3")


@lru_cache(maxsize=None)
def _normalisation(kind: str, number: int, length: float) -> float:
    """Constant C so that C*phi has max |.| = 1 on [0, l], positive at the max."""
    z = frequency_root(kind, number)
    beta = z / length
    x = np.linspace(0.0, length, 4001)
    d1 = _raw_shape(kind, beta, z, x, 1)
    candidates = [0.0, length]
    idx = np.nonzero(np.sign(d1[:-1]) * np.sign(d1[1:]) < 0)[0]
    for i in idx:
        candidates.append(
            brentq(lambda t: float(_raw_shape(kind, beta, z, t, 1)), x[i], x[i + 1], xtol=1e-15 * length)
        )
    candidates += list(x[np.nonzero(d1 == 0.0)[0]])
    xs = np.array(candidates)
    vals = _raw_shape(kind, beta, z, xs, 0)
    # Antisymmetric modes reach max |psi| at two places with opposite signs:
    # the sign is fixed at the one nearest the proximal end (smallest x).
    top = np.abs(vals) >= (1.0 - 1e-9) * np.abs(vals).max()
    k = int(np.flatnonzero(top)[np.argmin(xs[top])])
    return 1.0 / float(vals[k])


def shape(mode: Mode, length: float, x, derivative: int = 0) -> np.ndarray:
    """Normalised mode shape ``psi(x)`` or its ``derivative``-th x-derivative.

    Parameters
    ----------
    mode : Mode
    length : float
        Link length l [m].
    x : array_like, shape (K,)
        Abscissae in [0, l] [m].
    derivative : int
        0 gives psi [-], 1 psi' [1/m], 2 psi'' [1/m^2], 3 psi''' [1/m^3].

    Returns
    -------
    ndarray, shape (K,)
    """
    z = frequency_root(mode.kind, int(mode.number))
    beta = z / length
    c = _normalisation(mode.kind, int(mode.number), float(length))
    return c * _raw_shape(mode.kind, beta, z, x, derivative)


def natural_frequency(mode: Mode, length: float, mass_per_length: float, EI: float) -> float:
    """Closed-form circular frequency of a uniform beam, rad/s.

    omega_k = (beta_k l)^2 sqrt(EI / (mu l^4))
    """
    return mode.beta_l**2 * np.sqrt(EI / (mass_per_length * length**4))
