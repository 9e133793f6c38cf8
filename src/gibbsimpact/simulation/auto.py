"""method="auto": the explicit or the implicit solver, chosen from the chain's highest frequency.

An explicit Runge-Kutta method is stable on a mode lambda only for |h lambda| <= r(arg lambda)
(gibbsimpact.simulation.stability: r = 5.96 on the imaginary axis for DOP853), so over a span T it takes
at least

    n_stab = T |lambda_max| / r(arg lambda_max)

steps however slowly the chain moves. An L-stable implicit method (Radau IIA, order 5) has no such
bound: its steps follow the accuracy of the motion. Compiled (gibbsimpact.simulation.compiled_radau) a
Radau step costs about what a DOP853 step costs (R-Pb arm, N = 12, rtol 1e-2: 470 us against 600 us, each
with its share of the event search and the recording), but its error estimate is of order 3 against DOP853's 7 and 5: at tight
tolerances it needs many more steps (R-Pb arm at rtol 1e-4: 2032 against 522), at loose ones fewer
(rtol 1e-2: 143 against 342). The rule:

    Radau     if max_step does not bind first (max_step > T / n_stab) and either
              n_stab >= STIFF_STEPS (= 1e4), or rtol >= LOOSE_RTOL (= 1e-3) and n_stab >= LOOSE_STEPS (= 100)
    DOP853    otherwise

STIFF_STEPS is where stability alone costs the explicit method ~1e4 steps (~5 s of CPU on a
12-coordinate arm). Below it an explicit run is cheap whatever the implicit one would save, and
where the explicit step is set by accuracy (the stiff mode itself is excited above the tolerance:
after an impact on a stiff link, or tight tolerances on the bundled prismatic arms) Radau must
follow that mode too, with smaller steps than DOP853's (its error estimate is of order 3):
measured on fixed_base_R_Pb_arm (n_stab = 366 over 1 s) Radau costs ~12x DOP853's CPU at rtol 1e-8
and 4.8x at rtol 1e-4; on case 1 with EI = 1e9 on link 1 (n_stab = 1.8e5) it takes 5 steps to the first
impact where DOP853 takes 2.6e5 (docs/benchmarks.md, benchmarks/bench_stiff.py). The second branch: at
rtol 1e-3 the compiled Radau costs 0.17 s on the R-Pb arm's second (675 steps; DOP853 0.21 s at rtol 1e-2,
0.26 s at 1e-4), at rtol 1e-2 0.067 s, 3x less than DOP853 at that tolerance; below n_stab = 100 (case 1 as shipped: 26) DOP853's
steps are set by accuracy whatever the tolerance, and it stays.

The fast modes of a singularly perturbed chain. When auto takes Radau and the chain's frequencies at q0 have a
gap of FAST_GAP (= 100) or more between consecutive ones, omega_lo < omega_hi (case 1 with EI = 1e9 on link 1:
151 and 1.07e6 rad/s, a gap of 7086; the bundled cases' widest gaps are 1-17), the modes above it are a very
stiff spring on the slow chain, which an impact excites at amplitudes far above the tolerances: auto then sets
the cutoff_frequency sqrt(omega_lo omega_hi) (unless the user gave one), and the compiled Radau steps over
those modes (gibbsimpact.simulation.compiled_radau: left out of the error estimate, velocities weighted by h,
RADAU5's tolerances), damping them (docs/theory.md §14.1).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .flight import SOLVERS
from .stability import linearised_eigenvalues, stability_radius

AUTO = "auto"
#: Every value of simulate's ``method``: scipy's solvers and "auto".
METHODS = (*SOLVERS, AUTO)
EXPLICIT_METHOD, IMPLICIT_METHOD = "DOP853", "Radau"
#: Stability-bound explicit steps over the span from which auto takes the implicit method.
STIFF_STEPS = 1e4
#: Loosest rtol at which DOP853 is kept on a chain with n_stab >= LOOSE_STEPS (module docstring).
LOOSE_RTOL, LOOSE_STEPS = 1e-3, 100.0
#: Smallest ratio of consecutive frequencies that auto reads as fast modes to step over (module docstring).
FAST_GAP = 100.0
#: Frequencies below this fraction of the highest are rigid motions' zeros in round-off (fast_mode_cutoff).
RIGID_ROUNDOFF = 1e-6


class AutoChoice(NamedTuple):
    """What method="auto" chose: method ("Radau" or "DOP853"), reason (one sentence), cutoff_frequency [rad/s]
    of the fast modes to step over (None: every mode followed)."""

    method: str
    reason: str
    cutoff_frequency: float | None


def fast_mode_cutoff(lam: np.ndarray) -> tuple[float | None, str]:
    """(sqrt(omega_lo omega_hi) [rad/s], a sentence) at the widest gap omega_hi / omega_lo >= FAST_GAP between
    consecutive non-zero frequencies omega = |lambda| of the eigenvalues lam (n,) [1/s]; (None, "") without
    such a gap (module docstring). Frequencies below RIGID_ROUNDOFF omega_max count as zero: a rigid motion's
    zero eigenvalue is a 2 x 2 Jordan block, computed to ~sqrt(eps) omega_max = 1.5e-8 omega_max."""
    omega = np.abs(lam)
    omega = np.unique(omega[omega > RIGID_ROUNDOFF * omega.max(initial=0.0)])
    if omega.size < 2:
        return None, ""
    k = int(np.argmax(omega[1:] / omega[:-1]))
    lo, hi = float(omega[k]), float(omega[k + 1])
    if hi / lo < FAST_GAP:
        return None, ""
    cut = float(np.sqrt(lo * hi))
    return cut, (f"; the modes above {cut:.3g} rad/s (a gap of {hi / lo:.0f}x, {lo:.4g} to {hi:.4g} rad/s) are "
                 "stepped over and damped (cutoff_frequency; the energy audit's numerical part holds their energy)")


def auto_choice(model, q0: np.ndarray, t_span, max_step: float = np.inf, rtol: float = 0.0,
                cutoff_frequency: float | None = None) -> AutoChoice:
    """choose_method's (method, reason) and, when it takes Radau, the cutoff frequency [rad/s]: the user's
    cutoff_frequency if given, else fast_mode_cutoff's at q0 (N,) [m, rad] (None: no gap)."""
    method, why = choose_method(model, q0, t_span, max_step, rtol)
    if method != IMPLICIT_METHOD or cutoff_frequency is not None:
        return AutoChoice(method, why, cutoff_frequency)
    cut, more = fast_mode_cutoff(linearised_eigenvalues(model, np.asarray(q0, dtype=float)))
    return AutoChoice(method, why + more, cut)


