"""Validity limits of the model: states and stops the equations accept but do not describe well.

The checks name the quantity, its value and the limit; they never change or clip
anything. ``check_*`` return the messages (a list of str, empty when all is well),
``warn_*`` issue each as a :class:`ValidityWarning` and return them too. The
limits and their reasons are in docs/theory.md, "Validity limits":

* ``DEFLECTION_LIMIT``: the peak deflection of a link over its length. The links are
  linear Euler-Bernoulli beams (small slopes, no foreshortening, no geometric
  stiffening). At |v| = 0.1 l the first clamped-clamped mode has its slope up to
  pi 0.1 = 0.31 rad and a neglected foreshortening of (pi^2/4) 0.1^2 = 2.5 % of l;
  both errors grow with the square of the deflection beyond.
* ``STRAIN_ENERGY_FACTOR``: initial strain energy over the energy scale
  ``kinetic + max(|gravity|, m |g| L)`` (m the total mass, L the summed link
  lengths; m |g| L makes the scale independent of the gravity datum X2 = 0). A
  state whose strain energy is 100 times that scale is dominated by one violent
  vibration: the deflection is far outside small-deflection theory or the input
  has a wrong unit.
* ``GIMBAL_MARGIN``: the free base's rotations Rx(theta_-1) Ry(theta_0) Rz(theta_1)
  are singular at theta_0 = +-pi/2 (theta_-1 and theta_1 then turn about the same
  axis and the mass matrix loses rank). A run re-charts the base before it gets there
  (simulation.charts: |theta_0| <= 1.2 rad in every chart), from any initial angles;
  only a run whose base angles are prescribed keeps its first chart, and if it fails
  within 0.05 rad (2.9 deg) of +-pi/2 it stopped because of the coordinates, not the mechanics.
* Newton's law at a point whose effective mass depends on the discretisation
  (contact_points.ContactPoint.newton_ill_posed: a span point, the free tip of a
  finite-element or clamped-free link): ``check_impact`` names the first impact with an
  impulse there; the loop warns once per run (docs/theory.md §11.4).
* ``SPIN_LIMIT``: the rate at which a flexible link with ``geometric_stiffening=False`` turns about
  an axis across it, as a fraction of its first bending frequency omega_1 (clamped at its frame).
  Such a link has no geometric (centrifugal) stiffening (docs/theory.md): a link spinning at Omega misses the stiffness
  Omega^2 K_G, and its in-plane bending loses Omega^2 M, so that beyond Omega = omega_1 it
  becomes unstable and its deflection grows without bound. At Omega = 0.3 omega_1 (lambda = 1.05
  for a uniform clamped-free link) the missing stiffening already lowers the first bending
  frequency by 5 % (3.5160 against 3.6816 at lambda = 1): the answer is no longer a small error
  of the linear model.
"""

from __future__ import annotations

import warnings

import numpy as np

from .. import kernel as _k
from ..dynamics.kinematics import run_kernel, section, states
from ..dynamics.link_points import link_points
from ..model.shapes import link_deflection
from ..contact.walls import describe
from .contact_points import contact_points

__all__ = [
    "DEFLECTION_LIMIT", "GIMBAL_MARGIN", "SPIN_LIMIT", "STRAIN_ENERGY_FACTOR", "ValidityWarning", "check_impact",
    "check_result", "check_run", "check_spin", "check_state", "check_stop", "spin_rates", "warn_impact", "warn_result",
    "warn_state",
]

#: Largest peak deflection of a link, as a fraction of its length (small-deflection theory).
DEFLECTION_LIMIT = 0.1
#: Largest ratio of the initial strain energy to the kinetic + gravitational energy scale.
STRAIN_ENERGY_FACTOR = 100.0
#: Distance [rad] of theta_0 from +-pi/2 within which a failed run is attributed to gimbal lock.
GIMBAL_MARGIN = 0.05
#: Largest spin rate of a flexible link across its axis, as a fraction of its first bending frequency.
SPIN_LIMIT = 0.3

_SAMPLES = 201  # abscissae per link at which deflections are evaluated (FE nodes fall on them for n_e | 200)
_WALL_TOL = 1e-6  # m: a link point further than this beyond a wall is reported


