"""Compliant (Hunt-Crossley) contact: the normal force law of a wall with a stiffness (docs/theory.md §11.5).

A wall given ``stiffness=k`` resolves a collision in time instead of by Newton's impulse law. With
g_- = max(0, -g) [m] the penetration of a contact point, gdot_- = -gdot [m/s] its rate and v_0 [m/s]
the approach speed at the start of the contact (state of the contact episode):

    F_n = max(0, k g_-^p (1 + chi gdot_- / v_0))            [N]                         (Hunt-Crossley)

with chi from the coefficient of restitution e by a published relation (``damping``):

* ``"flores"``: chi = 8 (1 - e) / (5 e)  (Flores, Machado, Silva, Martins 2011, Nonlinear Dyn. 65:
  "On the continuous contact force models for soft materials in multibody dynamics"), derived for
  the whole range 0 < e <= 1; singular at e = 0, which is refused (ValueError);
* ``"lankarani-nikravesh"``: chi = 3 (1 - e^2) / 4  (Lankarani & Nikravesh 1990, ASME J. Mech. Des.
  112: "A contact force model with hysteresis damping for impact analysis of multibody systems"),
  derived for e near 1 (it under-damps for small e).

Friction: regularised Coulomb, F_t = -mu F_n v_t / sqrt(|v_t|^2 + v_eps^2) [N] with v_t [m/s] the
tangential velocity of the point and v_eps = FRICTION_REGULARISATION.
"""

from __future__ import annotations

from numbers import Real

import numpy as np

#: The damping relations chi(e) by name (module docstring); the first is the default.
DAMPING_RELATIONS = ("flores", "lankarani-nikravesh")
#: v_eps [m/s] of the regularised Coulomb friction of compliant walls: below it friction acts as a
#: viscous force mu F_n v_t / v_eps (creep), above it as Coulomb's mu F_n.
FRICTION_REGULARISATION = 1e-3
#: Smallest v_0 [m/s] the law divides by: a contact that starts slower than this (a grazing touch, a
#: chain settling onto a wall) is damped as one that starts at 1 mm/s, so that chi k g^p / v_0 stays finite.
MIN_APPROACH_SPEED = 1e-3


def check_compliance(owner: str, stiffness, exponent, damping) -> tuple:
    """(stiffness [N/m^p] or None, exponent p, damping relation) of a wall, checked; ValueError naming the bad one."""
    if stiffness is not None and (isinstance(stiffness, bool) or not isinstance(stiffness, Real)
                                  or not np.isfinite(stiffness) or stiffness <= 0):
        raise ValueError(f"{owner} stiffness={stiffness!r} must be a positive number k [N/m^p] of the compliant law "
                         "F_n = k g^p (1 + chi gdot / v0), or None for Newton's law")
    if isinstance(exponent, bool) or not isinstance(exponent, Real) or not 1.0 <= exponent <= 10.0:
        raise ValueError(f"{owner} exponent={exponent!r} must be a number p in [1, 10] (1.5: Hertz, 1: linear)")
    if damping not in DAMPING_RELATIONS:
        raise ValueError(f"{owner} damping={damping!r} must be one of {', '.join(map(repr, DAMPING_RELATIONS))} "
                         "(the relation between the restitution e and the damping factor chi)")
    return (None if stiffness is None else float(stiffness)), float(exponent), damping


def damping_factor(e: float, damping: str = "flores") -> float:
    """chi(e) (dimensionless) of the relation ``damping`` (module docstring); ValueError for e = 0 with Flores."""
    if not 0.0 <= e <= 1.0:
        raise ValueError(f"restitution e={e!r} must be in [0, 1]")
    if damping == "flores":
        if e <= 0.0:
            raise ValueError("restitution e=0 with damping='flores' makes chi = 8 (1 - e) / (5 e) infinite: give "
                             "e > 0 (chi ~ 1.6 / e), or damping='lankarani-nikravesh' (chi = 3/4 at e = 0)")
        return 8.0 * (1.0 - e) / (5.0 * e)
    if damping == "lankarani-nikravesh":
        return 0.75 * (1.0 - e * e)
    raise ValueError(f"damping={damping!r} must be one of {', '.join(map(repr, DAMPING_RELATIONS))}")


def normal_force(penetration, rate, k, p, chi, v0):
    """Hunt-Crossley normal force F_n (K,) [N] and its damping part F_d (K,) [N].

    penetration : g_- (K,) [m] (negative values: no contact); rate : gdot_- = -gdot (K,) [m/s];
    k [N/m^p], p, chi : the law's constants (K,) or scalars; v0 : (K,) [m/s] approach speeds (> 0).

        F_e = k g_-^p,   F_n = max(0, F_e (1 + chi gdot_- / v0)),   F_d = F_n - F_e

    F_d is the force of the damping term (its power F_d gdot_- ... is what the contact dissipates).
    """
    d = np.maximum(penetration, 0.0)
    Fe = k * d ** p
    Fn = np.maximum(Fe * (1.0 + chi * rate / v0), 0.0)
    return Fn, Fn - Fe


def friction_force(Fn, v_t, mu):
    """Regularised Coulomb force (K, 3) [N] of normal forces Fn (K,) [N] on points sliding at v_t (K, 3) [m/s].

    F_t = -mu F_n v_t / sqrt(|v_t|^2 + v_eps^2),   v_eps = FRICTION_REGULARISATION.
    """
    s = np.sqrt(np.einsum("kc,kc->k", v_t, v_t) + FRICTION_REGULARISATION ** 2)
    return -(np.asarray(mu) * Fn / s)[:, None] * v_t
