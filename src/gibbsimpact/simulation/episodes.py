"""Collision episodes: the impacts and contact phases of one meeting of the chain with the walls
(docs/theory.md §14.7), a plain function of a Result computed after the run (no change to the loop).

Rules, with the symbols of the docs (b the contact band, §14.2):

* **A pair is engaged** from an impact of it, or a sample where it carries a contact force
  (resting contact, Result.contact_forces; a compliant wall's force, Result.compliant_forces, from the
  sample before its force rises from zero: its start event, where the gap closes), until the first
  later sample where its gap is above the band, ``g > b``, and it carries no force: the loop's
  "leave" event (§14.3), whose time is always a sample. That sample ends the pair's engagement.
* **The body is the chain**: one impact couples every link through M, so contacts of several
  links, simultaneous or not, and of several walls belong to one episode while they overlap.
  Episodes are disjoint in time, and their energies add up.
* **An episode** starts at the first engagement and takes in every engagement that starts before
  ``max over its pairs of (end of the pair's engagement + dwell of the pair)``. The dwell of a pair
  is the period T_1 of the slowest vibration of the link that moves its point relative to that link's
  frame (contact_points.rebound_period: the longest a rebound of the point driven by that link's
  vibration takes to come back), 0 for a point no shape function moves (a rigid link's, a joint of
  clamped-clamped links: there each Newton impact, with its own rebound, is an episode, unless the
  pair stays in the band or rests). ``dwell=`` sets one dwell for every pair instead.
* **Effective restitution** of the chain's rigid motion, with p = M qdot the generalised momenta,
  p^- at the sample before the first contact, P the generalised impulse of every contact of the
  episode (sum over its impacts of M(q_i)(qdot_i^+ - qdot_i^-), and the integral of
  J_j^T (n lambda + f_t) over its resting samples), R the coordinates that are not elastic, and w the
  generalised direction of the first impact's impulse, M(q_1)(qdot_1^+ - qdot_1^-) / sum Lambda:

      e_eff = - w_R^T M_RR^-1 (p^- + P)_R / (w_R^T M_RR^-1 p^-_R)

  w_R^T M_RR^-1 p_R is the normal velocity of the first contact for the chain made rigid with the
  same momenta p_R. An episode that starts with a compliant contact (its start event: no impact) takes p^- at
  that sample, P from the integrated generalised impulse of the compliant forces (Result.compliant_integrals,
  exact to the integrator's tolerance) and w = J_j^T n_j of its first compliant pair there.
  p^- + P keeps the momenta the contacts gave and leaves out what gravity, the inputs and the
  velocity terms did during the episode. For one impact of a rigid chain it is
  -v_n^+ / v_n^- = e exactly; for an arm on a fixed pivot (R = {theta_1}) it is the ratio of the
  angular momenta about the pivot, after (gravity removed) over before. NaN for an episode that
  did not start with an impact or a compliant contact (it started resting: nothing approached). It presumes an impulsive
  collision: ``non_contact_share``, the change of w_R^T M_RR^-1 p_R that the other forces made during
  the episode over its value before, says how far that holds (e_eff moves by up to that much if they
  are counted).
"""

from __future__ import annotations

from numbers import Real
from typing import NamedTuple

import numpy as np

from ..dynamics.gibbs_appell import mass_matrix
from ..dynamics.kinematics import joint_positions_and_jacobians
from .contact_points import contact_points, rebound_period
from .contacts import Contacts, gap_lipschitz

__all__ = ["BAND_SETTINGS", "Episode", "dwell_times", "episodes", "has_episodes"]


