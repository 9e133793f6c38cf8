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
        if jt.kind == "R":
            continue
        k = model.theta_index[i]
        lo, hi = jt.range
        e = np.zeros(N)
        e[k] = 1.0
        out.append(Limit(f"{names[k]} >= d_min = {lo:g} m", i + 1, e, -lo))
        out.append(Limit(f"{names[k]} <= d_max = {hi:g} m", i + 1, -e, hi))
        if jt.kind == "Pa" and i > 0 and joints[i - 1].kind == "Pb":
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
        from .contacts import phase_events

        g = limit_gaps(self.limits, q)
        band = 2.0 * contact_tol
        self.near &= g <= band
        lim, lim_kinds = phase_events(self.near[None, :], g[None, :], band, sink_depth, row0=self.W)
        return EventSpec(*(np.concatenate((a, b)) for a, b in zip(events, lim))), list(kinds) + lim_kinds

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

    def accumulation(self, t, k, count, interval):
        """Stop message when the joint has come to rest at end stop k: ``count`` impacts of
        limit k in a row without its "leave" event in between (rule (a) of the module
        docstring), or ``count`` impacts in a row less than ``interval`` apart (rule (b))."""
        self.times.append(t)
        dts = np.diff(self.times[-(count + 1):])
        if self.streak[k] < count and not (dts.size >= count and np.all(dts < interval)):
            return None
        return (f"joint {self.limits[k].joint} came to rest at its end stop ({self.limits[k].name}) at "
                f"t = {t:.9g} s: {count} end-stop impacts without leaving the stop; resting contact "
                "at an end stop is not modelled: results up to here are kept")
