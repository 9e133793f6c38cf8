"""scipy's Radau stepping over fast modes, for the phases the compiled Radau does not run (resting contact).

With a cutoff frequency in force (simulate's cutoff_frequency, or method="auto" at a gap in the chain's
spectrum; docs/theory.md §14.1) the compiled Radau (gibbsimpact.simulation.compiled_radau) holds its error
estimate to RADAU5's tolerances and weights velocity errors by h. A phase it cannot run (a resting-contact
phase, a held end stop, prescribed coordinates, compliant walls, a callable input) runs scipy's Radau; without
the same treatment that one resolves the fast modes again (case 1 with EI = 1e9 on link 1, once O1 rests on the
wall: steps of ~1e-7 s, 1e-3 s of motion per 20 s of CPU). :class:`CutoffRadau` gives it the same treatment
through scipy's documented OdeSolver interface:

* rtol' = 0.1 rtol^(2/3), atol' = atol rtol' / rtol (compiled_radau.radau5_tolerances);
* before each step, the velocity entries y[N:2N] of the weights scale = atol + rtol |y| (scipy's
  ``_step_impl`` reads self.atol once a step, for Newton's norm and the error norm) are divided by
  w = min(1, h VELOCITY_RATE), h the step about to be tried: atol_v = (atol' + rtol' |y_v|) / w - rtol' |y_v|,
  so that scale_v = (atol' + rtol' |y_v|) / w at the step's start, RADAU5's scaling of index-2 variables
  (kernel.radau._velocity_weight). After a rejection scipy retries with a shorter h but the same weights,
  which are then stricter than the compiled stepper's (never looser).

The spectral filter of the compiled stepper (compiled_radau.slow_projector) is not applied: scipy's error
estimate cannot be reached without rewriting its step, and on the measured case the velocity weighting and the
tolerance map are enough (docs/theory.md §14.1). Without a cutoff nothing here is used: method="Radau" runs
scipy's Radau unchanged.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import Radau

from .compiled_radau import VELOCITY_RATE, radau5_tolerances


class CutoffRadau(Radau):
    """scipy's Radau with the error weights of a run with a cutoff frequency (module docstring).

    n_pos: N, the number of coordinates (y = (q, qdot, extra states), q and qdot (N,) each, [m, rad] and
    [m/s, rad/s]); rtol, atol: the user's (solve_ivp's meaning, atol a float or (n,) array), mapped here to
    RADAU5's; every other argument is scipy's Radau's.
    """

    def __init__(self, fun, t0, y0, t_bound, *, n_pos: int, rtol=1e-3, atol=1e-6, **options):
        n_pos = int(n_pos)
        if not 0 < 2 * n_pos <= np.size(y0):
            raise ValueError(f"CutoffRadau: n_pos = {n_pos} does not fit y0 of size {np.size(y0)}; "
                             "give the number of coordinates N (y = (q, qdot, ...), 2 N <= y0.size)")
        rtol5, atol5 = radau5_tolerances(max(float(rtol), 100.0 * np.finfo(float).eps), np.asarray(atol, float))
        super().__init__(fun, t0, y0, t_bound, rtol=rtol5, atol=atol5, **options)
        self.n_pos = n_pos
        #: qddot holds the damped fast modes: the event check samples the dense output (simulation.flight).
        self.steps_over_fast_modes = True
        self.atol_base = np.array(np.broadcast_to(self.atol, (self.n,)), dtype=float)

    def _step_impl(self):
        self.atol = velocity_weighted_atol(self.atol_base, self.rtol, self.y, self.n_pos,
                                           min(self.h_abs, self.max_step, abs(self.t_bound - self.t)))
        return super()._step_impl()


def velocity_weighted_atol(atol: np.ndarray, rtol: float, y: np.ndarray, n_pos: int, h: float) -> np.ndarray:
    """atol (n,) with its velocity entries [N:2N] (N = n_pos) set so that atol + rtol |y| is divided there by
    w = min(1, h VELOCITY_RATE): atol_v / w + rtol |y_v| (1 / w - 1); atol in y's units, h [s] the step about to
    be tried (RADAU5's h-scaling of index-2 variables; module docstring). A new array; w = 1 leaves it as is."""
    out = atol.copy()
    w = min(1.0, h * VELOCITY_RATE)
    if 0.0 < w < 1.0:
        v = slice(n_pos, 2 * n_pos)
        out[v] = atol[v] / w + rtol * np.abs(y[v]) * (1.0 / w - 1.0)
    return out
