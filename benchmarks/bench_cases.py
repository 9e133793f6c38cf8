"""Benchmark of the two published case studies.

For each case: wall time, accepted steps, right-hand-side evaluations, impacts
and the energy error, plus ratios against references measured in this same
run, so the numbers can be compared across machines:

* ``rhs/solve``: one dynamics evaluation (forward_dynamics) against one
  numpy linear solve of the same size N (a machine-speed yardstick);
* ``loop overhead``: simulate's wall time against nfev x (time of one RHS),
  i.e. what events, impulses and bookkeeping add on top of the dynamics;
* ``rhs/sympy``: one dynamics evaluation against one evaluation of the
  equations of motion generated symbolically for the same chain by the test
  oracle (tests/reference/sympy_chain.py: sympy.physics.mechanics Kane
  equations, lambdified with common-subexpression elimination) -- the usual
  alternative to a recursive formulation.

Usage: python benchmarks/bench_cases.py [--repeat R] [--t-end T]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import sys

import numpy as np

import gibbsimpact as gi
from gibbsimpact.dynamics import forward_dynamics

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "cases"
sys.path.insert(0, str(ROOT / "tests"))


def symbolic_rhs(model):
    """forward_dynamics of the sympy oracle for the same chain (uniform links only)."""
    from reference.sympy_chain import RefLink, RefMode, reference_model

    links = tuple(
        RefLink(lk.length, lk.mass_per_length, lk.EI_y, lk.EI_z,
                tuple(RefMode(m.kind, m.direction, m.number) for m in lk.modes), lk.rotary_inertia)
        for lk in model.chain.links
    )
    return reference_model(links, tuple(model.gravity)).forward_dynamics


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
        ref = symbolic_rhs(model)
        t_sym = per_call(lambda: ref(q0, qd0))
        E = res.energy().total
        rows.append(dict(
            case=name, N=N, wall_s=wall, steps=res.n_steps, nfev=res.nfev, impacts=len(res.impacts),
            energy_error_flight=res.energy_error, energy_error_total=float(np.max(np.abs(E - E[0])) / abs(E[0])),
            rhs_us=t_rhs * 1e6, rhs_per_solve=t_rhs / t_solve, loop_overhead=wall / (res.nfev * t_rhs),
            rhs_per_sympy=t_rhs / t_sym, status=res.status,
        ))
    cols = [("case", "{:<20}"), ("N", "{:>3}"), ("wall_s", "{:>8.3f}"), ("steps", "{:>6}"), ("nfev", "{:>7}"),
            ("impacts", "{:>7}"), ("energy_error_flight", "{:>10.2e}"), ("energy_error_total", "{:>10.2e}"),
            ("rhs_us", "{:>8.1f}"), ("rhs_per_solve", "{:>8.1f}"), ("loop_overhead", "{:>8.3f}"),
            ("rhs_per_sympy", "{:>9.3f}")]
    heads = ["case", "N", "wall[s]", "steps", "nfev", "impacts", "dE_flight", "dE_total", "rhs[us]",
             "rhs/solve", "loop/rhs", "rhs/sympy"]
    print(" ".join(f"{h:>{len(fmt.format(rows[0][c]))}}" for h, (c, fmt) in zip(heads, cols)))
    for r in rows:
        print(" ".join(fmt.format(r[c]) for c, fmt in cols))
    return rows


if __name__ == "__main__":
    main()
