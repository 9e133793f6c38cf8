"""Case files: everything one run needs, in TOML, validated in one pass.

``load_case(path)`` reads a ``cases/*.toml`` file (format: docs/case-format.md),
checks every key and collects *all* problems into one :class:`CaseError`
whose message names each problem by its key path (``links[2].EI_N_m2``,
``walls[1].radius_m``, ``initial.coordinates.theta_1_deg``). Array entries are
numbered from 1 in key paths, like links and joints.

Units are part of the key names (``length_m``, ``t_end_s``, ``theta_1_deg``);
a value is never silently converted from a unit the key does not name.

A link's ``[links.joint]`` table makes its joint prismatic (``type = "Pa"`` or
``"Pb"``, ``range_m``, ``angle_deg``, ``half_length_m``; revolute without one);
the variable of a prismatic joint i is ``d_i`` [m] (``d_2_m`` in
``[initial.coordinates]``, forces in N on it in ``[[inputs]]``), and
``[solver]`` ``joint_limit`` / ``joint_restitution`` say what its end stops do.
``[base]`` ``type = "planar"`` is a floating base in the X1-X2 plane.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from decimal import Decimal
from numbers import Integral, Real
from pathlib import Path

import numpy as np
import scipy.linalg as sl

from ..dynamics.gibbs_appell import SingularMassMatrixError, forward_dynamics
from ..model.elements import MAX_ELEMENTS
from ..dynamics.inputs import INPUT_KINDS, InputSpec, is_angle_coordinate, named_inputs
from ..simulation.joint_limits import joint_limits, limit_gaps
from ..model import Chain, FixedBase, FixedPrismatic, Link, Model, Revolute, SlidingPrismatic
from ..model.modes import MODE_DIRECTIONS, MODE_KINDS, Mode, natural_frequency
from ..contact.walls import MAX_FRICTION, Circle, Plane, Sphere, describe

__all__ = ["Case", "CaseError", "load_case", "case_from_dict", "SOLVER_KEYS", "RANGES", "Range"]

_MISSING = object()
_BAD = object()


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
        text = f"[{_fmt(self.low)}, {_fmt(self.high)}]" + (f" {self.unit}" if self.unit else "")
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
    "links.joint.angle_deg": Range(-1e4 * _DEG, 1e4 * _DEG, "deg", why="1e4 rad"),
    "links.joint.angle_rad": Range(-1e4, 1e4, "rad"),
    "links.joint.half_length_m": Range(0, 1e6, "m"),
    "links.joint.range_m": Range(-1e6, 1e6, "m"),
    "base.position_m": Range(-1e6, 1e6, "m"),
    "base.angle_rad": Range(-1e4, 1e4, "rad"),
    "base.angle_deg": Range(-1e4 * _DEG, 1e4 * _DEG, "deg", why="1e4 rad"),
    "walls.radius_m": Range(1e-6, 1e6, "m"),
    "walls.center_m": Range(-1e6, 1e6, "m"),
    "walls.point_m": Range(-1e6, 1e6, "m"),
    "walls.normal": Range(1e-6, 1e6, direction=True, why="it is normalised on load"),
    "walls.restitution": Range(0, 1, why="1 = elastic, 0 = plastic"),
    "walls.friction": Range(0, MAX_FRICTION, why="Coulomb's coefficient; 0 = frictionless"),
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
}
#: [solver] string keys with a fixed set of values (and what each means).
_SOLVER_CHOICES = {
    "joint_limit": {"stop": "end the run with status joint_limit", "impact": "an end-stop impact"},
    "accumulation": {"rest": "go on in resting contact", "stop": "end the run with status zeno"},
}
#: Keyword of Case.simulate that overrides a case-file key -> that key's path.
OVERRIDE_KEYS = {"t_end": "time.t_end_s", **{kw: f"solver.{key}" for key, (kw, _, _) in SOLVER_KEYS.items()}}
#: Keyword of a [solver] key -> its kind ("str", "bool", "number").
_SOLVER_KINDS = {kw: kind for kw, kind, _ in SOLVER_KEYS.values()}
_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA", "RK23")

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
    "joint": "[links.joint] table: the joint that carries this link (default: revolute)",
}
#: Joint types of [links.joint] (gi.Revolute, gi.SlidingPrismatic, gi.FixedPrismatic) -> what each is.
_JOINT_TYPES = {
    "R": "revolute: the link turns by theta_i at the host's tip",
    "Pa": "sliding prismatic: a carriage fixed to the link runs along the host, d_i",
    "Pb": "fixed prismatic: the link slides through a guide at the host's tip, d_i",
}
_JOINT_KEYS = {
    "type": "'R' (revolute, the default), 'Pa' (a carriage on the host) or 'Pb' (a guide at the host's tip)",
    "angle_deg": "fixed angle gamma of a Pa or Pb joint in deg",
    "angle_rad": "fixed angle gamma of a Pa or Pb joint in rad",
    "half_length_m": "half-length c of a Pa carriage in m",
    "range_m": "[d_min, d_max] of a Pa or Pb joint in m",
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
_MODE_KEYS = {
    "kind": f"boundary conditions, one of {', '.join(MODE_KINDS)}",
    "direction": "deflection direction, 'y' (in-plane v) or 'z' (out-of-plane w)",
    "number": "which eigenfunction, 1 = fundamental",
}
_WALL_KEYS = {
    "circle": {
        "type": "wall type",
        "radius_m": "radius R in m",
        "center_m": "centre (c1, c2) in m",
        "restitution": "coefficient of restitution of this wall",
        "friction": "Coulomb friction coefficient of this wall (impacts and resting contact; default 0)",
    },
    "sphere": {
        "type": "wall type",
        "radius_m": "radius R in m",
        "center_m": "centre (c1, c2, c3) in m",
        "restitution": "coefficient of restitution of this wall",
        "friction": "Coulomb friction coefficient of this wall (impacts and resting contact; default 0)",
    },
    "plane": {
        "type": "wall type",
        "point_m": "a point of the plane in m",
        "normal": "normal pointing into the free side (any length)",
        "restitution": "coefficient of restitution of this wall",
        "friction": "Coulomb friction coefficient of this wall (impacts and resting contact; default 0)",
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


class CaseError(ValueError):
    """A case file is invalid. ``problems`` lists (key path, message) for every problem found."""

    def __init__(self, source: str, problems: list[tuple[str, str]]):
        self.source = source
        self.problems = list(problems)
        if len(self.problems) == 1:
            path, msg = self.problems[0]
            text = f"{source}: {path}: {msg}" if path else f"{source}: {msg}"
        else:
            lines = [f"{source}: {len(self.problems)} problems:"]
            lines += [f"  {p}: {m}" if p else f"  {m}" for p, m in self.problems]
            text = "\n".join(lines)
        super().__init__(text)


def _fmt(x) -> str:
    """A number as short text: 1e-06 -> '1e-6', 10000.0 -> '1e4', an int of 401 digits -> '1e400'."""
    def short(text):
        return re.sub(r"e\+?(-?)0*(\d)", r"e\1\2", text)

    if isinstance(x, int) and not isinstance(x, bool):
        return short(format(Decimal(x).normalize(), ".6g")) if abs(x) >= 10**16 else str(x)
    plain = short(f"{x:.6g}")
    mantissa, _, exponent = f"{x:.5e}".partition("e")
    sci = short(f"{mantissa.rstrip('0').rstrip('.')}e{exponent}") if math.isfinite(x) else plain
    return sci if len(sci) + 1 < len(plain) else plain


def _type_name(v) -> str:
    if isinstance(v, bool):
        return f"the boolean {str(v).lower()}"
    if isinstance(v, str):
        return f"the string {v!r}"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, list):
        return f"an array of {len(v)}"
    if isinstance(v, Real):
        return f"the number {_fmt(v)}"
    return type(v).__name__


def _join(path: str, key) -> str:
    if isinstance(key, int):
        return f"{path}[{key + 1}]"
    return f"{path}.{key}" if path else str(key)


def _range_of(path: str) -> Range:
    """The entry of RANGES for a key path: array entries dropped (links[2].length_m -> links.length_m)."""
    return RANGES[re.sub(r"\[\d+\]", "", path)]


def _is_number(v) -> bool:
    return isinstance(v, Real) and not isinstance(v, bool)


def _too_large(x) -> bool:
    """An integer beyond the double range (TOML integers are unbounded)."""
    try:
        float(x)
    except OverflowError:
        return True
    return False


class _Reader:
    """Collects problems while reading nested TOML tables."""

    def __init__(self):
        self.problems: list[tuple[str, str]] = []

    def add(self, path: str, message: str):
        self.problems.append((path, message))

    def table(self, value, path: str, allowed: dict, what: str = "a table") -> dict | None:
        """Check that value is a table and report its unknown keys."""
        if not isinstance(value, dict):
            self.add(path, f"expected {what}, got {_type_name(value)}")
            return None
        for key in value:
            if key not in allowed:
                close = difflib.get_close_matches(key, list(allowed), n=1, cutoff=0.6)
                hint = f"did you mean {close[0]!r}?" if close else f"allowed keys: {', '.join(allowed)}"
                self.add(_join(path, key), f"unknown key ({hint})")
        return value

    def get(self, tbl: dict, path: str, key: str, kind: str, *, required=False, default=None, what=""):
        """Read tbl[key] as ``kind``; return default when absent, _BAD on a problem."""
        p = _join(path, key)
        if key not in tbl:
            if required:
                self.add(p, f"missing ({what})" if what else "missing")
                return _BAD
            return default
        return self.value(tbl[key], p, kind)

    def value(self, v, p: str, kind: str, rng: Range | None = None):
        """v read as ``kind`` ("str", "bool", "number", "vector<n>"); numbers and
        vectors are checked against ``rng``, by default RANGES of the key path p."""
        def bad(expected):
            self.add(p, f"expected {expected}, got {_type_name(v)}")
            return _BAD

        if kind == "str":
            return v if isinstance(v, str) else bad("a string")
        if kind == "bool":
            return v if isinstance(v, bool) else bad("true or false")
        rng = rng or _range_of(p)  # every numeric key has a range: a KeyError here is a bug
        if kind == "number":
            if rng.integer and not (isinstance(v, Integral) and not isinstance(v, bool)):
                return bad("an integer")
            if not _is_number(v):
                return bad("a number")
            if not self.in_range(p, v, rng):
                return _BAD
            return int(v) if rng.integer else float(v)
        m = re.fullmatch(r"vector(\d)", kind)
        if m:
            n = int(m.group(1))
            if not isinstance(v, list) or len(v) != n or not all(_is_number(x) for x in v):
                return bad(f"an array of {n} numbers")
            return [float(x) for x in v] if self.in_range(p, v, rng) else _BAD
        raise AssertionError(kind)

    def in_range(self, p: str, v, rng: Range) -> bool:
        """Check a number (or each component, or the length of a direction) against rng; add the problem."""
        values = v if isinstance(v, list) else [v]
        shown = f"[{', '.join(_fmt(x) for x in v)}]" if isinstance(v, list) else _fmt(v)
        why = f" ({rng.why})" if rng.why else ""
        if any(_too_large(x) for x in values):
            self.add(p, f"too large for a number: must be in {rng}{why}, got {shown}")
            return False
        xs = [float(x) for x in values]
        if rng.direction:
            if not any(xs):
                self.add(p, "is the zero vector; give a direction")
                return False
            length = math.hypot(*xs) if all(math.isfinite(x) for x in xs) else math.nan
            if not rng.low <= length <= rng.high:
                self.add(p, f"must have a length in {rng}{why}, got {shown}")
                return False
            return True
        ok = all((rng.low <= x <= rng.high) or (rng.inf_ok and x == math.inf) for x in xs)
        if not ok:
            every = "every component " if isinstance(v, list) else ""
            self.add(p, f"{every}must be in {rng}{why}, got {shown}")
        return ok


@dataclass(frozen=True, eq=False)
class Case:
    """A validated case: the model, the initial state, the walls and the settings of one run.

    Attributes
    ----------
    name : str
    model : Model
    q0, qdot0 : (N,) initial coordinates [m, rad] and velocities [m/s, rad/s]
    t_span : (t_start, t_end) [s]
    walls : tuple of Circle, Sphere, Plane
    restitution : float, global coefficient of restitution (walls without their own)
    solver : dict of keyword arguments for :func:`gibbsimpact.simulate`
        (only those the case file sets; simulate's defaults fill the rest)
    output : dict of output options (see OUTPUT_DEFAULTS)
    description : str
    path : Path or None, the file it came from
    source : dict, the parsed TOML table
    inputs : tuple of gibbsimpact.inputs.InputSpec, the [[inputs]] tables in SI units
        (simulate_kwargs turns them into simulate's ``inputs``)
    """

    name: str
    model: Model
    q0: np.ndarray
    qdot0: np.ndarray
    t_span: tuple
    walls: tuple
    restitution: float
    solver: dict = field(default_factory=dict)
    output: dict = field(default_factory=lambda: dict(OUTPUT_DEFAULTS))
    description: str = ""
    path: Path | None = None
    source: dict = field(default_factory=dict, repr=False)
    inputs: tuple = ()

    def override_problems(self, names: dict | None = None, **overrides) -> list[tuple[str, str]]:
        """Check keywords that override case-file keys (``t_end``, ``rtol``, ``output_dt``, ... see
        OVERRIDE_KEYS) against the ranges of those keys (RANGES), t_end after t_start and the
        sample limit, like load_case does for the file.

        ``names`` maps a keyword to its name in the messages (the command line passes
        ``{"rtol": "--rtol", ...}``); by default the keyword itself. Returns the
        (name, message) problems; keywords that override nothing are not checked.
        """
        r = _Reader()
        given = {kw: v for kw, v in overrides.items() if kw in OVERRIDE_KEYS and v is not None}
        labels = {**_FILE_NAMES, **{kw: (names or {}).get(kw, kw) for kw in given}}
        solver = {kw: v for kw, v in self.solver.items() if not (kw in overrides and overrides[kw] is None)}
        t_span = tuple(self.t_span)
        for kw, v in given.items():
            if kw == "method":
                v = r.value(v, labels[kw], "str")
                if v is not _BAD and v not in _METHODS:
                    r.add(labels[kw], f"unknown method {v!r}; use one of {', '.join(_METHODS)}")
                continue
            if kw in _SOLVER_CHOICES:
                v = r.value(v, labels[kw], "str")
                if v is not _BAD and v not in _SOLVER_CHOICES[kw]:
                    r.add(labels[kw], _choice_message(kw, v))
                continue
            if _SOLVER_KINDS.get(kw) == "bool":
                v = r.value(v, labels[kw], "bool")
                if v is not _BAD:
                    solver[kw] = v
                continue
            v = r.value(v, labels[kw], "number", _range_of(OVERRIDE_KEYS[kw]))
            if v is _BAD:
                t_span = None if kw == "t_end" else t_span
            elif kw == "t_end" and not v > t_span[0]:
                r.add(labels[kw], f"must be after {labels['t_start']} = {_fmt(t_span[0])} s, got {_fmt(v)}")
                t_span = None
            elif kw == "t_end":
                t_span = (t_span[0], v)
            else:
                solver[kw] = v
        if t_span is not None:
            _check_samples(r, t_span, solver, labels)
        return r.problems

    def simulate_kwargs(self, **overrides) -> dict:
        """Keyword arguments of gibbsimpact.simulate for this case, with overrides applied.

        ``t_end=`` is a shorthand for ``t_span=(t_start, t_end)``. Overrides of case-file
        keys are held to the file's ranges: a CaseError lists every problem. ``inputs`` is
        the dict {coordinate name: f(t, q, qdot)} of the case's [[inputs]] (several on one
        coordinate summed), None without any.
        """
        problems = self.override_problems(**overrides)
        if problems:
            raise CaseError(str(self.path) if self.path is not None else self.name, problems)
        kw = dict(
            model=self.model, q0=self.q0.copy(), qdot0=self.qdot0.copy(), t_span=tuple(self.t_span),
            walls=self.walls, restitution=self.restitution, **self.solver,
            inputs=named_inputs(self.inputs, self.model.coordinate_names) if self.inputs else None,
        )
        if "t_end" in overrides:
            t_end = overrides.pop("t_end")
            if t_end is not None:
                kw["t_span"] = (self.t_span[0], float(t_end))
        kw.update(overrides)
        return kw

    def simulate(self, **overrides):
        """Run :func:`gibbsimpact.simulate` on this case; keyword arguments override the case's settings."""
        from ..simulation.simulate import simulate

        return simulate(**self.simulate_kwargs(**overrides))

    def initial_energy(self):
        """Energy(kinetic, gravity, strain, total) at (q0, qdot0) [J]."""
        return self.model.energy(self.q0, self.qdot0)

    def initial_gaps(self) -> np.ndarray:
        """Gap g of every joint to every wall at q0, shape (n_walls, n+1) [m] (> 0 inside)."""
        p = self.model.joint_positions(self.q0)
        return np.array([w.gap(p) for w in self.walls]).reshape(len(self.walls), len(p))

    @property
    def output_directory(self) -> Path:
        d = self.output.get("directory")
        return Path(d) if d else Path("out") / self.name


def load_case(path) -> Case:
    """Read and validate a case file (TOML, format in docs/case-format.md).

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    CaseError
        Listing every problem found, each with its key path.
    """
    path = Path(path)
    raw = path.read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise CaseError(str(path), [("", f"not UTF-8 text ({exc})")]) from None
    except tomllib.TOMLDecodeError as exc:
        raise CaseError(str(path), [("", f"not valid TOML: {exc}")]) from None
    return case_from_dict(data, name=path.stem, source=str(path), path=path)


def _build_each(tables, build):
    """[build(k, table) ...], or _BAD if any entry is bad (every entry is still checked)."""
    out = [build(k, t) for k, t in enumerate(tables)]
    return _BAD if any(x is _BAD for x in out) else out


def _link(r: _Reader, tbl, path: str):
    tbl = r.table(tbl, path, _LINK_KEYS, "a [[links]] table")
    if tbl is None:
        return _BAD
    length = r.get(tbl, path, "length_m", "number", required=True, what=_LINK_KEYS["length_m"])
    mu = r.get(tbl, path, "mass_per_length_kg_per_m", "number", required=True,
               what=_LINK_KEYS["mass_per_length_kg_per_m"])
    ei = _BAD
    p_ei = _join(path, "EI_N_m2")
    if "EI_N_m2" not in tbl:
        r.add(p_ei, f"missing ({_LINK_KEYS['EI_N_m2']})")
    elif isinstance(tbl["EI_N_m2"], list):
        ei = r.value(tbl["EI_N_m2"], p_ei, "vector2")
        ei = tuple(ei) if ei is not _BAD else _BAD
    else:
        ei = r.value(tbl["EI_N_m2"], p_ei, "number")
    j = r.get(tbl, path, "rotary_inertia_kg_m", "vector3", default=None)
    radius = r.get(tbl, path, "cross_section_radius_m", "number", default=None)
    if j is not None and radius is not None:
        r.add(_join(path, "cross_section_radius_m"), "give either rotary_inertia_kg_m or cross_section_radius_m, not both")
        j = _BAD
    elif radius is not None and radius is not _BAD and mu is not _BAD:
        j = [mu * radius**2 / 2.0, mu * radius**2 / 4.0, mu * radius**2 / 4.0]
    elif radius is _BAD:
        j = _BAD
    modes = []
    p_modes = _join(path, "modes")
    raw_modes = tbl.get("modes", [])
    if not isinstance(raw_modes, list):
        r.add(p_modes, f"expected [[links.modes]] tables, got {_type_name(raw_modes)}")
        modes = _BAD
    else:
        for k, md in enumerate(raw_modes):
            pm = _join(p_modes, k)
            mt = r.table(md, pm, _MODE_KEYS, "a [[links.modes]] table")
            if mt is None:
                modes = _BAD
                continue
            kind = r.get(mt, pm, "kind", "str", required=True, what=_MODE_KEYS["kind"])
            direction = r.get(mt, pm, "direction", "str", default="y")
            number = r.get(mt, pm, "number", "number", default=1)
            if kind is not _BAD and kind not in MODE_KINDS:
                r.add(_join(pm, "kind"), f"unknown kind {kind!r}; use one of {', '.join(MODE_KINDS)}")
                kind = _BAD
            if direction is not _BAD and direction not in MODE_DIRECTIONS:
                r.add(_join(pm, "direction"), f"unknown direction {direction!r}; use 'y' or 'z'")
                direction = _BAD
            if _BAD in (kind, direction, number) or modes is _BAD:
                modes = _BAD
                continue
            mode = Mode(kind, direction, number)
            if mode in modes:
                r.add(pm, f"repeats mode {k}: the same mode twice makes the mass matrix singular")
                modes = _BAD
                continue
            modes.append(mode)
    elements, directions, zeta = _discretisation(r, tbl, path, modes)
    if _BAD in (length, mu, ei, j, elements, directions, zeta) or modes is _BAD:
        return _BAD
    try:
        link = Link(length=length, mass_per_length=mu, EI=ei, modes=tuple(modes),
                    rotary_inertia=tuple(j) if j is not None else (0.0, 0.0, 0.0),
                    elements=elements, element_directions=directions, damping=zeta)
    except ValueError as exc:  # pragma: no cover - every check above mirrors Link's
        r.add(path, str(exc))
        return _BAD
    for k, md in enumerate(link.modes, start=1):
        # omega = (beta l)^2 sqrt(EI / (mu l^4)); a y-mode bends against EI_z, a z-mode against EI_y.
        ei_mode = link.EI_z if md.direction == "y" else link.EI_y
        omega = natural_frequency(md, length, mu, ei_mode)
        if omega > MAX_MODE_FREQUENCY:
            r.add(p_ei, f"makes modes[{k}] ({md.kind} number {md.number} in {md.direction}) vibrate at "
                        f"omega = {_fmt(omega)} rad/s with length_m = {_fmt(length)} and mass_per_length_kg_per_m "
                        f"= {_fmt(mu)}; above {_fmt(MAX_MODE_FREQUENCY)} rad/s (periods of picoseconds) a beam model "
                        f"has no meaning: lower EI_N_m2 or the mode number, or drop the mode")
            return _BAD
    return link


def _element_frequencies_ok(r: _Reader, model: Model) -> bool:
    """Every finite-element link's highest eigenfrequency at most MAX_MODE_FREQUENCY (the modes' limit).

    omega_max = sqrt of the largest generalised eigenvalue of the link's (K, M_dd) (clamped at its frame).
    A link behind a Pb guide bends over its protruding length d only (stretching elements):
    omega scales as (l / d)^2, largest at d_min.
    """
    ok = True
    for i, (link, ld, jt) in enumerate(zip(model.chain.links, model.link_data, model.chain.joints), start=1):
        if not link.elements:
            continue
        omega = math.sqrt(max(float(sl.eigh(ld.K, ld.M_dd, eigvals_only=True)[-1]), 0.0))
        at = ""
        if jt.kind == "Pb":
            omega *= (link.length / jt.range[0]) ** 2
            at = f" at the shortest protruding length d_min = {_fmt(jt.range[0])} m (links[{i}].joint.range_m)"
        if not omega <= MAX_MODE_FREQUENCY:
            r.add(f"links[{i}].EI_N_m2",
                  f"makes the highest mode of elements = {link.elements} vibrate at omega = {_fmt(omega)} rad/s with "
                  f"length_m = {_fmt(link.length)} and mass_per_length_kg_per_m = {_fmt(link.mass_per_length)}{at}; "
                  f"above {_fmt(MAX_MODE_FREQUENCY)} rad/s (periods of picoseconds) a beam model has no meaning: "
                  f"lower EI_N_m2 or elements")
            ok = False
    return ok


def _discretisation(r: _Reader, tbl: dict, path: str, modes):
    """(elements, element_directions, damping ratio) of a [[links]] table; _BAD entries on a problem."""
    elements = r.get(tbl, path, "elements", "number", default=0)
    if "elements" in tbl and "modes" in tbl:
        r.add(_join(path, "elements"), "give either modes (assumed modes) or elements (finite elements), not both")
        elements = _BAD
    directions = ("y",)
    p_dirs = _join(path, "element_directions")
    if "element_directions" in tbl:
        raw = tbl["element_directions"]
        if not isinstance(raw, list) or not raw or not all(isinstance(d, str) for d in raw):
            r.add(p_dirs, f"expected an array of directions, ['y'] or ['y', 'z'], got {_type_name(raw)}")
            directions = _BAD
        elif any(d not in MODE_DIRECTIONS for d in raw) or len(set(raw)) != len(raw):
            r.add(p_dirs, f"must be ['y'], ['z'] or ['y', 'z'] ('y': in-plane bending v, 'z': out-of-plane w), "
                          f"got {raw!r}")
            directions = _BAD
        else:
            directions = tuple(raw)
        if elements == 0:
            r.add(p_dirs, "applies to finite elements only: set elements (at least 1) or remove element_directions")
            directions = _BAD
    zeta = r.get(tbl, path, "damping_ratio", "number", default=0.0)
    if zeta not in (_BAD, 0.0) and elements == 0 and not (modes is _BAD or modes):
        r.add(_join(path, "damping_ratio"), "needs elastic coordinates: give the link modes or elements")
        zeta = _BAD
    return elements, directions, zeta


def _base(r: _Reader, tbl):
    """'free' or a FixedBase from the [base] table; _BAD on a problem."""
    tbl = r.table(tbl, "base", _BASE_KEYS, "a [base] table")
    if tbl is None:
        return _BAD
    kind = r.get(tbl, "base", "type", "str", required=True, what="'fixed', 'free' or 'planar'")
    if kind is _BAD:
        return _BAD
    if kind not in ("fixed", "free", "planar"):
        r.add("base.type",
              f"unknown base type {kind!r}; use 'fixed' (joint 1 at a fixed point), 'free' (free-flying in "
              "space) or 'planar' (free-flying in the X1-X2 plane)")
        return _BAD
    if kind in ("free", "planar"):
        extra = [k for k in ("position_m", "angle_deg", "angle_rad") if k in tbl]
        for k in extra:
            r.add(_join("base", k),
                  f"a {'planar ' if kind == 'planar' else ''}free-flying base has no fixed position or angle: "
                  "remove it or set type = 'fixed'")
        return _BAD if extra else kind
    position = [0.0, 0.0, 0.0]
    if "position_m" in tbl:
        raw = tbl["position_m"]
        if isinstance(raw, list) and len(raw) in (2, 3):
            position = r.value(raw, "base.position_m", f"vector{len(raw)}")
        else:
            r.add("base.position_m", f"expected an array of 2 or 3 numbers (b1, b2[, b3]) in m, got {_type_name(raw)}")
            position = _BAD
    angle = 0.0
    if "angle_deg" in tbl and "angle_rad" in tbl:
        r.add("base.angle_rad", "sets the base angle again (already set by angle_deg); give one of them")
        angle = _BAD
    elif "angle_deg" in tbl:
        angle = r.get(tbl, "base", "angle_deg", "number")
        angle = math.radians(angle) if angle is not _BAD else _BAD
    elif "angle_rad" in tbl:
        angle = r.get(tbl, "base", "angle_rad", "number")
    if _BAD in (position, angle):
        return _BAD
    return FixedBase(position=tuple(position), angle=angle)


def _joint(r: _Reader, link_tbl, path: str):
    """The joint of one [[links]] table (its [links.joint]; Revolute() without one), _BAD on a problem.

    path is the link's key path (links[i]); the joint's keys are links[i].joint.<key>.
    """
    if not isinstance(link_tbl, dict):
        return _BAD  # _link reports it
    if "joint" not in link_tbl:
        return Revolute()
    path = _join(path, "joint")
    tbl = r.table(link_tbl["joint"], path, _JOINT_KEYS, "a [links.joint] table")
    if tbl is None:
        return _BAD
    kind = r.get(tbl, path, "type", "str", required=True, what=_JOINT_KEYS["type"])
    if kind is _BAD:
        return _BAD
    if kind not in _JOINT_TYPES:
        close = [k for k in _JOINT_TYPES if k.lower() == kind.lower()]
        hint = f"did you mean {close[0]!r}? " if close else ""
        r.add(_join(path, "type"), f"unknown joint type {kind!r}; {hint}use "
                                   + ", ".join(f"{k!r} ({what})" for k, what in _JOINT_TYPES.items()))
        return _BAD
    # Keys the type does not have.
    ok = True
    allowed = {"R": (), "Pa": ("angle_deg", "angle_rad", "half_length_m", "range_m"),
               "Pb": ("angle_deg", "angle_rad", "range_m")}[kind]
    for key in tbl:
        if key == "type" or key in allowed or key not in _JOINT_KEYS:
            continue
        ok = False
        if kind == "R":
            r.add(_join(path, key), f"a revolute joint (type = 'R') has no {_JOINT_KEYS[key].split(' of ')[0]}: "
                                    "remove it, or set type = 'Pa' or 'Pb' for a prismatic joint")
        else:
            r.add(_join(path, key), "only a Pa carriage has a half-length (a Pb guide sits at the host's tip): "
                                    "remove it or set type = 'Pa'")
    if kind == "R":
        return Revolute() if ok else _BAD
    angle = 0.0
    if "angle_deg" in tbl and "angle_rad" in tbl:
        r.add(_join(path, "angle_rad"), "sets the joint angle again (already set by angle_deg); give one of them")
        angle = _BAD
    elif "angle_deg" in tbl:
        angle = r.get(tbl, path, "angle_deg", "number")
        angle = math.radians(angle) if angle is not _BAD else _BAD
    elif "angle_rad" in tbl:
        angle = r.get(tbl, path, "angle_rad", "number")
    half = r.get(tbl, path, "half_length_m", "number", default=0.0)
    rng = r.get(tbl, path, "range_m", "vector2", required=True,
                what=f"[d_min, d_max] in m, the travel of the joint's coordinate ({_JOINT_KEYS['range_m']})")
    if rng is not _BAD and not rng[0] < rng[1]:
        r.add(_join(path, "range_m"), f"must be [d_min, d_max] with d_min < d_max, got "
                                      f"[{_fmt(rng[0])}, {_fmt(rng[1])}]")
        rng = _BAD
    elif rng is not _BAD and kind == "Pb" and not rng[0] > 0:
        r.add(_join(path, "range_m"), f"d_min = {_fmt(rng[0])} m must be > 0: a Pb joint's d is the length "
                                      "protruding from the guide, and the link's stiffness grows like 1/d^3 as "
                                      "d -> 0")
        rng = _BAD
    if not ok or _BAD in (angle, half, rng):
        return _BAD
    if kind == "Pa":
        return SlidingPrismatic(angle=angle, half_length=half, range=tuple(rng))
    return FixedPrismatic(angle=angle, range=tuple(rng))


def _chain_ok(r: _Reader, links, joints, base) -> bool:
    """The rules of a chain with prismatic joints or a planar base (docs/theory.md §8, §7.3, §7.4, §9, §13),
    each reported at the key to change."""
    ok = True
    kinds = [j.kind for j in joints]
    prismatic = [k for k, kd in enumerate(kinds) if kd != "R"]
    if base == "planar" and kinds[0] != "R":
        r.add("links[1].joint.type", "on a planar free-flying base ([base] type = 'planar') joint 1 must be 'R': "
                                     "theta_1 is the chain's orientation; set [base] type = 'fixed' for a "
                                     "prismatic joint 1")
        ok = False
    if not prismatic and base != "planar":
        return ok
    if base == "free":
        for k in prismatic:
            r.add(f"links[{k + 1}].joint.type",
                  f"a prismatic joint ({kinds[k]!r}) needs a planar chain, and a chain without [base] (or with "
                  "type = 'free') flies in space: add [base] with type = 'fixed' (or 'planar' for a floating chain)")
        return False
    for k, lk in enumerate(links, start=1):
        if lk.elements and lk.element_directions != ("y",):
            r.add(f"links[{k}].element_directions",
                  "a planar chain (prismatic joints or [base] type = 'planar') bends in the plane only: "
                  "set element_directions = ['y']")
            ok = False
        if any(md.direction != "y" for md in lk.modes):
            r.add(f"links[{k}].modes", "a planar chain (prismatic joints or [base] type = 'planar') bends in the "
                                       "plane only: give modes in direction 'y' only")
            ok = False
    for k in prismatic:
        i, jt, lk = k + 1, joints[k], links[k]
        p = f"links[{i}].joint"
        lo, hi = jt.range
        if kinds[k] == "Pb":
            if lk.modes:
                r.add(f"links[{i}].modes", f"link {i} slides through a Pb guide ({p}): it is discretised by "
                                           "stretching finite elements; give it elements instead of modes (or "
                                           "neither: rigid)")
                ok = False
            if hi > lk.length + 1e-12:
                r.add(_join(p, "range_m"), f"d_max = {_fmt(hi)} m is more than links[{i}].length_m = "
                                           f"{_fmt(lk.length)}: d_{i} is the length protruding from the guide, at "
                                           "most the link's length")
                ok = False
            continue
        if k == 0:
            continue  # a carriage on a straight rigid rail along the base x axis: any range
        host, c, h = links[k - 1], jt.half_length, i - 1
        if host.modes:
            r.add(_join(p, "type"), f"a Pa carriage rides on link {h}, which has assumed modes: give links[{h}] "
                                    "elements instead of modes, or neither (rigid)")
            ok = False
        if host.elements and c <= 0:
            r.add(_join(p, "half_length_m"),
                  f"must be > 0 on a finite-element host (links[{h}].elements = {host.elements}), got {_fmt(c)}: a "
                  "point carriage follows the host's slope, whose derivative jumps at every element node, so the "
                  f"mass matrix would jump there (docs/theory.md §7.3); e.g. half_length_m = "
                  f"{_fmt(float(f'{host.length / host.elements / 10:.1g}'))}")
            ok = False
        if lo < c - 1e-12 or hi > host.length - c + 1e-12:
            r.add(_join(p, "range_m"), f"the carriage must stay on link {h}: half_length_m <= d_min < d_max <= "
                                       f"links[{h}].length_m - half_length_m = {_fmt(host.length - c)} m, got "
                                       f"[{_fmt(lo)}, {_fmt(hi)}] with half_length_m = {_fmt(c)}")
            ok = False
    return ok


def _joint_ranges_ok(r: _Reader, model: Model, q0, coordinates: dict) -> bool:
    """Every prismatic joint's initial d inside its range (gibbsimpact.limits), reported at its key."""
    ok = True
    names = model.coordinate_names
    for lim, g in zip(joint_limits(model), limit_gaps(joint_limits(model), q0)):
        if g >= 0:
            continue
        ok = False
        own = names[model.theta_index[lim.joint - 1]]
        touched = [own] + [names[k] for k in np.nonzero(lim.n)[0] if names[k] != own]  # the joint's own d first
        keys = sorted((key for key in coordinates if re.sub(r"_m$", "", key) in touched),
                      key=lambda key: touched.index(re.sub(r"_m$", "", key)))
        values = ", ".join(f"{n} = {_fmt(float(q0[names.index(n)]))} m" for n in touched)
        unset = [n for n in touched if not any(re.sub(r"_m$", "", key) == n for key in keys)]
        fix = (f"set {' and '.join(f'initial.coordinates.{n}_m' for n in unset)} (0 when not given)" if unset
               else "change the initial value")
        r.add(f"initial.coordinates.{keys[0]}" if keys else "initial.coordinates",
              f"{values} is outside the range of joint {lim.joint}: {lim.name} (links[{lim.joint}].joint.range_m); "
              f"{fix}")
    return ok


def _input(r: _Reader, tbl, path: str, model):
    """InputSpec of one [[inputs]] table, _BAD on a problem; model None when the chain is invalid."""
    tbl = r.table(tbl, path, _INPUT_TABLE_KEYS, "an [[inputs]] table")
    if tbl is None:
        return _BAD
    coordinate = r.get(tbl, path, "coordinate", "str", required=True, what=_INPUT_TABLE_KEYS["coordinate"])
    kind = r.get(tbl, path, "kind", "str", required=True, what=_INPUT_TABLE_KEYS["kind"])
    if kind is not _BAD and kind not in INPUT_KINDS:
        r.add(_join(path, "kind"), f"unknown input kind {kind!r}; use one of {', '.join(INPUT_KINDS)}")
        kind = _BAD
    name = angle = None
    if coordinate is not _BAD:
        name = coordinate.replace("theta_m1", "theta_-1")
        if model is not None and name not in model.coordinate_names:
            r.add(_join(path, "coordinate"), _unknown_coordinate(name, model.coordinate_names))
            name = None
        elif model is not None:
            angle = is_angle_coordinate(model, model.coordinate_names.index(name))
    if kind is _BAD or name is None or model is None:
        return _BAD
    # The keys of this kind for this coordinate; a key of the other unit family or of another kind is named.
    keys = _input_keys(kind, angle)
    ok = True
    for key in tbl:
        if key in keys or key in ("coordinate", "kind"):
            continue
        ok = False
        if key in _input_keys(kind, not angle):
            stem = key.split("_")[0]
            what = "an angle: its input is a torque in N m" if angle else "a length: its input is a force in N"
            r.add(_join(path, key), f"{name} is {what}; use {' or '.join(k for k in keys if k.split('_')[0] == stem)}")
        else:
            r.add(_join(path, key), f"not a key of a {kind!r} input (its keys: {', '.join(keys)})")
    if angle and "target_rad" in tbl and "target_deg" in tbl:
        r.add(_join(path, "target_deg"), "sets the target again (already set by target_rad); give one of them")
        ok = False
    params = {}
    for key, (param, required, default, factor) in keys.items():
        if key in tbl:
            v = r.get(tbl, path, key, "number")
            if v is _BAD:
                ok = False
            else:
                params[param] = v * factor
        elif required:
            needed = ", ".join(k for k, spec in keys.items() if spec[1])
            r.add(_join(path, key), f"missing (a {kind!r} input on {name} needs {needed})")
            ok = False
        else:
            params.setdefault(param, default)
    if ok and kind == "ramp" and not params["end"] > params["start"]:
        r.add(_join(path, "end_s"), f"must be after start_s = {_fmt(params['start'])} s, got {_fmt(params['end'])}")
        ok = False
    return InputSpec(coordinate=name, kind=kind, parameters=params) if ok else _BAD


def _unknown_coordinate(name: str, names) -> str:
    """The message for a coordinate name the model does not have."""
    hint = ""
    joint = re.fullmatch(r"(theta|d)_([1-9][0-9]*)", name)
    if name in _FREE_BASE_COORDINATES and "X1" not in names:
        hint = f" (a fixed base has no {', '.join(_FREE_BASE_COORDINATES)}: [base] type = 'fixed')"
    elif name in _SPATIAL_COORDINATES and "X1" in names and "X3" not in names:
        hint = (f" (a planar base has no {', '.join(_SPATIAL_COORDINATES)}: [base] type = 'planar' moves in "
                "the X1-X2 plane with X1, X2 and theta_1)")
    elif joint and f"{'d' if joint[1] == 'theta' else 'theta'}_{joint[2]}" in names:
        other = f"{'d' if joint[1] == 'theta' else 'theta'}_{joint[2]}"
        what = "prismatic: its coordinate is d_{0} in m" if other[0] == "d" else "revolute: its coordinate is theta_{0}"
        hint = f" (joint {joint[2]} is {what.format(joint[2])}, set by links[{joint[2]}].joint.type)"
    return f"unknown coordinate {name}{hint}; this model has {', '.join(names)}"


def _wall(r: _Reader, tbl, path: str):
    if not isinstance(tbl, dict):
        r.add(path, f"expected a [[walls]] table, got {_type_name(tbl)}")
        return _BAD
    kind = r.get(tbl, path, "type", "str", required=True, what="circle, sphere or plane")
    if kind is _BAD:
        return _BAD
    if kind not in _WALL_KEYS:
        r.add(_join(path, "type"), f"unknown wall type {kind!r}; use circle, sphere or plane")
        return _BAD
    r.table(tbl, path, _WALL_KEYS[kind])
    e = r.get(tbl, path, "restitution", "number", default=None)
    mu = r.get(tbl, path, "friction", "number", default=0.0)
    if kind in ("circle", "sphere"):
        radius = r.get(tbl, path, "radius_m", "number", required=True, what="radius R in m")
        dim = 2 if kind == "circle" else 3
        center = r.get(tbl, path, "center_m", f"vector{dim}", default=[0.0] * dim)
        if _BAD in (radius, center, e, mu):
            return _BAD
        cls = Circle if kind == "circle" else Sphere
        return cls(radius=radius, center=tuple(center), restitution=e, friction=mu)
    point = r.get(tbl, path, "point_m", "vector3", default=[0.0, 0.0, 0.0])
    normal = r.get(tbl, path, "normal", "vector3", required=True, what="normal pointing into the free side")
    if _BAD in (point, normal, e, mu):
        return _BAD
    return Plane(point=tuple(point), normal=tuple(normal), restitution=e, friction=mu)


def _com_vector(r: _Reader, it: dict, key: str, base):
    """[initial] center_of_mass_m / center_of_mass_velocity_m_per_s: 3 numbers, or on a planar base 2
    (or 3 with the third 0); None when absent, _BAD on a problem."""
    if base != "planar" or not isinstance(it.get(key), list) or len(it[key]) != 3:
        kind = "vector2" if base == "planar" and isinstance(it.get(key), list) and len(it[key]) == 2 else "vector3"
        return r.get(it, "initial", key, kind, default=None)
    v = r.get(it, "initial", key, "vector3")
    if v is not _BAD and v[2] != 0.0:
        r.add(_join("initial", key), f"a planar base ([base] type = 'planar') moves in the X1-X2 plane: the third "
                                     f"component must be 0, got {_fmt(v[2])}; or give two numbers")
        return _BAD
    return v


def _state_table(r: _Reader, tbl, path: str, pattern, units: dict, names, coord_units=None):
    """Read {name_unit: value} into {coordinate index: value in SI}; names None if the model is unknown.

    coord_units : the model's unit of each coordinate ('m' or 'rad'); an elastic
    coordinate in rad (a finite-element node slope) takes angle units.
    """

    def family(name):
        if name.startswith("theta") or (names is not None and coord_units is not None and name in names
                                        and coord_units[names.index(name)] == "rad"):
            return "theta"
        return "delta" if name.startswith("delta") else "X"

    out = {}
    if not isinstance(tbl, dict):
        r.add(path, f"expected a table, got {_type_name(tbl)}")
        return _BAD
    ok = True
    seen = {}
    for key, v in tbl.items():
        p = _join(path, key)
        m = pattern.match(key)
        if not m:
            bare = re.sub(r"_(m|rad|deg|m_per_s|rad_per_s|deg_per_s)$", "", key)
            if names is not None and key.replace("theta_m1", "theta_-1") in names:
                r.add(p, f"add the unit to the key: {' or '.join(key + '_' + u for u in units[family(key)])}")
            elif names is not None and bare.replace("theta_m1", "theta_-1") in names:
                r.add(p, f"unit {key[len(bare) + 1:]} is not allowed here; use "
                      f"{' or '.join(bare + '_' + u for u in units[family(bare)])}")
            else:
                known = f"; this model has {', '.join(names)}" if names is not None else ""
                r.add(p, f"unknown coordinate (keys are <coordinate>_<unit>, e.g. X1_{units['X'][0]}, "
                      f"theta_1_{units['theta'][-1]}){known}")
            ok = False
            continue
        name, unit = m.group(1).replace("theta_m1", "theta_-1"), m.group(2)
        fam = family(name)
        if unit not in units[fam]:
            r.add(p, f"{name} takes unit {' or '.join(units[fam])}, not {unit}")
            ok = False
            continue
        if names is not None and name not in names:
            r.add(p, _unknown_coordinate(name, names))
            ok = False
            continue
        val = r.value(v, p, "number", RANGES[f"{path}.*_{unit}"])
        if val is _BAD:
            ok = False
            continue
        if name in seen:
            r.add(p, f"sets {name} again (already set by {seen[name]})")
            ok = False
            continue
        seen[name] = key
        if unit.startswith("deg"):
            val = math.radians(val)
        if names is not None:
            out[names.index(name)] = val
    return out if ok else _BAD


def _choice_message(key: str, v: str) -> str:
    """The message for a value of a [solver] choice key (_SOLVER_CHOICES) it does not take."""
    return f"unknown value {v!r}; use " + " or ".join(f"{c!r} ({what})" for c, what in _SOLVER_CHOICES[key].items())


#: How messages name the time and solver keys of a case file.
_FILE_NAMES = {"t_start": "time.t_start_s", **OVERRIDE_KEYS}


def _check_samples(r: _Reader, t_span, solver: dict, names: dict):
    """Samples (t_end - t_start)/output_dt and steps (t_end - t_start)/max_step at most MAX_SAMPLES."""
    span = t_span[1] - t_span[0]
    for kw, what in (("output_dt", "samples"), ("max_step", "solver steps at least")):
        dt = solver.get(kw)
        if dt is None or not math.isfinite(dt) or span / dt <= MAX_SAMPLES:
            continue
        r.add(names[kw], f"({names['t_end']} - {names['t_start']}) / {names[kw]} = {_fmt(span)} s / {_fmt(dt)} s = "
                         f"{_fmt(span / dt)} {what}, more than {_fmt(MAX_SAMPLES)} (memory and run time); make "
                         f"{names[kw]} at least {_fmt(span / MAX_SAMPLES)} s or shorten the time span")


def case_from_dict(data: dict, name: str = "case", source: str = "<case>", path=None) -> Case:
    """Validate a parsed case table (what ``tomllib`` returns) and build the Case.

    Raises CaseError listing every problem.
    """
    r = _Reader()
    # The ranges keep every number of the model far from overflow; should one still
    # happen, numpy stays silent (no RuntimeWarning ahead of the error) and the
    # finiteness checks of _build_case report it as a problem.
    with np.errstate(all="ignore"):
        case = _build_case(r, data, name, path)
    if r.problems:
        raise CaseError(source, r.problems)
    return case


def _build_case(r: _Reader, data: dict, name: str, path) -> Case | None:
    """The Case of a parsed table, or None when r has collected problems."""
    top = r.table(data, "", _TOP_KEYS)
    if top is None:
        return None

    case_name = r.get(top, "", "name", "str", default=name)
    if case_name is not _BAD and (not case_name or re.search(r"[/\\]", case_name)):
        r.add("name", f"{case_name!r} must be a non-empty name without path separators")
        case_name = _BAD
    description = r.get(top, "", "description", "str", default="")
    gravity = r.get(top, "", "gravity_m_per_s2", "vector3", required=True, what=_TOP_KEYS["gravity_m_per_s2"])
    restitution = r.get(top, "", "restitution", "number", default=1.0)

    # Links -> model.
    links = []
    raw_links = top.get("links", _MISSING)
    if raw_links is _MISSING:
        r.add("links", "missing (at least one [[links]] table with length_m, mass_per_length_kg_per_m, EI_N_m2)")
        links = _BAD
    elif not isinstance(raw_links, list) or not raw_links:
        r.add("links", f"expected one or more [[links]] tables, got {_type_name(raw_links)}")
        links = _BAD
    else:
        links = _build_each(raw_links, lambda k, lt: _link(r, lt, _join("links", k)))
    joints = _build_each(raw_links, lambda k, lt: _joint(r, lt, _join("links", k))) \
        if isinstance(raw_links, list) and raw_links else _BAD
    base = _base(r, top["base"]) if "base" in top else "free"
    model = None
    if _BAD not in (links, joints, gravity, base) and _chain_ok(r, links, joints, base):
        try:
            chain = Chain(tuple(links), joints=tuple(joints), base=base)
        except ValueError as exc:  # pragma: no cover - _chain_ok mirrors Chain's checks
            r.add("links", str(exc))
        else:
            model = Model(chain, gravity=tuple(gravity))
            if not _element_frequencies_ok(r, model):
                model = None

    # Walls.
    walls = []
    raw_walls = top.get("walls", [])
    if not isinstance(raw_walls, list):
        r.add("walls", f"expected [[walls]] tables, got {_type_name(raw_walls)}")
        walls = _BAD
    else:
        walls = _build_each(raw_walls, lambda k, wt: _wall(r, wt, _join("walls", k)))

    # Time.
    t_span = _BAD
    tt = r.table(top.get("time", _MISSING), "time", _TIME_KEYS, "a [time] table") if "time" in top else None
    if "time" not in top:
        r.add("time", "missing ([time] table with t_end_s)")
    elif tt is not None:
        t0 = r.get(tt, "time", "t_start_s", "number", default=0.0)
        t1 = r.get(tt, "time", "t_end_s", "number", required=True, what="end time in s")
        if _BAD not in (t0, t1):
            if not t1 > t0:
                r.add("time.t_end_s", f"must be after t_start_s = {_fmt(t0)} s, got {_fmt(t1)}")
            else:
                t_span = (t0, t1)

    # Solver.
    solver = {}
    if "solver" in top:
        st = r.table(top["solver"], "solver", {k: v[2] for k, v in SOLVER_KEYS.items()}, "a [solver] table")
        if st is not None:
            for key, (kw, kind, what) in SOLVER_KEYS.items():
                v = r.get(st, "solver", key, kind, default=_MISSING)
                if v is _MISSING or v is _BAD:
                    continue
                if key == "method" and v not in _METHODS:
                    r.add("solver.method", f"unknown method {v!r}; use one of {', '.join(_METHODS)}")
                    continue
                if key in _SOLVER_CHOICES and v not in _SOLVER_CHOICES[key]:
                    r.add(f"solver.{key}", _choice_message(key, v))
                    continue
                solver[kw] = v
    if t_span is not _BAD:
        _check_samples(r, t_span, solver, _FILE_NAMES)

    # Output.
    output = dict(OUTPUT_DEFAULTS)
    if "output" in top:
        ot = r.table(top["output"], "output", _OUTPUT_KEYS, "an [output] table")
        if ot is not None:
            kinds = dict(directory="str", plots="bool", animate="bool", dpi="number", animation_fps="number",
                         animation_speed="number", points_per_link="number")
            for key, kind in kinds.items():
                v = r.get(ot, "output", key, kind, default=_MISSING)
                if v is not _MISSING and v is not _BAD:
                    output[key] = v

    # Initial state.
    q0 = qdot0 = None
    it = top.get("initial", {})
    names = model.coordinate_names if model is not None else None
    units_of = model.coordinate_units if model is not None else None
    it = r.table(it, "initial", _INITIAL_KEYS, "an [initial] table")
    if it is not None:
        cq = _state_table(r, it.get("coordinates", {}), "initial.coordinates", _COORD,
                          {"X": ("m",), "theta": ("rad", "deg"), "delta": ("m",)}, names, units_of)
        cv = _state_table(r, it.get("velocities", {}), "initial.velocities", _RATE,
                          {"X": ("m_per_s",), "theta": ("rad_per_s", "deg_per_s"), "delta": ("m_per_s",)}, names,
                          units_of)
        com = _com_vector(r, it, "center_of_mass_m", base)
        comv = _com_vector(r, it, "center_of_mass_velocity_m_per_s", base)
        nx = 2 if base == "planar" else 3  # X1, X2 (, X3) lead q on a free-flying base
        xs = "X1, X2" if base == "planar" else "X1, X2, X3"
        if isinstance(base, FixedBase):
            # Both set the base coordinates X of a free-flying chain.
            for key, v in (("center_of_mass_m", com), ("center_of_mass_velocity_m_per_s", comv)):
                if v is not None:
                    r.add(_join("initial", key), "needs a free-flying base (it sets X1, X2, X3); a fixed base "
                                                 "([base] type = 'fixed') has none: place the chain with "
                                                 "base.position_m and the joint angles instead")
            com = _BAD if com is not None else None
            comv = _BAD if comv is not None else None
        if com not in (None, _BAD) and cq is not _BAD and names is not None and any(i < nx for i in cq):
            r.add("initial.center_of_mass_m",
                  f"sets {xs}; remove {'/'.join(x + '_m' for x in xs.split(', '))} from [initial.coordinates]")
            com = _BAD
        if comv not in (None, _BAD) and cv is not _BAD and names is not None and any(i < nx for i in cv):
            r.add("initial.center_of_mass_velocity_m_per_s",
                  f"sets the rates of {xs}; remove {'/'.join(x + '_m_per_s' for x in xs.split(', '))} from "
                  "[initial.velocities]")
            comv = _BAD
        if model is not None and _BAD not in (cq, cv, com, comv):
            q0 = np.zeros(model.n_dof)
            qdot0 = np.zeros(model.n_dof)
            for i, v in cq.items():
                q0[i] = v
            for i, v in cv.items():
                qdot0[i] = v
            coords = it.get("coordinates", {})
            if not _joint_ranges_ok(r, model, q0, coords if isinstance(coords, dict) else {}):
                q0 = qdot0 = None  # the kinematics need d inside its range (a Pb link: d > 0)
        if q0 is not None:
            if com is not None:
                # c(q) = X + c(q with X = 0) because Trans(X) comes first; the
                # undeformed chain: delta = 0.
                q_und = q0.copy()
                q_und[:nx] = 0.0
                for idx in model.delta_index:
                    q_und[idx] = 0.0
                q0[:nx] = np.asarray(com)[:nx] - model.center_of_mass(q_und)[:nx]
            if comv is not None:
                # Linear momentum is m Xdot + (terms without Xdot).
                qd = qdot0.copy()
                qd[:nx] = 0.0
                qdot0[:nx] = np.asarray(comv)[:nx] - model.linear_momentum(q0, qd)[:nx] / model.total_mass

    # Inputs.
    inputs = []
    raw_inputs = top.get("inputs", [])
    if not isinstance(raw_inputs, list):
        r.add("inputs", f"expected [[inputs]] tables, got {_type_name(raw_inputs)}")
    else:
        inputs = _build_each(raw_inputs, lambda k, t: _input(r, t, _join("inputs", k), model))

    # Checks that need the assembled state.
    if q0 is not None and walls is not _BAD and walls:
        p = model.joint_positions(q0)
        tol = solver.get("contact_tol", 1e-9)
        for k, w in enumerate(walls):
            g = w.gap(p)
            for j in np.nonzero(g < -tol)[0]:
                pos = ", ".join(f"{c:.6g}" for c in p[j])
                r.add("initial", f"joint O{j + 1} at ({pos}) m is outside walls[{k + 1}] ({describe(w)}) by "
                      f"{-g[j]:.6g} m at t = 0; move the chain inside")
    if q0 is not None:
        try:
            qddot0 = forward_dynamics(model, q0, qdot0)
        except SingularMassMatrixError as exc:
            r.add("links", f"the initial state has a singular mass matrix: {exc}")
        else:
            if not (np.all(np.isfinite(q0)) and np.all(np.isfinite(qdot0)) and np.all(np.isfinite(qddot0))):
                r.add("initial", "the initial state overflows floating point; bring the links' parameters and "
                                 "the initial values closer to 1 in SI units")

    if r.problems:
        return None
    q0.setflags(write=False)  # a Case is not mutated; simulate_kwargs hands out copies
    qdot0.setflags(write=False)
    return Case(
        name=case_name, model=model, q0=q0, qdot0=qdot0, t_span=t_span, walls=tuple(walls),
        restitution=restitution, solver=solver, output=output, description=description,
        path=Path(path) if path is not None else None, source=data, inputs=tuple(inputs),
    )
