"""Cost of locating events inside steps (gibbsimpact.flight), measured in one run.

For each published case, and for the grazing reproducer of issue 12 (a spinning
rigid rod passing 1e-4 m beyond a circle within one step), the same simulation
runs with the in-step search on (the default) and off (solve_ivp's sign test
at step ends only). Printed: CPU time (median of repeats; the machine is shared,
CPU time is steadier than wall time), right-hand-side evaluations, accepted
steps, steps whose dense output was searched, impacts, and the ratio on/off of
CPU time and of nfev. Identical impact lists show that nothing else changed.

Then the cost of the contact search per event-function call (Contacts.gaps_batch of one state,
one call per in-step sample): a flat finite-element beam lying 1e-4 m above a floor (every
interval near the wall) and a modal beam tilted over it, with and without the search for dips
that the sampled slope signs miss (contact.closest_points._hidden_brackets, issue 25 item 5).

Usage: python benchmarks/bench_events.py [--repeat R] [--search-only]
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


def search_models():
    """(name, model, q, walls): states whose links lie near a floor, so that every event call searches them."""
    floor = [gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))]
    fe = gi.Model(gi.Chain([gi.Link(1.0, 1.0, (20.0, 20.0), elements=4, rotary_inertia=(1e-4, 5e-5, 5e-5))],
                           base="planar"), gravity=(0.0, -9.81, 0.0))
    q = np.zeros(fe.n_dof)
    q[:2] = (-0.5, 1e-4)
    yield "FE beam, 4 elements", fe, q, floor
    modal = gi.Model(gi.Chain([gi.Link(1.0, 1.0, (20.0, 20.0), modes=[gi.Mode("clamped-clamped", "y", 1), gi.Mode("clamped-clamped", "y", 2)])]),
                     gravity=(0.0, -9.81, 0.0))
    q = np.zeros(modal.n_dof)
    q[:2], q[5], q[6:8] = (-0.5, 0.01), 0.005, (-0.001, 0.0005)
    yield "modal beam, 2 modes", modal, q, floor
    # tests/contact/test_closest_points.py's tilted arm (3 stiffened elements, theta = -0.1 rad, element 3 bent so
    # that its foreshortened gap dips 4e-5 m below the tip at x = 0.871 m), its base lowered so that the dip is
    # 1e-4 m above the floor: a bracket refined on element 3, then confirmed on the foreshortened centreline.
    arm = gi.Model(gi.Chain([gi.Link(1.0, 1.0, (20.0, 20.0), elements=3)], base=gi.FixedBase((0.0, 0.0668636))),
                   gravity=(0.0, -9.81, 0.0))
    q = np.array([-0.1, -0.008082050196454086, -0.02424615058936226, 0.0, 0.09698460235744903,
                  0.03307266072537224, 0.10033467208545054])
    yield "FE arm, dip refined", arm, q, floor


def search_cost(calls=2000):
    """CPU time [us] per Contacts.gaps_batch call of one state, with and without _hidden_brackets."""
    from gibbsimpact.contact import closest_points as cp
    from gibbsimpact.simulation.contacts import Contacts

    print(f"{'model':<22} {'us/call before':>14} {'us/call after':>13}  (before/after: without/with _hidden_brackets)")
    hidden = cp._hidden_brackets
    for name, model, q, walls in search_models():
        contacts = Contacts(model, walls)
        cost = []
        for fn in ((lambda *a: None), hidden):
            cp._hidden_brackets = fn
            qs = q[None, :]
            contacts.gaps_batch(qs)
            t = time.process_time()
            for _ in range(calls):
                contacts.gaps_batch(qs)
            cost.append(1e6 * (time.process_time() - t) / calls)
        cp._hidden_brackets = hidden
        print(f"{name:<22} {cost[0]:>14.1f} {cost[1]:>13.1f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per measurement; the median CPU time is reported")
    ap.add_argument("--search-only", action="store_true", help="only the contact search's cost per call")
    args = ap.parse_args(argv)
    search_cost()
    if args.search_only:
        return
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
