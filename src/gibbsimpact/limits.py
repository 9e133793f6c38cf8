"""Joint limits of prismatic joints (formulation.md section 13): gaps, checks, end-stop impacts.

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
  with restitution e_stop solved by the impulse solver of formulation.md
  section 6 with W = n:  M (qdot+ - qdot-) = n Lambda,  n.qdot+ = -e_stop n.qdot-,  Lambda >= 0.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: Status of a run stopped at a joint limit.
STATUS_JOINT_LIMIT = "joint_limit"
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
