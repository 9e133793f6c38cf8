"""Joint limits of prismatic joints (docs/theory.md §13): gaps, checks, end-stop impacts.

Every Pa/Pb joint i has a range [d_min, d_max]; each bound is a *limit gap*
that must stay >= 0:

    g = d_i - d_min,   n = e_(d_i)                       (lower bound)
    g = d_max - d_i,   n = -e_(d_i)                      (upper bound)
    g = d_i - c_i - (l_(i-1) - d_(i-1)),   n = e_(d_i) + e_(d_(i-1))
                                                         (a carriage on a Pb link stays on its protruding part)

n = dg/dq (N,) is constant. The simulation loop (simulate.py) watches each gap
with a terminal event of direction -1, like a wall gap. At an event:

* ``joint_limit="stop"`` (default): the run stops with status "joint_limit"
  and a message naming the joint, the bound and the time;
* ``joint_limit="impact"``: an end-stop impact in joint space, Newton's law
  with restitution e_stop solved by the impulse solver of docs/theory.md §11 with W = n:  M (qdot+ - qdot-) = n Lambda,  n.qdot+ = -e_stop n.qdot-,  Lambda >= 0.

Resting at an end stop (``joint_limit="impact"``, ``accumulation="rest"``; docs/theory.md §13).
A stop in its band with |n.qdot| <= grazing_velocity after an end-stop impact, or whose impacts
accumulate (zeno_count of them without leaving), is *held*: a unilateral constraint in joint
space, g = n.q + offset = 0 with a force mu >= 0 [N, or N m] along n,

    M qddot = f + W lambda + n_H^T mu,     n_H qddot = 0                          (S1)

(n_H (h, N) the held stops' rows; g is linear in q, so gddot = n.qddot). At a fixed contact mode
of the walls qddot is affine in the applied forces Q (docs/theory.md §15: equations (3) and (6)
are linear in f), qddot(Q + n_H^T mu) = a0 + A mu with a0 = qddot(Q) and the columns of A (N, h)
read from one evaluation each with a probe force s n_k (s = the force scale m |g|, 1 N without
gravity), so

    (n_H A) mu = -n_H a0                                                          (S2)

and the stop force joins Q (so the walls' resting forces, their release, stick and slip events
see it as an applied force). Release: the event mu_k = 0 (falling) of a held stop; drift:
g = +-contact_tol, which projects the state onto g = 0, n.qdot = 0 again (along M^-1 n, the
M-orthogonal correction: the kinetic energy never rises).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..dynamics.gibbs_appell import energy, mass_matrix
from .flight import EventSpec
from ..contact.impact import actuator_impulses, held_impulses, solve_impulses
from .results import ImpactRecord

JOINT_LIMIT_MODES = ("stop", "impact")


class Limit(NamedTuple):
    """One bound: g(q) = n . q + offset >= 0."""

    name: str  # e.g. "d_2 >= d_min = 0.1 m"
    joint: int  # joint number i (1-based)
    n: np.ndarray  # (N,) dg/dq
    offset: float  # [m]


def joint_limits(model) -> tuple[Limit, ...]:
    """Every limit gap of the model's prismatic joints (empty for an all-revolute chain)."""
    N = model.n_dof
    names = model.coordinate_names
    out = []
    joints = model.chain.joints
    links = model.chain.links
    for i, jt in enumerate(joints):
        if not jt.spec.prismatic:  # a revolute or a weld (no coordinate) has no limits
            continue
        k = model.theta_index[i]
        lo, hi = jt.range
        e = np.zeros(N)
        e[k] = 1.0
        out.append(Limit(f"{names[k]} >= d_min = {lo:g} m", i + 1, e, -lo))
        out.append(Limit(f"{names[k]} <= d_max = {hi:g} m", i + 1, -e, hi))
        if jt.spec.carriage and i > 0 and joints[i - 1].spec.guide:
            kp = model.theta_index[i - 1]
            n = e.copy()
            n[kp] = 1.0
            c, lh = jt.half_length, links[i - 1].length
            # (i is 0-based: joint i + 1's host is link i)
            out.append(Limit(f"{names[k]} - c >= l_{i} - {names[kp]} (the carriage stays on the protruding "
                             f"part of link {i})", i + 1, n, -c - lh))
    for lim in out:
        lim.n.setflags(write=False)
    return tuple(out)


def limit_gaps(limits, q) -> np.ndarray:
    """g (L,) [m] of the limits at q (N,)."""
    if not limits:
        return np.zeros(0)
    return np.array([lim.n @ q + lim.offset for lim in limits])