class Episode(NamedTuple):
    """One collision episode of a Result (module docstring; docs/theory.md §14.7).

    start, end : [s] the sample before its first contact, the sample where its last pair left the
        band (``ended``) or the run's last sample (``ended`` False: still in contact when the run ended)
    walls : 0-based indices into Result.walls of the walls it touched
    points : 1-based contact columns it engaged (ImpactRecord.joints numbering), in order of first contact
    first_point : the column that struck first (the largest impulse of the first impact, or the largest
        force of the first resting sample)
    impacts : 0-based indices into Result.impacts of the impacts between start and end (end stops included)
    samples : (k_start, k_end), the indices into Result.t of start and end
    impulse : [N s] total normal impulse of the walls: sum of the impacts' Lambda and the integral of the
        resting forces (trapezoid over the samples)
    max_impulse : [N s] the largest Lambda of one contact; max_force : [N] the largest resting force
    resting_time : [s] the time with a pair of it resting
    energy_before, energy_after : [J] E = T + V_g + V_s at start and at end (with inputs or damping their
        work over the episode is in the difference)
    restitution : e_eff (module docstring), NaN when it did not start with an impact (or the free base was
        re-charted during it)
    non_contact_share : |w_R^T M_RR^-1 (p(end) - p^- - P)_R| / |w_R^T M_RR^-1 p^-_R|, what the other forces
        (gravity, inputs, the velocity terms) changed of the approach during the episode: e_eff describes an
        impulsive collision when it is small (0.005 for the arm of issue 26), and it moves e_eff by up to that
        much; large when the wall also carried a load for long (a driven arm pressed onto a floor)
    max_penetration : [m] max(0, -g) over its pairs and samples, the deepest gap recorded
    damping_work, friction_work : [J] the work of the compliant contacts' damping and regularised friction over
        the episode (<= 0; 0 without compliant walls): with nothing else dissipating, energy_lost is
        -(damping_work + friction_work) to the integrator's tolerance (the contact's elastic energy is zero
        at both ends)
    """

    start: float
    end: float
    ended: bool
    walls: tuple
    points: tuple
    first_point: int
    impacts: tuple
    samples: tuple
    impulse: float
    max_impulse: float
    max_force: float
    resting_time: float
    energy_before: float
    energy_after: float
    restitution: float
    non_contact_share: float
    max_penetration: float
    damping_work: float = 0.0
    friction_work: float = 0.0

    @property
    def duration(self) -> float:
        """end - start [s]."""
        return self.end - self.start

    @property
    def energy_lost(self) -> float:
        """energy_before - energy_after [J]."""
        return self.energy_before - self.energy_after

    @property
    def n_impacts(self) -> int:
        return len(self.impacts)


#: The settings of a run that the rules read (the contact band, contacts.contact_band).
BAND_SETTINGS = ("contact_tol", "rtol", "atol")


def has_episodes(result) -> bool:
    """Whether the Result records the contact band of its run (a Result of simulate or load_result does;
    one built by hand without settings does not), so that :func:`episodes` applies."""
    return all(k in result.settings for k in BAND_SETTINGS)


def _run_settings(result) -> tuple[float, float, float, bool]:
    """(contact_tol [m], rtol, atol, link_contacts) of the run that made the Result."""
    s = result.settings
    missing = [k for k in BAND_SETTINGS if k not in s]
    if missing:
        raise ValueError(f"result.settings has no {', '.join(missing)}: collision episodes need the contact band "
                         "of the run that made the Result (gibbsimpact.simulate records it); give a Result of "
                         "simulate or load_result, or add those settings")
    return float(s["contact_tol"]), float(s["rtol"]), float(s["atol"]), bool(s.get("link_contacts", True))


def dwell_times(model, link_contacts: bool = True, walls=()) -> np.ndarray:
    """The dwell [s] of every gap-matrix column (C,): rebound_period of the link whose shape functions
    move the point, 0 where none does (contact_points.ContactPoint.link)."""
    return np.array([0.0 if p.link is None else rebound_period(model, p.link)
                     for p in contact_points(model, link_contacts, walls)])


class _Samples(NamedTuple):
    """What the rules read at every sample: gaps g (K, W, C) [m], band b (K,) [m], normal forces (K, W, C) [N]
    (zero in the columns that cannot rest), and, per impact, its sample after (n_impacts,); compliant
    normal forces (K, W, C) [N] and their integrals (K, 3 + N) (zeros without compliant walls)."""

    gap: np.ndarray
    band: np.ndarray
    force: np.ndarray
    after: np.ndarray
    compliant: np.ndarray
    integrals: np.ndarray


