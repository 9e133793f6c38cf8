"""Hermite cubic finite elements of a link (docs/theory.md §4).

A link of length l [m] is cut into n_e elements of length h = l / n_e with
nodes x_j = j h. Node 0 is clamped to the link frame (v(0) = v'(0) = 0) and
removed, so the elastic coordinates are, per bending direction,

    delta = (w_1, t_1, ..., w_ne, t_ne),   w_j = v(x_j) [m],  t_j = v'(x_j) [rad].

On element e, eta = (x - x_(e-1)) / h in [0, 1]:

    v(x) = H1(eta) w_(e-1) + h H2(eta) t_(e-1) + H3(eta) w_e + h H4(eta) t_e
    H1 = 1 - 3 eta^2 + 2 eta^3,  H2 = eta - 2 eta^2 + eta^3,
    H3 = 3 eta^2 - 2 eta^3,      H4 = -eta^2 + eta^3

so v = sum_k psi_k(x) delta_k with the global basis psi_(2j-1) (H3 on element
j, H1 on element j+1) and psi_(2j) (h H4 on element j, h H2 on element j+1).
Behind a revolute joint these psi_k are assumed modes like any other
(section 9.4): the kernel sees them only through the link's moment matrices.
"""

from __future__ import annotations

import numpy as np

#: Largest number of elements per link accepted (beyond it the explicit
#: integrators' step, ~ 1/omega_max ~ h^2, becomes impractically small).
MAX_ELEMENTS = 200


def _hermite_local(eta: np.ndarray, h: float, derivative: int) -> np.ndarray:
    """(4, K): H1, h H2, H3, h H4 at eta (K,) or their x-derivatives (order 0..3)."""
    e = np.asarray(eta, dtype=float)
    one = np.ones_like(e)
    if derivative == 0:
        H = [1 - 3 * e**2 + 2 * e**3, e - 2 * e**2 + e**3, 3 * e**2 - 2 * e**3, -(e**2) + e**3]
    elif derivative == 1:
        H = [-6 * e + 6 * e**2, 1 - 4 * e + 3 * e**2, 6 * e - 6 * e**2, -2 * e + 3 * e**2]
    elif derivative == 2:
        H = [-6 + 12 * e, -4 + 6 * e, 6 - 12 * e, -2 + 6 * e]
    elif derivative == 3:
        H = [12 * one, 6 * one, -12 * one, 6 * one]
    else:
        raise ValueError("derivative must be 0..3")
    scale = h ** (-derivative)  # d/dx = (1/h) d/deta
    return np.array([H[0] * scale, h * H[1] * scale, H[2] * scale, h * H[3] * scale])


def hermite_shape(n_elements: int, length: float, x, derivative: int = 0) -> np.ndarray:
    """Global Hermite basis psi_k(x) (clamped at x = 0) or its x-derivative.

    Parameters
    ----------
    n_elements : int, n_e >= 1
    length : float, l [m]
    x : array_like (K,), abscissae in [0, l] [m]
    derivative : int, 0 .. 3

    Returns
    -------
    (2 n_e, K): rows psi_1 ... psi_(2 n_e); units m^(a_k - derivative) with
    a_k = 0 for a deflection function (odd k), 1 for a slope function (even k).
    At a node the value of the element to its left is used (the right one for x = 0).
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    h = length / n_elements
    e = np.clip(np.ceil(x / h).astype(int), 1, n_elements)  # element of each x, 1-based
    eta = (x - (e - 1) * h) / h
    loc = _hermite_local(eta, h, derivative)  # (4, K) for dofs (w_(e-1), t_(e-1), w_e, t_e)
    out = np.zeros((2 * n_elements, x.size))
    cols = np.arange(x.size)
    # Dofs of node e-1 (absent for e = 1: the clamped node) and of node e.
    left = e >= 2
    out[2 * (e[left] - 2), cols[left]] = loc[0, left]
    out[2 * (e[left] - 2) + 1, cols[left]] = loc[1, left]
    out[2 * (e - 1), cols] = loc[2]
    out[2 * (e - 1) + 1, cols] = loc[3]
    return out


def element_mass(mu: float, h: float) -> np.ndarray:
    """Consistent element mass matrix (4, 4) [kg, kg m, kg m^2] (the paper's eq. (13))."""
    return mu * h / 420.0 * np.array([
        [156.0, 22 * h, 54.0, -13 * h],
        [22 * h, 4 * h * h, 13 * h, -3 * h * h],
        [54.0, 13 * h, 156.0, -22 * h],
        [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
    ])


def element_stiffness(EI: float, h: float) -> np.ndarray:
    """Element bending stiffness matrix (4, 4) [N/m, N, N m] (the paper's eq. (27))."""
    return EI / h**3 * np.array([
        [12.0, 6 * h, -12.0, 6 * h],
        [6 * h, 4 * h * h, -6 * h, 2 * h * h],
        [-12.0, -6 * h, 12.0, -6 * h],
        [6 * h, 2 * h * h, -6 * h, 4 * h * h],
    ])


def assemble(element_matrix: np.ndarray, n_elements: int) -> np.ndarray:
    """Assemble equal (4, 4) element matrices over n_e elements, clamped node 0 removed: (2 n_e, 2 n_e)."""
    n = 2 * (n_elements + 1)
    A = np.zeros((n, n))
    for e in range(n_elements):
        s = slice(2 * e, 2 * e + 4)
        A[s, s] += element_matrix
    return A[2:, 2:]


def element_quadrature(n_elements: int) -> tuple[int, int]:
    """(panels, points) of a Gauss-Legendre rule whose panel edges include the element nodes.

    Every element gets max(1, 16 // n_e) panels of 8 points: exact for the
    polynomial integrands of a uniform link (degree <= 7 per element), and a
    converging approximation for mu(x), EI(x) given as callables.
    """
    return n_elements * max(1, 16 // n_elements), 8
