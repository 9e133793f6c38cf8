"""The right-hand side of a run: y' = f(t, y) of a flight or contact phase, with the work of the applied forces.

State y = (q, qdot) (2N,), or (q, qdot, W_in, W_damp) (2N + 2,) for a driven run (inputs, damping or
friction), whose two extra states integrate the work rates of the applied forces (power balance,
gibbsimpact.dynamics.forces):

    q' = qdot,   M qddot = Q_in + Q_damp - h - dV/dq,   W_in' = qdot . Q_in,   W_damp' = qdot . Q_damp

In a contact phase (pairs resting on walls) qddot comes from the constrained equations of
gibbsimpact.contact.resting, and the power of friction joins the damping's. Held end stops
(gibbsimpact.simulation.joint_limits, equations (S1)-(S2)) add their forces n_H^T mu to Q: every
user of ``applied`` (the walls' resting forces, their events, the recorded forces) sees them.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.forces import CallbackError, damping_depends_on_q, damping_matrix, generalized_force
from ..dynamics.gibbs_appell import SingularMassMatrixError, forward_dynamics
from .budget import Budget


class Equations:
    """f(t, y) of one run, the applied forces Q(t, q, qdot), and the counters of its calls.

    resting : the run's RestingContacts (asked for the constrained accelerations in a contact phase)
    clock : a progress throttle with ``tick(t)`` (gibbsimpact.simulation.progress.Clock)
    budget : the run's limits (gibbsimpact.simulation.budget), checked when nfev reaches check_at
    """

    def __init__(self, model, settings, q0, qdot0, resting, clock, stops=None):
        self.model, self.resting, self.clock, self.stops = model, resting, clock, stops
        self._stop_cache = (None, None)
        self.N = N = model.n_dof
        self.Q_in = generalized_force(model, settings.inputs, settings.t0, q0, qdot0)
        self.C_varies = damping_depends_on_q(model)  # a damped Pb link: C = C(d)
        self.C_damp = damping_matrix(model, q0)
        self.damped = bool(np.any(self.C_damp))
        # Friction in resting contact does work too: a frictional wall makes the run keep its work.
        self.driven = self.Q_in is not None or self.damped or any(w.friction > 0 for w in settings.walls)
        self.zeros = np.zeros(N)
        self.nfev = 0
        self.budget = Budget(settings.max_rhs_calls, settings.max_cpu_time)
        self.check_at = self.budget.check_at
        self.resting_phase = False  # whether the phase under way has resting pairs (fixed during a phase)
        self.singular = None  # diagnosis of the last trial state with a singular M

    def forces(self, t, q, qd):
        """(Q_in, Q_damp) (N,) each [N, N m], or None for an undriven, undamped run."""
        if not self.driven:
            return None
        Qi = self.Q_in(t, q, qd) if self.Q_in is not None else self.zeros
        if not self.damped:
            return Qi, self.zeros
        C = damping_matrix(self.model, q) if self.C_varies else self.C_damp
        return Qi, -(C @ qd)

    def applied(self, t, q, qd):
        """Q = Q_in + Q_damp + n_H^T mu (N,) of the equations of motion, or None (gibbsimpact.contact.resting);
        mu (h,) [N] the forces of the held end stops (stop_forces)."""
        f = self.forces(t, q, qd)
        return self.with_stops(t, q, qd, None if f is None else f[0] + f[1])

    def with_stops(self, t, q, qd, Q):
        """Q (N,) or None plus the held end stops' forces n_H^T mu (unchanged when no stop is held)."""
        if self.stops is None or not self.stops.held.any():
            return Q
        mu = self.stop_forces(t, q, qd, Q)
        return (self.zeros if Q is None else Q) + mu @ self.stops.n[self.stops.held]

    def stop_forces(self, t, q, qd, Q=False) -> np.ndarray:
        """mu (h,) [N or N m] of the held end stops at (t, q, qd) (joint_limits.EndStops.stop_forces),
        cached per state; Q (N,) or None: Q_in + Q_damp if known (False: computed)."""
        key = (t, q.tobytes(), qd.tobytes(), self.stops.held.tobytes(), self.resting.active.tobytes())
        if self._stop_cache[0] == key:
            return self._stop_cache[1]
        if Q is False:
            f = self.forces(t, q, qd)
            Q = None if f is None else f[0] + f[1]
        Q = self.zeros if Q is None else Q
        if self.resting.any():
            def acceleration(Qx):
                return self.resting.acceleration(q, qd, Qx)[0].copy()
        else:
            def acceleration(Qx):
                return forward_dynamics(self.model, q, qd, Qx)
        mu = self.stops.stop_forces(acceleration, Q, self.resting.force_scale)
        self._stop_cache = (key, mu)
        return mu

    def constrained(self, q, qd, Q):
        """(qddot (N,), friction power (k,) [W]) of a contact phase: walls (gibbsimpact.contact.resting)
        and held end stops, their forces in Q (N,) or None."""
        if self.resting.any():
            qdd, _, _, power, *_ = self.resting.acceleration(q, qd, Q)
            return qdd, power
        return forward_dynamics(self.model, q, qd, Q), np.zeros(0)

    def __call__(self, t, y):
        """y' (y.shape) at (t, y); NaN where M is singular, so that the solver rejects the step.
        Raises BudgetExceeded (the call not made) once the run has used up a limit."""
        if self.nfev >= self.check_at:
            self.check_at = self.budget.check(self.nfev, t)
        self.nfev += 1
        self.clock.tick(t)
        N = self.N
        try:
            q, qd = y[:N], y[N:2 * N]
            if self.resting_phase:
                f = self.forces(t, q, qd)
                qdd, power = self.constrained(q, qd, self.with_stops(t, q, qd, None if f is None else f[0] + f[1]))
                return np.concatenate((qd, qdd) if f is None else (qd, qdd, [qd @ f[0], qd @ f[1] + power.sum()]))
            if not self.driven:
                return np.concatenate((qd, forward_dynamics(self.model, q, qd)))
            Qi, Qd = self.forces(t, q, qd)
            qdd = forward_dynamics(self.model, q, qd, Qi + Qd)
            return np.concatenate((qd, qdd, [qd @ Qi, qd @ Qd]))
        except SingularMassMatrixError as exc:
            # A trial stage of a too-long step can land on a meaningless state (e.g. right
            # after an impact that excites high modes): NaN makes the solver reject the
            # step and shrink it. Only if it cannot go on is the diagnosis reported.
            self.singular = f"at t = {t:.9g} s: {exc}"
            return np.full(y.shape, np.nan)
        except CallbackError:
            # An input given a non-finite trial state (a too-long step of a stiff chain) may well
            # return NaN: that is the step's failure, not the input's; the solver rejects it.
            if np.all(np.isfinite(y)):
                raise
            return np.full(y.shape, np.nan)
