"""Prescribed coordinates of a run (simulate's ``prescribed``; formulation §16), validated once.

``prescribed = {name: f}`` with f(t) -> (q, qdot, qddot) for joint coordinates only (``theta_i``,
``d_i``; not elastic coordinates, not a free-flying or planar base's position and orientation,
which include theta_1 there). The run keeps the full y = (q, qdot, ...): the prescribed slots are
read from f(t) by the right-hand side (never from y), their derivatives are f's, so they ride
along as known functions of t, and every stored sample and phase end is reset to f(t) exactly
(:meth:`Prescribed.fill`). The initial state must agree with the profiles: q0, qdot0 at a
prescribed coordinate differing from f(t0) by more than 1e-9 (1 + |f|) is refused (not overridden:
a silently changed initial state would hide a wrong profile or a wrong q0).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

#: Relative mismatch allowed between q0, qdot0 and f(t0) at a prescribed coordinate.
START_TOL = 1e-9


class Prescribed(NamedTuple):
    """The prescribed coordinates of a run: names (n_p,), their indices in q (sorted), their profiles."""

    names: tuple
    index: np.ndarray
    functions: tuple

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_p, qdot_p, qddot_p) (n_p,) each at t [s]."""
        v = np.array([f(t) for f in self.functions], dtype=float).reshape(-1, 3)
        return v[:, 0], v[:, 1], v[:, 2]

    def fill(self, T: np.ndarray, Y: np.ndarray, N: int) -> None:
        """Set the prescribed slots of the states Y (K, 2N + ...) at the times T (K,) to f(T), in place."""
        for t, y in zip(np.atleast_1d(T), np.atleast_2d(Y)):
            q, qd, _ = self.at(float(t))
            y[self.index], y[N + self.index] = q, qd


def _call(name, f, t):
    try:
        v = np.asarray(f(t), dtype=float)
    except Exception as exc:  # the user's function: say which one failed and how
        raise ValueError(f"simulate prescribed[{name!r}] failed at t = {t:g} s: {exc!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"simulate prescribed[{name!r}](t = {t:g} s) returned {v.tolist()!r}; it must return "
                         "three finite numbers (q, qdot, qddot)")
    return v


def _joint_names(model) -> list:
    """Names of the coordinates a profile may drive: the joints, without a moving base's orientation."""
    names = model.coordinate_names
    joints = [names[k] for k in model.theta_index if k >= 0]  # a weld (-1) has no coordinate
    return joints if not model.chain.free_base else joints[1:]


def prescription(model, prescribed, t_span, q0, qdot0) -> Prescribed | None:
    """The validated Prescribed of simulate's ``prescribed`` (None or {}: None); each error names the
    coordinate and the fix."""
    if prescribed is None or (isinstance(prescribed, dict) and not prescribed):
        return None
    if not isinstance(prescribed, dict):
        raise ValueError(f"simulate prescribed={prescribed!r} must be a dict {{coordinate name: f(t) -> (q, qdot, "
                         "qddot)}}, e.g. {'theta_1': gi.profiles.constant_speed(0.0, 1.0)}")
    names, allowed = model.coordinate_names, _joint_names(model)
    t0, t_end = t_span
    for name, f in prescribed.items():
        if name not in allowed:
            what = ("is not a coordinate of this model" if name not in names else
                    "is an elastic coordinate" if name.startswith("delta") else "is a coordinate of the moving base")
            raise ValueError(f"simulate prescribed[{name!r}] {what}; only joint coordinates can be prescribed: "
                             f"{', '.join(allowed) or 'none in this model'}")
        if not callable(f):
            raise ValueError(f"simulate prescribed[{name!r}]={f!r} must be a function f(t) -> (q, qdot, qddot), "
                             "e.g. gi.profiles.spin_up(Omega_s, T_s)")
        lo, hi = getattr(f, "domain", (-math.inf, math.inf))
        if t0 < lo or t_end > hi:
            raise ValueError(f"simulate prescribed[{name!r}] is defined on [{lo:g}, {hi:g}] s only; t_span = "
                             f"({t0:g}, {t_end:g}) s leaves it: give samples over the whole span")
    order = sorted(prescribed, key=names.index)
    index = np.array([names.index(n) for n in order], dtype=int)
    for name, k in zip(order, index):
        v = _call(name, prescribed[name], t0)
        for what, given, want in (("q0", q0[k], v[0]), ("qdot0", qdot0[k], v[1])):
            if abs(given - want) > START_TOL * (1.0 + abs(want)):
                raise ValueError(f"simulate {what}[{k}] = {float(given)!r} ({name}) differs from "
                                 f"prescribed[{name!r}](t0 = {t0:g} s) = {float(want)!r}; start on the profile: "
                                 f"set {what}[{k}] = {float(want)!r}")
        _call(name, prescribed[name], t_end)
    return Prescribed(tuple(order), index, tuple(prescribed[n] for n in order))