def _samples(result) -> _Samples:
    """_Samples of the Result (one Contacts.gaps_batch call over every sample)."""
    contact_tol, rtol, atol, link_contacts = _run_settings(result)
    model, K = result.model, len(result.t)
    # Each sample's gaps in its own chart of the free base (Result.per_chart).
    gap = result.per_chart(lambda m, qs: Contacts(m, tuple(result.walls), link_contacts).gaps_batch(qs),
                           np.asarray(result.q, dtype=float))
    # b = max(2 contact_tol, L_q (atol + rtol max|q|)) at every sample (contacts.contact_band).
    band = np.maximum(2.0 * contact_tol, gap_lipschitz(model) * (atol + rtol * np.abs(result.q).max(axis=1)))
    force = np.zeros(gap.shape)
    if result.contact_forces is not None:
        F = np.asarray(result.contact_forces, dtype=float)
        force[:, :F.shape[1], :F.shape[2]] = F[:, :gap.shape[1], :gap.shape[2]]
    # Impact i starts flight phase i + 1: its state after is the first sample of that phase.
    after = np.minimum(np.searchsorted(np.asarray(result.phase), np.arange(1, len(result.impacts) + 1)), K - 1)
    if getattr(result, "compliant_forces", None) is None:
        compliant, integrals = np.zeros(gap.shape), np.zeros((K, 3 + model.n_dof))
    else:
        compliant, integrals = np.asarray(result.compliant_forces), np.asarray(result.compliant_integrals)
    return _Samples(gap, band, force, after, compliant, integrals)


def _seeds(result, s: _Samples) -> np.ndarray:
    """(K, W, C) bool: the samples where a pair starts or renews an engagement (an impact of it: the
    samples before and after; a contact force)."""
    seed = (s.force > 0.0) | (s.compliant > 0.0)
    # A compliant force rises from zero after its start event (the gap closing): that sample seeds too.
    seed[:-1] |= (s.compliant[1:] > 0.0) & (s.compliant[:-1] == 0.0)
    for i, rec in enumerate(result.impacts):
        k = int(s.after[i])
        for c, w in zip(rec.joints, rec.wall):
            if w >= 0:
                seed[max(k - 1, 0):k + 1, w, int(c) - 1] = True
    return seed


def _engagements(result, s: _Samples) -> list[tuple]:
    """Every engagement of a pair: (k_seed, k_end, ended, w, c), k_seed its first seed sample, k_end the sample
    where it left (g > b without force) or the last sample (ended False)."""
    seed = _seeds(result, s)
    engaged = seed | (s.gap <= s.band[:, None, None]) | (s.force > 0.0) | (s.compliant > 0.0)
    K = engaged.shape[0]
    out = []
    for w, c in zip(*np.nonzero(seed.any(axis=0))):
        e, sd = engaged[:, w, c], seed[:, w, c]
        starts = np.flatnonzero(e & ~np.r_[False, e[:-1]])
        stops = np.flatnonzero(e & ~np.r_[e[1:], False])  # last engaged sample of each run
        for a, z in zip(starts, stops):
            hits = np.flatnonzero(sd[a:z + 1])
            if hits.size:
                out.append((int(a + hits[0]), int(min(z + 1, K - 1)), bool(z + 1 < K), int(w), int(c)))
    return sorted(out)


def _group(t, engagements: list, dwell: np.ndarray) -> list[list]:
    """The engagements (sorted by first seed) in episodes: one joins the episode open at its start, open until
    max(t(end) + dwell of its pair) over the engagements it holds (module docstring); t (K,) [s], dwell (C,) [s]."""
    groups, open_until = [], -np.inf
    for eng in engagements:
        k_seed, k_end, ended, _, c = eng
        if not (groups and t[k_seed] <= open_until):
            groups.append([])
            open_until = -np.inf
        groups[-1].append(eng)
        open_until = max(open_until, t[k_end] + dwell[c] if ended else np.inf)
    return groups


