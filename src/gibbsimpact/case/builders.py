"""A case file into a :class:`Case`: walls, inputs, and the assembly of every section, in one pass.

``load_case(path)`` reads a ``cases/*.toml`` file (format: docs/case-format.md), checks every key
and collects *all* problems into one :class:`~gibbsimpact.case.reader.CaseError` whose message
names each problem by its key path (``links[2].EI_N_m2``, ``walls[1].radius_m``,
``initial.coordinates.theta_1_deg``; gibbsimpact.case.keypaths). The sections are read in file
order by their own modules: the chain (gibbsimpact.case.links), the run settings
(gibbsimpact.case.run_options), the initial state and its checks at t = 0 (gibbsimpact.case.initial).

A link's ``[links.joint]`` table makes its joint prismatic (``type = "Pa"`` or ``"Pb"``,
``range_m``, ``angle_deg``, ``half_length_m``; revolute without one); the variable of a prismatic
joint i is ``d_i`` [m] (``d_2_m`` in ``[initial.coordinates]``, forces in N on it in
``[[inputs]]``), and ``[solver]`` ``joint_limit`` / ``joint_restitution`` say what its end stops
do. ``[base]`` ``type = "planar"`` is a floating base in the X1-X2 plane.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..contact.compliant import DAMPING_RELATIONS
from ..contact.walls import WALL_KINDS, Plane
from ..dynamics.inputs import INPUT_KINDS, InputSpec, is_angle_coordinate, named_inputs
from ..model.model import Model
from .links import read_chain
from .keypaths import join
from .reader import _BAD, CaseError, _build_each, _Reader
from .schema import _FILE_NAMES, _INPUT_TABLE_KEYS, _TOP_KEYS, _WALL_KEYS, OUTPUT_DEFAULTS, _input_keys
from .run_options import check_samples, override_problems, read_output, read_solver, read_time
from .initial import check_start, read_initial, unknown_coordinate
from .contact_filter import read_contact_filter
from .prescribed import check_no_compliant_walls, read_prescribed, start_on_profiles
from .text import fmt, type_name

__all__ = ["Case", "load_case", "case_from_dict"]


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
    prescribed : tuple of (coordinate name, gibbsimpact.profiles.Profile), the [[prescribed]] tables
        (simulate's ``prescribed``; q0, qdot0 of those coordinates are the profiles' at t_start)
    contact_filter : None or simulation.contact_filter.LeadFilter, the [contact_filter] table
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
    prescribed: tuple = ()
    contact_filter: object = None

    def override_problems(self, names: dict | None = None, **overrides) -> list[tuple[str, str]]:
        """Check keywords that override case-file keys (``t_end``, ``rtol``, ``output_dt``, ... see
        OVERRIDE_KEYS) against the ranges of those keys (RANGES), t_end after t_start and the
        sample limit, like load_case does for the file.

        ``names`` maps a keyword to its name in the messages (the command line passes
        ``{"rtol": "--rtol", ...}``); by default the keyword itself. Returns the
        (name, message) problems; keywords that override nothing are not checked.
        """
        return override_problems(tuple(self.t_span), self.solver, overrides, names)

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
            **({"prescribed": dict(self.prescribed)} if self.prescribed else {}),
            **({"contact_filter": self.contact_filter} if self.contact_filter is not None else {}),
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

    def estimate_cost(self, **overrides):
        """What :meth:`simulate` with these overrides should cost, before it runs: the highest frequency, the
        steps, right-hand sides and CPU time of its method (gibbsimpact.simulation.cost.estimate_cost)."""
        from ..simulation.cost import estimate_cost

        return estimate_cost(**self.simulate_kwargs(**overrides))

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
    if raw.startswith(b"PK\x03\x04"):  # a zip: result.npz of Result.save or `gibbsimpact run`
        raise CaseError(str(path), [("", "a result file (NPZ archive), not a case file: read it in Python with "
                                         "gibbsimpact.load_result(path); the summary.json beside it (gibbsimpact run) "
                                         "describes the run; give show/run the case's .toml file")])
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise CaseError(str(path), [("", f"not UTF-8 text ({exc})")]) from None
    except tomllib.TOMLDecodeError as exc:
        raise CaseError(str(path), [("", f"not valid TOML: {exc}")]) from None
    return case_from_dict(data, name=path.stem, source=str(path), path=path)


def case_from_dict(data: dict, name: str = "case", source: str = "<case>", path=None) -> Case:
    """Validate a parsed case table (what ``tomllib`` returns) and build the Case.

    Raises CaseError listing every problem.
    """
    r = _Reader()
    # The ranges keep every number of the model far from overflow; should one still
    # happen, numpy stays silent (no RuntimeWarning ahead of the error) and the
    # finiteness checks of check_start report it as a problem.
    with np.errstate(all="ignore"):
        case = _build_case(r, data, name, path)
    if r.problems:
        raise CaseError(source, r.problems)
    return case


def _build_case(r: _Reader, data: dict, name: str, path) -> Case | None:
    """The Case of a parsed table, or None when r has collected problems (each section in file order)."""
    top = r.table(data, "", _TOP_KEYS)
    if top is None:
        return None
    case_name, description, gravity, restitution = _header(r, top, name)
    model, base = read_chain(r, top, gravity)
    walls = _walls(r, top)
    t_span = read_time(r, top)
    solver = read_solver(r, top)
    if t_span is not _BAD:
        check_samples(r, t_span, solver, _FILE_NAMES)
    output = read_output(r, top)
    q0, qdot0 = read_initial(r, top, model, base)
    inputs = _inputs(r, top, model)
    prescribed = read_prescribed(r, top, model)
    check_no_compliant_walls(r, prescribed, walls if walls is not _BAD else ())
    contact_filter = read_contact_filter(r, top, model)
    if q0 is not None and t_span is not _BAD:
        start_on_profiles(r, top, model, prescribed, q0, qdot0, t_span[0])
    if q0 is not None:
        check_start(r, model, q0, qdot0, walls if walls is not _BAD else (), solver, prescribed)
    if r.problems:
        return None
    q0.setflags(write=False)  # a Case is not mutated; simulate_kwargs hands out copies
    qdot0.setflags(write=False)
    return Case(
        name=case_name, model=model, q0=q0, qdot0=qdot0, t_span=t_span, walls=tuple(walls),
        restitution=restitution, solver=solver, output=output, description=description,
        path=Path(path) if path is not None else None, source=data, inputs=tuple(inputs),
        prescribed=tuple(prescribed.items()), contact_filter=contact_filter,
    )


def _header(r: _Reader, top: dict, name: str) -> tuple:
    """(name, description, gravity (3,) [m/s^2], restitution) of the top-level keys; _BAD entries on a problem."""
    case_name = r.get(top, "", "name", "str", default=name)
    if case_name is not _BAD and (not case_name or re.search(r"[/\\]", case_name)):
        r.add("name", f"{case_name!r} must be a non-empty name without path separators")
        case_name = _BAD
    description = r.get(top, "", "description", "str", default="")
    gravity = r.get(top, "", "gravity_m_per_s2", "vector3", required=True, what=_TOP_KEYS["gravity_m_per_s2"])
    restitution = r.get(top, "", "restitution", "number", default=1.0)
    return case_name, description, gravity, restitution


# -- walls ----------------------------------------------------------------------------------

def _walls(r: _Reader, top: dict):
    """The walls of [[walls]] (none without), _BAD on a problem."""
    raw = top.get("walls", [])
    if not isinstance(raw, list):
        r.add("walls", f"expected [[walls]] tables, got {type_name(raw)}")
        return _BAD
    return _build_each(raw, lambda k, wt: _wall(r, wt, join("walls", k)))


def _wall(r: _Reader, tbl, path: str):
    """The Circle, Sphere or Plane of one [[walls]] table at ``path`` (walls[k]), _BAD on a problem."""
    if not isinstance(tbl, dict):
        r.add(path, f"expected a [[walls]] table, got {type_name(tbl)}")
        return _BAD
    kind = r.get(tbl, path, "type", "str", required=True, what="circle, sphere or plane")
    if kind is _BAD:
        return _BAD
    if kind not in _WALL_KEYS:
        r.add(join(path, "type"), f"unknown wall type {kind!r}; use circle, sphere or plane")
        return _BAD
    r.table(tbl, path, _WALL_KEYS[kind])
    e = r.get(tbl, path, "restitution", "number", default=None)
    mu = r.get(tbl, path, "friction", "number", default=0.0)
    law = {"stiffness": r.get(tbl, path, "stiffness", "number", default=None),
           "exponent": r.get(tbl, path, "exponent", "number", default=1.5),
           "damping": r.get(tbl, path, "damping", "str", default="flores")}
    if law["damping"] not in (_BAD, *DAMPING_RELATIONS):
        r.add(join(path, "damping"), f"unknown damping {law['damping']!r}; use "
              + " or ".join(map(repr, DAMPING_RELATIONS)))
        return _BAD
    if _BAD in law.values():
        return _BAD
    if kind in ("circle", "sphere"):
        radius = r.get(tbl, path, "radius_m", "number", required=True, what="radius R in m")
        dim = 2 if kind == "circle" else 3
        center = r.get(tbl, path, "center_m", f"vector{dim}", default=[0.0] * dim)
        inside = r.get(tbl, path, "inside", "bool", default=True)
        if _BAD in (radius, center, e, mu, inside):
            return _BAD
        return WALL_KINDS[kind](radius=radius, center=tuple(center), restitution=e, friction=mu, inside=inside,
                               **law)
    point = r.get(tbl, path, "point_m", "vector3", default=[0.0, 0.0, 0.0])
    normal = r.get(tbl, path, "normal", "vector3", required=True, what="normal pointing into the free side")
    if _BAD in (point, normal, e, mu):
        return _BAD
    return Plane(point=tuple(point), normal=tuple(normal), restitution=e, friction=mu, **law)


# -- inputs ---------------------------------------------------------------------------------

def _inputs(r: _Reader, top: dict, model) -> list:
    """The InputSpec of every [[inputs]] table ([] on a problem: the case is refused anyway)."""
    raw = top.get("inputs", [])
    if not isinstance(raw, list):
        r.add("inputs", f"expected [[inputs]] tables, got {type_name(raw)}")
        return []
    inputs = _build_each(raw, lambda k, t: _input(r, t, join("inputs", k), model))
    return [] if inputs is _BAD else inputs


def _input(r: _Reader, tbl, path: str, model):
    """InputSpec of one [[inputs]] table, _BAD on a problem; model None when the chain is invalid
    (then only the coordinate's spelling and the kind are checked)."""
    tbl = r.table(tbl, path, _INPUT_TABLE_KEYS, "an [[inputs]] table")
    if tbl is None:
        return _BAD
    coordinate = r.get(tbl, path, "coordinate", "str", required=True, what=_INPUT_TABLE_KEYS["coordinate"])
    kind = r.get(tbl, path, "kind", "str", required=True, what=_INPUT_TABLE_KEYS["kind"])
    if kind is not _BAD and kind not in INPUT_KINDS:
        r.add(join(path, "kind"), f"unknown input kind {kind!r}; use one of {', '.join(INPUT_KINDS)}")
        kind = _BAD
    name = angle = None
    if coordinate is not _BAD:
        name = coordinate.replace("theta_m1", "theta_-1")
        if model is not None and name not in model.coordinate_names:
            r.add(join(path, "coordinate"), unknown_coordinate(name, model.coordinate_names))
            name = None
        elif model is not None:
            angle = is_angle_coordinate(model, model.coordinate_names.index(name))
    if kind is _BAD or name is None or model is None:
        return _BAD
    params = _input_parameters(r, tbl, path, kind, name, angle)
    return InputSpec(coordinate=name, kind=kind, parameters=params) if params is not _BAD else _BAD


def _input_parameters(r: _Reader, tbl: dict, path: str, kind: str, name: str, angle: bool):
    """{parameter of InputSpec: value in SI} of an input of ``kind`` on coordinate ``name`` (an angle
    or a length); a key of the other unit family or of another kind is named; _BAD on a problem."""
    keys = _input_keys(kind, angle)
    ok = True
    for key in tbl:
        if key in keys or key in ("coordinate", "kind"):
            continue
        ok = False
        if key in _input_keys(kind, not angle):
            stem = key.split("_")[0]
            what = "an angle: its input is a torque in N m" if angle else "a length: its input is a force in N"
            r.add(join(path, key), f"{name} is {what}; use {' or '.join(k for k in keys if k.split('_')[0] == stem)}")
        else:
            r.add(join(path, key), f"not a key of a {kind!r} input (its keys: {', '.join(keys)})")
    if angle and "target_rad" in tbl and "target_deg" in tbl:
        r.add(join(path, "target_deg"), "sets the target again (already set by target_rad); give one of them")
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
            r.add(join(path, key), f"missing (a {kind!r} input on {name} needs {needed})")
            ok = False
        else:
            params.setdefault(param, default)
    if ok and kind == "ramp" and not params["end"] > params["start"]:
        r.add(join(path, "end_s"), f"must be after start_s = {fmt(params['start'])} s, got {fmt(params['end'])}")
        ok = False
    return params if ok else _BAD
