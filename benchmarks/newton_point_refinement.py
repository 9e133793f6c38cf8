"""Newton's law at the tip of a finite-element link under mesh refinement (issue 26; docs/theory.md §11.4).

The arm of the issue: one link, l = 1 m, mu = 1 kg/m, on gi.FixedBase((0, 0.5)), released horizontal at
rest under gravity onto the floor Y = 0 with e = 0.5. Its tip lands at -30 deg, 0.268 s after release.

Table 1 (``first``): for n_e = 0 (the rigid rod), 1, 2, 4, 8, 16 elements and EI = 1e4 N m^2, the time
and impulse of the first impact (simulated, max_impacts=1), and the same impulse from the effective mass
of the tip, (1 + e) v_n m_eff, with the arm rigid at -30 deg (omega^2 = 3 g sin 30 / l, v_n = l cos 30
omega, m_eff = 1 / (n^T J M^-1 J^T n) of each mesh). n_e = 16 takes about 5 minutes (the highest element
mode is stiff for the explicit solver).

Table 2 (``episodes``): the whole collision as one episode (Result.episodes) for EI in 1e3, 1e4, 1e5
and n_e in 1, 2, 4: impacts, duration, resting time, impulse, energy lost and the effective restitution
(the angular momentum about the pivot after the collision, gravity removed, over before); 2 minutes.

Usage: python benchmarks/newton_point_refinement.py [first|episodes] [--max-elements 16]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import gibbsimpact as gi
from gibbsimpact.simulation.contact_points import rebound_period

FLOOR = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.5)
G = 9.81


def arm(elements: int, EI: float) -> gi.Model:
    link = gi.Link(1.0, 1.0, EI, elements=elements)
    return gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.5))), gravity=(0.0, -G, 0.0))


def release(model, t_end, **options):
    q0 = np.zeros(model.n_dof)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)  # the point of the exercise
        return gi.simulate(model, q0, np.zeros_like(q0), (0.0, t_end), walls=[FLOOR], **options)


def rigid_impulse(model) -> float:
    """(1 + e) v_n m_eff at -30 deg with the arm rigid (module docstring) [N s]."""
    q = model.state(theta_1=-np.pi / 6)
    w = model.joint_jacobians(q)[1].T @ np.array([0.0, 1.0, 0.0])
    m_eff = 1.0 / (w @ np.linalg.solve(model.mass_matrix(q), w))
    return 1.5 * np.cos(np.pi / 6) * np.sqrt(3.0 * G * 0.5) * m_eff


def first(max_elements: int) -> None:
    print(f"{'n_e':>4} {'t_impact [s]':>13} {'impulse [N s]':>14} {'(1+e) v_n m_eff':>16} {'cpu [s]':>8}")
    for ne in [0] + [k for k in (1, 2, 4, 8, 16, 32) if k <= max_elements]:
        model = arm(ne, 1e4)
        c = time.process_time()
        res = release(model, 0.3, max_impacts=1)
        rec = res.impacts[0]
        print(f"{ne:>4} {rec.time:>13.6f} {rec.impulses[0]:>14.5f} {rigid_impulse(model):>16.5f} "
              f"{time.process_time() - c:>8.1f}", flush=True)


def episodes() -> None:
    print(f"{'EI':>6} {'n_e':>4} {'impacts':>8} {'duration [ms]':>14} {'resting [ms]':>13} {'impulse [N s]':>14} "
          f"{'lost [J]':>9} {'e_eff':>6} {'cpu [s]':>8}")
    for EI in (1e3, 1e4, 1e5):
        for ne in (1, 2, 4):
            model = arm(ne, EI)
            c = time.process_time()
            # Until the tip has been off the floor for one dwell (the cantilever's period) after the collision.
            res = release(model, 0.30 + 2.0 * rebound_period(model, 0))
            ep = res.episodes[0]
            print(f"{EI:>6.0e} {ne:>4} {ep.n_impacts:>8} {1e3 * ep.duration:>14.3f} {1e3 * ep.resting_time:>13.3f} "
                  f"{ep.impulse:>14.4f} "
                  f"{ep.energy_lost:>9.4f} {ep.restitution:>6.3f} {time.process_time() - c:>8.1f}", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("table", nargs="?", choices=("first", "episodes"), default="first")
    parser.add_argument("--max-elements", type=int, default=16)
    args = parser.parse_args()
    first(args.max_elements) if args.table == "first" else episodes()