def _trapezoid(t, f) -> np.ndarray:
    """Integral over the samples t (k,) [s] of f (k, ...) by the trapezoidal rule (samples at one time add 0)."""
    if len(t) < 2:
        return np.zeros(np.shape(f)[1:])
    dt = np.diff(t).reshape((-1,) + (1,) * (np.ndim(f) - 1))
    return (0.5 * (f[1:] + f[:-1]) * dt).sum(axis=0)


def _resting_impulse(result, s: _Samples, k0: int, k1: int) -> np.ndarray:
    """Integral over the samples k0 ... k1 of the generalised resting-contact forces
    sum_(w, j) J_j^T (n_w lambda_wj + f_t,wj) (N,) [N s, N m s per coordinate]."""
    N, P = result.model.n_dof, result.model.n_joints
    F = s.force[k0:k1 + 1, :, :P]
    Ft = None if result.friction_forces is None else np.asarray(result.friction_forces)[k0:k1 + 1]
    Q = np.zeros((k1 - k0 + 1, N))
    for k in np.flatnonzero(F.any(axis=(1, 2))):
        p, J = joint_positions_and_jacobians(result.model_at(k0 + k), result.q[k0 + k])
        for w, wall in enumerate(result.walls):
            f = wall.normal(p) * F[k, w][:, None] + (0.0 if Ft is None else Ft[k, w])  # (P, 3) [N]
            Q[k] += np.einsum("jcn,jc->n", J, f)
    return _trapezoid(result.t[k0:k1 + 1], Q)


def _first_contact(result, s: _Samples, k0: int, impacts: list):
    """(M (N, N), p^- (N,), w (N,)) at the first sample k0 of an episode (module docstring): the mass matrix, the
    momenta before, and the generalised direction of the first contact (an impact's W Lambda / sum Lambda, or
    J_j^T n_j of the compliant pair whose force rises first); None when the episode starts otherwise."""
    model, q0 = result.model_at(k0), result.q[k0]
    if impacts and int(s.after[impacts[0]]) == k0 + 1:
        first = result.impacts[impacts[0]]
        total = float(np.sum(first.impulses))
        if not total > 0.0:
            return None
        M0 = mass_matrix(model, q0)
        return M0, M0 @ first.qdot_before, M0 @ (first.qdot_after - first.qdot_before) / total
    F = s.compliant[k0 + 1] if k0 + 1 < len(result.t) else None
    if F is None or not F.any() or s.compliant[k0].any():
        return None
    w, c = np.unravel_index(np.argmax(F), F.shape)
    _, nrm, J, _, _ = Contacts(model, tuple(result.walls), _run_settings(result)[3]).full(q0)
    M0 = mass_matrix(model, q0)
    return M0, M0 @ result.qdot[k0], J[w, c].T @ nrm[w, c]


def _restitution(result, s: _Samples, k0: int, k1: int, impacts: list) -> tuple[float, float]:
    """(e_eff, non-contact share) of the episode of samples k0 ... k1 and impacts (module docstring); NaN, NaN
    when its first sample is not the state before an impact or a compliant contact's start, the first
    impact carried no impulse, or the free base was re-charted during the episode."""
    nan = (float("nan"), float("nan"))
    if any(k0 < c.sample <= k1 for c in result.charts):
        return nan  # the base's generalised momenta of two charts of the free base do not add (Result.charts)
    first = _first_contact(result, s, k0, impacts)
    if first is None:
        return nan
    model, (M0, p_before, w_full) = result.model_at(k0), first
    # P: the impacts' M (qdot+ - qdot-) (exact, no Jacobian needed), the resting forces' integral, and the
    # compliant forces' (integrated with the state).
    P = sum(mass_matrix(model, result.q[s.after[i]]) @ (result.impacts[i].qdot_after - result.impacts[i].qdot_before)
            for i in impacts) + _resting_impulse(result, s, k0, k1) + (s.integrals[k1, 3:] - s.integrals[k0, 3:])
    elastic = np.concatenate([np.zeros(0, dtype=int)] + [np.asarray(d, dtype=int) for d in model.delta_index])
    R = np.setdiff1d(np.arange(model.n_dof), elastic)
    w = w_full[R]
    M_RR = M0[np.ix_(R, R)]

    def v(p):  # the rigid chain's normal velocity of the first contact with the momenta p_R [m/s]
        return float(w @ np.linalg.solve(M_RR, p[R]))

    v_before = v(p_before)
    if not v_before < 0.0:
        return nan
    # What the other forces did to p over the episode: p(end) - p- - P.
    other = mass_matrix(model, result.q[k1]) @ result.qdot[k1] - p_before - P
    return -v(p_before + P) / v_before, abs(v(other) / v_before)


