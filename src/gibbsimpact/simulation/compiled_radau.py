"""The compiled Radau IIA solver: scipy's OdeSolver interface over one compiled call a step.

solve_ivp's machinery (here gibbsimpact.simulation.flight: event location on the dense output, the
loop, the samples) drives any ``scipy.integrate.OdeSolver``; :class:`CompiledRadau` is one whose
``_step_impl`` is one call of ``kernel.radau.radau_step`` (three-stage Radau IIA, order 5, simplified
Newton with the real and complex transformed systems, the embedded error estimate and
Hairer-Wanner's step control; kernel/radau.py), with the right-hand side of the flight phase compiled
into it. Python is left with what happens once every several steps: df/dy when Newton contracts
slowly (the kernel's Jacobian, gibbsimpact.simulation.implicit.rhs_jacobian) and the dense output
(the collocation polynomial, evaluated with numpy).

Which phases get it (:func:`flight_program`): a flight phase of the plain equations (no resting pair,
no held end stop), without prescribed coordinates or compliant walls, whose damping matrix is
constant (no damped link behind a FixedPrismatic guide) and whose inputs are the closed-form ones of
a case file (constant, sine, ramp, pd on its own coordinate: gibbsimpact.dynamics.inputs) or
constants. Every other phase of a run with method="Radau" runs scipy's Radau with the kernel's
Jacobian; so does every phase when the user's inputs are Python callables (with a cutoff, with this
stepper's error weights: gibbsimpact.simulation.cutoff_radau).

Stepping over fast modes (docs/theory.md §14.1): with a cutoff frequency (simulate's cutoff_frequency, or
method="auto" at a gap in the chain's spectrum) the modes of d qddot/d q above it leave the error estimate
(:func:`slow_projector`), velocity errors count min(1, h VELOCITY_RATE) of position errors (RADAU5's
scaling of index-2 variables, in the error norm and in Newton's) and the estimate is held to RADAU5's
tolerances (:func:`radau5_tolerances`): the L-stable steps then pass over those modes and damp them.
"""

from __future__ import annotations

from numbers import Real

import numpy as np
import scipy.linalg
from scipy.integrate import DenseOutput, OdeSolver

from ..kernel import radau_entry
from ..kernel import radau as rk

_EPS = np.finfo(float).eps
#: [1/s] With the fast modes stepped over, a velocity error counts min(1, h VELOCITY_RATE) of a position error
#: (kernel.radau._velocity_weight): RADAU5's h-scaling of index-2 variables, h taken in seconds.
VELOCITY_RATE = 1.0


class FlightProgram:
    """The compiled flight equations of one run: the kernel's packed model, the input rows fin (m, 6), the
    damping C (N, N), the run's Equations (for df/dy, the counters and the limits), and the cutoff frequency
    [rad/s] of the error estimate (None: every mode followed)."""

    def __init__(self, equations, fin: np.ndarray, C: np.ndarray, cutoff: float | None = None):
        model = equations.model
        _, self.fdat, self.idat, _, v0, v1, _ = model.kernel_call
        self.variant = (v0, v1)
        self.entry = radau_entry(self.variant)
        self.fin, self.C = np.array(fin, dtype=float), np.array(C, dtype=float)  # writable copies (the signature)
        self.A = np.zeros((0, 0))
        self.equations, self.cutoff = equations, cutoff
        # with a cutoff, the fast modes are stepped over (module docstring): velocity weighting on q (N,)
        self.n_pos = 0 if cutoff is None else equations.N

    def jacobian(self, t: float, y: np.ndarray) -> np.ndarray:
        """df/dy (n, n) at (t, y) (gibbsimpact.simulation.implicit.rhs_jacobian)."""
        return self.equations.jacobian(t, y)

    def count(self, nfev: int, t: float) -> None:
        """Add nfev compiled right-hand sides to the run's counter; tick the progress clock; check the
        limits (raises BudgetExceeded once one is used up)."""
        eq = self.equations
        eq.nfev += nfev
        eq.clock.tick(t)
        if eq.nfev >= eq.check_at:
            eq.check_at = eq.budget.check(eq.nfev, t)