class ValidityWarning(UserWarning):
    """A state or a stop outside the validity limits of the model (gibbsimpact.validity)."""


def _deflections(model, q, n: int = _SAMPLES) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per link: (x (n,) [m], |(v, w)| (n,) [m]), the deflection off the link's x axis at q (N,)."""
    out = []
    for i, lk in enumerate(model.chain.links):
        x = np.linspace(0.0, lk.length, n)
        idx = model.delta_index[i]
        if len(idx) == 0:
            out.append((x, np.zeros(n)))
            continue
        v, w = link_deflection(model, q, i, x)
        out.append((x, np.hypot(v, w)))
    return out


def _gimbal_distance(theta_0: float) -> float:
    """|theta_0 - (pi/2 + k pi)| for the nearest integer k [rad]."""
    r = float(np.mod(theta_0 - 0.5 * np.pi, np.pi))
    return min(r, np.pi - r)


def check_state(model, q0, qdot0, walls=()) -> list[str]:
    """Messages for an initial state (q0, qdot0) (N,) outside the model's validity limits.

    * a link whose peak deflection exceeds DEFLECTION_LIMIT times its length;
    * a strain energy above STRAIN_ENERGY_FACTOR times kinetic + max(|gravity|, m |g| L)
      (skipped when that scale is zero: a chain at rest without gravity is pure vibration);
    * a point of a deformed link beyond a wall (only joints touch walls in this model).

    Nothing is changed. Returns [] for a state within the limits.
    """
    q0 = np.asarray(q0, dtype=float)
    qdot0 = np.asarray(qdot0, dtype=float)
    msgs = []
    for i, (lk, (x, r)) in enumerate(zip(model.chain.links, _deflections(model, q0)), start=1):
        peak = float(r.max())
        limit = DEFLECTION_LIMIT * lk.length
        if peak > limit:
            at = float(x[int(np.argmax(r))])
            msgs.append(
                f"link {i}: initial peak deflection {peak:.4g} m (at x = {at:.3g} m) is {peak / lk.length:.3g} "
                f"link lengths, beyond the small-deflection limit {DEFLECTION_LIMIT:g} l = {limit:.4g} m of the "
                "linear Euler-Bernoulli links; the model does not describe such a shape (check the unit of its "
                "delta coordinates)")
    E = model.energy(q0, qdot0)
    g = float(np.linalg.norm(np.asarray(model.gravity, dtype=float)))
    weight_scale = model.total_mass * g * sum(lk.length for lk in model.chain.links)
    scale = abs(float(E.kinetic)) + max(abs(float(E.gravity)), weight_scale)
    strain = float(E.strain)
    if scale > 0 and strain > STRAIN_ENERGY_FACTOR * scale:
        msgs.append(
            f"initial strain energy {strain:.5g} J is {strain / scale:.3g} times the energy scale {scale:.4g} J "
            f"of the state (kinetic {float(E.kinetic):.4g} J + max(|gravity| {abs(float(E.gravity)):.4g} J, "
            f"m g L {weight_scale:.4g} J)), beyond the limit of {STRAIN_ENERGY_FACTOR:g} times: the initial "
            "deflections dominate everything else")
    if walls:
        pts = link_points(model, q0, _SAMPLES)
        for k, w in enumerate(walls, start=1):
            gaps = w.gap(pts.reshape(-1, 3)).reshape(pts.shape[:2])
            for i in range(pts.shape[0]):
                depth = -float(gaps[i].min())
                if depth > _WALL_TOL:
                    msgs.append(
                        f"link {i + 1}: a point of the deformed link lies {depth:.4g} m beyond wall {k} "
                        f"({describe(w)}) at t0 (limit {_WALL_TOL:g} m); only the joints touch walls in this "
                        "model, so the link passes through it")
    return msgs


