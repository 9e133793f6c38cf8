"""Benchmark of the two published case studies.

For each case: wall time, accepted steps, right-hand-side evaluations, impacts
and the energy error, plus ratios against references measured in this same
run, so the numbers can be compared across machines:

* ``rhs/solve``: one dynamics evaluation (forward_dynamics) against one
  numpy linear solve of the same size N (a machine-speed yardstick);
* ``loop overhead``: simulate's wall time against nfev x (time of one RHS),
  i.e. what events, impulses and bookkeeping add on top of the dynamics;
* ``events/flight``: simulate with walls against the same span integrated
  with solve_ivp and no walls at all (flight only).

Usage: python benchmarks/bench_cases.py [--repeat R] [--t-end T]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import gibbsimpact as gi
from gibbsimpact.dynamics import forward_dynamics

CASES = Path(__file__).resolve().parent.parent / "cases"


def best_of(fn, repeat):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def per_call(fn, n=400):
    fn()
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t0) / n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per measurement; the best is reported")
    ap.add_argument("--t-end", type=float, default=None, help="override the cases' end time [s]")
    args = ap.parse_args(argv)
    rows = []
    for name in ("circle_two_link", "sphere_single_link"):
        case = gi.load_case(CASES / f"{name}.toml")
        t_span = (case.t_span[0], args.t_end if args.t_end else case.t_span[1])
        kw = dict(restitution=case.restitution, rtol=1e-10, atol=1e-12, method="DOP853")
        model, q0, qd0 = case.model, case.q0, case.qdot0
        wall, res = best_of(lambda: gi.simulate(model, q0, qd0, t_span, walls=case.walls, **kw), args.repeat)
        N = model.n_dof
        t_rhs = per_call(lambda: forward_dynamics(model, q0, qd0))
        A = model.mass_matrix(q0)
        b = np.ones(N)
        t_solve = per_call(lambda: np.linalg.solve(A, b), 2000)
        f = lambda t, y: np.concatenate((y[N:], forward_dynamics(model, y[:N], y[N:])))
        t_flight, _ = best_of(
            lambda: solve_ivp(f, t_span, np.concatenate((q0, qd0)), method="DOP853", rtol=1e-10, atol=1e-12), 1
        )
        E = res.energy().total
        rows.append(dict(
            case=name, N=N, wall_s=wall, steps=res.n_steps, nfev=res.nfev, impacts=len(res.impacts),
            energy_error_flight=res.energy_error, energy_error_total=float(np.max(np.abs(E - E[0])) / abs(E[0])),
            rhs_us=t_rhs * 1e6, rhs_per_solve=t_rhs / t_solve, loop_overhead=wall / (res.nfev * t_rhs),
            events_per_flight=wall / t_flight, status=res.status,
        ))
    cols = [("case", "{:<20}"), ("N", "{:>3}"), ("wall_s", "{:>8.3f}"), ("steps", "{:>6}"), ("nfev", "{:>7}"),
            ("impacts", "{:>7}"), ("energy_error_flight", "{:>10.2e}"), ("energy_error_total", "{:>10.2e}"),
            ("rhs_us", "{:>8.1f}"), ("rhs_per_solve", "{:>8.1f}"), ("loop_overhead", "{:>8.3f}"),
            ("events_per_flight", "{:>8.3f}")]
    heads = ["case", "N", "wall[s]", "steps", "nfev", "impacts", "dE_flight", "dE_total", "rhs[us]",
             "rhs/solve", "loop/rhs", "ev/flight"]
    print(" ".join(f"{h:>{len(fmt.format(rows[0][c]))}}" for h, (c, fmt) in zip(heads, cols)))
    for r in rows:
        print(" ".join(fmt.format(r[c]) for c, fmt in cols))
    return rows


if __name__ == "__main__":
    main()