class LinearProgram:
    """y' = A y (A (n, n) [1/s]) through the same compiled stepper (the tests' closed forms); the packed
    model ``model`` only sizes the unused chain work arrays."""

    def __init__(self, A: np.ndarray, model):
        _, self.fdat, self.idat, _, v0, v1, _ = model.kernel_call
        self.variant = (v0, v1)
        self.entry = radau_entry(self.variant)
        self.A = np.ascontiguousarray(A, dtype=float)
        self.fin, self.C = np.zeros((0, 6)), np.zeros((int(self.idat[1]), int(self.idat[1])))
        self.nfev, self.cutoff, self.n_pos = 0, None, 0

    def jacobian(self, t, y):
        return self.A

    def count(self, nfev, t):
        self.nfev += nfev


class CompiledRadau(OdeSolver):
    """Radau IIA of order 5 with each step one compiled call (module docstring); forward in time only.

    fun(t, y) -> (n,): the right-hand side in Python (its first value and the first step's choice only);
    program: a FlightProgram or LinearProgram, the same equations compiled; rtol, atol, max_step,
    first_step: solve_ivp's meanings (atol a float or an (n,) array).
    """

    def __init__(self, fun, t0, y0, t_bound, *, program, rtol=1e-3, atol=1e-6, max_step=np.inf, first_step=None,
                 **extraneous):
        super().__init__(fun, t0, y0, t_bound, vectorized=False)
        if self.direction < 0:
            raise ValueError("CompiledRadau integrates forward in time only: give t_bound > t0")
        n, self.program = self.n, program
        self.max_step = float(max_step)
        rtol = max(float(rtol), 100.0 * _EPS)  # as scipy: below that round-off dominates
        atol = np.asarray(atol, dtype=float)
        if program.n_pos:
            rtol, atol = radau5_tolerances(rtol, atol)
        self.atol = np.array(np.broadcast_to(atol, (n,)))  # writable (the signature)
        self.f = self.fun(self.t, self.y)
        h0 = first_step if first_step is not None else _first_step(self.fun, self.t, self.y, self.f, t_bound,
                                                                    self.max_step, rtol, self.atol)
        st = self.st = np.zeros(rk.SLOTS)
        st[rk.T], st[rk.T_BOUND], st[rk.H], st[rk.H_OLD], st[rk.ERR_OLD] = t0, t_bound, h0, -1.0, -1.0
        st[rk.MAX_STEP], st[rk.RTOL] = self.max_step, rtol
        st[rk.N_POS], st[rk.VEL_RATE] = program.n_pos, VELOCITY_RATE
        st[rk.NEWTON_TOL] = max(10.0 * _EPS / rtol, min(0.03, rtol ** 0.5))
        self.J = np.ascontiguousarray(program.jacobian(t0, self.y), dtype=float)
        st[rk.JAC_CURRENT] = 1.0
        self.njev = 1
        self.Pf = slow_projector(self.J, program.cutoff, program.n_pos or None)
        self.LUr, self.LUc = np.zeros((n, n)), np.zeros((n, n), dtype=complex)
        self.pr, self.pc = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
        self.Z, self.Qd = np.zeros((3, n)), np.zeros((n, 3))
        self.y_new, self.f_new = np.zeros(n), np.zeros(n)
        self.y_old = None
        #: With a cutoff qddot holds the damped fast modes: the event check samples the dense output (flight.py).
        self.steps_over_fast_modes = bool(program.n_pos)

    def _step_impl(self):
        p, st = self.program, self.st
        y = np.ascontiguousarray(self.y, dtype=float)
        f = np.ascontiguousarray(self.f, dtype=float)
        while True:
            code = p.entry(p.fdat, p.idat, p.fin, p.C, p.A, self.atol, self.Pf, y, f, self.J, self.LUr, self.pr,
                           self.LUc, self.pc, self.Z, self.Qd, self.y_new, self.f_new, st, *p.variant)
            p.count(int(st[rk.NFEV]), float(st[rk.T]))
            self.nfev += int(st[rk.NFEV])
            st[rk.NFEV] = 0.0
            if code != rk.NEED_JACOBIAN:
                break
            self._new_jacobian(float(st[rk.T]), y)
        if code == rk.STEP_TOO_SMALL:
            return False, self.TOO_SMALL_STEP
        if code != rk.ACCEPTED:  # pragma: no cover - the arrays are sized above
            raise RuntimeError(f"radau_step refused its arguments (code {code})")
        self.y_old, self.y, self.f = y, self.y_new.copy(), self.f_new.copy()
        self.t = float(st[rk.T])
        self.nlu = int(st[rk.N_LU])
        if st[rk.RECOMPUTE]:
            self._new_jacobian(self.t, self.y)
        return True, None

    def _new_jacobian(self, t, y):
        """df/dy at (t, y) into J; the LU factors are then stale."""
        self.J[:] = self.program.jacobian(t, y)
        self.njev += 1
        self.Pf = slow_projector(self.J, self.program.cutoff, self.program.n_pos or None)
        self.st[rk.JAC_CURRENT], self.st[rk.LU_OK] = 1.0, 0.0

    def _dense_output_impl(self):
        return RadauPolynomial(float(self.st[rk.T_OLD]), self.t, self.y_old, self.Qd.copy())


