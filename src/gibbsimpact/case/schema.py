"""The schema of case files: every key, its meaning, its unit and the range of every number.

docs/case-format.md is the same schema for readers; tests/case/test_schema.py holds the two to
each other. Units are part of the key names (``length_m``, ``t_end_s``, ``theta_1_deg``); a value
is never converted from a unit its key does not name. Key paths: gibbsimpact.case.keypaths.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..contact.walls import MAX_FRICTION
from ..dynamics.inputs import INPUT_KINDS
from ..model.elements import MAX_ELEMENTS
from ..model.joints import JOINT_KINDS
from ..model.modes import MODE_KINDS
from ..simulation.auto import METHODS
from .keypaths import schema_key
from .text import fmt

__all__ = ["Range", "RANGES", "MAX_SAMPLES", "MAX_MODE_FREQUENCY", "SOLVER_KEYS", "OVERRIDE_KEYS", "OUTPUT_DEFAULTS",
           "range_of"]


@dataclass(frozen=True)
class Range:
    """The closed interval [low, high] a numeric key must lie in, in the key's own unit.

    For an array key every component must lie in it, or with ``direction`` its
    length (a direction: only its sense matters). ``integer`` keys take TOML
    integers only; ``inf_ok`` also admits ``inf`` (no limit). ``why`` is the
    reason for the bounds, shown in the message.
    """

    low: float
    high: float
    unit: str = ""
    integer: bool = False
    inf_ok: bool = False
    direction: bool = False
    why: str = ""

    def __str__(self) -> str:
        text = f"[{fmt(self.low)}, {fmt(self.high)}]" + (f" {self.unit}" if self.unit else "")
        return text + (" or inf" if self.inf_ok else "")


_DEG = math.degrees(1.0)

#: Allowed range of every numeric key, by key path with array entries left out
#: (``links.length_m`` is the length of every link); ``*_<unit>`` stands for every
#: key of [initial.coordinates] / [initial.velocities] with that unit suffix.
#: docs/case-format.md lists the same ranges and their reasons. Wide enough for
#: any study from micrometre fibres to kilometre tethers, tight enough that
#: nothing overflows a double or exhausts memory.
RANGES = {
    "gravity_m_per_s2": Range(-1e4, 1e4, "m/s^2", why="1000 g per component"),
    "restitution": Range(0, 1, why="1 = elastic, 0 = plastic"),
    "links.length_m": Range(1e-6, 1e6, "m", why="a micrometre to 1000 km"),
    "links.mass_per_length_kg_per_m": Range(1e-12, 1e9, "kg/m"),
    "links.EI_N_m2": Range(1e-15, 1e15, "N m^2", why="a 1 um glass fibre to a bridge girder"),
    "links.rotary_inertia_kg_m": Range(0, 1e12, "kg m"),
    "links.cross_section_radius_m": Range(1e-6, 1e6, "m"),
    "links.modes.number": Range(1, 50, integer=True,
                                why="the modal integrals lose accuracy above mode 50"),
    "links.elements": Range(0, MAX_ELEMENTS, integer=True,
                            why="the explicit solvers' step shrinks as 1/elements^2"),
    "links.damping_ratio": Range(0, 10, why="of the link's first elastic mode; 1 = critical"),
    "links.bodies.mass_kg": Range(1e-12, 1e12, "kg"),
    "links.bodies.center_m": Range(-1e6, 1e6, "m"),
    "links.bodies.inertia_kg_m2": Range(0, 1e15, "kg m^2"),
    "links.bodies.inertia_products_kg_m2": Range(-5e14, 5e14, "kg m^2",
                                                 why="|J_xy| <= J_xx/2 with J_xx <= 1e15 (triangle inequality)"),
    "links.bodies.at_m": Range(0, 1e6, "m"),
    "links.joint.angle_deg": Range(-1e4 * _DEG, 1e4 * _DEG, "deg", why="1e4 rad"),
    "links.joint.angle_rad": Range(-1e4, 1e4, "rad"),
    "links.joint.half_length_m": Range(0, 1e6, "m"),
    "links.joint.range_m": Range(-1e6, 1e6, "m"),
    "links.joint.parent": Range(0, 10**6, integer=True, why="a link number"),
    "links.joint.at_m": Range(0, 1e6, "m"),
    "links.joint.rotation_xyz_deg": Range(-360.0, 360.0, "deg"),
    "base.position_m": Range(-1e6, 1e6, "m"),
    "base.angle_rad": Range(-1e4, 1e4, "rad"),
    "base.angle_deg": Range(-1e4 * _DEG, 1e4 * _DEG, "deg", why="1e4 rad"),
    "walls.radius_m": Range(1e-6, 1e6, "m"),
    "walls.center_m": Range(-1e6, 1e6, "m"),
    "walls.point_m": Range(-1e6, 1e6, "m"),
    "walls.normal": Range(1e-6, 1e6, direction=True, why="it is normalised on load"),
    "walls.restitution": Range(0, 1, why="1 = elastic, 0 = plastic"),
    "contact_filter.direction": Range(1e-6, 1e6, direction=True, why="it is normalised on load"),
    "contact_filter.clearance_m": Range(0, 1e6, "m"),
    "walls.friction": Range(0, MAX_FRICTION, why="Coulomb's coefficient; 0 = frictionless"),
    "walls.stiffness": Range(1e-6, 1e20, "N/m^p", why="k of the compliant law F_n = k g^p (1 + chi gdot / v0)"),
    "walls.exponent": Range(1, 10, why="p of the compliant law: 1.5 Hertz, 1 linear"),
    **{f"inputs.{key}": rng for key, rng in {
        # {F}: N_m on an angle coordinate, N on a length coordinate (_INPUT_KEYS).
        "value_N_m": Range(-1e12, 1e12, "N m", why="far beyond any machine, far from overflow"),
        "value_N": Range(-1e12, 1e12, "N", why="far beyond any machine, far from overflow"),
        "amplitude_N_m": Range(-1e12, 1e12, "N m"),
        "amplitude_N": Range(-1e12, 1e12, "N"),
        "offset_N_m": Range(-1e12, 1e12, "N m"),
        "offset_N": Range(-1e12, 1e12, "N"),
        "frequency_hz": Range(0, 1e6, "Hz", why="the solver resolves every period"),
        "phase_deg": Range(-360, 360, "deg"),
        "slope_N_m_per_s": Range(-1e12, 1e12, "N m/s"),
        "slope_N_per_s": Range(-1e12, 1e12, "N/s"),
        "start_s": Range(-1e9, 1e9, "s", why="about 30 years"),
        "end_s": Range(-1e9, 1e9, "s", inf_ok=True, why="about 30 years; inf: never held"),
        "target_rad": Range(-1e4, 1e4, "rad"),
        "target_deg": Range(-1e4 * _DEG, 1e4 * _DEG, "deg", why="1e4 rad"),
        "target_m": Range(-1e6, 1e6, "m"),
        "stiffness_N_m_per_rad": Range(0, 1e12, "N m/rad"),
        "stiffness_N_per_m": Range(0, 1e12, "N/m"),
        "damping_N_m_s_per_rad": Range(0, 1e12, "N m s/rad"),
        "damping_N_s_per_m": Range(0, 1e12, "N s/m"),
    }.items()},
    **{f"prescribed.{key}": rng for key, rng in {
        "Omega_rad_per_s": Range(-1e6, 1e6, "rad/s"),
        "Omega_m_per_s": Range(-1e6, 1e6, "m/s"),
        "T_s": Range(1e-9, 1e9, "s", why="a nanosecond to about 30 years"),
        "q0_rad": Range(-1e4, 1e4, "rad"), "q0_m": Range(-1e6, 1e6, "m"),
        "v_rad_per_s": Range(-1e6, 1e6, "rad/s"), "v_m_per_s": Range(-1e6, 1e6, "m/s"),
        "q_a_rad": Range(-1e4, 1e4, "rad"), "q_a_m": Range(-1e6, 1e6, "m"),
        "q_b_rad": Range(-1e4, 1e4, "rad"), "q_b_m": Range(-1e6, 1e6, "m"),
        "t_a_s": Range(-1e9, 1e9, "s", why="about 30 years"), "t_b_s": Range(-1e9, 1e9, "s", why="about 30 years"),
        "t_s": Range(-1e9, 1e9, "s", why="about 30 years"),
        "q_rad": Range(-1e4, 1e4, "rad"), "q_m": Range(-1e6, 1e6, "m"),
    }.items()},
    "initial.center_of_mass_m": Range(-1e6, 1e6, "m"),
    "initial.center_of_mass_velocity_m_per_s": Range(-1e6, 1e6, "m/s"),
    "initial.coordinates.*_m": Range(-1e6, 1e6, "m"),
    "initial.coordinates.*_rad": Range(-1e4, 1e4, "rad"),
    "initial.coordinates.*_deg": Range(-1e4 * _DEG, 1e4 * _DEG, "deg", why="1e4 rad"),
    "initial.velocities.*_m_per_s": Range(-1e6, 1e6, "m/s"),
    "initial.velocities.*_rad_per_s": Range(-1e6, 1e6, "rad/s"),
    "initial.velocities.*_deg_per_s": Range(-1e6 * _DEG, 1e6 * _DEG, "deg/s", why="1e6 rad/s"),
    "time.t_start_s": Range(-1e9, 1e9, "s", why="about 30 years"),
    "time.t_end_s": Range(-1e9, 1e9, "s", why="about 30 years"),
    "solver.rtol": Range(1e-13, 0.1, why="solve_ivp cannot go below 2.2e-14"),
    "solver.atol": Range(1e-20, 1.0),
    "solver.output_dt_s": Range(1e-15, 1e9, "s"),
    "solver.max_step_s": Range(1e-15, 1e9, "s", inf_ok=True),
    "solver.contact_tol_m": Range(1e-15, 1.0, "m"),
    "solver.grazing_velocity_m_per_s": Range(1e-15, 1.0, "m/s"),
    "solver.penetration_tol_m": Range(1e-15, 1.0, "m"),
    "solver.zeno_interval_s": Range(1e-15, 1e9, "s"),
    "solver.zeno_count": Range(1, 1e6, integer=True),
    "solver.max_impacts": Range(1, 1e6, integer=True, why="each impact keeps about 2 kB in memory"),
    "solver.joint_restitution": Range(0, 1, why="1 = elastic, 0 = plastic"),
    "solver.max_cpu_time_s": Range(1e-3, 1e9, "s", why="a millisecond to about 30 years"),
    "solver.max_rhs_calls": Range(1, 1e15, integer=True),
    "solver.cutoff_frequency_rad_per_s": Range(1e-3, 1e15, "rad/s"),
    "solver.contact_step_s": Range(1e-9, 1.0, "s"),
    "output.dpi": Range(10, 1200, integer=True, why="up to journal line-art resolution"),
    "output.animation_fps": Range(1, 100, integer=True, why="GIF frame delays are whole hundredths of a second"),
    "output.animation_speed": Range(1e-12, 1e12),
    "output.points_per_link": Range(2, 10_000, integer=True),
}

#: Samples (t_end - t_start) / output_dt, and solver steps at least
#: (t_end - t_start) / max_step, of one run: each sample is a row of every
#: array of the Result and of timeseries.csv (1e7 rows are ~1.5 GB in memory).
MAX_SAMPLES = 1e7
#: Largest natural frequency of an assumed mode [rad/s]: periods below ~6 ps
#: are lattice vibrations, not beam bending (Euler-Bernoulli needs
#: wavelengths far above the cross-section).
MAX_MODE_FREQUENCY = 1e12

#: Case-file key in [solver] -> (keyword of gibbsimpact.simulate, kind, description).
SOLVER_KEYS = {
    "method": ("method", "str", "solve_ivp method"),
    "rtol": ("rtol", "number", "relative tolerance"),
    "atol": ("atol", "number", "absolute tolerance"),
    "output_dt_s": ("output_dt", "number", "uniform output interval in s"),
    "max_step_s": ("max_step", "number", "largest solver step in s"),
    "contact_tol_m": ("contact_tol", "number", "gap within which joints share one impact, m"),
    "grazing_velocity_m_per_s": ("grazing_velocity", "number", "normal speed below which a touch is no impact, m/s"),
    "penetration_tol_m": ("penetration_tol", "number", "largest tolerated gap below zero between events, m"),
    "zeno_interval_s": ("zeno_interval", "number", "impact spacing counted as accumulating, s"),
    "zeno_count": ("zeno_count", "number", "consecutive close impacts that stop the run"),
    "max_impacts": ("max_impacts", "number", "impact budget"),
    "joint_limit": ("joint_limit", "str", "at the end of a prismatic joint's range: 'stop' the run or 'impact'"),
    "joint_restitution": ("joint_restitution", "number", "coefficient of restitution of the end-stop impacts"),
    "accumulation": ("accumulation", "str", "after an accumulation of impacts: 'rest' (resting contact) or 'stop'"),
    "link_contacts": ("link_contacts", "bool", "closest points of flexible links are contact candidates (true)"),
    "max_cpu_time_s": ("max_cpu_time", "number", "CPU seconds after which the run stops (status budget_exceeded)"),
    "max_rhs_calls": ("max_rhs_calls", "number", "right-hand sides after which the run stops (status "
                                                 "budget_exceeded)"),
    "cutoff_frequency_rad_per_s": ("cutoff_frequency", "number", "Radau: modes above it are left out of the error "
                                                             "estimate (stepped over and damped), rad/s"),
    "contact_step_s": ("contact_step", "number", "step of the time-stepping contact phases (a link's span at rest), s"),
}
#: [solver] string keys with a fixed set of values (and what each means).
_SOLVER_CHOICES = {
    "joint_limit": {"stop": "end the run with status joint_limit", "impact": "an end-stop impact"},
    "accumulation": {"rest": "go on in resting contact", "step": "step contact phases from the first impact at a "
                     "link's span", "stop": "end the run with status zeno"},
}
#: Keyword of Case.simulate that overrides a case-file key -> that key's path.
OVERRIDE_KEYS = {"t_end": "time.t_end_s", **{kw: f"solver.{key}" for key, (kw, _, _) in SOLVER_KEYS.items()}}
#: Keyword of a [solver] key -> its kind ("str", "bool", "number").
_SOLVER_KINDS = {kw: kind for kw, kind, _ in SOLVER_KEYS.values()}
_METHODS = METHODS  # the one solver list: simulation.flight.SOLVERS and "auto"

#: Output options with their defaults.
OUTPUT_DEFAULTS = {
    "directory": None,  # None: out/<case name>, relative to the working directory
    "plots": True,
    "animate": False,
    "dpi": 120,
    "animation_fps": 20,
    "animation_speed": 0.25,  # simulated seconds per second of animation
    "points_per_link": 41,
}

_TOP_KEYS = {
    "name": "case name (used for the default output directory)",
    "description": "free text",
    "gravity_m_per_s2": "gravitational acceleration (g1, g2, g3) in m/s^2",
    "restitution": "global coefficient of restitution in [0, 1]",
    "links": "[[links]] tables, link 1 first",
    "base": "[base] table: a fixed or free-flying base",
    "walls": "[[walls]] tables",
    "inputs": "[[inputs]] tables: applied torques and forces",
    "prescribed": "[[prescribed]] tables: joint coordinates that follow a given motion",
    "contact_filter": "[contact_filter] table: where a contact may begin",
    "initial": "[initial] table: initial state",
    "time": "[time] table: t_start_s, t_end_s",
    "solver": "[solver] table: integration settings",
    "output": "[output] table: what `gibbsimpact run` writes",
}
_LINK_KEYS = {
    "length_m": "link length l in m",
    "mass_per_length_kg_per_m": "mass per unit length mu in kg/m",
    "EI_N_m2": "bending stiffness in N m^2: a number, or [EI_y, EI_z]",
    "rotary_inertia_kg_m": "cross-section rotary inertia per length [j_x, j_y, j_z] in kg m",
    "cross_section_radius_m": "radius r of a solid circular section: j = mu r^2 (1/2, 1/4, 1/4)",
    "modes": "[[links.modes]] tables",
    "elements": "number of Hermite cubic finite elements (exclusive with modes)",
    "element_directions": "bending directions of the elements, ['y'] or ['y', 'z']",
    "damping_ratio": "structural damping ratio of the link's first elastic mode",
    "geometric_stiffening": "true (default): the bent link foreshortens, so spinning stiffens it; false: the "
                            "linear beam of the source papers",
    "joint": "[links.joint] table: the joint that carries this link (default: revolute)",
    "bodies": "[[links.bodies]] tables: rigid bodies attached to the link (payloads, a hub)",
}
#: Joint types of [links.joint] (gi.Revolute, gi.SlidingPrismatic, gi.FixedPrismatic) -> what each is.
_JOINT_TYPES = {code: kind.summary for code, kind in JOINT_KINDS.items()}
_JOINT_KEYS = {
    "type": "'R' (revolute, the default), 'Pa' (a carriage on the host), 'Pb' (a guide at the host's tip) or 'W' (a weld)",
    "angle_deg": "fixed angle gamma of a Pa, Pb or W joint in deg",
    "angle_rad": "fixed angle gamma of a Pa, Pb or W joint in rad",
    "half_length_m": "half-length c of a Pa carriage in m",
    "range_m": "[d_min, d_max] of a Pa or Pb joint in m",
    "parent": "number of the host link (1-based; 0: the base) of a tree, default: the link before",
    "at_m": "abscissa x_a on the host where the joint sits, in m (default: the host's tip)",
    "rotation_xyz_deg": "[a, b, c] in deg: the constant rotation Rx(a) Ry(b) Rz(c) of an R joint's axis or a W weld",
}
_BASE_KEYS = {
    "type": "'fixed', 'free' or 'planar'",
    "position_m": "base position (b1, b2) or (b1, b2, b3) in m",
    "angle_deg": "base angle beta about X3 in deg",
    "angle_rad": "base angle beta about X3 in rad",
}
#: Coordinates of a free base that a fixed base does not have.
_FREE_BASE_COORDINATES = ("X1", "X2", "X3", "theta_-1", "theta_0")
#: Coordinates of a free base that a planar floating base does not have.
_SPATIAL_COORDINATES = ("X3", "theta_-1", "theta_0")
#: [[inputs]] keys of each kind -> (parameter of InputSpec, required, default, factor to SI).
#: ``{F}`` is N_m on an angle coordinate and N on a length coordinate, ``{Q}`` rad or m.
_INPUT_KEYS = {
    "constant": {"value_{F}": ("value", True, None, 1.0)},
    "sine": {
        "amplitude_{F}": ("amplitude", True, None, 1.0),
        "frequency_hz": ("frequency", True, None, 1.0),
        "phase_deg": ("phase", False, 0.0, math.radians(1.0)),
        "offset_{F}": ("offset", False, 0.0, 1.0),
    },
    "ramp": {
        "slope_{F}_per_s": ("slope", True, None, 1.0),
        "start_s": ("start", False, 0.0, 1.0),
        "end_s": ("end", False, math.inf, 1.0),
    },
    "pd": {
        "target_{Q}": ("target", False, 0.0, 1.0),
        "target_deg": ("target", False, 0.0, math.radians(1.0)),  # angle coordinates only
        "stiffness_{F}_per_{Q}": ("stiffness", True, None, 1.0),
        "damping_{F}_s_per_{Q}": ("damping", False, 0.0, 1.0),
    },
}
_UNITS = {True: {"F": "N_m", "Q": "rad"}, False: {"F": "N", "Q": "m"}}


def _input_keys(kind: str, angle: bool) -> dict:
    """The [[inputs]] keys of ``kind`` on an angle (True) or length (False) coordinate."""
    keys = {k.format(**_UNITS[angle]): v for k, v in _INPUT_KEYS[kind].items()}
    if not angle:
        keys.pop("target_deg", None)
    return keys


_INPUT_TABLE_KEYS = {
    "coordinate": "coordinate the input acts on, e.g. 'theta_1'",
    "kind": f"one of {', '.join(INPUT_KINDS)}",
    **{key: f"{kind} input parameter" for kind in INPUT_KINDS for angle in (True, False)
       for key in _input_keys(kind, angle)},
}
_BODY_KEYS = {
    "mass_kg": "mass m of the body in kg",
    "center_m": "offset [c_x, c_y, c_z] of its centre of mass from the centreline point, link axes, in m",
    "inertia_kg_m2": "inertia about its centre [J_xx, J_yy, J_zz] in kg m^2 (link axes)",
    "inertia_products_kg_m2": "products of inertia [J_xy, J_xz, J_yz] in kg m^2 (default 0)",
    "at_m": "abscissa x_a on the link in m (default: the tip; 0: the joint, a hub)",
}
#: [[prescribed]] keys of each profile kind -> (parameter of gibbsimpact.profiles, required, default);
#: ``{Q}`` is rad on an angle coordinate and m on a length; t_s and q_{Q} of "samples" are arrays.
_PRESCRIBED_KEYS = {
    "spin_up": {"Omega_{Q}_per_s": ("Omega_s", True, None), "T_s": ("T_s", True, None),
                "q0_{Q}": ("q0", False, 0.0)},
    "constant_speed": {"q0_{Q}": ("q0", False, 0.0), "v_{Q}_per_s": ("v", True, None)},
    "point_to_point": {"q_a_{Q}": ("q_a", True, None), "q_b_{Q}": ("q_b", True, None), "t_a_s": ("t_a", True, None),
                       "t_b_s": ("t_b", True, None)},
    "samples": {"t_s": ("t", True, None), "q_{Q}": ("q", True, None)},
}


def _prescribed_keys(kind: str, angle: bool) -> dict:
    """The [[prescribed]] keys of profile ``kind`` on an angle (True) or length (False) coordinate."""
    return {k.format(Q="rad" if angle else "m"): v for k, v in _PRESCRIBED_KEYS[kind].items()}


_PRESCRIBED_TABLE_KEYS = {
    "coordinate": "joint coordinate that follows the profile, e.g. 'theta_1' or 'd_2'",
    "profile": f"one of {', '.join(_PRESCRIBED_KEYS)}",
    **{key: f"{kind} profile parameter" for kind in _PRESCRIBED_KEYS for angle in (True, False)
       for key in _prescribed_keys(kind, angle)},
}
_MODE_KEYS = {
    "kind": f"boundary conditions, one of {', '.join(MODE_KINDS)}",
    "direction": "deflection direction, 'y' (in-plane v) or 'z' (out-of-plane w)",
    "number": "which eigenfunction, 1 = fundamental",
}
#: The compliant law's keys of every wall kind (gibbsimpact.contact.compliant; without stiffness: Newton's law).
_COMPLIANT_KEYS = {
    "stiffness": "k in N/m^p of the compliant (Hunt-Crossley) contact law; absent: Newton's impulse law",
    "exponent": "p of the compliant law (default 1.5, Hertz)",
    "damping": "chi(e) of the compliant law: 'flores' (default) or 'lankarani-nikravesh'",
}
_WALL_KEYS = {
    "circle": {
        "type": "wall type",
        "radius_m": "radius R in m",
        "center_m": "centre (c1, c2) in m",
        "inside": "true: the chain stays inside (a container, the default); false: outside (an obstacle)",
        "restitution": "coefficient of restitution of this wall",
        "friction": "Coulomb friction coefficient of this wall (impacts and resting contact; default 0)",
        **_COMPLIANT_KEYS,
    },
    "sphere": {
        "type": "wall type",
        "radius_m": "radius R in m",
        "center_m": "centre (c1, c2, c3) in m",
        "inside": "true: the chain stays inside (a container, the default); false: outside (an obstacle)",
        "restitution": "coefficient of restitution of this wall",
        "friction": "Coulomb friction coefficient of this wall (impacts and resting contact; default 0)",
        **_COMPLIANT_KEYS,
    },
    "plane": {
        "type": "wall type",
        "point_m": "a point of the plane in m",
        "normal": "normal pointing into the free side (any length)",
        "restitution": "coefficient of restitution of this wall",
        "friction": "Coulomb friction coefficient of this wall (impacts and resting contact; default 0)",
        **_COMPLIANT_KEYS,
    },
}
_INITIAL_KEYS = {
    "coordinates": "[initial.coordinates]: q by coordinate name with unit suffix",
    "velocities": "[initial.velocities]: qdot by coordinate name with unit suffix",
    "center_of_mass_m": "place the mass centre of the undeformed chain here (sets X1, X2, X3)",
    "center_of_mass_velocity_m_per_s": "velocity of the mass centre (sets the rates of X1, X2, X3)",
}
_TIME_KEYS = {"t_start_s": "start time in s (default 0)", "t_end_s": "end time in s"}
_OUTPUT_KEYS = {
    "directory": "output directory (default out/<name>)",
    "plots": "write PNG figures",
    "animate": "write animation.gif",
    "dpi": "figure resolution in dots per inch",
    "animation_fps": "frames per second of the animation",
    "animation_speed": "simulated seconds per second of animation",
    "points_per_link": "sample points drawn along each link",
}

_NAME = r"(X[123]|theta_(?:-1|m1|0|[1-9][0-9]*)|d_[1-9][0-9]*|delta_[1-9][0-9]*_[1-9][0-9]*)"
_COORD = re.compile(rf"^{_NAME}_(m|rad|deg)$")
_RATE = re.compile(rf"^{_NAME}_(m_per_s|rad_per_s|deg_per_s)$")

#: How messages name the time and solver keys of a case file (the keywords of Case.simulate -> key paths).
_FILE_NAMES = {"t_start": "time.t_start_s", **OVERRIDE_KEYS}


def range_of(path: str) -> Range:
    """The entry of RANGES for a key path: entries left out (links[2].length_m -> links.length_m)."""
    return RANGES[schema_key(path)]
