"""The right-hand side of a run: y' = f(t, y) of a flight or contact phase, with the work of the applied forces.

State y = (q, qdot) (2N,), or (q, qdot, W_in, W_damp) (2N + 2,) for a driven run (inputs, damping or
friction), whose two extra states integrate the work rates of the applied forces (power balance,
gibbsimpact.dynamics.forces):

    q' = qdot,   M qddot = Q_in + Q_damp - h - dV/dq,   W_in' = qdot . Q_in,   W_damp' = qdot . Q_damp

In a contact phase (pairs resting on walls) qddot comes from the constrained equations of
gibbsimpact.contact.resting, and the power of friction joins the damping's. Held end stops
(gibbsimpact.simulation.joint_limits, equations (S1)-(S2)) add their forces n_H^T mu to Q: every
user of ``applied`` (the walls' resting forces, their events, the recorded forces) sees them.

With prescribed coordinates q_p (gibbsimpact.simulation.prescribed) y has a third work state, the
actuator's: W_act' = qdot_p . Q_p, Q_p the effort of gibbsimpact.dynamics.prescribed, and qddot
comes from the free rows M_ff qddot_f = Q_f - h_f - dV/dq_f - M_fp qddot_p (:meth:`Equations.partitioned`).
With compliant walls (gibbsimpact.simulation.compliant) their contact force joins Q_damp, and y ends
with the 3 + N states of that module (Settings refuses compliant walls with prescribed coordinates).
"""

from __future__ import annotations

import numpy as np

from ..dynamics.forces import CallbackError, damping_depends_on_q, damping_matrix, generalized_force
from ..dynamics.gibbs_appell import SingularMassMatrixError, forward_dynamics
from ..dynamics.prescribed import partitioned_dynamics
from .budget import Budget
from .compiled_radau import CompiledRadau, flight_program
from .cutoff_radau import CutoffRadau
from .implicit import IMPLICIT, rhs_jacobian

#: The method whose flight phases run the compiled stepper where they can (simulation.compiled_radau).
COMPILED_METHOD = "Radau"


