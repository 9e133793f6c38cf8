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


def hermite_local(eta, h, orders: int) -> np.ndarray:
    """(orders, 4, K): the element's Hermite cubics H1, h H2, H3, h H4 at eta = (x - x_(e-1)) / h (K,) and
    their x-derivatives of order 0 .. orders - 1 (orders <= 4); h [m] a float or (K,).

    H1 = 1 - 3 eta^2 + 2 eta^3,  H2 = eta - 2 eta^2 + eta^3,  H3 = 3 eta^2 - 2 eta^3,  H4 = eta^3 - eta^2,
    d/dx = (1/h) d/deta. The one Hermite basis of the package's Python code (the kernel's compiled
    twin is kernel._hermite_at, checked against it in tests/kernel).
    """
    if not 1 <= orders <= 4:
        raise ValueError(f"orders={orders!r} must be 1 .. 4 (derivatives 0 .. 3)")
    e = np.asarray(eta, dtype=float)
    e2 = e * e
    e3 = e2 * e
    out = np.empty((orders, 4, e.size))
    out[0] = (1 - 3 * e2 + 2 * e3, h * (e - 2 * e2 + e3), 3 * e2 - 2 * e3, h * (e3 - e2))
    if orders > 1:
        out[1] = ((-6 * e + 6 * e2) / h, 1 - 4 * e + 3 * e2, (6 * e - 6 * e2) / h, -2 * e + 3 * e2)
    if orders > 2:
        h2 = h * h
        out[2] = ((-6 + 12 * e) / h2, (-4 + 6 * e) / h, (6 - 12 * e) / h2, (-2 + 6 * e) / h)
    if orders > 3:
        h3 = h * h * h
        out[3] = (12 / h3 + 0 * e, 6 / (h * h) + 0 * e, -12 / h3 + 0 * e, 6 / (h * h) + 0 * e)
    return out


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
    if derivative not in (0, 1, 2, 3):
        raise ValueError("derivative must be 0..3")
    loc = hermite_local(eta, h, derivative + 1)[derivative]  # (4, K): dofs (w_(e-1), t_(e-1), w_e, t_e)
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
