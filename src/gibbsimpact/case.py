"""Case files: everything one run needs, in TOML, validated in one pass.

``load_case(path)`` reads a ``cases/*.toml`` file (format: docs/case-format.md),
checks every key and collects *all* problems into one :class:`CaseError`
whose message names each problem by its key path (``links[2].EI_N_m2``,
``walls[1].radius_m``, ``initial.coordinates.theta_1_deg``). Array entries are
numbered from 1 in key paths, like links and joints.

Units are part of the key names (``length_m``, ``t_end_s``, ``theta_1_deg``);
a value is never silently converted from a unit the key does not name.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path

import numpy as np

from .dynamics import SingularMassMatrixError, forward_dynamics
from .model import Chain, Link, Model
from .modes import MODE_DIRECTIONS, MODE_KINDS, Mode
from .walls import Circle, Plane, Sphere, describe

__all__ = ["Case", "CaseError", "load_case", "case_from_dict", "SOLVER_KEYS"]

_MISSING = object()
_BAD = object()

#: Case-file key in [solver] -> (keyword of gibbsimpact.simulate, kind, description).
SOLVER_KEYS = {
    "method": ("method", "str", "solve_ivp method"),
    "rtol": ("rtol", "positive", "relative tolerance"),
    "atol": ("atol", "positive", "absolute tolerance"),
    "output_dt_s": ("output_dt", "positive", "uniform output interval in s"),
    "max_step_s": ("max_step", "positive_or_inf", "largest solver step in s"),
    "contact_tol_m": ("contact_tol", "positive", "gap within which joints share one impact, m"),
    "grazing_velocity_m_per_s": ("grazing_velocity", "positive", "normal speed below which a touch is no impact, m/s"),
    "penetration_tol_m": ("penetration_tol", "positive", "largest tolerated gap below zero between events, m"),
    "zeno_interval_s": ("zeno_interval", "positive", "impact spacing counted as accumulating, s"),
    "zeno_count": ("zeno_count", "count", "consecutive close impacts that stop the run"),
    "max_impacts": ("max_impacts", "count", "impact budget"),
}
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
    "walls": "[[walls]] tables",
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
    },
    "sphere": {
        "type": "wall type",
        "radius_m": "radius R in m",
        "center_m": "centre (c1, c2, c3) in m",
        "restitution": "coefficient of restitution of this wall",
    },
    "plane": {
        "type": "wall type",
        "point_m": "a point of the plane in m",
        "normal": "normal pointing into the free side (any length)",
        "restitution": "coefficient of restitution of this wall",
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

_COORD = re.compile(r"^(X[123]|theta_(?:-1|m1|0|[1-9][0-9]*)|delta_[1-9][0-9]*_[1-9][0-9]*)_(m|rad|deg)$")
_RATE = re.compile(
    r"^(X[123]|theta_(?:-1|m1|0|[1-9][0-9]*)|delta_[1-9][0-9]*_[1-9][0-9]*)_(m_per_s|rad_per_s|deg_per_s)$"
)


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
        return f"the number {v!r}"
    return type(v).__name__


def _join(path: str, key) -> str:
    if isinstance(key, int):
        return f"{path}[{key + 1}]"
    return f"{path}.{key}" if path else str(key)


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

    def value(self, v, p: str, kind: str):
        def bad(expected):
            self.add(p, f"expected {expected}, got {_type_name(v)}")
            return _BAD

        is_num = isinstance(v, Real) and not isinstance(v, bool)
        if kind == "str":
            return v if isinstance(v, str) else bad("a string")
        if kind == "bool":
            return v if isinstance(v, bool) else bad("true or false")
        if kind == "count":
            if not isinstance(v, int) or isinstance(v, bool):
                return bad("an integer")
            if v < 1:
                self.add(p, f"must be an integer >= 1, got {v}")
                return _BAD
            return v
        if kind in ("number", "positive", "nonnegative", "positive_or_inf", "unit_interval"):
            if not is_num:
                return bad("a number")
            v = float(v)
            if math.isnan(v) or (math.isinf(v) and kind != "positive_or_inf"):
                self.add(p, f"must be finite, got {v}")
                return _BAD
            if kind in ("positive", "positive_or_inf") and not v > 0:
                self.add(p, f"must be positive, got {v:g}")
                return _BAD
            if kind == "nonnegative" and v < 0:
                self.add(p, f"must not be negative, got {v:g}")
                return _BAD
            if kind == "unit_interval" and not 0.0 <= v <= 1.0:
                self.add(p, f"must be in [0, 1] (1 = elastic, 0 = plastic), got {v:g}")
                return _BAD
            return v
        m = re.fullmatch(r"vector(\d)(\+?)", kind)
        if m:
            n, nonneg = int(m.group(1)), bool(m.group(2))
            if not isinstance(v, list) or len(v) != n:
                return bad(f"an array of {n} numbers")
            if not all(isinstance(x, Real) and not isinstance(x, bool) for x in v):
                return bad(f"an array of {n} numbers")
            out = [float(x) for x in v]
            if not all(math.isfinite(x) for x in out):
                self.add(p, f"must be finite numbers, got {v}")
                return _BAD
            if nonneg and any(x < 0 for x in out):
                self.add(p, f"must not be negative, got {v}")
                return _BAD
            return out
        raise AssertionError(kind)


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

    def simulate_kwargs(self, **overrides) -> dict:
        """Keyword arguments of gibbsimpact.simulate for this case, with overrides applied.

        ``t_end=`` is a shorthand for ``t_span=(t_start, t_end)``.
        """
        kw = dict(
            model=self.model, q0=self.q0.copy(), qdot0=self.qdot0.copy(), t_span=tuple(self.t_span),
            walls=self.walls, restitution=self.restitution, **self.solver,
        )
        if "t_end" in overrides:
            t_end = overrides.pop("t_end")
            if t_end is not None:
                kw["t_span"] = (self.t_span[0], float(t_end))
        kw.update(overrides)
        return kw

    def simulate(self, **overrides):
        """Run :func:`gibbsimpact.simulate` on this case; keyword arguments override the case's settings."""
        from .simulate import simulate

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
    length = r.get(tbl, path, "length_m", "positive", required=True, what=_LINK_KEYS["length_m"])
    mu = r.get(tbl, path, "mass_per_length_kg_per_m", "positive", required=True,
               what=_LINK_KEYS["mass_per_length_kg_per_m"])
    ei = _BAD
    p_ei = _join(path, "EI_N_m2")
    if "EI_N_m2" not in tbl:
        r.add(p_ei, f"missing ({_LINK_KEYS['EI_N_m2']})")
    elif isinstance(tbl["EI_N_m2"], list):
        ei = r.value(tbl["EI_N_m2"], p_ei, "vector2")
        if ei is not _BAD and not all(x > 0 for x in ei):
            r.add(p_ei, f"must be positive, got {tbl['EI_N_m2']}")
            ei = _BAD
        ei = tuple(ei) if ei is not _BAD else _BAD
    else:
        ei = r.value(tbl["EI_N_m2"], p_ei, "positive")
    j = r.get(tbl, path, "rotary_inertia_kg_m", "vector3+", default=None)
    radius = r.get(tbl, path, "cross_section_radius_m", "positive", default=None)
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
            number = r.get(mt, pm, "number", "count", default=1)
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
    if _BAD in (length, mu, ei, j) or modes is _BAD:
        return _BAD
    try:
        return Link(length=length, mass_per_length=mu, EI=ei, modes=tuple(modes),
                    rotary_inertia=tuple(j) if j is not None else (0.0, 0.0, 0.0))
    except ValueError as exc:  # pragma: no cover - every check above mirrors Link's
        r.add(path, str(exc))
        return _BAD


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
    e = r.get(tbl, path, "restitution", "unit_interval", default=None)
    if kind in ("circle", "sphere"):
        radius = r.get(tbl, path, "radius_m", "positive", required=True, what="radius R in m")
        dim = 2 if kind == "circle" else 3
        center = r.get(tbl, path, "center_m", f"vector{dim}", default=[0.0] * dim)
        if _BAD in (radius, center, e):
            return _BAD
        cls = Circle if kind == "circle" else Sphere
        return cls(radius=radius, center=tuple(center), restitution=e)
    point = r.get(tbl, path, "point_m", "vector3", default=[0.0, 0.0, 0.0])
    normal = r.get(tbl, path, "normal", "vector3", required=True, what="normal pointing into the free side")
    if normal is not _BAD and not any(normal):
        r.add(_join(path, "normal"), "is the zero vector; give the direction into the free side")
        normal = _BAD
    if _BAD in (point, normal, e):
        return _BAD
    return Plane(point=tuple(point), normal=tuple(normal), restitution=e)


