"""Every option of simulate, validated once into one immutable record (the loop reads nothing else)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from numbers import Real

import numpy as np

from ..contact.walls import WALL_TYPES, is_compliant
from .auto import AUTO, METHODS, auto_choice
from .contact_filter import checked_filter
from .joint_limits import JOINT_LIMIT_MODES
from .prescribed import prescription

ACCUMULATION_MODES = ("rest", "step", "stop")


def _positive(name, v, allow_inf=False) -> float:
    if isinstance(v, bool) or not isinstance(v, Real) or not (v > 0) or (not allow_inf and not np.isfinite(v)):
        raise ValueError(f"simulate {name}={v!r} must be a positive number")
    return float(v)


def _count(name, v) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
        raise ValueError(f"simulate {name}={v!r} must be an integer >= 1")
    return int(v)


def _limit(name, v, check):
    """None (no limit) or the limit checked by ``check`` (_positive or _count)."""
    return None if v is None else check(name, v)


def _fraction(name, v) -> float:
    if isinstance(v, bool) or not isinstance(v, Real) or not 0.0 <= v <= 1.0:
        raise ValueError(f"simulate {name}={v!r} must be a number in [0, 1]")
    return float(v)


def _t_span(t_span) -> tuple[float, float]:
    ts = np.asarray(t_span, dtype=float) if not isinstance(t_span, str) else np.array([])
    if ts.shape != (2,) or not np.all(np.isfinite(ts)) or not ts[1] > ts[0]:
        raise ValueError(f"simulate t_span={t_span!r} must be (t0, t_end) in seconds with t_end > t0")
    return float(ts[0]), float(ts[1])


def _walls(walls) -> tuple:
    if isinstance(walls, WALL_TYPES):
        walls = (walls,)
    walls = tuple(walls)
    for k, w in enumerate(walls):
        if not isinstance(w, WALL_TYPES):
            raise ValueError(f"simulate walls[{k}]={w!r} is not a wall; use gi.Circle, gi.Sphere or gi.Plane")
    return walls


def _choice(name, v, choices, meaning: str):
    if v not in choices:
        raise ValueError(f"simulate {name}={v!r} must be {meaning}")
    return v


@dataclass(frozen=True)
class Settings:
    """The options of one run: simulate's arguments, validated once (the loop reads nothing else).

    Attributes
    ----------
    t0, t_end : [s], simulate's t_span
    walls : tuple of Circle, Sphere, Plane
    restitution : e in [0, 1] of the walls whose own ``restitution`` is None (wall_restitution)
    rtol, atol, method : the solver's tolerances and method (solve_ivp's meaning); method "auto" (simulate's
        argument) is DOP853 or Radau from the highest frequency (simulation.auto; resolve_auto; the record
        keeps the choice in Result.settings["method"] and why in ["method_choice"])
    output_dt : [s] or None: None stores every accepted step, a float uniform samples from the dense output
        (plus both sides of every impact)
    max_step : [s] the solver's largest step (inf: none)
    contact_tol : [m] gaps within the contact band max(2 contact_tol, L_q (atol + rtol max|q|)),
        L_q = 1 + 2 sum l_i, belong to one impact
    grazing_velocity : [m/s] an event with v_n >= -grazing_velocity is no impact
    penetration_tol : [m] a gap below -penetration_tol between events stops the run
    zeno_interval [s], zeno_count : the accumulation criteria (simulate's module docstring)
    max_impacts : the impact budget
    progress : None, True (a tqdm bar on stderr) or progress(t, n_impacts), called at most 5 times a second
        of wall time and once at the end
    inputs : applied generalised forces Q_in (gibbsimpact.dynamics.forces): a callable Q(t, q, qdot) -> (N,),
        a constant (N,), or {coordinate name: number or f(t, q, qdot)} (N m on an angle, N on a translation).
        With inputs or damped links the run integrates their work (Result.work) and energy_error measures
        E(t) - E(start) - (W(t) - W(start))
    joint_limit : "stop" (status "joint_limit" at a prismatic joint's end of range) or "impact" (an end-stop
        impact with joint_restitution in [0, 1], an ImpactRecord with wall -1; a stop that no longer
        rebounds then holds its joint with a force mu >= 0, Result.stop_forces, until mu falls to zero:
        gibbsimpact.simulation.joint_limits)
    accumulation : "rest" (an accumulation of impacts goes on in resting contact, Result.contact_forces,
        or at a held end stop; stepped where a point of a link's span takes part: contact_step), "step" (as "rest",
        and the first impact at a link's span starts a stepped phase already) or "stop" (status "zeno" there, or
        "joint_limit" at an end stop)
    link_contacts : True: the closest point of every flexible link to every wall is a contact candidate
        too; False: joints only, as in the published case studies
    in_step_check : simulate's private _in_step_check; False leaves solve_ivp's sign test at step ends only
    max_cpu_time [s], max_rhs_calls : None (no limit), or the CPU time (its thread's) and right-hand sides
        after which the run stops with "budget_exceeded" (simulation.budget; simulation.cost estimates them)
    method_choice : why method="auto" chose ``method``; "" if not auto
    prescribed : None (every coordinate free), or simulation.prescribed.Prescribed from simulate's
        {joint coordinate: f(t) -> (q, qdot, qddot)}: motions imposed by actuators (docs/api.md)
    contact_filter : None, or contact_filter(q) -> (C,) bool over the contact candidates (O1 .. O<P>, then
        "link i" columns, "body k"): a candidate that is False at q and not resting is no candidate there
        (no event, impact, resting contact or penetration check): a rule of the run where contacts may
        begin (simulation.contact_filter)
    cutoff_frequency : None, or [rad/s]: with method "Radau" (or "auto" choosing it), the modes of the
        linearised chain above it are left out of the error estimate of the compiled Radau steps, which
        then step over them and damp them: their energy goes to the energy audit's numerical part
        (gibbsimpact.simulation.compiled_radau; the phases it does not run, resting contact among them, run
        scipy's Radau with the same error weights, simulation.cutoff_radau; docs/theory.md §14.1)
    contact_step : [s] the step h of a time-stepping contact phase: with accumulation="rest", an accumulation of
        impacts in which a point of a link's span takes part is stepped by Moreau-Jean's scheme until every
        contact opens (gibbsimpact.simulation.stepping; docs/theory.md §15.5); with accumulation="step", already
        the first impact at a link's span
    """

    t0: float
    t_end: float
    walls: tuple
    restitution: float
    rtol: float
    atol: float
    method: str
    output_dt: float | None
    max_step: float
    contact_tol: float
    grazing_velocity: float
    penetration_tol: float
    zeno_interval: float
    zeno_count: int
    max_impacts: int
    progress: object
    inputs: object
    joint_limit: str
    joint_restitution: float
    accumulation: str
    link_contacts: bool
    in_step_check: bool
    max_cpu_time: float | None = None  # [s] of CPU; None: no limit
    max_rhs_calls: int | None = None  # right-hand sides; None: no limit
    method_choice: str = ""  # why method="auto" chose ``method`` (gibbsimpact.simulation.auto); "" if not auto
    prescribed: object = None  # simulation.prescribed.Prescribed, or None: every coordinate free
    contact_filter: object = None  # None, or contact_filter(q) -> (C,) bool (simulation.contact_filter)
    cutoff_frequency: float | None = None  # [rad/s] modes above it left out of Radau's error estimate; None: none
    contact_step: float = 1e-4  # [s] the step of a time-stepping contact phase (simulation.stepping)

    @classmethod
    def from_arguments(cls, t_span, walls, restitution, method, output_dt, progress, inputs, zeno_count,
                       max_impacts, joint_limit, joint_restitution, accumulation, link_contacts, prescribed=None,
                       state=None, contact_filter=None, **positive) -> Settings:
        """Validate simulate's options (each error names the argument and what it must be).

        prescribed : simulate's ``prescribed``, checked against state = (model, q0, qdot0)
        (simulation.prescribed)."""
        t0, t_end = _t_span(t_span)
        prescribed = None if prescribed is None else prescription(*state[:1], prescribed, (t0, t_end), *state[1:])
        walls = _walls(walls)
        if prescribed is not None and any(map(is_compliant, walls)):
            raise ValueError("simulate prescribed=... with a compliant wall (stiffness=...) is not supported yet: "
                             "give the walls no stiffness (Newton's law) or drive the joints by inputs")
        restitution = _fraction("restitution", restitution)
        _choice("method", method, METHODS, f"a solve_ivp method or 'auto'; use one of {', '.join(METHODS)}")
        in_step_check = bool(positive.pop("in_step_check", True))
        max_cpu_time = _limit("max_cpu_time", positive.pop("max_cpu_time", None), _positive)
        max_rhs_calls = _limit("max_rhs_calls", positive.pop("max_rhs_calls", None), _count)
        cutoff_frequency = _limit("cutoff_frequency", positive.pop("cutoff_frequency", None), _positive)
        values = {name: _positive(name, v, allow_inf=(name == "max_step")) for name, v in positive.items()}
        if output_dt is not None:
            output_dt = _positive("output_dt", output_dt)
        if not (progress is None or isinstance(progress, bool) or callable(progress)):
            raise ValueError(f"simulate progress={progress!r} must be None, True (a progress bar on stderr) "
                             "or a callable progress(t, n_impacts)")
        zeno_count, max_impacts = _count("zeno_count", zeno_count), _count("max_impacts", max_impacts)
        _choice("joint_limit", joint_limit, JOINT_LIMIT_MODES, "'stop' (end the run at a joint limit) or "
                "'impact' (an end-stop impact with joint_restitution)")
        joint_restitution = _fraction("joint_restitution", joint_restitution)
        if not isinstance(link_contacts, (bool, np.bool_)):
            raise ValueError(f"simulate link_contacts={link_contacts!r} must be True (links' closest points are "
                             "contact candidates too) or False (joints only)")
        _choice("accumulation", accumulation, ACCUMULATION_MODES, "'rest' (go on in resting contact; stepped where a "
                "link's span takes part), 'step' (step from the first impact at a link's span) or 'stop' (end the run "
                "with status 'zeno')")
        return cls(t0=t0, t_end=t_end, walls=walls, restitution=restitution, method=method, output_dt=output_dt,
                   progress=progress, inputs=inputs, zeno_count=zeno_count, max_impacts=max_impacts, joint_limit=joint_limit,
                   joint_restitution=joint_restitution, accumulation=accumulation,
                   link_contacts=bool(link_contacts), in_step_check=in_step_check, max_cpu_time=max_cpu_time,
                   max_rhs_calls=max_rhs_calls, prescribed=prescribed, contact_filter=checked_filter(contact_filter),
                   cutoff_frequency=cutoff_frequency, **values)

    def resolve_auto(self, model, q0) -> Settings:
        """These settings with method="auto" replaced by the method it chooses for model from q0 (N,)
        [m, rad], the reason in method_choice and the cutoff of the fast modes it steps over
        (gibbsimpact.simulation.auto.auto_choice); unchanged for any other method."""
        if self.method != AUTO:
            return self
        c = auto_choice(model, q0, (self.t0, self.t_end), self.max_step, self.rtol, self.cutoff_frequency)
        return dataclasses.replace(self, method=c.method, method_choice=c.reason, cutoff_frequency=c.cutoff_frequency)

    @property
    def wall_restitution(self) -> np.ndarray:
        """e of every wall (W,): its own ``restitution``, else the run's."""
        return np.array([self.restitution if w.restitution is None else w.restitution for w in self.walls])

    def record(self) -> dict:
        """The options as Result.settings stores them (plain values; inputs and progress are not kept)."""
        extra = {} if self.prescribed is None else {"prescribed": list(self.prescribed.names)}
        if self.contact_filter is not None:  # the rule itself is code: its name is kept
            extra["contact_filter"] = getattr(self.contact_filter, "__name__", type(self.contact_filter).__name__)
        return dict(
            method=self.method, method_choice=self.method_choice, rtol=self.rtol, atol=self.atol,
            restitution=self.restitution,
            wall_restitution=[w.restitution for w in self.walls], output_dt=self.output_dt, max_step=self.max_step,
            contact_tol=self.contact_tol, grazing_velocity=self.grazing_velocity,
            penetration_tol=self.penetration_tol, zeno_interval=self.zeno_interval, zeno_count=self.zeno_count,
            max_impacts=self.max_impacts, t_span=[self.t0, self.t_end], joint_limit=self.joint_limit,
            joint_restitution=self.joint_restitution, accumulation=self.accumulation,
            link_contacts=self.link_contacts, max_cpu_time=self.max_cpu_time, max_rhs_calls=self.max_rhs_calls,
            cutoff_frequency=self.cutoff_frequency, contact_step=self.contact_step,
            **extra,
        )