class RadauPolynomial(DenseOutput):
    """The collocation polynomial of the last step: y(t) = y_old + Q (x, x^2, x^3), x = (t - t_old) / h;
    y_old (n,), Q (n, 3)."""

    def __init__(self, t_old, t, y_old, Q):
        super().__init__(t_old, t)
        self.h, self.y_old, self.Q = t - t_old, y_old, Q

    def _call_impl(self, t):
        x = (np.asarray(t, dtype=float) - self.t_old) / self.h
        if x.ndim == 0:
            return self.y_old + self.Q @ np.array((x, x * x, x * x * x))
        return self.y_old[:, None] + self.Q @ x[None, :] ** _POWERS


_POWERS = np.arange(1.0, 4.0)[:, None]  # (3, 1): x, x^2, x^3 of the dense output


def radau5_tolerances(rtol: float, atol):
    """(rtol', atol') that the error estimate is held to when the fast modes are stepped over: rtol' =
    0.1 rtol^(2/3), atol' = atol rtol' / rtol (atol a float or (n,) array, in y's units), as Hairer and
    Wanner's RADAU5 does for every run. Its estimate is of order 3 (local error ~ h^4) for a method of order 5
    (~ h^6): held to rtol' the local error of the slow motion is about rtol's, where held to rtol itself the
    steps are as short as an order-3 method's (docs/theory.md §14.1, measured there)."""
    rtol_new = 0.1 * rtol ** (2.0 / 3.0)
    return rtol_new, atol * (rtol_new / rtol)


def slow_projector(J: np.ndarray, cutoff: float | None, n_pos: int | None = None) -> np.ndarray:
    """The error filter Pf (n, n) = I - diag(P, P) (on y = (q, qdot, ...), q (N,), N = n_pos or n // 2; the
    other entries of y unfiltered), P = V (U^H V)^-1 U^H (N, N) the spectral projector on the modes of the
    stiffness block A = J[N:2N, :N] = d qddot/d q [1/s^2] with |mu_k| > cutoff^2 (V, U their right and left
    eigenvectors: A v = mu v, mu = -omega^2 for a mode of omega [rad/s]; damping and gyroscopic terms are left
    out of the shapes), along the others; a (0, 0) array (no filter) when cutoff [rad/s] is None or no mode is
    above it. The error estimate Pf err then measures the modes at or below the cutoff only, and the steps may
    grow past the periods of those above it. Taken from A (N x N), whose zero eigenvalues (rigid motions) are
    semi-simple, rather than from J (2N x 2N), where each is a 2 x 2 Jordan block: the eigenvectors of J of a
    free-flying chain with a 1e6 rad/s mode are lost to round-off (case 1 with EI = 1e9: |Pf| ~ 1e9, and the
    filter made the error it was to remove), those of A are not (|Pf| ~ 1)."""
    if cutoff is None:
        return np.zeros((0, 0))
    n = J.shape[0]
    N = n // 2 if n_pos is None else int(n_pos)
    mu, u, v = scipy.linalg.eig(J[N:2 * N, :N], left=True, right=True)
    fast = np.abs(mu) > cutoff * cutoff
    if not fast.any():
        return np.zeros((0, 0))
    u, v = u[:, fast], v[:, fast]
    P = (v @ np.linalg.solve(u.conj().T @ v, u.conj().T)).real
    Pf = np.eye(n)
    Pf[:N, :N] -= P
    Pf[N:2 * N, N:2 * N] -= P
    return Pf


