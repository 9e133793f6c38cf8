"""Long runs with restitution e < 1 that end in resting contact (gibbsimpact.resting), measured in one run.

The two published cases run with e = 0.8 over T seconds (default 10 s; issue 9).
Before resting contact existed both stopped with status "zeno". Printed for
each: status, CPU time (median of repeats; the machine is shared, CPU time is
steadier than wall time), impacts, the simulated time spent in resting contact,
right-hand-side evaluations, the largest rise of the total energy between any
two samples relative to the initial energy, and the final contact forces. The
reference measured in the same run is the elastic case (e = 1, no resting
contact) over the same span: "cpu/ref" is the ratio of CPU times.

Usage: python benchmarks/bench_resting.py [--t-end T] [--repeat R]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import gibbsimpact as gi

CASES = Path(__file__).resolve().parent.parent / "cases"


def measure(case, e, t_end, repeat):
    cpu = []
    for _ in range(repeat):
        t = time.process_time()
        res = gi.simulate(case.model, case.q0, case.qdot0, (case.t_span[0], t_end), walls=case.walls, restitution=e)
        cpu.append(time.process_time() - t)
    return float(np.median(cpu)), res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=10.0, help="simulated time [s] (default 10)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per measurement; the median CPU time is reported")
    args = ap.parse_args(argv)
    gi.simulate(*(lambda c: (c.model, c.q0, c.qdot0, (0.0, 1e-3)))(gi.load_case(CASES / "circle_two_link.toml")))
    print(f"{'case':<20} {'e':>4} {'status':>9} {'cpu[s]':>7} {'cpu/ref':>7} {'impacts':>7} {'resting[s]':>10} "
          f"{'nfev':>7} {'max dE/E0':>9}  final contact forces [N]")
    for name in ("circle_two_link", "sphere_single_link"):
        case = gi.load_case(CASES / f"{name}.toml")
        ref_cpu, _ = measure(case, 1.0, args.t_end, args.repeat)
        for e in (1.0, 0.8):
            cpu, res = (ref_cpu, None) if e == 1.0 else measure(case, e, args.t_end, args.repeat)
            if res is None:
                _, res = measure(case, e, args.t_end, 1)
            E = res.energy().total
            rise = float(np.max(np.maximum.accumulate(E) - E[0]) / abs(E[0]))
            F = res.contact_forces[-1]
            forces = ", ".join(f"{res.model.contact_point_names[j]}: {F[w, j]:.4g}" for w, j in np.argwhere(F != 0))
            print(f"{name:<20} {e:>4.1f} {res.status:>9} {cpu:>7.2f} {cpu / ref_cpu:>7.2f} {len(res.impacts):>7} "
                  f"{res.resting_time:>10.3f} {res.nfev:>7} {rise:>9.1e}  {forces or '-'}")


if __name__ == "__main__":
    main()
