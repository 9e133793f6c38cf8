"""The linearised free motion of a chain and the stability and accuracy radii of the explicit methods.

The equations and the numbers are those of gibbsimpact.simulation.cost's docstring (Linearised free
motion, Stability, Accuracy), which estimates a run's cost from them; method="auto"
(gibbsimpact.simulation.auto) reads the same radii to choose between explicit and implicit methods.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from scipy.integrate import DOP853, RK23, RK45

from ..dynamics.forces import damping_matrix
from ..dynamics.gibbs_appell import mass_matrix, potential_forces

#: The explicit methods whose steps are estimated: (scipy class, new right-hand sides per step
#: (FSAL: the last stage is the next step's first), extra right-hand sides of a dense output).
EXPLICIT = {"DOP853": (DOP853, 12, 3), "RK45": (RK45, 6, 0), "RK23": (RK23, 3, 0)}
_R_MAX = 20.0  # beyond every radius of these methods [|z|]


def _tableau(method: str):
    """(A (s+1, s+1), b (s,)) of an explicit method: the s stages and the FSAL stage f(t + h, y_new)."""
    cls = EXPLICIT[method][0]
    s = cls.n_stages
    A0 = np.asarray(cls.A, dtype=float)
    A = np.zeros((s + 1, s + 1))
    A[:s, :min(A0.shape[1], s)] = A0[:s, :s]
    A[s, :s] = cls.B
    return A, np.asarray(cls.B, dtype=float)


def _stages(method: str, z: complex) -> np.ndarray:
    """h K_j / y (s+1,) of every stage for y' = lambda y, z = h lambda: hK = z (I - z A)^-1 1."""
    A, _ = _tableau(method)
    return z * np.linalg.solve(np.eye(len(A)) - z * A, np.ones(len(A)))


def stability_function(method: str, z: complex) -> complex:
    """R(z) = y_1 / y_0 of one step of ``method`` on y' = lambda y, z = h lambda."""
    _, b = _tableau(method)
    return complex(1.0 + b @ _stages(method, z)[:len(b)])


def error_estimate(method: str, z: complex) -> float:
    """|error estimate| / |y| of one step on y' = lambda y, as scipy's controller computes it for one component."""
    hK = _stages(method, z)
    cls = EXPLICIT[method][0]
    if method == "DOP853":
        e5, e3 = abs(hK @ cls.E5), abs(hK @ cls.E3)
        return 0.0 if e5 == 0.0 else e5 * e5 / math.sqrt(e5 * e5 + 0.01 * e3 * e3)
    return float(abs(hK @ cls.E))


def _first_radius(f, phi: float, level: float) -> float:
    """The smallest r > 0 with f(r e^{i phi}) > level (scan of 400 points, then bisection), or _R_MAX."""
    d = complex(math.cos(phi), math.sin(phi))
    rs = np.linspace(_R_MAX / 400, _R_MAX, 400)
    above = [f(r * d) > level for r in rs]
    if not any(above):
        return _R_MAX
    k = above.index(True)
    lo, hi = (rs[k - 1] if k else 0.0), rs[k]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if f(mid * d) > level else (mid, hi)
    return lo


def stability_radius(method: str, phi: float) -> float:
    """r(phi) [|z|]: the step h lambda of ``method`` along the ray of angle phi [rad] stays stable up to r.

    |R| <= 1 + 1e-9 counts as stable (RK45's imaginary axis: |R(iy)| - 1 < 5e-10 up to y = 0.997).
    """
    return _first_radius(lambda z: abs(stability_function(method, z)), phi, 1.0 + 1e-9)


def accuracy_radius(method: str, phi: float, tol: float) -> float:
    """The largest |h lambda| along the ray of angle phi [rad] whose error estimate stays below tol (relative)."""
    return _first_radius(lambda z: error_estimate(method, z), phi, tol)


def stiffness_matrix(model, q0: np.ndarray) -> np.ndarray:
    """K = d(dV/dq)/dq (N, N) [N/m, N, N m by block] at q0 (N,) [m, rad]: the Hessian of the potential (strain and
    gravity), by central differences of dV/dq with steps 1e-6 max(1, |q_k|), symmetrised (V is quadratic in the
    elastic coordinates, so these columns are exact to round-off)."""
    N = model.n_dof
    q0 = np.asarray(q0, dtype=float)
    K = np.empty((N, N))
    for k in range(N):
        dq = np.zeros(N)
        dq[k] = 1e-6 * max(1.0, abs(q0[k]))
        K[:, k] = (potential_forces(model, q0 + dq) - potential_forces(model, q0 - dq)) / (2.0 * dq[k])
    return 0.5 * (K + K.T)


def linearised_eigenvalues(model, q0: np.ndarray) -> np.ndarray:
    """Eigenvalues lambda (2N,) [1/s] of A = [[0, I], [-M^-1 K, -M^-1 C]] at q0 (N,) [m, rad] (module docstring;
    K: stiffness_matrix)."""
    N = model.n_dof
    q0 = np.asarray(q0, dtype=float)
    M = mass_matrix(model, q0)
    A = np.zeros((2 * N, 2 * N))
    A[:N, N:] = np.eye(N)
    A[N:, :N] = -np.linalg.solve(M, stiffness_matrix(model, q0))
    A[N:, N:] = -np.linalg.solve(M, damping_matrix(model, q0))
    return np.linalg.eigvals(A)


def free_vibration_frequencies(model, q0: np.ndarray) -> np.ndarray:
    """The undamped frequencies omega (N,) [rad/s], ascending, of the chain linearised at q0 (N,) [m, rad]:
    K phi = omega^2 M phi, omega = sqrt(|omega^2|) (a negative omega^2, a position where gravity topples the
    chain, counts by its magnitude; a rigid motion's omega is 0 to round-off). These are the modes of
    d qddot/d q = -M^-1 K that the compiled Radau's filter sorts against a cutoff frequency
    (compiled_radau.slow_projector: |mu| > cutoff^2)."""
    q0 = np.asarray(q0, dtype=float)
    w2 = scipy.linalg.eigh(stiffness_matrix(model, q0), mass_matrix(model, q0), eigvals_only=True)
    return np.sort(np.sqrt(np.abs(w2)))
