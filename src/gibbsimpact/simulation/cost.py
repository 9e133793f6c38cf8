"""What a run will cost, estimated before it starts: the highest frequency and the steps of the method.

**Linearised free motion.** At the initial state (q0, qdot0) the equations of motion
M qddot = Q - h - dV/dq, linearised about q0 with the velocity-product terms h left out
(quadratic in qdot), are y' = A y for y = (dq, dqdot) (2N,):

    A = [[0, I], [-M^-1 K, -M^-1 C]],   K = d(dV/dq)/dq (N, N),   C = the links' damping matrix (N, N)

K is the Hessian of the potential (strain and gravity; for a link behind a Pb guide its
stiffness at the protruding length d(q0)), by central differences of the kernel's dV/dq;
C is gibbsimpact.dynamics.forces.damping_matrix at q0. Applied inputs (servos) are left out.
An eigenvalue lambda_k = -sigma_k + i omega_d,k of A is a mode of natural frequency
|lambda_k| [rad/s]; omega_max = max_k |lambda_k|.

**Stability.** An explicit Runge-Kutta method applied to y' = lambda y multiplies y by the
stability polynomial R(z), z = h lambda, each step (Hairer & Wanner, Solving ODEs II, §IV.2):

    R(z) = 1 + z b^T (I - z A_rk)^-1 1    (A_rk, b: the method's Butcher tableau, scipy's own)

and stays bounded only for |R(h lambda_k)| <= 1 for every mode: h <= r(arg lambda_k) / |lambda_k|,
r(phi) the distance from 0 to the boundary of {|R| <= 1} along the ray of angle phi. On the
imaginary axis (undamped oscillations) r = 5.96 for scipy's DOP853, 1.73 = sqrt(3) for RK23
(the textbook interval of a 3-stage third-order method, a check of this computation) and 1.0
for RK45 (scipy's Dormand-Prince 5(4) with local extrapolation; |R(iy)| - 1 is only 1e-4 at
y = 1.1 and 3e-3 at 1.5, so its practical limit is soft); on the negative real axis 6.39,
2.51 and 3.31. These numbers are computed from the tableaux
(:func:`gibbsimpact.simulation.stability.stability_radius`).

**Accuracy.** The step controller keeps the embedded error estimate of each step below
atol + rtol |y| per component; for a mode it is |E(h lambda)| times the mode's amplitude, with
E(z) the error estimator's polynomial (for DOP853 scipy's blend of its 5th- and 3rd-order
estimates, stability.error_estimate). A mode is taken to be excited at the start (a load
switched on at t0) with velocity amplitude v_k = a / |lambda_k|, a [m/s^2] the larger of |g|
and the largest acceleration of a joint at t0, so that the step must keep

    |E(h lambda_k)| <= rtol + atol / v_k

for as long as the mode lasts: the whole run when it is undamped, else until its velocity
amplitude has decayed to atol, T_k = ln(v_k / atol) / sigma_k. A mode of amplitude below the
tolerance is not followed: only the stability limit binds it (a stiff link whose deflections
are below atol). The estimate is then

    n_steps = max_k [ T_k / min(h_acc,k, h_stab) + (t_end - t0 - T_k) / h_stab ],
    n_rhs = n_steps * (stages per step) + min(n_steps, n_samples) * (dense-output stages)

with h_stab also at most max_step, the stages of scipy's FSAL methods (DOP853 12 and 3 more
for a dense output, RK45 6, RK23 3) and n_samples = (t_end - t0) / output_dt. The CPU time is
n_rhs right-hand sides timed at q0 plus n_steps STEP_OVERHEAD bare scipy steps timed on this
machine. Rejected steps, impacts and the in-step event check are not counted (10-30 % of the
right-hand sides). The mode's amplitude is the guess: it enters through |E(z)| ~ |z|^8 for
DOP853, so an amplitude off by 256 changes the step by 2. On the bundled cases and variants
the estimate is 0.55-2.4 times the measured steps (docs/benchmarks.md). Implicit methods
(Radau, BDF) are not bound by the stability limit and LSODA switches between both: their steps
are not estimated.
"""

from __future__ import annotations

import inspect
import math
import time
from dataclasses import dataclass

import numpy as np

from ..dynamics.forces import generalized_force
from ..dynamics.gibbs_appell import forward_dynamics
from ..dynamics.kinematics import joint_jacobians
from .auto import AUTO, auto_choice
from .charts import charted, start_chart
from .flight import SOLVERS
# The linearised modes and the methods' stability and accuracy radii are in stability.py, so that
# method="auto" reads them without this module's tie to simulate's defaults.
from .stability import EXPLICIT, accuracy_radius, linearised_eigenvalues, stability_radius