def check_initial(limits, q0, tol: float = 0.0) -> None:
    """ValueError naming every joint whose initial value is outside its range."""
    g = limit_gaps(limits, q0)
    bad = [f"joint {lim.joint}: {lim.name} violated by {-gk:.3g} m" for lim, gk in zip(limits, g) if gk < -tol]
    if bad:
        raise ValueError("initial state q0 is outside a joint range: " + "; ".join(bad)
                         + ". Start inside the range given to gi.SlidingPrismatic / gi.FixedPrismatic")


class EndStops:
    """The joint limits as row W of the gap matrix, their events and end-stop impacts (gibbsimpact.limits)."""

    def __init__(self, limits, n_walls, n_joints):
        self.limits, self.W, self.J = limits, n_walls, n_joints
        self.cols = max(n_joints, len(limits))
        self.n = np.array([lim.n for lim in limits])  # (L, N)
        self.offset = np.array([lim.offset for lim in limits])
        self.near = np.zeros(len(limits), dtype=bool)  # limits in their contact band (after an end-stop impact)
        self.streak = np.zeros(len(limits), dtype=int)
        self.times: list[float] = []
        self.held = np.zeros(len(limits), dtype=bool)  # stops resting: mu >= 0 holds g = 0 (S1)
        self.forced = np.zeros(len(limits), dtype=bool)  # an accumulation: candidate whatever its velocity
        self.released = np.zeros(len(limits), dtype=bool)  # its release event fired: out of the next decision

    def _full(self, g_walls, qs):
        """(K, W + 1, cols): wall gaps, then the limit gaps; +inf pads unused entries."""
        K = qs.shape[0]
        G = np.full((K, self.W + 1, self.cols), np.inf)
        G[:, :self.W, :self.J] = g_walls.reshape(K, self.W, self.J)
        G[:, self.W, :len(self.limits)] = qs @ self.n.T + self.offset
        return G

    def wrap(self, gaps):
        return lambda q: self._full(gaps(q), q[None, :])[0]

    def wrap_batch(self, gaps_batch):
        return lambda qs: self._full(gaps_batch(qs), qs)

    def events(self, events, kinds, q, contact_tol, sink_depth):
        """Append the limits' events (gibbsimpact.contacts.phase_events on row W, band 2 contact_tol)
        to the wall events."""
        from .contacts import event_spec, phase_events

        g = limit_gaps(self.limits, q)
        band = 2.0 * contact_tol
        self.near &= g <= band
        lim, lim_kinds = phase_events(self.near[None, :], g[None, :], band, sink_depth, row0=self.W,
                                      skip=self.held[None, :])
        # A held stop is watched by its drift events g = +-contact_tol instead (module docstring).
        rows = [(self.W, k, off, d) for k in np.nonzero(self.held)[0] for off, d in ((-contact_tol, 1.0),
                                                                                  (contact_tol, -1.0))]
        drift = event_spec(rows)
        kinds = list(kinds) + lim_kinds + [("drift", self.W, int(r[1])) for r in rows]
        return EventSpec(*(np.concatenate((a, b, c)) for a, b, c in zip(events, lim, drift))), kinds

    # -- resting at an end stop (S1)-(S2) -------------------------------------------------
    def stop_forces(self, acceleration, Q, scale) -> np.ndarray:
        """mu (h,) [N or N m] of the held stops, equation (S2).

        acceleration(Q) -> qddot (N,) at the current state and contact mode for applied forces
        Q (N,); scale [N]: the probe force s of (S2).
        """
        nH = self.n[self.held]
        if not len(nH):
            return np.zeros(0)
        a0 = acceleration(Q)
        A = np.column_stack([acceleration(Q + scale * nk) - a0 for nk in nH]) / scale  # (N, h)
        K = nH @ A
        try:
            return np.linalg.solve(K, -(nH @ a0))
        except np.linalg.LinAlgError:
            # Dependent stops (a carriage bound with its host's bound): the least-squares split.
            return np.linalg.lstsq(K, -(nH @ a0), rcond=1e-10)[0]

    def project(self, M, q, qd, which):
        """(q, qdot) (N,) moved onto g = 0, n.qdot = 0 of the stops ``which`` (L,) bool along the metric
        of M (N, N): q <- q - M^-1 n^T (n M^-1 n^T)^-1 g, and the same for qdot (one step: g is linear)."""
        nS = self.n[which]
        if not len(nS):
            return q, qd
        MinvN = np.linalg.solve(M, nS.T)  # (N, s)
        G = nS @ MinvN
        g = nS @ q + self.offset[which]
        q = q - MinvN @ np.linalg.lstsq(G, g, rcond=1e-12)[0]
        qd = qd - MinvN @ np.linalg.lstsq(G, nS @ qd, rcond=1e-12)[0]
        return q, qd

    def candidates(self, q, qd, band, v_tol) -> np.ndarray:
        """(L,) bool: the stops of a mode decision: held, in the band g <= band [m] with |n.qdot| <=
        v_tol [m/s], or of an accumulation (forced); never one whose release just fired."""
        g, v = self.n @ q + self.offset, self.n @ qd
        return (self.held | ((g <= band) & ((np.abs(v) <= v_tol) | self.forced))) & ~self.released

    def decide(self, stop_forces, M, q, qd, band, v_tol, scale):
        """Choose the held stops (module docstring); returns the projected (q, qdot) (N,).

        stop_forces(q, qdot) -> mu (h,) [N] of the stops held at the time of the call (S2);
        M (N, N) at q; band [m], v_tol [m/s] as in candidates; scale [N]: the force scale. The
        candidates are projected onto g = 0, n.qdot = 0; then the most negative mu leaves until
        every mu >= 0; a stop with mu <= 1e-10 scale separates (as resting.py's walls).
        """
        on = self.candidates(q, qd, band, v_tol)
        self.forced[:] = self.released[:] = False
        q, qd = self.project(M, q, qd, on)
        while on.any():
            self.held[:] = on
            mu = stop_forces(q, qd)
            if np.any(mu < -1e-10 * scale):
                on[np.nonzero(on)[0][int(np.argmin(mu))]] = False
                continue
            on[np.nonzero(on)[0][mu <= 1e-10 * scale]] = False
            break
        self.held[:] = on
        self.near |= on
        return q, qd

    def release_events(self, stop_forces):
        """(fun(t, y) -> mu (h,) [N], directions (h,) = -1) and kinds ("release", W, k) of the held stops."""
        kinds = [("release", self.W, int(k)) for k in np.nonzero(self.held)[0]]
        return (stop_forces, -np.ones(len(kinds))), kinds

    def impact(self, model, t, q, qd, k, e_stop, grazing_velocity, sinking, prescribed=None):
        """End-stop impact of limit k (Newton's law with W = n), or None when it does not approach;
        with prescribed (n_p,) coordinates, on the free ones (contact.impact.held_impulses)."""
        n = self.limits[k].n
        # consecutive impacts of this stop without a "leave" event in between
        self.streak[k] = self.streak[k] + 1 if self.near[k] else 1
        self.near[k] = True
        v = float(n @ qd)
        if not (v < -grazing_velocity or (sinking and v < 0)):
            return None
        M, W, e = mass_matrix(model, q), n[:, None], np.array([e_stop])
        held = {}
        if prescribed is None:
            sol = solve_impulses(M, W, qd, e)
            qdot_after = sol.qdot_after
        else:
            sol, qdot_after = held_impulses(M, W, qd, prescribed, lambda M_, r, v: solve_impulses(M_, W[r], v, e))
            held = dict(actuator_impulses=actuator_impulses(M, qd, qdot_after, W @ sol.impulses, prescribed))
        return ImpactRecord(
            time=t, joints=(self.limits[k].joint,), wall=(-1,), normals=np.zeros((1, 3)),
            impulses=sol.impulses, v_before=sol.v_before, v_after=sol.v_after, restitution=np.array([e_stop]),
            qdot_before=qd.copy(), qdot_after=qdot_after.copy(),
            energy_before=energy(model, q, qd), energy_after=energy(model, q, qdot_after),
            rounds=len(sol.rounds), **held,
        )

    def accumulation(self, t, k, count, interval, rest=False):
        """An accumulation of impacts at end stop k: ``count`` impacts of limit k in a row without
        its "leave" event in between (rule (a) of gibbsimpact.simulate's docstring), or ``count``
        impacts in a row less than ``interval`` [s] apart (rule (b)). rest=True (accumulation="rest"):
        the stop is marked to be held at the next mode decision, None returned; else the stop
        message (None without an accumulation)."""
        self.times.append(t)
        dts = np.diff(self.times[-(count + 1):])
        if self.streak[k] < count and not (dts.size >= count and np.all(dts < interval)):
            return None
        if rest:
            # accumulation="rest": the stop is held from the next mode decision on (module docstring).
            self.forced[k] = True
            self.streak[k] = 0
            self.times = []
            return None
        return (f"joint {self.limits[k].joint} came to rest at its end stop ({self.limits[k].name}) at "
                f"t = {t:.9g} s: {count} end-stop impacts without leaving the stop; stopped there "
                "(accumulation='stop'; accumulation='rest' holds the joint at its stop): results up to here are kept")
