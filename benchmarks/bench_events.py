"""Cost of locating events inside steps (gibbsimpact.flight), measured in one run.

For each published case, and for the grazing reproducer of issue 12 (a spinning
rigid rod passing 1e-4 m beyond a circle within one step), the same simulation
runs with the in-step search on (the default) and off (solve_ivp's sign test
at step ends only). Printed: CPU time (median of repeats; the machine is shared,
CPU time is steadier than wall time), right-hand-side evaluations, accepted
steps, steps whose dense output was searched, impacts, and the ratio on/off of
CPU time and of nfev. Identical impact lists show that nothing else changed.

Usage: python benchmarks/bench_events.py [--repeat R]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import gibbsimpact as gi

CASES = Path(__file__).resolve().parent.parent / "cases"


def grazing_rod():
    link = gi.Link(1.0, 1.0, (20.0, 20.0), modes=[], rotary_inertia=(5e-5, 2.5e-5, 2.5e-5))
    model = gi.Model(gi.Chain([link]), gravity=(0.0, 0.0, 0.0))
    q0 = np.array([0.1, -0.5, 0.0, 0.0, 0.0, np.pi / 2])
    qd0 = np.array([5.0, 0.0, 0.0, 0.0, 0.0, 10.0])
    return model, q0, qd0, (0.0, 0.2), [gi.Circle(0.5999)], 1.0


def runs():
    for name in ("circle_two_link", "sphere_single_link"):
        case = gi.load_case(CASES / f"{name}.toml")
        yield name, case.model, case.q0, case.qdot0, case.t_span, case.walls, case.restitution
    yield ("grazing_rod", *grazing_rod())


def measure(args, check, repeat):
    model, q0, qd0, t_span, walls, e = args
    cpu = []
    for _ in range(repeat):
        t = time.process_time()
        res = gi.simulate(model, q0, qd0, t_span, walls=walls, restitution=e, rtol=1e-10, atol=1e-12,
                          _in_step_check=check)
        cpu.append(time.process_time() - t)
    return float(np.median(cpu)), res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per measurement; the median CPU time is reported")
    args = ap.parse_args(argv)
    head = (f"{'case':<20} {'check':>5} {'cpu[s]':>7} {'nfev':>6} {'steps':>6} {'searched':>8} {'impacts':>7}"
            f" {'cpu on/off':>10} {'nfev on/off':>11}")
    print(head)
    for name, *rest in runs():
        on = measure(rest, True, args.repeat)
        off = measure(rest, False, args.repeat)
        for label, (cpu, res) in (("on", on), ("off", off)):
            ratio = f"{on[0] / off[0]:>10.3f} {on[1].nfev / off[1].nfev:>11.3f}" if label == "on" else ""
            print(f"{name:<20} {label:>5} {cpu:>7.3f} {res.nfev:>6} {res.n_steps:>6} {res.n_examined:>8} "
                  f"{len(res.impacts):>7} {ratio}")
        same = [round(r.time, 12) for r in on[1].impacts] == [round(r.time, 12) for r in off[1].impacts]
        print(f"{'':<20} impacts identical on/off: {same}")


if __name__ == "__main__":
    main()