#: CPU time of one accepted step of a run besides its right-hand sides (scipy's step, the event checks,
#: the recorder), in units of one bare scipy step of the same method on a linear system of the same
#: size (:func:`step_seconds`): 4 - 8 on the bundled cases and variants (docs/benchmarks.md).
STEP_OVERHEAD = 5.0


def acceleration_scale(model, q0, qdot0, Q0=None) -> float:
    """a [m/s^2] that excites the elastic modes at the start: max(|g|, largest joint acceleration |J_j qddot0|)."""
    qdd = forward_dynamics(model, q0, qdot0, Q0)
    J = joint_jacobians(model, q0)  # (P, 3, N)
    return max(float(np.linalg.norm(model.gravity)), float(np.linalg.norm(J @ qdd, axis=-1).max(initial=0.0)))


def _fastest(call, repeat: int) -> float:
    """CPU seconds of one call(): the fastest of 3 batches of ``repeat`` calls, after one warm-up call."""
    call()
    best = math.inf
    for _ in range(3):
        start = time.process_time()
        for _ in range(repeat):
            call()
        best = min(best, (time.process_time() - start) / repeat)
    return best


def rhs_seconds(model, q0, qdot0, Q_in=None, t0: float = 0.0) -> float:
    """CPU seconds of one right-hand side at the initial state: forward_dynamics with the inputs evaluated."""
    return _fastest(lambda: forward_dynamics(model, q0, qdot0, None if Q_in is None else Q_in(t0, q0, qdot0)), 40)


def step_seconds(method: str, n: int) -> float:
    """CPU seconds of one bare step of ``method`` (scipy) on y' = S y, S (n, n) a skew shift: the solver's
    own Python per step on this machine (its right-hand side costs ~1 us)."""
    S = np.diag(np.ones(n - 1), 1) - np.diag(np.ones(n - 1), -1)
    solver = EXPLICIT[method][0](lambda t, y: S @ y, 0.0, np.ones(n), math.inf, max_step=1e-3)
    return _fastest(solver.step, 50)


@dataclass(frozen=True)
class CostEstimate:
    """What a run should cost (module docstring); None where a number is not estimated (implicit methods).

    omega_max : [rad/s] the highest natural frequency of the linearised free motion at q0
    method : the solver; span : t_end - t0 [s]
    h_stability : [s] the largest stable step of an explicit method, or None
    n_steps, n_rhs : estimated accepted steps and right-hand sides, or None
    binding : what sets the step ("stability ..." or "accuracy ..."), or why nothing is estimated
    rhs_seconds : [s] CPU of one right-hand side at q0, measured
    cpu_seconds : [s] n_rhs rhs_seconds + n_steps STEP_OVERHEAD step_seconds, or None
    choice : for method="auto", the sentence of gibbsimpact.simulation.auto.choose_method; else ""
    """

    omega_max: float
    method: str
    span: float
    h_stability: float | None
    n_steps: float | None
    n_rhs: float | None
    binding: str
    rhs_seconds: float
    cpu_seconds: float | None
    choice: str = ""  # method="auto": which method it chose and why (gibbsimpact.simulation.auto)

    def describe(self) -> str:
        """One line: omega_max, and the steps, right-hand sides and CPU time of the method over the span."""
        head = f"highest frequency {self.omega_max:.4g} rad/s (period {_period(self.omega_max)})"
        if self.choice:
            head = f"{self.choice}; {head}"
        if self.n_steps is None:
            return f"{head}; {self.method}: steps not estimated ({self.binding})"
        return (f"{head}; {self.method} over {self.span:g} s: about {_count(self.n_steps)} steps, "
                f"{_count(self.n_rhs)} right-hand sides, {duration(self.cpu_seconds)} of CPU ({self.binding})")


def _period(omega: float) -> str:
    return "none" if omega <= 0 else f"{2 * math.pi / omega:.3g} s"


def _count(x: float) -> str:
    """A count: whole below 10,000, else three significant digits."""
    return f"{x:.0f}" if x < 1e4 else f"{x:.3g}"


