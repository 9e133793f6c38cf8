"""Symbolic derivation cost and evaluation speed for planar chains of n = 1 ... 8 links.

Each link: l = 1 m, mu = 1 kg/m, EI = 20 N m^2, one clamped-free y-mode, rotary
inertia (1e-3, 1e-3, 1e-3) kg m (N = 5 + 2 n). For both routes (gibbs-appell,
lagrange): derivation time, CSE time, operation count after CSE (adds, muls,
functions); for the Gibbs-Appell route also the time of one evaluation of
qddot by eqs.numeric().forward_dynamics against model.forward_dynamics (best
of repeats) and their ratio, and the largest relative difference of M and the
forcing from the kernel at one random state.

    python benchmarks/bench_symbolic.py [--n-max 8] [--lagrange-max 5] [--repeats 200]
"""

from __future__ import annotations

import argparse
import importlib
import time
import timeit

import numpy as np

import gibbsimpact as gi


def chain(n: int) -> gi.Model:
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-free", "y")], rotary_inertia=(1e-3, 1e-3, 1e-3), geometric_stiffening=False)
    return gi.Model(gi.Chain([link] * n), gravity=(0.0, -9.81, 0.0))


def best(fn, repeats: int) -> float:
    return min(timeit.repeat(fn, number=1, repeat=repeats))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-max", type=int, default=8)
    ap.add_argument("--lagrange-max", type=int, default=5, help="largest n for the (slower) Lagrange route")
    ap.add_argument("--repeats", type=int, default=200)
    args = ap.parse_args(argv)
    importlib.import_module("sympy")  # loaded before timing: its import time is not derivation time

    print(f"{'n':>2} {'N':>3} {'route':>12} {'derive[s]':>9} {'cse[s]':>7} {'adds':>6} {'muls':>6} {'funcs':>5} "
          f"{'numeric[us]':>11} {'kernel[us]':>10} {'ratio':>6} {'err':>8}")
    rng = np.random.default_rng(0)
    for n in range(1, args.n_max + 1):
        model = chain(n)
        q = rng.uniform(-0.5, 0.5, model.n_dof)
        qd = rng.normal(size=model.n_dof)
        for method in ("gibbs-appell", "lagrange"):
            if method == "lagrange" and n > args.lagrange_max:
                continue
            t0 = time.perf_counter()
            eqs = gi.derive_equations(model, method=method)
            t1 = time.perf_counter()
            count = eqs.operation_count()
            t2 = time.perf_counter()
            num = eqs.numeric()
            M, f = num.mass_matrix_and_forcing(q, qd)
            Mk = model.mass_matrix(q)
            fk = Mk @ model.forward_dynamics(q, qd)
            err = max(np.abs(M - Mk).max() / np.abs(Mk).max(), np.abs(f - fk).max() / np.abs(fk).max())
            t_num = best(lambda: num.forward_dynamics(q, qd), args.repeats) * 1e6
            t_ker = best(lambda: model.forward_dynamics(q, qd), args.repeats) * 1e6
            print(f"{n:>2} {model.n_dof:>3} {method:>12} {t1 - t0:>9.2f} {t2 - t1:>7.2f} {count.adds:>6} "
                  f"{count.muls:>6} {count.functions:>5} {t_num:>11.1f} {t_ker:>10.1f} {t_num / t_ker:>6.2f} "
                  f"{err:>8.1e}", flush=True)


if __name__ == "__main__":
    main()