class Equations:
    """f(t, y) of one run, the applied forces Q(t, q, qdot), and the counters of its calls.

    resting : the run's RestingContacts (asked for the constrained accelerations in a contact phase)
    clock : a progress throttle with ``tick(t)`` (gibbsimpact.simulation.progress.Clock)
    budget : the run's limits (gibbsimpact.simulation.budget), checked when nfev reaches check_at
    compliant : None, or the run's CompliantContacts (simulation.compliant): its force and extra states
    """

    def __init__(self, model, settings, q0, qdot0, resting, clock, compliant=None, stops=None):
        self.model, self.resting, self.clock, self.stops = model, resting, clock, stops
        self._stop_cache = (None, None)
        self.N = N = model.n_dof
        self.Q_in = generalized_force(model, settings.inputs, settings.t0, q0, qdot0)
        self.C_varies = damping_depends_on_q(model)  # a damped Pb link: C = C(d)
        self.C_damp = damping_matrix(model, q0)
        self.damped = bool(np.any(self.C_damp))
        # Friction in resting contact does work too: a frictional wall makes the run keep its work.
        self.prescribed = settings.prescribed  # None, or the Prescribed coordinates (their work is the third state)
        self.compliant = compliant
        self.driven = (self.Q_in is not None or self.damped or any(w.friction > 0 for w in settings.walls)
                       or compliant is not None or self.prescribed is not None)
        self.n_work = 0 if not self.driven else 2 if self.prescribed is None else 3  # work states after (q, qdot)
        #: States after (q, qdot): the work states, then the compliant contacts' own.
        self.n_extra = self.n_work + (0 if compliant is None else compliant.n_extra)
        self._compliant_rates = None
        self.zeros = np.zeros(N)
        self.nfev = 0
        self.budget = Budget(settings.max_rhs_calls, settings.max_cpu_time)
        self.check_at = self.budget.check_at
        self.resting_phase = False  # whether the phase under way has resting pairs (fixed during a phase)
        self.singular = None  # diagnosis of the last trial state with a singular M
        self.inputs, self.cutoff = settings.inputs, settings.cutoff_frequency
        self._program = None  # (FlightProgram or None, why not): built on the first phase_solver("Radau")
        #: Phases run by each Radau: {"compiled": k, "scipy": m}, and why scipy's ran ({reason: count}).
        self.radau_phases = {"compiled": 0, "scipy": 0}
        self.scipy_reasons = {}

    def forces(self, t, q, qd):
        """(Q_in, Q_damp) (N,) each [N, N m], or None for an undriven, undamped run."""
        if not self.driven:
            return None
        Qi = self.Q_in(t, q, qd) if self.Q_in is not None else self.zeros
        Qd = self.zeros
        if self.damped:
            C = damping_matrix(self.model, q) if self.C_varies else self.C_damp
            Qd = -(C @ qd)
        if self.compliant is not None:
            Qc, self._compliant_rates = self.compliant.generalized_force(q, qd)
            Qd = Qd + Qc
        return Qi, Qd

    def _extra(self, *rates):
        """The extra states' rates: W_in', W_damp' (rates), then the compliant contacts' of the last forces()."""
        return rates if self.compliant is None else (*rates, *self._compliant_rates)

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

    def jacobian(self, t, y):
        """df/dy (y.size, y.size) of a flight phase's f at (t, y), for an implicit method
        (gibbsimpact.simulation.implicit.rhs_jacobian)."""
        return rhs_jacobian(self, t, y)

    def phase_jacobian(self, method):
        """The solver's jac for the phase under way: ``jacobian`` for an implicit method in a phase of the plain
        flight equations; None (the solver's own differences) for an explicit method and for the right-hand
        sides rhs_jacobian does not model: resting pairs, prescribed motion, compliant contacts."""
        plain = not self.resting_phase and self.prescribed is None and self.compliant is None
        return self.jacobian if method in IMPLICIT and plain else None

    def phase_solver(self, method):
        """The solver of the phase under way: a factory of the compiled Radau (CompiledRadau with the run's
        FlightProgram) for method="Radau" in a phase it can run; else, for method="Radau" with a cutoff
        frequency, one of scipy's Radau with the same error weights (simulation.cutoff_radau.CutoffRadau);
        else None (scipy's solver of ``method``, with phase_jacobian). Counts the phases of each kind and
        scipy's reasons (radau_phases)."""
        if method != COMPILED_METHOD:
            return None
        if self._program is None:
            self._program = flight_program(self, self.inputs)
        program, why = self._program
        if program is not None and self.resting_phase:
            why = "a contact phase (resting pairs or held end stops)"
        if why:
            self.radau_phases["scipy"] += 1
            self.scipy_reasons[why] = self.scipy_reasons.get(why, 0) + 1
            if self.cutoff is None:
                return None
            N = self.N

            def stepping(fun, t0, y0, t_bound, **options):
                return CutoffRadau(fun, t0, y0, t_bound, n_pos=N, **options)

            return stepping
        self.radau_phases["compiled"] += 1

        def solver(fun, t0, y0, t_bound, **options):
            options.pop("jac", None)
            return CompiledRadau(fun, t0, y0, t_bound, program=program, **options)

        return solver

    def radau_record(self) -> dict:
        """For Result.settings with method="Radau": {"radau_phases": {"compiled": k, "scipy": m}, "radau_scipy_why":
        {reason: phases}} (which flight phases ran the compiled stepper, and why the others did not); {} else."""
        if not any(self.radau_phases.values()):
            return {}
        return {"radau_phases": dict(self.radau_phases), "radau_scipy_why": dict(self.scipy_reasons)}

    def partitioned(self, t, q, qd):
        """The prescribed run's dynamics at t: (qdot (N,) with the prescribed entries from f(t), qddot (N,),
        Q_in, Q_damp (N,), effort Q_p (n_p,) [N m or N], qdot_p (n_p,)); q, qd (N,) are not modified."""
        P = self.prescribed
        q_p, qd_p, qdd_p = P.at(t)
        q, qd = q.copy(), qd.copy()
        q[P.index], qd[P.index] = q_p, qd_p
        Qi, Qd = self.forces(t, q, qd)
        qdd, effort = partitioned_dynamics(self.model, q, qd, P.index, qdd_p, Qi + Qd)
        return qd, qdd, Qi, Qd, effort, qd_p

    def efforts(self, T, Q, Qdot) -> np.ndarray:
        """The actuators' efforts Q_p (K, n_p) [N m or N] at the samples T (K,), Q, Qdot (K, N)."""
        return np.array([self.partitioned(t, q, qd)[4] for t, q, qd in zip(T, Q, Qdot)]).reshape(
            len(T), len(self.prescribed.index))

    def __call__(self, t, y):
        """y' (y.shape) at (t, y); NaN where M is singular or y is not finite, so that the solver rejects the step.
        Raises BudgetExceeded (the call not made) once the run has used up a limit."""
        if self.nfev >= self.check_at:
            self.check_at = self.budget.check(self.nfev, t)
        self.nfev += 1
        self.clock.tick(t)
        N = self.N
        if not np.all(np.isfinite(y)):
            # A trial stage of a step far beyond the stability bound of an explicit method overflows (scipy's
            # first step ignores stiffness: 4.7e-3 s on a pressed arm whose constrained modes reach 3.7e4 rad/s,
            # h |lambda| = 172): NaN rejects the step and the solver shrinks it, as for a singular M.
            return np.full(y.shape, np.nan)
        try:
            q, qd = y[:N], y[N:2 * N]
            if self.resting_phase:
                f = self.forces(t, q, qd)
                qdd, power = self.constrained(q, qd, self.with_stops(t, q, qd, None if f is None else f[0] + f[1]))
                return np.concatenate((qd, qdd) if f is None else
                                      (qd, qdd, self._extra(qd @ f[0], qd @ f[1] + power.sum())))
            if not self.driven:
                return np.concatenate((qd, forward_dynamics(self.model, q, qd)))
            if self.prescribed is not None:
                qd, qdd, Qi, Qd, effort, qd_p = self.partitioned(t, q, qd)
                return np.concatenate((qd, qdd, [qd @ Qi, qd @ Qd, qd_p @ effort]))
            Qi, Qd = self.forces(t, q, qd)
            qdd = forward_dynamics(self.model, q, qd, Qi + Qd)
            return np.concatenate((qd, qdd, self._extra(qd @ Qi, qd @ Qd)))
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