def duration(seconds: float) -> str:
    """A CPU time in the largest unit that keeps it above 1 (s, min, h, days)."""
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def _steps(method, lam, span, a, rtol, atol, max_step) -> tuple[float, float, str]:
    """(h_stability [s], n_steps, binding) of an explicit method over the modes lambda (module docstring)."""
    modes = lam[(np.abs(lam) > 1e-9 * max(1.0, np.abs(lam).max(initial=0.0))) & (lam.imag >= 0)]
    h_stab, binding = min(max_step, span), "max_step" if max_step < span else "the time span"
    # Undamped modes come out of eig with real parts of round-off (+3.7e-11 at 1.07e6 rad/s on case 1
    # with EI = 1e9): a real part below 1e-9 |lambda| is zero, else the stiffest mode's limit was skipped.
    for lk in modes[modes.real <= 1e-9 * np.abs(modes)]:
        h = stability_radius(method, float(np.angle(lk))) / abs(lk)
        if h < h_stab:
            h_stab, binding = h, f"stability limit of the mode at {abs(lk):.4g} rad/s"
    n_steps = span / h_stab
    for lk in modes:
        v = a / abs(lk)  # velocity amplitude of the mode excited at t0 [m/s]
        if not v > atol:
            continue
        sigma = -float(lk.real)
        lasts = span if sigma <= 0 else min(span, math.log(v / atol) / sigma)
        h_acc = accuracy_radius(method, float(np.angle(lk)), rtol + atol / v) / abs(lk)
        n = lasts / min(h_acc, h_stab) + (span - lasts) / h_stab
        if n > n_steps:
            n_steps, binding = n, f"accuracy on the mode at {abs(lk):.4g} rad/s"
    return h_stab, n_steps, binding


def _simulate_defaults() -> dict:
    """simulate's keyword arguments and their defaults (the one place they are written)."""
    from .simulate import simulate

    return {k: p.default for k, p in inspect.signature(simulate).parameters.items() if p.default is not p.empty}


def estimate_cost(model, q0, qdot0, t_span, **options) -> CostEstimate:
    """The cost of ``simulate(model, q0, qdot0, t_span, **options)`` before it runs (module docstring).

    q0, qdot0 : (N,) [m, rad; m/s, rad/s]; t_span : (t0, t_end) [s]
    options : simulate's keywords (simulate's defaults for those left out); method, rtol, atol,
        output_dt, max_step and inputs (evaluated at t0 for the acceleration scale and the cost
        of a call) are used. Impacts, resting contact and joint limits are not foreseen.
    """
    defaults = _simulate_defaults()
    unknown = sorted(set(options) - set(defaults))
    if unknown:
        raise ValueError(f"estimate_cost {', '.join(unknown)}: not a keyword of simulate; give simulate's keywords "
                         f"({', '.join(defaults)})")
    o = {**defaults, **options}
    q0, qdot0 = model.check_state(q0, qdot0, "q0", "qdot0")
    # In the chart the run starts in: at theta_0 = +-pi/2 the given chart's M is singular (theory §2.1).
    fixed = [model.coordinate_names.index(c) if isinstance(c, str) else int(c) for c in o["prescribed"] or ()]
    model, q0, qdot0 = start_chart(model, q0, qdot0, charted(model, fixed or None))
    method, choice = o["method"], ""
    if method == AUTO:
        method, choice = auto_choice(model, q0, t_span, o["max_step"], o["rtol"], o["cutoff_frequency"])[:2]
    if method not in SOLVERS:
        raise ValueError(f"estimate_cost method={method!r} must be a solve_ivp method; use one of {', '.join(SOLVERS)}")
    t0, t_end = float(t_span[0]), float(t_span[1])
    Q_in = generalized_force(model, o["inputs"], t0, q0, qdot0)
    lam = linearised_eigenvalues(model, q0)
    omega_max = float(np.abs(lam).max(initial=0.0))
    seconds = rhs_seconds(model, q0, qdot0, Q_in, t0)
    span = t_end - t0
    if method not in EXPLICIT:
        why = "LSODA switches between explicit and implicit steps" if method == "LSODA" else \
            f"{method} is implicit: no stability limit, its steps follow the accuracy of the motion"
        return CostEstimate(omega_max, method, span, None, None, None, why, seconds, None, choice)
    a = acceleration_scale(model, q0, qdot0, None if Q_in is None else Q_in(t0, q0, qdot0))
    h_stab, n_steps, binding = _steps(method, lam, span, a, o["rtol"], o["atol"], o["max_step"])
    _, per_step, dense = EXPLICIT[method]
    n_samples = 0.0 if o["output_dt"] is None else span / o["output_dt"]
    n_rhs = n_steps * per_step + min(n_steps, n_samples) * dense
    cpu = n_rhs * seconds + n_steps * STEP_OVERHEAD * step_seconds(method, 2 * model.n_dof)
    return CostEstimate(omega_max, method, span, h_stab, n_steps, n_rhs, binding, seconds, cpu, choice)