def _state_table(r: _Reader, tbl, path: str, pattern, units: dict, names):
    """Read {name_unit: value} into {coordinate index: value in SI}; names None if the model is unknown."""
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
                r.add(p, f"add the unit to the key: {' or '.join(key + '_' + u for u in _allowed_units(key, units))}")
            elif names is not None and bare.replace("theta_m1", "theta_-1") in names:
                r.add(p, f"unit {key[len(bare) + 1:]} is not allowed here; use "
                      f"{' or '.join(bare + '_' + u for u in _allowed_units(bare, units))}")
            else:
                known = f"; this model has {', '.join(names)}" if names is not None else ""
                r.add(p, f"unknown coordinate (keys are <coordinate>_<unit>, e.g. X1_{units['X'][0]}, "
                      f"theta_1_{units['theta'][-1]}){known}")
            ok = False
            continue
        name, unit = m.group(1).replace("theta_m1", "theta_-1"), m.group(2)
        family = "theta" if name.startswith("theta") else ("delta" if name.startswith("delta") else "X")
        if unit not in units[family]:
            r.add(p, f"{name} takes unit {' or '.join(units[family])}, not {unit}")
            ok = False
            continue
        if names is not None and name not in names:
            r.add(p, f"unknown coordinate {name}; this model has {', '.join(names)}")
            ok = False
            continue
        val = r.value(v, p, "number")
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


