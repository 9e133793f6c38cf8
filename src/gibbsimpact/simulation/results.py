"""Simulation results: trajectory samples, impact records, status (every status: gibbsimpact.simulation.status).

Produced by :func:`gibbsimpact.simulate`; never mutated by the core after
it is returned.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..dynamics.gibbs_appell import Energy, energies
from .status import STATUS_FINISHED



def energy_scale(model, E, work_span: float = 0.0) -> float:
    """The energy [J] that the relative energy errors divide by (docs/theory.md §9).

    scale = max(|E|, |T| + |V_g| + |V_s|, work_span, m |g| sum l), with E = T + V_g + V_s at the
    start of the span measured and work_span = max |W(t) - W(start)| over it [J]. The floor
    m |g| sum l (total mass, gravity, summed link lengths) gives a scale to a chain at rest at
    the gravity datum, whose E is about 0; it is datum-independent, so for a chain hanging far
    below the datum the scale is |E| and otherwise often the floor (case 1: 39.24 J, |E0| = 4.905 J).

    E : Energy of floats [J] (one state); returns a float > 0 [J].
    """
    floor = model.total_mass * float(np.linalg.norm(model.gravity)) * sum(ld.length for ld in model.link_data)
    return max(abs(E.total), abs(E.kinetic) + abs(E.gravity) + abs(E.strain), float(work_span), floor, 1e-300)


class ImpactRecord(NamedTuple):
    """One impact (possibly several simultaneous contacts, k of them).

    time : float [s]
    joints : tuple of int, length k, 1-based contact numbers: O_1 ... O_P (model.contact_point_names),
        then P + 1 + f for the closest point of the f-th flexible link, then the centres of the attached
        bodies with a centre offset (contacts.Contacts.names)
    wall : tuple of int, length k, index of each contact's wall in Result.walls;
        -1 for an end-stop impact of a prismatic joint (joints then holds the joint number i)
    normals : (k, 3) unit wall normals into the free region
    impulses : (k,) normal impulses Lambda [N s], >= 0
    v_before, v_after : (k,) normal velocities n.J qdot [m/s]
    restitution : (k,) coefficients used
    qdot_before, qdot_after : (N,) generalised velocities
    energy_before, energy_after : Energy [J]
    points : (k, 3) [m] or None: where each contact touched its wall (None in files of older versions)
    friction_impulses, slip_before, slip_after : (k, 3) or None: with friction on a wall
        (gibbsimpact.friction), the tangential impulse of each contact [N s] and its tangential
        velocity before and after [m/s], world vectors; None for a frictionless impact
    actuator_impulses : (n_p,) or None: with prescribed coordinates (Result.prescribed), the impulse each
        actuator takes to hold its qdot_p, Lambda_p = M_pf (qdot_f+ - qdot_f-) - W_p Lambda [N m s or N s]
    rounds : int, rounds of Newton's law the impact took (gibbsimpact.impact): 1
        when every contact carrying an impulse approached; more when an impulse
        pushed a contact that was moving away back into the wall
    """

    time: float
    joints: tuple
    wall: tuple
    normals: np.ndarray
    impulses: np.ndarray
    v_before: np.ndarray
    v_after: np.ndarray
    restitution: np.ndarray
    qdot_before: np.ndarray
    qdot_after: np.ndarray
    energy_before: Energy
    energy_after: Energy
    rounds: int = 1
    points: np.ndarray | None = None
    friction_impulses: np.ndarray | None = None
    slip_before: np.ndarray | None = None
    slip_after: np.ndarray | None = None
    actuator_impulses: np.ndarray | None = None


@dataclass(eq=False)
class Result:
    """Output of :func:`gibbsimpact.simulate`.

    Attributes
    ----------
    model : Model
    walls : tuple of walls
    t : (K,) sample times [s]; an impact time appears twice (before, after)
    q, qdot : (K, N) coordinates and velocities at the samples
    phase : (K,) int, index of the flight phase (0 before the first impact)
    impacts : list of ImpactRecord
    status : str, a key of gibbsimpact.simulation.status.STATUSES: "finished", "zeno", "max_impacts",
        "penetration", "failed", "joint_limit", "interrupted" (a KeyboardInterrupt or the CLI's
        SIGTERM: the samples up to there), "callback_failed", "budget_exceeded" (a limit of the run)
    message : str, why the run ended
    settings : dict, the solver settings used (method, rtol, atol, restitution, ...)
    nfev : int, right-hand-side evaluations; n_steps : int, accepted steps
    n_examined : int, steps whose dense output was searched for a gap dip (flight.py)
    wall_time : float [s]
    energy_error : float, PER FLIGHT PHASE: max over the flight phases of
        |E(t) - E(start) - (W(t) - W(start))| / energy_scale(start), "start" the phase's first
        sample; W = 0 without inputs and damping (then it is the energy drift). Each phase starts
        afresh, so it does not grow with the number of impacts: the drift of the whole run is
        ``energy_error_whole_run``. Same as ``energy_error_per_phase`` (kept under this name for
        existing scripts and files).
    energy_error_whole_run_J : float [J], signed: the energy balance error accumulated over the whole
        run, E(end) - E(t0) - (W(end) - W(t0)) less the energy that impacts with e < 1 or friction
        and contact-mode projections (gibbsimpact.resting) dissipate by design; impacts with e = 1 and
        no friction count (they should conserve E). Equal to E(end) - E(t0) - (W(end) - W(t0)) when
        every impact has e = 1 and no pair rests. NaN for results of files written before it existed.
    work : (K, 2) [J] or None: work of the inputs and of the structural damping
        since t_span[0] at every sample (None for an undriven, undamped run); (K, 3) with prescribed
        coordinates, the third column their actuators' work (int qdot_p . Q_p dt and Lambda_p . qdot_p at impacts)
    prescribed : tuple of str, the prescribed coordinates (simulate's ``prescribed``; () for none)
    effort : (K, n_p) or None: the generalised force Q_p each prescribed coordinate's actuator applies at
        every sample [N m on an angle, N on a length] (formulation §16), columns in ``prescribed``'s order
    contact_forces : (K, W, C) [N] or None: the normal force of wall w on contact point
        O_(j+1) at every sample while the pair is in resting contact (gibbsimpact.resting),
        0 elsewhere (impulses of impacts are in ``impacts``); None for results of older files.
        C = P joint points, then, when a span point rested (contact.span_resting), one column per
        link column of the run (contacts.link_column_cells: one per cell of a link, "link 1.2" for
        cell 2 of link 1): the force on that cell's resting span point
    contact_abscissae : (K, W, C) [m] or None: where on its link the span point of each contact_forces column
        acts while it rests (its abscissa x along link i of the column "link i.c", measured from O_i; the point
        is then the material point at x, gibbsimpact.dynamics.link_points.material_points); NaN for the joint
        points and for pairs that do not rest; None when no span point rested
    friction_forces : (K, W, C, 3) [N] or None: the tangential (friction) force of wall w on
        O_(j+1) while the pair rests on a wall with friction (sticking or slipping); None when
        no wall has friction
    resting_time : float [s], the simulated time spent with at least one pair in resting contact
    stop_forces : (K, L) [N, or N m] or None: the force mu >= 0 of joint limit k (the order of
        gibbsimpact.simulation.joint_limits.joint_limits: per prismatic joint its lower bound, its
        upper bound, then a carriage's bound on a Pb host) along its normal n while its end stop
        holds the joint (joint_limit="impact", accumulation="rest"; docs/theory.md §13), 0 elsewhere;
        None for a chain without prismatic joints (and results of older files)
    compliant_forces : (K, W, C) [N] or None: the normal force F_n of compliant wall w (a wall with a
        stiffness: gibbsimpact.simulation.compliant) on contact column c (the joints O_1 .. O_P, then the
        closest point of each flexible link, as ImpactRecord.joints numbers them) at every sample; None
        for a run without compliant walls
    compliant_points : (K, W, C, 3) [m] or None: where each pair's contact point is while the pair is in
        compliant contact (for a link column: the link's material point closest to the wall, deflection
        included), NaN elsewhere
    compliant_integrals : (K, 3 + N) or None: since t_span[0], the work of the compliant contacts'
        damping [J] and friction [J] (both <= 0), their normal impulse sum_j int F_n dt [N s], and their
        generalised impulse int sum_j J_j^T (n F_n + F_t) dt (N,)
    compliant_contacts : list of CompliantContact (gibbsimpact.simulation.compliant): every contact of a
        pair on a compliant wall, its start and end events and approach speed v_0; [] without compliant walls
    base_chart : (K, 3, 3) or None: R_ref of every sample's chart of a spatial free base (formulation §18,
        docs/theory.md §1.1): the base frame is T_1 = Trans(X) R_ref Rx(theta_-1) Ry(theta_0) Rz(theta_1), so q
        alone no longer fixes the orientation once a run re-charted; None when it never did (R_ref = I).
        The angles theta_-1, theta_0, theta_1 in q are the current chart's and jump at a re-chart;
        use base_orientation for a chart-free orientation, chart_segments / model_at for kinematics
    charts : list of ChartChange (gibbsimpact.simulation.charts): every re-chart, its time, the index of the
        sample after it (the sample before has the same time), the old angles and the new R_ref
    episodes : list of Episode (property, computed from the above at its first use;
        gibbsimpact.simulation.episodes, docs/theory.md §14.7): the collision episodes, each the
        impacts and resting phases of one meeting of the chain with the walls. The chain is the body
        (contacts of several links or walls that overlap in time are one episode); a pair is engaged
        from its impact or resting force until its gap leaves the contact band, and the episode takes
        in what starts within one period of the struck link's slowest vibration (0 for a point of a
        rigid part: there each Newton impact is an episode). Each gives its start and end, impulse,
        energy lost E(start) - E(end), effective restitution (the rigid chain's normal velocity of the
        first contact from the generalised momenta after, gravity and inputs removed, over before: e for
        one impact of a rigid chain, the angular-momentum ratio for an arm on a pivot; non_contact_share says
        how impulsive the episode was), largest impulse and resting force, and deepest penetration (below
        contact_tol with Newton's law)
    """

    model: object
    walls: tuple
    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    phase: np.ndarray
    impacts: list
    status: str
    message: str
    settings: dict = field(default_factory=dict)
    nfev: int = 0
    n_steps: int = 0
    n_examined: int = 0
    wall_time: float = 0.0
    energy_error: float = float("nan")
    energy_error_whole_run_J: float = float("nan")
    work: np.ndarray | None = None
    contact_forces: np.ndarray | None = None
    friction_forces: np.ndarray | None = None
    contact_abscissae: np.ndarray | None = None
    resting_time: float = 0.0
    stop_forces: np.ndarray | None = None
    prescribed: tuple = ()
    effort: np.ndarray | None = None
    compliant_forces: np.ndarray | None = None
    compliant_points: np.ndarray | None = None
    compliant_integrals: np.ndarray | None = None
    compliant_contacts: list = field(default_factory=list)
    base_chart: np.ndarray | None = None
    charts: list = field(default_factory=list)
    _energy_cache: Energy | None = field(default=None, repr=False)
    # Not an __init__ argument: dataclasses.replace (new samples or forces) must not carry it over.
    _episodes_cache: list | None = field(default=None, init=False, repr=False)

    def __repr__(self) -> str:
        """One line: status, time span, samples, N, impacts (the first few times), energy error, cost."""
        t0, t1 = (float(self.t[0]), float(self.t[-1])) if len(self.t) else (float("nan"), float("nan"))
        n_imp = len(self.impacts)
        times = ", ".join(f"{r.time:.6g}" for r in self.impacts[:3]) + (", ..." if n_imp > 3 else "")
        impacts = f"{n_imp} impacts" + (f" at t = {times} s" if n_imp else "")
        status = self.status
        if self.status != STATUS_FINISHED:
            msg = str(self.message)
            status += f" ({msg[:77] + '...' if len(msg) > 80 else msg})"
        return (f"Result({status}; t = {t0:.6g} ... {t1:.6g} s, {len(self.t)} samples, N = {self.q.shape[-1]}; "
                f"{impacts}; energy_error_whole_run = {self.energy_error_whole_run:.2e}, "
                f"energy_error_per_phase = {self.energy_error:.2e}; nfev = {self.nfev}, "
                f"wall_time = {self.wall_time:.3g} s)")

    @property
    def success(self) -> bool:
        return self.status == STATUS_FINISHED

    @property
    def has_resting_forces(self) -> bool:
        """Whether some wall pair rested, some end stop held its joint or some pair pressed on a compliant wall
        (contact_forces.csv, the contact-force figure)."""
        return any(F is not None and np.any(F) for F in (self.contact_forces, self.stop_forces, self.compliant_forces))

    @property
    def energy_error_per_phase(self) -> float:
        """Max over the flight phases of the relative energy balance error, each phase measured from its own
        start (the field ``energy_error``). Not the drift over the run: see ``energy_error_whole_run``."""
        return self.energy_error

    @property
    def energy_scale(self) -> float:
        """energy_scale(model, E(t0), max |W(t) - W(t0)|) [J]: what ``energy_error_whole_run`` divides by."""
        E = self.energy()
        W = self.work.sum(axis=1) if self.work is not None else np.zeros(1)
        return energy_scale(self.model, Energy(*(float(a[0]) for a in E)), float(np.max(np.abs(W - W[0]))))

    @property
    def energy_error_whole_run(self) -> float:
        """|energy_error_whole_run_J| / energy_scale: the relative energy balance error from t0 to the last
        sample, impacts with e = 1 included. This, not ``energy_error_per_phase``, is the drift of the run
        (case 1 over 19 s: 1.6e-9 against 3.7e-10 per phase)."""
        return abs(self.energy_error_whole_run_J) / self.energy_scale

    def energy_audit(self) -> dict:
        """Where the energy went from t0 to the last sample [J], signed (gained > 0): E(end) - E(t0) =
        inputs + damping_and_friction + actuators + impacts + stepped_contacts + numerical, with

        * inputs, damping_and_friction: the work of the inputs and of the structural damping and resting
          friction (Result.work; 0 for an undriven, undamped run);
        * actuators: the work of the prescribed coordinates' actuators, int qdot_p . Q_p dt plus
          Lambda_p . qdot_p at the impacts (Result.work[:, 2]; 0 without prescribed coordinates);
        * impacts: the energy jumps of the impacts that dissipate by design (e < 1, a friction impulse),
          less the actuators' impulse work Lambda_p . qdot_p in them (counted under actuators);
        * stepped_contacts: the work of the contact impulses and position projections of the time-stepping
          contact phases (Result.settings["stepped_contact_work_J"], simulation.stepping; 0 without them);
        * numerical: the rest, energy_error_whole_run_J: what the integrator (and the contact-mode
          projections) added or removed. Explicit methods keep it at ~rtol; implicit ones (Radau, BDF)
          damp the modes they step over, so it is negative and can reach the energy of those modes
          (docs/theory.md: when that matters).
        """
        W = self.work[-1] - self.work[0] if self.work is not None and len(self.work) else np.zeros(2)
        held = [self.model.coordinate_names.index(name) for name in self.prescribed]
        impacts = sum(float(r.energy_after.total - r.energy_before.total)
                      - (float(r.actuator_impulses @ r.qdot_after[held]) if r.actuator_impulses is not None else 0.0)
                      for r in self.impacts
                      if not (np.all(np.asarray(r.restitution) == 1.0)
                              and (r.friction_impulses is None or not np.any(r.friction_impulses))))
        return {"inputs": float(W[0]), "damping_and_friction": float(W[1]),
                "actuators": float(W[2]) if len(W) > 2 else 0.0, "impacts": impacts,
                "stepped_contacts": float(self.settings.get("stepped_contact_work_J", 0.0)),
                "numerical": float(self.energy_error_whole_run_J)}

    def chart_segments(self) -> list:
        """[(model, slice of samples)]: the runs of consecutive samples in one chart of the free base, each with
        the model of that chart (Model.with_base_chart; Result.model itself when the run never re-charted).
        Any kinematics of q[k] must use the model of k's segment."""
        K = len(self.t)
        if self.base_chart is None:
            return [(self.model, slice(0, K))]
        starts = [0] + [c.sample for c in self.charts if 0 < c.sample < K]
        return [(self.model.with_base_chart(self.base_chart[a]), slice(a, b)) for a, b in zip(starts, starts[1:] + [K])]

    def model_at(self, k: int):
        """The model of sample k's chart (chart_segments): kinematics of q[k] are model_at(k)'s."""
        if self.base_chart is None:
            return self.model
        return self.model.with_base_chart(self.base_chart[k])

    def per_chart(self, fn, *arrays):
        """fn(model, *(a[segment] for a in arrays)) over the chart segments, joined along the first axis
        (a NamedTuple result field by field): a batch kinematics function of every sample in its own chart."""
        parts = [fn(m, *(a[sl] for a in arrays)) for m, sl in self.chart_segments()]
        if len(parts) == 1:
            return parts[0]
        if isinstance(parts[0], tuple):
            return type(parts[0])(*(np.concatenate(f) for f in zip(*parts)))
        return np.concatenate(parts)

    @property
    def base_orientation(self) -> np.ndarray | None:
        """(K, 4) unit quaternions [w, x, y, z] of the free base frame's world orientation R_ref Rx Ry Rz at every
        sample, chart-free and continuous (each sign chosen to follow the last; w >= 0 at the first sample);
        None for a base that is not spatial-free (docs/theory.md §1.1)."""
        from ..dynamics.base_chart import base_orientation_matrix, quaternion

        if self.model.chain.base != "free":
            return None
        return quaternion(base_orientation_matrix(self.model, self.q, self.base_chart))

    def energy(self) -> Energy:
        """Energy(kinetic, gravity, strain, total), each an array (K,) [J]."""
        if self._energy_cache is None:
            self._energy_cache = self.per_chart(energies, self.q, self.qdot)
        return self._energy_cache

    def joint_positions(self) -> np.ndarray:
        """O_1 ... O_(n+1) at every sample, shape (K, n+1, 3) [m]."""
        from ..dynamics.kinematics import joint_positions_batch

        return self.per_chart(joint_positions_batch, self.q)

    def joint_velocities(self) -> np.ndarray:
        """Absolute joint velocities at every sample, shape (K, n+1, 3) [m/s]."""
        from ..dynamics.kinematics import joint_velocities_batch

        return self.per_chart(joint_velocities_batch, self.q, self.qdot)

    @property
    def episodes(self) -> list:
        """The collision episodes, a list of gibbsimpact.simulation.episodes.Episode (computed at the first use)."""
        from .episodes import episodes

        if self._episodes_cache is None:
            self._episodes_cache = episodes(self)
        return self._episodes_cache

    @property
    def impact_times(self) -> np.ndarray:
        """(n_impacts,) [s]."""
        return np.array([r.time for r in self.impacts])

    # -- output (thin delegations to gibbsimpact.io and gibbsimpact.plotting) --
    def to_csv(self, directory, every: int = 1) -> dict:
        """Write ``timeseries.csv`` and ``impacts.csv`` into ``directory``; returns their paths.

        See :func:`gibbsimpact.io.to_csv` for the columns and ``every`` (every K-th sample only).
        """
        from ..io.result_files import to_csv

        return to_csv(self, directory, every)

    def save(self, path, metadata: dict | None = None):
        """Store everything in an NPZ archive; ``gibbsimpact.load_result(path)`` reads it back exactly."""
        from ..io.result_files import save_result

        return save_result(self, path, metadata)

    def summary(self, case=None) -> dict:
        """JSON-ready summary: versions, settings, impacts, energies, status, counters."""
        from ..io.result_files import summary

        return summary(self, case)

    def plot(self, which=None, ax=None, directory=None, dpi: int = 120, case_name=None, n_points: int = 41,
             kinds=None):
        """Draw figures (matplotlib); one Figure for a name, {name: Figure} otherwise.

        which : a name from gibbsimpact.plotting.FIGURES or OPTIONAL_FIGURES ("angles", "modes",
            "deflection", "joint_positions", "joint_velocities", "energy", "contact_forces",
            "configurations", "trajectory") -> that Figure (None for "modes" and "deflection" of a
            rigid chain, "contact_forces" without resting contact); a list of names, or None for
            all, -> {name: Figure}.
        ax : with a single ``which``, a matplotlib Axes (or a sequence of them) to draw into
            instead of a new figure; the Figure holding it is returned. What one or several
            Axes receive is documented by each gibbsimpact.plotting.plot_* function.
        directory : if given, also save each figure as <directory>/<name>.png.
        kinds : the former name of a list ``which`` (kept for existing scripts).

        The figures are ``matplotlib.figure.Figure`` objects that pyplot does not hold, so
        repeated calls (a notebook cell run again and again) leave nothing open; in Jupyter
        a returned Figure is shown inline.
        """
        from ..plotting.figures import plot_one, plot_result, save_figures

        if kinds is not None:
            if which is not None:
                raise ValueError("Result.plot: give the figures as which= or kinds=, not both")
            which = list(kinds)
        if isinstance(which, str):
            fig = plot_one(self, which, ax=ax, case_name=case_name, n_points=n_points)
            if directory is not None and fig is not None:
                save_figures({which: fig}, directory, dpi=dpi, close=False)
            return fig
        if ax is not None:
            raise ValueError("Result.plot: ax= draws one figure; name it with which='angles' (or another of "
                             "gibbsimpact.plotting.FIGURES)")
        figs = plot_result(self, kinds=which, case_name=case_name, n_points=n_points)
        if directory is not None:
            save_figures(figs, directory, dpi=dpi, close=False)
        return figs