def check_stop(model, result) -> list[str]:
    """A message when a free-base run failed with theta_0 within GIMBAL_MARGIN of +-pi/2, else [].

    The stop is then due to the singular rotation sequence Rx Ry Rz of the free base
    (gimbal lock), not to the mechanics. Only a run that cannot re-chart its base (a base angle
    prescribed: simulation.charts) gets there; the others keep |theta_0| <= 1.2 rad.
    """
    if model.chain.base != "free" or result.status != "failed" or len(result.t) == 0:
        return []
    theta_0 = float(result.q[-1, 4])
    d = _gimbal_distance(theta_0)
    if d >= GIMBAL_MARGIN:
        return []
    message = (
        f"the run failed at t = {float(result.t[-1]):.9g} s with theta_0 = {theta_0:.9g} rad, {d:.3g} rad from "
        f"+-pi/2 (gimbal-lock margin {GIMBAL_MARGIN:g} rad): the free base's rotations Rx(theta_-1) Ry(theta_0) "
        "Rz(theta_1) are singular there (theta_-1 and theta_1 turn about one axis), so the coordinates, not the "
        "motion, stopped it; a run re-charts the base before it gets there (simulation.charts) unless a base angle "
        "is prescribed, as here: prescribe a motion that keeps theta_0 away from +-pi/2")
    return [message]


def _discretisation(link) -> str:
    """How a link is discretised, in words: '1 finite element', '2 assumed modes (clamped-free)'."""
    if link.elements:
        return f"{link.elements} finite element{'s' if link.elements > 1 else ''}"
    kinds = ", ".join(dict.fromkeys(m.kind for m in link.modes))
    return f"{len(link.modes)} assumed mode{'s' if len(link.modes) > 1 else ''} ({kinds})"


def _newton_message(model, rec, walls, w: int, point) -> str:
    """The text of check_impact for the impact rec on wall w at ``point`` (a ContactPoint)."""
    i = point.link
    span = point.description.startswith("span")
    return (
        f"Newton's law applied at {point.name} ({point.description}) on wall {w + 1} ({describe(walls[w])}) at "
        f"t = {rec.time:.9g} s: the effective mass of a point of a flexible link that nothing else holds depends "
        f"on the discretisation (link {i + 1}: {_discretisation(model.chain.links[i])}); it tends to zero as the "
        "link is refined, and so do this impulse and the micro-impacts that follow (with finite elements the "
        "impulse halves with every doubling of elements; docs/theory.md §11.4). Give the wall a stiffness "
        f"(e.g. gi.{type(walls[w]).__name__}(..., restitution=e, stiffness=k): the compliant contact law of "
        "docs/theory.md §11.5, which converges as the link is refined and has the rigid limit"
        + ("; not with prescribed coordinates yet: drive the joint by inputs instead"
           if rec.actuator_impulses is not None else "")
        + f"), or make link {i + 1} rigid (no modes or "
        "elements), or give it clamped-clamped modes (its ends then move with its frame; the number of modes still sets their "
        "effective mass)" + ("; keep the contacts at the joints (link_contacts=False)" if span else "")
        + "; and read the collision as a whole in Result.episodes (its impulse and effective restitution), "
        "not impact by impact" + (". Where the micro-impacts accumulate at the span the run steps them "
                                  "(accumulation='rest' or 'step', docs/theory.md §15.5): the link comes to rest, "
                                  "but the transient still depends on the mesh" if span else ""))


def check_impact(model, rec, walls, link_contacts: bool = True) -> list[str]:
    """A message when the impact ``rec`` (ImpactRecord) applies Newton's law, with an impulse, at a point
    whose effective mass depends on the discretisation (contact_points.ContactPoint.newton_ill_posed), else [].

    There 1 / (n^T J M^-1 J^T n) tends to 0 as the link is refined: the impulse has no limit (with finite
    elements it halves with every doubling of elements), and the micro-impacts that follow have none either.
    """
    points = contact_points(model, link_contacts and bool(walls), walls)
    for c, w, lam in zip(rec.joints, rec.wall, rec.impulses):
        point = points[int(c) - 1] if 0 < int(c) <= len(points) else None
        if w < 0 or not lam > 0.0 or point is None or not point.newton_ill_posed:
            continue
        return [_newton_message(model, rec, walls, int(w), point)]
    return []


def warn_impact(model, rec, walls, link_contacts: bool = True, stacklevel: int = 2) -> list[str]:
    """check_impact, its message issued as a ValidityWarning; returns it (stacklevel as for warn_state)."""
    return _warn(check_impact(model, rec, walls, link_contacts), stacklevel)