def _episode(result, s: _Samples, group: list, energy: np.ndarray) -> Episode:
    """The Episode of one group of engagements (k_seed, k_end, ended, w, c); energy (K,) [J]."""
    k0, k1 = min(g[0] for g in group), max(g[1] for g in group)
    impacts = [i for i in range(len(result.impacts)) if k0 < s.after[i] <= k1]
    lam = [float(v) for i in impacts for v, w in zip(result.impacts[i].impulses, result.impacts[i].wall) if w >= 0]
    F = s.force[k0:k1 + 1]
    t = result.t[k0:k1 + 1]
    points = tuple(dict.fromkeys(c + 1 for _, _, _, _, c in group))
    C = s.compliant[k0:k1 + 1]
    if impacts and s.after[impacts[0]] == k0 + 1:
        rec = result.impacts[impacts[0]]
        first = int(rec.joints[int(np.argmax(rec.impulses))])
    elif F[0].any():
        first = int(np.unravel_index(np.argmax(F[0]), F[0].shape)[1]) + 1
    else:  # the compliant pair whose force rises first, else the first point
        k = int(np.argmax(C.any(axis=(1, 2)))) if C.any() else 0
        first = int(np.unravel_index(np.argmax(C[k]), C[k].shape)[1]) + 1 if C.any() else points[0]
    depth = max(-float(s.gap[k0:k1 + 1, w, c].min()) for _, _, _, w, c in group)
    e_eff, share = _restitution(result, s, k0, k1, impacts)
    return Episode(
        start=float(result.t[k0]), end=float(result.t[k1]), ended=all(g[2] for g in group),
        walls=tuple(sorted({w for _, _, _, w, _ in group})), points=points, first_point=first,
        impacts=tuple(impacts), samples=(k0, k1),
        impulse=sum(lam) + float(_trapezoid(t, F.sum(axis=(1, 2)))) + float(s.integrals[k1, 2] - s.integrals[k0, 2]),
        max_impulse=max(lam, default=0.0), max_force=max(float(F.max(initial=0.0)), float(C.max(initial=0.0))),
        resting_time=float(np.sum(np.diff(t) * F[:-1].any(axis=(1, 2)))),
        energy_before=float(energy[k0]), energy_after=float(energy[k1]),
        restitution=e_eff, non_contact_share=share, max_penetration=max(depth, 0.0),
        damping_work=float(s.integrals[k1, 0] - s.integrals[k0, 0]),
        friction_work=float(s.integrals[k1, 1] - s.integrals[k0, 1]),
    )


def episodes(result, dwell: float | None = None) -> list[Episode]:
    """The collision episodes of a Result, in time order (module docstring; docs/theory.md §14.7).

    result : a Result of gibbsimpact.simulate or load_result (its settings give the contact band)
    dwell : None (each pair's own: dwell_times) or one dwell [s] >= 0 for every pair (0: an episode ends
        when its last pair leaves the band)

    Returns [] for a run without walls. Raises ValueError for a bad ``dwell`` or a Result whose settings
    lack contact_tol, rtol, atol.
    """
    if dwell is not None and (isinstance(dwell, bool) or not isinstance(dwell, Real) or not 0.0 <= dwell < np.inf):
        raise ValueError(f"episodes dwell={dwell!r} must be None (each contact point's own) or a time >= 0 in s")
    if not result.walls or len(result.t) == 0:
        return []
    s = _samples(result)
    C = s.gap.shape[2]
    times = dwell_times(result.model, _run_settings(result)[3], result.walls) if dwell is None else np.full(C, float(dwell))
    groups = _group(result.t, _engagements(result, s), times)
    energy = result.energy().total
    return [_episode(result, s, g, energy) for g in groups]