def choose_method(model, q0: np.ndarray, t_span, max_step: float = np.inf, rtol: float = 0.0) -> tuple[str, str]:
    """(method, reason) of method="auto" for a run of ``model`` from q0 (N,) [m, rad] over t_span (t0, t_end) [s]
    with the solver's largest step max_step [s] and relative tolerance rtol (module docstring): "Radau" or
    "DOP853", and one sentence saying why, with n_stab and the highest frequency [rad/s]."""
    span = float(t_span[1]) - float(t_span[0])
    lam = linearised_eigenvalues(model, np.asarray(q0, dtype=float))
    if lam.size == 0 or not np.abs(lam).max() > 0.0:
        return EXPLICIT_METHOD, "auto: DOP853, the chain has no vibration mode"
    top = lam[np.argmax(np.abs(lam))]
    omega = float(abs(top))
    r = stability_radius(EXPLICIT_METHOD, float(np.angle(top if top.imag >= 0 else np.conj(top))))
    n_stab = span * omega / r
    head = (f"{EXPLICIT_METHOD} needs {n_stab:.3g} steps over {span:g} s for stability alone on the mode at "
            f"{omega:.4g} rad/s")
    if max_step <= span / n_stab:
        return EXPLICIT_METHOD, f"auto: {EXPLICIT_METHOD}, max_step = {max_step:g} s binds before the stability limit"
    if n_stab >= STIFF_STEPS:
        return IMPLICIT_METHOD, (f"auto: {IMPLICIT_METHOD}, {head} (>= {STIFF_STEPS:.0e}); {IMPLICIT_METHOD} is not "
                                 "bound by it but damps the modes it steps over (energy audit: numerical)")
    if rtol >= LOOSE_RTOL and n_stab >= LOOSE_STEPS:
        return IMPLICIT_METHOD, (f"auto: {IMPLICIT_METHOD}, {head} (>= {LOOSE_STEPS:g}) and rtol = {rtol:g} >= "
                                 f"{LOOSE_RTOL:g}: at this accuracy Radau's steps are longer than DOP853's")
    return EXPLICIT_METHOD, f"auto: {EXPLICIT_METHOD}, {head} (< {STIFF_STEPS:.0e})"
