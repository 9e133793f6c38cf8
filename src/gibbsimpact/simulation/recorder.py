"""The samples and impacts of a simulation, recorded chunk by chunk, with the flight-phase energy balance."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..dynamics.gibbs_appell import Energy, energies, energy
from .results import ImpactRecord, energy_scale


class Chunk(NamedTuple):
    """Samples recorded at once: an impact (one sample, its record) or a flight phase (k samples)."""

    t: np.ndarray  # (k,) [s]
    q: np.ndarray  # (k, N)
    qdot: np.ndarray  # (k, N)
    phase: np.ndarray  # (k,) int
    work: np.ndarray  # (k, 2) [J], (k, 3) with prescribed coordinates (their actuators' work)
    energy: Energy  # each field (k,) [J]
    error: float  # energy balance error of these samples (relative)
    impact: ImpactRecord | None
    forces: np.ndarray | None = None  # (k, W, P) [N] resting-contact forces; None: all zero
    friction: np.ndarray | None = None  # (k, W, P, 3) [N] their tangential forces; None: all zero
    balance: float = 0.0  # [J] signed change of E - W from the sample before, counted in the whole-run error
    compliant: tuple | None = None  # compliant normal forces (k, W, C) [N], their points (k, W, C, 3) [m] and
    # integrals (k, 3 + N) (simulation.compliant); None: no compliant force on these samples
    stops: np.ndarray | None = None  # (k, L) [N or N m] forces of the held end stops; None: all zero
    chart: np.ndarray | None = None  # (3, 3) R_ref of the free base's chart of these samples (model.base_chart)
    change: object = None  # the ChartChange (simulation.charts) whose sample after it this chunk is
    where: np.ndarray | None = None  # (k, W, C) [m] abscissae of the resting span points (NaN: none); None: none


def one_sample(E: Energy) -> Energy:
    """Energy of one state as arrays of one sample."""
    return Energy(*(np.array([float(v)]) for v in E))


class Recorder:
    """Stored samples (t, q, qdot, phase, work), their energies, the impacts, and the flight-phase energy balance.

    work : (K, 2) [J] the work of the inputs and of the damping since t0 (zeros
    for an undriven, undamped run), and with prescribed coordinates a third column, the work of
    their actuators: int qdot_p . Q_p dt, plus Lambda_p . qdot_p at each impact (qdot_p does not
    jump). In a flight phase E(t) - E(start) equals W(t) - W(start) up to the integration error,
    which is what energy_error measures per phase; balance_J adds up those errors, signed, with the energy jumps of the impacts that
    should conserve E (e = 1, no friction impulse) into the error of the whole run.

    Everything is kept as a list of Chunk, each added by one ``list.append``:
    a KeyboardInterrupt anywhere leaves whole chunks only, so the Result built
    from them after an interrupt is consistent (every sample with its energy,
    every impact with the sample after it).
    """

    def __init__(self, model, t0, q0, qdot0, n_walls=0, prescribed=None, n_limits=0, n_cols=None):
        self.model = model
        self.prescribed = prescribed  # (n_p,) indices of the prescribed coordinates, or None
        n_work = 2 if prescribed is None else 3
        # (W, C): the P joint points, then the span points of the link columns (contacts.Contacts).
        self.force_shape = (n_walls, model.n_joints if n_cols is None else n_cols)
        self.n_limits = n_limits  # L joint limits (their end-stop forces: Result.stop_forces)
        # Energy of every stored sample: needed for the flight-phase drift, then handed
        # to the Result so res.energy() does not evaluate M at every sample again.
        self.chunks = [Chunk(np.array([t0]), q0[None, :], qdot0[None, :], np.array([0]), np.zeros((1, n_work)),
                              one_sample(energy(model, q0, qdot0)), 0.0, None, chart=model.base_chart)]
        self.n_impacts = 0

    def impact(self, rec, q, phase):
        last = self.chunks[-1]
        work = last.work[-1:].copy()
        if rec.actuator_impulses is not None:  # the actuators' impulses work at the (unchanged) qdot_p
            work[0, 2] += float(rec.actuator_impulses @ rec.qdot_after[self.prescribed])
        # An impact with e = 1 and no friction impulse should keep E: its jump is an error of the run.
        # Others dissipate by design (Newton's law with e < 1, Coulomb friction), and do not count.
        conserving = np.all(np.asarray(rec.restitution) == 1.0) and (
            rec.friction_impulses is None or not np.any(rec.friction_impulses))
        jump = float(rec.energy_after.total - last.energy.total[-1] - (work[0].sum() - last.work[-1].sum())) \
            if conserving else 0.0
        self.chunks.append(Chunk(np.array([rec.time]), q[None, :].copy(), rec.qdot_after[None, :].copy(),
                                  np.array([phase]), work, one_sample(rec.energy_after), 0.0, rec,
                                  balance=jump, chart=self.model.base_chart))
        self.n_impacts += 1

    def flight(self, T, Y, phase, forces=None, friction=None, compliant=None, stops=None, where=None,
               contact_work=None):
        """Samples T (K,), Y (K, 2N [+ 2 or 3 [+ 3 + N]]) of a flight phase that started at the last stored sample.

        forces : None or (K, W, P) [N], the resting-contact forces at the samples;
        friction : None or (K, W, P, 3) [N], their tangential (friction) forces;
        compliant : None or ((K, W, C) [N], (K, W, C, 3) [m]), the compliant contacts' normal forces and points
        (simulation.compliant), whose integrals are Y's last 3 + N columns;
        stops : None or (K, L) [N or N m], the forces of the held end stops;
        where : None or (K, W, C) [m], the abscissae of the resting span points (NaN: a pair that does not rest);
        contact_work : None or (K,) [J], the work of the contact impulses since the last stored sample (a stepped
        contact phase, simulation.stepping), which the balance leaves out: it dissipates by design.
        """
        N = self.model.n_dof
        last = self.chunks[-1]
        E_start = Energy(*(float(a[-1]) for a in last.energy))
        W_start = last.work[-1].sum()
        nw = last.work.shape[1]  # 2 work states, 3 with prescribed coordinates
        W = Y[:, 2 * N:2 * N + nw] if Y.shape[1] > 2 * N else np.zeros((T.size, nw))
        scale = energy_scale(self.model, E_start, float(np.max(np.abs(W.sum(axis=1) - W_start), initial=0.0)))
        # All samples in one kernel call; the balance E(t) - E(start) - (W(t) - W(start)) per sample.
        E = energies(self.model, Y[:, :N], Y[:, N:2 * N])
        balance = E.total - E_start.total - (W.sum(axis=1) - W_start)
        if contact_work is not None:
            balance = balance - contact_work
        err = float(np.abs(balance).max() / scale) if T.size else 0.0
        extra = None if compliant is None else (*compliant, Y[:, 2 * N + nw:])
        self.chunks.append(Chunk(T, Y[:, :N], Y[:, N:2 * N], np.full(T.size, phase), W, E, err, None, forces,
                                  friction, float(balance[-1]) if T.size else 0.0, extra, stops,
                                  self.model.base_chart, where=where))

    def mode(self, t, q, qdot, phase, forces, friction, stops=None, where=None):
        """After a contact-mode decision at t: its contact forces (W, P) and friction forces (W, P, 3) [N]
        (and end-stop forces (L,) or None, span abscissae (W, P) [m] or None) on the last sample, or a new sample
        when the projection
        (gibbsimpact.resting, the end stops') moved the state (q, qdot) (N,)."""
        last = self.chunks[-1]
        S = np.zeros(self.n_limits) if stops is None else stops
        if np.array_equal(last.q[-1], q) and np.array_equal(last.qdot[-1], qdot):
            F = np.zeros((last.t.size,) + self.force_shape) if last.forces is None else last.forces.copy()
            Ft = np.zeros(F.shape + (3,)) if last.friction is None else last.friction.copy()
            Sk = np.zeros((last.t.size, self.n_limits)) if last.stops is None else last.stops.copy()
            F[-1], Ft[-1], Sk[-1] = forces, friction, S
            Xk = last.where
            if where is not None or Xk is not None:
                Xk = np.full(F.shape, np.nan) if Xk is None else Xk.copy()
                Xk[-1] = np.nan if where is None else where
            self.chunks[-1] = last._replace(forces=F, friction=Ft, stops=Sk, where=Xk)
            return
        self.chunks.append(Chunk(np.array([t]), q[None, :].copy(), qdot[None, :].copy(), np.array([phase]),
                                  last.work[-1:].copy(), one_sample(energy(self.model, q, qdot)), 0.0, None,
                                  forces[None].copy(), friction[None].copy(), stops=S[None].copy(),
                                  chart=self.model.base_chart, where=None if where is None else where[None].copy()))

    def chart(self, t, q, qdot, phase, change):
        """A re-chart at t (simulation.charts): the state (q, qdot) (N,) in the new chart (self.model's, already
        handed over) as a new sample, the ChartChange with its index. The chart keeps E; its jump, round-off,
        counts in the whole-run balance like that of an impact that should conserve E."""
        last = self.chunks[-1]
        E = one_sample(energy(self.model, q, qdot))
        last_forces = None if last.forces is None else last.forces[-1:].copy()
        last_friction = None if last.friction is None else last.friction[-1:].copy()
        last_stops = None if last.stops is None else last.stops[-1:].copy()
        last_compliant = None if last.compliant is None else tuple(a[-1:].copy() for a in last.compliant)
        change = change._replace(sample=sum(c.t.size for c in self.chunks))
        self.chunks.append(Chunk(np.array([t]), q[None, :].copy(), qdot[None, :].copy(), np.array([phase]),
                                  last.work[-1:].copy(), E, 0.0, None, last_forces, last_friction,
                                  float(E.total[0] - last.energy.total[-1]), last_compliant, last_stops,
                                  chart=self.model.base_chart, change=change,
                                  where=None if last.where is None else last.where[-1:].copy()))

    def abscissae(self):
        """Abscissae (K, W, C) [m] of the resting span points at every sample (NaN where a pair does not rest), or
        None when no span point rested."""
        if all(c.where is None for c in self.chunks):
            return None
        return np.concatenate([np.full((c.t.size,) + self.force_shape, np.nan) if c.where is None else c.where
                               for c in self.chunks])

    @property
    def chart_changes(self) -> list:
        """The ChartChange of every re-chart, in time order."""
        return [c.change for c in self.chunks if c.change is not None]

    def base_charts(self):
        """R_ref (K, 3, 3) of every sample's chart (simulation.charts), or None when no sample has another
        chart than I (a run that never re-charted: its angles are measured from the world axes)."""
        if not self.chart_changes:
            return None
        return np.concatenate([np.broadcast_to(c.chart, (c.t.size, 3, 3)) for c in self.chunks])

    def ends_with(self, T) -> bool:
        """Whether the last chunk holds the samples T (the same array)."""
        return self.chunks[-1].t is T

    @property
    def energy_error(self) -> float:
        return max(c.error for c in self.chunks)

    @property
    def balance_J(self) -> float:
        """Result.energy_error_whole_run_J [J]: the flight phases' balance errors at their ends plus the
        energy jumps of the impacts that should conserve E; the projections of a contact-mode change
        (mode(): the resting pairs onto g = 0 with v_n = 0) dissipate by design and do not count."""
        return float(sum(c.balance for c in self.chunks))

    @property
    def impacts(self) -> list:
        return [c.impact for c in self.chunks if c.impact is not None]

    def compliant_arrays(self, shape: tuple):
        """Compliant normal forces (K, W, C) [N], their points (K, W, C, 3) [m] and integrals (K, 3 + N)
        (simulation.compliant) at every sample; shape = (W, C). Samples of an impact or a mode change hold
        no compliant force (points NaN) and the integrals of the sample before."""
        F, X, I = [], [], []
        last = np.zeros(3 + self.model.n_dof)
        for c in self.chunks:
            if c.compliant is None:
                F.append(np.zeros((c.t.size,) + shape))
                X.append(np.full((c.t.size,) + shape + (3,), np.nan))
                I.append(np.tile(last, (c.t.size, 1)))
            else:
                F.append(c.compliant[0])
                X.append(c.compliant[1])
                I.append(c.compliant[2])
                if c.t.size:
                    last = c.compliant[2][-1]
        return np.concatenate(F), np.concatenate(X), np.concatenate(I)

    def arrays(self):
        """t (K,), q (K, N), qdot (K, N), phase (K,), work (K, 2 or 3), Energy of (K,) arrays,
        contact forces (K, W, P) [N], friction forces (K, W, P, 3) [N], end-stop forces (K, L) [N or
        N m] (None for a chain without joint limits)."""
        cs = self.chunks
        cat = np.concatenate
        F = cat([np.zeros((c.t.size,) + self.force_shape) if c.forces is None else c.forces for c in cs])
        Ft = cat([np.zeros((c.t.size,) + self.force_shape + (3,)) if c.friction is None else c.friction for c in cs])
        S = cat([np.zeros((c.t.size, self.n_limits)) if c.stops is None else c.stops for c in cs]) \
            if self.n_limits else None
        return (cat([c.t for c in cs]), cat([c.q for c in cs]), cat([c.qdot for c in cs]),
                cat([c.phase for c in cs]), cat([c.work for c in cs]),
                Energy(*(cat([getattr(c.energy, f) for c in cs]) for f in Energy._fields)), F, Ft, S)
