"""Joint inputs of a case file: closed-form generalised forces on one coordinate each.

A case file's ``[[inputs]]`` tables become :class:`InputSpec` values (SI units,
angles in rad, frequencies in Hz) and then the dict form of the ``inputs``
argument of :func:`gibbsimpact.simulate`, ``{coordinate name: f(t, q, qdot)}``
(gibbsimpact.forces). For coordinate q_k the kinds give

    constant   Q_k = value
    sine       Q_k = offset + amplitude sin(2 pi frequency t + phase)
    ramp       Q_k = slope (min(max(t, start), end) - start)   (0 before start, held after end)
    pd         Q_k = stiffness (target - q_k) - damping qdot_k  (a joint servo)

Q_k is a torque [N m] on an angle coordinate (theta_i, and the node slopes of a
finite-element link) and a force [N] on a length coordinate (X_i, modal
amplitudes, node deflections). Several inputs on one coordinate add up.
Pure functions; nothing here reads files or prints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

from ..kernel.radau import IN_CONSTANT, IN_PD, IN_RAMP, IN_SINE

__all__ = [
    "INPUT_KINDS", "InputSpec", "constant_input", "sine_input", "ramp_input", "pd_input",
    "input_function", "named_inputs", "is_angle_coordinate", "describe_input",
]

#: Input kinds of a case file, in the order the docs list them.
INPUT_KINDS = ("constant", "sine", "ramp", "pd")


@dataclass(frozen=True)
class InputSpec:
    """One input on one coordinate, in SI units.

    Attributes
    ----------
    coordinate : str
        Name of q_k in ``Model.coordinate_names`` (e.g. ``"theta_1"``).
    kind : str
        One of INPUT_KINDS.
    parameters : mapping
        constant: ``value``; sine: ``amplitude``, ``frequency`` [Hz], ``phase`` [rad],
        ``offset``; ramp: ``slope`` [per s], ``start``, ``end`` [s] (``end`` may be inf);
        pd: ``target`` [rad or m], ``stiffness`` [N m/rad or N/m], ``damping``
        [N m s/rad or N s/m]. Forces in N m (angle) or N (length).
    """

    coordinate: str
    kind: str
    parameters: Mapping = field(default_factory=dict)


def constant_input(value: float) -> Callable:
    """f(t, q, qdot) = value [N m or N]."""
    value = float(value)

    def f(t, q, qdot):
        return value

    return _with_rows(f, (IN_CONSTANT, -1, value, 0.0, 0.0, 0.0))


def sine_input(amplitude: float, frequency: float, phase: float = 0.0, offset: float = 0.0) -> Callable:
    """f(t, q, qdot) = offset + amplitude sin(2 pi frequency t + phase); frequency [Hz], phase [rad]."""
    a, w, p, c = float(amplitude), 2.0 * math.pi * float(frequency), float(phase), float(offset)

    def f(t, q, qdot):
        return c + a * math.sin(w * t + p)

    return _with_rows(f, (IN_SINE, -1, a, w, p, c))


def ramp_input(slope: float, start: float = 0.0, end: float = math.inf) -> Callable:
    """f(t, q, qdot) = slope (min(max(t, start), end) - start): 0 before start, linear, held after end [s]."""
    s, t0, t1 = float(slope), float(start), float(end)

    def f(t, q, qdot):
        return s * (min(max(t, t0), t1) - t0)

    return _with_rows(f, (IN_RAMP, -1, s, t0, t1, 0.0))


def pd_input(k: int, target: float, stiffness: float, damping: float = 0.0) -> Callable:
    """f(t, q, qdot) = stiffness (target - q[k]) - damping qdot[k]: a servo on coordinate k."""
    k, r, kp, kd = int(k), float(target), float(stiffness), float(damping)

    def f(t, q, qdot):
        return kp * (r - q[k]) - kd * qdot[k]

    return _with_rows(f, (IN_PD, k, kp, r, kd, 0.0))


def _with_rows(f: Callable, *rows) -> Callable:
    """f with the attribute ``kernel_rows``: its terms as rows (kind, k of a pd's q_k or -1, a, b, c, d) of the
    compiled inputs (gibbsimpact.kernel.radau._inputs), so that the compiled Radau step evaluates the
    same closed form without calling f."""
    f.kernel_rows = rows
    return f


def input_function(spec: InputSpec, k: int) -> Callable:
    """The closure f(t, q, qdot) of ``spec`` acting on coordinate index k."""
    p = spec.parameters
    if spec.kind == "constant":
        return constant_input(p["value"])
    if spec.kind == "sine":
        return sine_input(p["amplitude"], p["frequency"], p.get("phase", 0.0), p.get("offset", 0.0))
    if spec.kind == "ramp":
        return ramp_input(p["slope"], p.get("start", 0.0), p.get("end", math.inf))
    if spec.kind == "pd":
        return pd_input(k, p.get("target", 0.0), p["stiffness"], p.get("damping", 0.0))
    raise ValueError(f"input kind {spec.kind!r} is not one of {', '.join(INPUT_KINDS)}")


def named_inputs(specs, coordinate_names) -> dict:
    """``{name: f(t, q, qdot)}`` for gibbsimpact.simulate: the sum of every spec on that coordinate.

    coordinate_names : the model's names, length N (``Model.coordinate_names``).
    Raises ValueError for a coordinate the model does not have.
    """
    names = tuple(coordinate_names)
    groups: dict[str, list] = {}
    for spec in specs:
        name = spec.coordinate.replace("theta_m1", "theta_-1")
        if name not in names:
            raise ValueError(f"input on unknown coordinate {spec.coordinate!r}; this model has {', '.join(names)}")
        groups.setdefault(name, []).append(input_function(spec, names.index(name)))
    out = {}
    for name, fs in groups.items():
        if len(fs) == 1:
            out[name] = fs[0]
        else:
            out[name] = _sum_of(tuple(fs))
    return out


def _sum_of(fs: tuple) -> Callable:
    def f(t, q, qdot):
        return sum(g(t, q, qdot) for g in fs)

    return _with_rows(f, *(r for g in fs for r in g.kernel_rows))


def is_angle_coordinate(model, k: int) -> bool:
    """True when q_k is an angle [rad] (its generalised force a torque [N m]), False for a length [m].

    Angles: theta_i, and the node slopes t_j of a finite-element link
    (coordinates (w_1, t_1, ..., w_ne, t_ne) per bending direction, gibbsimpact.elements).
    """
    name = model.coordinate_names[k]
    if name.startswith("theta"):
        return True
    for link, idx in zip(model.chain.links, model.delta_index):
        if k in idx:
            # Within each direction's block of 2 n_e coordinates, odd positions (1, 3, ...) are slopes.
            return bool(link.elements) and (int(list(idx).index(k)) % 2 == 1)
    return False


def describe_input(spec: InputSpec, angle: bool) -> str:
    """The input as a formula in words, e.g. ``sine Q = 8.7 - 3 sin(2 pi 1 Hz t + 0 deg) N m``.

    angle : True when the coordinate is an angle (torque in N m), False for a length (force in N).
    """
    p = spec.parameters
    F = "N m" if angle else "N"
    u = "rad" if angle else "m"
    name = spec.coordinate
    if spec.kind == "constant":
        return f"constant Q = {_g(p['value'])} {F}"
    if spec.kind == "sine":
        a, sign = p["amplitude"], "-" if p["amplitude"] < 0 else "+"
        return (f"sine Q = {_g(p.get('offset', 0.0))} {sign} {_g(abs(a))} sin(2 pi {_g(p['frequency'])} Hz t "
                f"+ {_g(math.degrees(p.get('phase', 0.0)))} deg) {F}")
    if spec.kind == "ramp":
        start, end = p.get("start", 0.0), p.get("end", math.inf)
        held = f", held at {_g(p['slope'] * (end - start))} {F} from t = {_g(end)} s" if math.isfinite(end) else ""
        return f"ramp Q = {_g(p['slope'])} {F}/s * (t - {_g(start)} s) from t = {_g(start)} s (0 before){held}"
    if spec.kind == "pd":
        target = p.get("target", 0.0)
        deg = f" ({_g(math.degrees(target))} deg)" if angle else ""
        return (f"pd servo Q = {_g(p['stiffness'])} {F}/{u} * (target - {name}) - {_g(p.get('damping', 0.0))} "
                f"{F} s/{u} * {name}_dot, target {_g(target)} {u}{deg}")
    return spec.kind


def _g(x: float) -> str:
    return f"{x:.6g}"