def _first_step(fun, t0, y0, f0, t_bound, max_step, rtol, atol, order=3):
    """First step [s] by Hairer, Norsett, Wanner (Solving ODEs I, II.4): h0 = 0.01 |y0| / |f0| in the scaled
    norm, then h1 = (0.01 / max(|f0|, |f1 - f0| / h0))^(1 / (order + 1)), one more f call; at most
    100 h0, the span and max_step (order: of the error estimate, 3 for Radau IIA's)."""
    span = t_bound - t0
    scale = atol + np.abs(y0) * rtol
    d0, d1 = _rms(y0 / scale), _rms(f0 / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    f1 = fun(t0 + h0, y0 + h0 * f0)
    d2 = _rms((f1 - f0) / scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100.0 * h0, h1, span, max_step)


def _rms(x):
    return float(np.linalg.norm(x)) / x.size ** 0.5


def input_rows(model, inputs) -> np.ndarray | None:
    """The rows (kind, k, a, b, c, d) (m, 6) of kernel.radau's compiled inputs for simulate's ``inputs``,
    or None when one of them is not closed-form (a Python callable without kernel rows): None and {}
    give no rows; a constant vector (N,) one per non-zero entry; a dict {name: number or the closures
    of gibbsimpact.dynamics.inputs}, a pd closure only on its own coordinate."""
    N = model.n_dof
    if inputs is None:
        return np.zeros((0, 6))
    if callable(inputs):
        return None
    if not isinstance(inputs, dict):
        Q = np.asarray(inputs, dtype=float).reshape(N)
        return np.array([(rk.IN_CONSTANT, k, Q[k], 0, 0, 0) for k in range(N) if Q[k] != 0.0]).reshape(-1, 6)
    names, rows = model.coordinate_names, []
    for name, f in inputs.items():
        k = names.index(str(name).replace("theta_m1", "theta_-1"))
        if isinstance(f, Real):
            rows.append((rk.IN_CONSTANT, k, float(f), 0, 0, 0))
            continue
        parts = getattr(f, "kernel_rows", None)
        if parts is None or any(kind == rk.IN_PD and pd_k != k for kind, pd_k, *_ in parts):
            return None
        rows += [(kind, k, *abcd) for kind, _, *abcd in parts]
    return np.array(rows, dtype=float).reshape(-1, 6)


def flight_program(equations, inputs) -> tuple[FlightProgram | None, str]:
    """(the run's compiled flight equations, "") or (None, why not) (module docstring: which runs get the
    compiled stepper; a contact phase never does, equations.Equations.phase_solver). inputs: simulate's
    ``inputs``. Compiles the stepper for the model's kernel variant on first use (20-40 s, cached)."""
    eq = equations
    if eq.prescribed is not None or eq.compliant is not None:
        return None, "prescribed coordinates or compliant walls"
    if eq.C_varies:
        return None, "a damped link behind a FixedPrismatic guide (C depends on q)"
    fin = input_rows(eq.model, inputs)
    if fin is None:
        return None, "an input given as a Python callable"
    return FlightProgram(eq, fin, eq.C_damp, eq.cutoff), ""
