"""The run settings of a case file: ``[time]``, ``[solver]``, ``[output]``, and the keywords of
Case.simulate that override them (OVERRIDE_KEYS), held to the same ranges and rules."""

from __future__ import annotations

import math

from .keypaths import join
from .reader import _BAD, _MISSING, _Reader
from .schema import (
    _FILE_NAMES, _METHODS, _OUTPUT_KEYS, _SOLVER_CHOICES, _SOLVER_KINDS, _TIME_KEYS, MAX_SAMPLES, OUTPUT_DEFAULTS,
    OVERRIDE_KEYS, SOLVER_KEYS, range_of,
)
from .text import fmt

__all__ = ["read_time", "read_solver", "read_output", "check_samples", "override_problems"]

#: [output] key -> its kind.
_OUTPUT_KINDS = dict(directory="str", plots="bool", animate="bool", dpi="number", animation_fps="number",
                     animation_speed="number", points_per_link="number")


def read_time(r: _Reader, top: dict):
    """(t_start, t_end) [s] of [time], t_end > t_start; _BAD on a problem."""
    if "time" not in top:
        r.add("time", "missing ([time] table with t_end_s)")
        return _BAD
    tt = r.table(top["time"], "time", _TIME_KEYS, "a [time] table")
    if tt is None:
        return _BAD
    t0 = r.get(tt, "time", "t_start_s", "number", default=0.0)
    t1 = r.get(tt, "time", "t_end_s", "number", required=True, what="end time in s")
    if _BAD in (t0, t1):
        return _BAD
    if not t1 > t0:
        r.add("time.t_end_s", f"must be after t_start_s = {fmt(t0)} s, got {fmt(t1)}")
        return _BAD
    return (t0, t1)


def read_solver(r: _Reader, top: dict) -> dict:
    """{keyword of simulate: value} of the [solver] keys the case sets (SOLVER_KEYS); bad ones left out."""
    solver = {}
    if "solver" not in top:
        return solver
    st = r.table(top["solver"], "solver", {k: v[2] for k, v in SOLVER_KEYS.items()}, "a [solver] table")
    if st is None:
        return solver
    for key, (kw, _, _) in SOLVER_KEYS.items():
        if key in st:
            v = _solver_setting(r, kw, st[key], join("solver", key))
            if v is not _BAD:
                solver[kw] = v
    return solver


def read_output(r: _Reader, top: dict) -> dict:
    """OUTPUT_DEFAULTS updated with the good keys of [output]."""
    output = dict(OUTPUT_DEFAULTS)
    ot = r.table(top["output"], "output", _OUTPUT_KEYS, "an [output] table") if "output" in top else None
    if ot is not None:
        for key, kind in _OUTPUT_KINDS.items():
            v = r.get(ot, "output", key, kind, default=_MISSING)
            if v is not _MISSING and v is not _BAD:
                output[key] = v
    return output


def _solver_setting(r: _Reader, kw: str, v, label: str):
    """v read as the value of simulate's keyword kw (a [solver] key): its kind, its range (RANGES), a
    known method, one of its choices (_SOLVER_CHOICES); _BAD on a problem, reported at ``label``."""
    kind = _SOLVER_KINDS[kw]
    v = r.value(v, label, kind, range_of(OVERRIDE_KEYS[kw]) if kind == "number" else None)
    if v is _BAD:
        return _BAD
    if kw == "method" and v not in _METHODS:
        r.add(label, f"unknown method {v!r}; use one of {', '.join(_METHODS)}")
        return _BAD
    if kw in _SOLVER_CHOICES and v not in _SOLVER_CHOICES[kw]:
        r.add(label, f"unknown value {v!r}; use " + " or ".join(
            f"{c!r} ({what})" for c, what in _SOLVER_CHOICES[kw].items()))
        return _BAD
    return v


def check_samples(r: _Reader, t_span, solver: dict, names: dict) -> None:
    """Samples (t_end - t_start) / output_dt and steps (t_end - t_start) / max_step at most MAX_SAMPLES;
    ``names`` maps t_start, t_end, output_dt, max_step to their names in the messages."""
    span = t_span[1] - t_span[0]
    for kw, what in (("output_dt", "samples"), ("max_step", "solver steps at least")):
        dt = solver.get(kw)
        if dt is None or not math.isfinite(dt) or span / dt <= MAX_SAMPLES:
            continue
        r.add(names[kw], f"({names['t_end']} - {names['t_start']}) / {names[kw]} = {fmt(span)} s / {fmt(dt)} s = "
                         f"{fmt(span / dt)} {what}, more than {fmt(MAX_SAMPLES)} (memory and run time); make "
                         f"{names[kw]} at least {fmt(span / MAX_SAMPLES)} s or shorten the time span")


def override_problems(t_span, solver: dict, overrides: dict, names: dict | None = None) -> list[tuple[str, str]]:
    """The (name, message) problems of keywords that override case-file keys (OVERRIDE_KEYS) of a case
    with ``t_span`` [s] and ``solver`` settings: the keys' ranges and rules, t_end after t_start, the
    sample limit. ``names`` maps a keyword to its name in the messages (by default the keyword);
    keywords that override nothing, and None (the case's own value), are not checked."""
    r = _Reader()
    given = {kw: v for kw, v in overrides.items() if kw in OVERRIDE_KEYS and v is not None}
    labels = {**_FILE_NAMES, **{kw: (names or {}).get(kw, kw) for kw in given}}
    solver = {kw: v for kw, v in solver.items() if not (kw in overrides and overrides[kw] is None)}
    t0, t1 = t_span
    for kw, v in given.items():
        if kw != "t_end":
            v = _solver_setting(r, kw, v, labels[kw])
            if v is not _BAD:
                solver[kw] = v
            continue
        v = r.value(v, labels[kw], "number", range_of(OVERRIDE_KEYS[kw]))
        if v is not _BAD and not v > t0:
            r.add(labels[kw], f"must be after {labels['t_start']} = {fmt(t0)} s, got {fmt(v)}")
            v = _BAD
        t1 = None if v is _BAD else v
    if t1 is not None:
        check_samples(r, (t0, t1), solver, labels)
    return r.problems
