"""Motion profiles of a prescribed coordinate: q(t) with its first two derivatives (formulation §16).

A profile is a callable ``f(t) -> (q, qdot, qddot)`` [rad or m; per s; per s^2], the form
``simulate(..., prescribed={"theta_1": f})`` takes; a case file's ``[[prescribed]]`` tables build
the same objects (gibbsimpact.case). ``domain`` is the time interval [s] on which the profile is
defined (simulate refuses a t_span outside it).

    spin_up         t < T_s: q = q0 + (Omega_s/T_s) (t^2/2 + (T_s/(2 pi))^2 (cos(2 pi t/T_s) - 1)),
                    then q = q0 + Omega_s (t - T_s/2)   (Kane, Ryan & Banerjee 1987; q = q0 for t < 0)
    constant_speed  q = q0 + v t
    point_to_point  s = (t - t_a)/(t_b - t_a) in [0, 1]: q = q_a + (q_b - q_a)(10 s^3 - 15 s^4 + 6 s^5)
                    (zero velocity and acceleration at both ends), q_a before t_a, q_b after t_b
    samples         the cubic spline through (t_k, q_k) (scipy CubicSpline, not-a-knot ends) and its
                    derivatives; defined on [t_0, t_last] only
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

__all__ = ["PROFILE_KINDS", "Profile", "spin_up", "constant_speed", "point_to_point", "samples", "profile"]

#: Profile kinds of a case file's [[prescribed]] tables, in the order the docs list them.
PROFILE_KINDS = ("spin_up", "constant_speed", "point_to_point", "samples")


@dataclass(frozen=True)
class Profile:
    """A motion profile: ``profile(t) -> (q, qdot, qddot)`` floats [rad or m, per s, per s^2].

    kind : one of PROFILE_KINDS; parameters : its parameters (SI); domain : (t_lo, t_hi) [s] where
    it is defined; fun : the closed form t -> (q, qdot, qddot).
    """

    kind: str
    parameters: dict
    domain: tuple
    fun: Callable = field(repr=False, compare=False)

    def __call__(self, t: float) -> tuple[float, float, float]:
        return self.fun(float(t))

    def __reduce__(self):
        """Pickled as its kind and parameters (its closure is not picklable): sweeps over processes send it."""
        return _rebuild, (self.kind, self.parameters)


def _number(kind, name, v, positive=False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v) \
            or (positive and not v > 0):
        raise ValueError(f"profile {kind} {name}={v!r} must be a finite {'positive ' if positive else ''}number")
    return float(v)


def spin_up(Omega_s: float, T_s: float, q0: float = 0.0) -> Profile:
    """From rest at q0 (t <= 0) to the constant rate Omega_s [rad/s or m/s] at T_s [s], smoothly (module docstring):
    qddot = (Omega_s/T_s)(1 - cos(2 pi t/T_s)) on [0, T_s], zero at both ends."""
    Om, T, q0 = _number("spin_up", "Omega_s", Omega_s), _number("spin_up", "T_s", T_s, True), \
        _number("spin_up", "q0", q0)
    w = 2.0 * math.pi / T

    def f(t):
        if t <= 0.0:
            return q0, 0.0, 0.0
        if t < T:
            return (q0 + Om / T * (0.5 * t * t + (math.cos(w * t) - 1.0) / (w * w)),
                    Om / T * (t - math.sin(w * t) / w), Om / T * (1.0 - math.cos(w * t)))
        return q0 + Om * (t - 0.5 * T), Om, 0.0

    return Profile("spin_up", dict(Omega_s=Om, T_s=T, q0=q0), (-math.inf, math.inf), f)


def constant_speed(q0: float, v: float) -> Profile:
    """q = q0 + v t [rad or m], at the constant rate v [per s]."""
    q0, v = _number("constant_speed", "q0", q0), _number("constant_speed", "v", v)
    return Profile("constant_speed", dict(q0=q0, v=v), (-math.inf, math.inf), lambda t: (q0 + v * t, v, 0.0))


def point_to_point(q_a: float, q_b: float, t_a: float, t_b: float) -> Profile:
    """The quintic rest-to-rest move from q_a at t_a to q_b at t_b [s] (module docstring)."""
    q_a, q_b = _number("point_to_point", "q_a", q_a), _number("point_to_point", "q_b", q_b)
    t_a, t_b = _number("point_to_point", "t_a", t_a), _number("point_to_point", "t_b", t_b)
    if not t_b > t_a:
        raise ValueError(f"profile point_to_point t_b={t_b!r} must be later than t_a={t_a!r}")
    D, T = q_b - q_a, t_b - t_a

    def f(t):
        s = min(max((t - t_a) / T, 0.0), 1.0)
        return (q_a + D * s ** 3 * (10.0 - 15.0 * s + 6.0 * s * s), D / T * 30.0 * s * s * (1.0 - s) ** 2,
                D / (T * T) * 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s))

    return Profile("point_to_point", dict(q_a=q_a, q_b=q_b, t_a=t_a, t_b=t_b), (-math.inf, math.inf), f)


def samples(t, q) -> Profile:
    """The cubic spline (not-a-knot) through the samples t (K,) [s] increasing, q (K,) [rad or m], K >= 4."""
    from scipy.interpolate import CubicSpline

    t, q = np.asarray(t, dtype=float), np.asarray(q, dtype=float)
    if t.ndim != 1 or t.shape != q.shape or t.size < 4:
        raise ValueError(f"profile samples t, q have shapes {t.shape}, {q.shape}; give two 1-d arrays of the "
                         "same length, at least 4 samples")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))) or not np.all(np.diff(t) > 0):
        raise ValueError("profile samples: t must be finite and strictly increasing, q finite")
    spline = CubicSpline(t, q)
    d1, d2 = spline.derivative(1), spline.derivative(2)
    return Profile("samples", dict(t=t.tolist(), q=q.tolist()), (float(t[0]), float(t[-1])),
                   lambda s: (float(spline(s)), float(d1(s)), float(d2(s))))


_BUILDERS = {"spin_up": spin_up, "constant_speed": constant_speed, "point_to_point": point_to_point,
             "samples": samples}


def _rebuild(kind: str, parameters: dict) -> Profile:
    return profile(kind, **parameters)


def profile(kind: str, **parameters) -> Profile:
    """The profile of ``kind`` (PROFILE_KINDS) with its parameters (SI): what a [[prescribed]] table builds."""
    if kind not in _BUILDERS:
        raise ValueError(f"profile kind={kind!r} must be one of {', '.join(PROFILE_KINDS)}")
    return _BUILDERS[kind](**parameters)