def spin_rates(model, qs, qdots, chunk: int = 1024) -> np.ndarray:
    """Omega (K, n) [rad/s]: the rate at which each link frame turns about axes across the link,
    |(omega_y, omega_z)| of its body angular velocity omega = vee(R^T Rdot), at the states qs, qdots (K, N)."""
    n, K = model.n_links, len(qs)
    out = np.empty((K, n))
    job = _k.JOB_FRAMES
    for a in range(0, K, chunk):
        b = min(a + chunk, K)
        F = section(model, run_kernel(model, states(qs[a:b], qdots[a:b]), job), b - a, job, "frames")
        F = F.reshape(b - a, n + 1, 3, 4, 4)[:, :n]
        R, Rd = F[:, :, 0, :3, :3], F[:, :, 1, :3, :3]
        W = np.einsum("knji,knjl->knil", R, Rd)  # R^T Rdot, skew: omega_x = W21, omega_y = W02, omega_z = W10
        out[a:b] = np.hypot(W[..., 0, 2], W[..., 1, 0])
    return out


def check_spin(model, result) -> list[str]:
    """A message per flexible link without geometric stiffening that turned across its axis faster than
    SPIN_LIMIT omega_1 during the run (a stiffened link's centrifugal stiffening is modelled)."""
    lds = model.link_data
    flexible = [i for i, ld in enumerate(lds) if ld.K.size and not model.chain.links[i].stiffened]
    if not flexible or len(result.t) == 0:
        return []
    rates = spin_rates(model, result.q, result.qdot)
    msgs = []
    for i in flexible:
        w1 = lds[i].first_frequency
        k = int(np.argmax(rates[:, i]))
        if rates[k, i] > SPIN_LIMIT * w1:
            msgs.append(
                f"link {i + 1} turns across its axis at up to {rates[k, i]:.4g} rad/s (t = {float(result.t[k]):.6g} s), "
                f"{rates[k, i] / w1:.3g} times its first bending frequency omega_1 = {w1:.4g} rad/s (limit "
                f"{SPIN_LIMIT:g}): the link has no geometric (centrifugal) stiffening, so a spinning link's "
                "bending is underestimated in stiffness, and beyond omega_1 it grows without bound; trust the "
                "deflections of this run only qualitatively, or give the link geometric_stiffening=True")
    return msgs


def check_result(result) -> list[str]:
    """The messages of a finished or stopped run: check_stop, check_spin."""
    return check_stop(result.model, result) + check_spin(result.model, result)


def check_run(result) -> list[str]:
    """Every message a run issued, recomputed from its Result (a saved run's, gibbsimpact show): check_state at
    the first sample (q, qdot (N,) [m, rad, m/s, rad/s] and the walls), check_impact of the first impact that
    has one (a run warns once), then check_result; in the order the run issued them."""
    if len(result.t) == 0:
        return []
    model = result.model_at(0)
    msgs = check_state(model, result.q[0], result.qdot[0], result.walls)
    link_contacts = bool(result.settings.get("link_contacts", True))
    for rec in result.impacts:
        newton = check_impact(result.model, rec, result.walls, link_contacts)
        if newton:
            msgs += newton
            break
    return msgs + check_result(result)


def _warn(msgs, stacklevel):
    for m in msgs:
        # +2: this function and warn_state / warn_result.
        warnings.warn(m, ValidityWarning, stacklevel=stacklevel + 2)
    return msgs


def warn_state(model, q0, qdot0, walls=(), stacklevel: int = 2) -> list[str]:
    """check_state, each message issued as a ValidityWarning; returns the messages.

    stacklevel : as if the function calling warn_state called warnings.warn with it
    (2, the default, names the line that called that function, e.g. the user's
    ``gi.simulate(...)``).
    """
    return _warn(check_state(model, q0, qdot0, walls), stacklevel)


def warn_result(result, stacklevel: int = 2) -> list[str]:
    """check_result, each message issued as a ValidityWarning; returns the messages (stacklevel as
    for warn_state)."""
    return _warn(check_result(result), stacklevel)