def _allowed_units(name: str, units: dict):
    family = "theta" if name.startswith("theta") else ("delta" if name.startswith("delta") else "X")
    return units[family]


def case_from_dict(data: dict, name: str = "case", source: str = "<case>", path=None) -> Case:
    """Validate a parsed case table (what ``tomllib`` returns) and build the Case.

    Raises CaseError listing every problem.
    """
    r = _Reader()
    top = r.table(data, "", _TOP_KEYS)
    if top is None:
        raise CaseError(source, r.problems)

    case_name = r.get(top, "", "name", "str", default=name)
    if case_name is not _BAD and (not case_name or re.search(r"[/\\]", case_name)):
        r.add("name", f"{case_name!r} must be a non-empty name without path separators")
        case_name = _BAD
    description = r.get(top, "", "description", "str", default="")
    gravity = r.get(top, "", "gravity_m_per_s2", "vector3", required=True, what=_TOP_KEYS["gravity_m_per_s2"])
    restitution = r.get(top, "", "restitution", "unit_interval", default=1.0)

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
    model = None
    if links is not _BAD and gravity is not _BAD:
        model = Model(Chain(tuple(links)), gravity=tuple(gravity))

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
                r.add("time.t_end_s", f"must be after t_start_s = {t0:g} s, got {t1:g}")
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
                solver[kw] = v

    # Output.
    output = dict(OUTPUT_DEFAULTS)
    if "output" in top:
        ot = r.table(top["output"], "output", _OUTPUT_KEYS, "an [output] table")
        if ot is not None:
            kinds = dict(directory="str", plots="bool", animate="bool", dpi="count", animation_fps="count",
                         animation_speed="positive", points_per_link="count")
            for key, kind in kinds.items():
                v = r.get(ot, "output", key, kind, default=_MISSING)
                if v is not _MISSING and v is not _BAD:
                    output[key] = v
            if isinstance(output["points_per_link"], int) and output["points_per_link"] < 2:
                r.add("output.points_per_link", "must be at least 2")

    # Initial state.
    q0 = qdot0 = None
    it = top.get("initial", {})
    names = model.coordinate_names if model is not None else None
    it = r.table(it, "initial", _INITIAL_KEYS, "an [initial] table")
    if it is not None:
        cq = _state_table(r, it.get("coordinates", {}), "initial.coordinates", _COORD,
                          {"X": ("m",), "theta": ("rad", "deg"), "delta": ("m",)}, names)
        cv = _state_table(r, it.get("velocities", {}), "initial.velocities", _RATE,
                          {"X": ("m_per_s",), "theta": ("rad_per_s", "deg_per_s"), "delta": ("m_per_s",)}, names)
        com = r.get(it, "initial", "center_of_mass_m", "vector3", default=None)
        comv = r.get(it, "initial", "center_of_mass_velocity_m_per_s", "vector3", default=None)
        if com is not None and cq is not _BAD and names is not None and any(i < 3 for i in cq):
            r.add("initial.center_of_mass_m", "sets X1, X2, X3; remove X1_m/X2_m/X3_m from [initial.coordinates]")
            com = _BAD
        if comv is not None and cv is not _BAD and names is not None and any(i < 3 for i in cv):
            r.add("initial.center_of_mass_velocity_m_per_s",
                  "sets the rates of X1, X2, X3; remove X1_m_per_s/X2_m_per_s/X3_m_per_s from [initial.velocities]")
            comv = _BAD
        if model is not None and _BAD not in (cq, cv, com, comv):
            q0 = np.zeros(model.n_dof)
            qdot0 = np.zeros(model.n_dof)
            for i, v in cq.items():
                q0[i] = v
            for i, v in cv.items():
                qdot0[i] = v
            if com is not None:
                # c(q) = X + c(q with X = 0) because Trans(X) comes first; the
                # undeformed chain: delta = 0.
                q_und = q0.copy()
                q_und[:3] = 0.0
                for idx in model.delta_index:
                    q_und[idx] = 0.0
                q0[:3] = np.asarray(com) - model.center_of_mass(q_und)
            if comv is not None:
                # Linear momentum is m Xdot + (terms without Xdot).
                qd = qdot0.copy()
                qd[:3] = 0.0
                qdot0[:3] = np.asarray(comv) - model.linear_momentum(q0, qd) / model.total_mass

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
            forward_dynamics(model, q0, qdot0)
        except SingularMassMatrixError as exc:
            r.add("links", f"the initial state has a singular mass matrix: {exc}")

    if r.problems:
        raise CaseError(source, r.problems)
    q0.setflags(write=False)  # a Case is not mutated; simulate_kwargs hands out copies
    qdot0.setflags(write=False)
    return Case(
        name=case_name, model=model, q0=q0, qdot0=qdot0, t_span=t_span, walls=tuple(walls),
        restitution=restitution, solver=solver, output=output, description=description,
        path=Path(path) if path is not None else None, source=data,
    )
