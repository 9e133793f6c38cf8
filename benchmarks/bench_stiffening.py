"""Cost and effect of foreshortening (Link geometric_stiffening, docs/theory.md "Foreshortening").

1. ``forward_dynamics`` per call [us] with every flexible link stiffened ("on") and with none
   ("off", the linear beam), and their ratio, in one run: case 1 (cases/circle_two_link.toml),
   an 8-link free-flying modal chain (clamped-free y and z modes, 2 per link), the bundled
   finite-element arms (cases/fixed_base_*.toml: a link behind a Pb guide or under a Pa carriage
   keeps the linear beam, the others are stiffened), and a one-link arm of 4, 8, 16 elements
   (the per-call foreshortening sum costs O(G m^2) for G quadrature points and m coordinates).
   Minimum of 5 loops of ~0.2 s each (a shared machine: the least disturbed estimate).
2. The two published cases run with every link stiffened: their first impact times next to the
   shipped (linear) ones.

Run: python benchmarks/bench_stiffening.py
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

import gibbsimpact as gi
from gibbsimpact.case.builders import load_case

CASES = Path(__file__).resolve().parent.parent / "cases"


def with_stiffening(model, on: bool):
    """The model with geometric_stiffening = on on every link that allows it (not behind a Pb
    guide, not under a Pa carriage)."""
    joints = model.chain.joints
    links = []
    for i, lk in enumerate(model.chain.links):
        allowed = joints[i].kind != "Pb" and not (i + 1 < len(joints) and joints[i + 1].kind == "Pa")
        links.append(dataclasses.replace(lk, geometric_stiffening=on and allowed))
    chain = gi.Chain(links, joints=joints, base=model.chain.base)
    return gi.Model(chain, gravity=tuple(model.gravity), quadrature=model.quadrature)


def per_call_us(fn, repeats=5, budget=0.2) -> float:
    fn()
    best = np.inf
    for _ in range(repeats):
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < budget:
            fn()
            n += 1
        best = min(best, (time.perf_counter() - t0) / n)
    return 1e6 * best


def state(model, seed=0):
    rng = np.random.default_rng(seed)
    q = np.zeros(model.n_dof)
    for i, jt in enumerate(model.chain.joints):
        c = model.theta_index[i]
        q[c] = rng.uniform(*jt.range) if jt.kind != "R" else rng.uniform(-0.5, 0.5)
    for idx in model.delta_index:
        q[idx] = rng.uniform(-0.01, 0.01, idx.size)
    if model.free_base:
        q[:model.theta_index[0]] = 0.1
    return q, rng.normal(size=model.n_dof)


def models():
    yield "case 1 (2 links, 1 mode each)", load_case(CASES / "circle_two_link.toml").model
    link = gi.Link(0.5, 1.0, (20.0, 20.0), modes=[gi.Mode("clamped-free", d) for d in "yz"],
                   rotary_inertia=(1e-4, 1e-4, 1e-4))
    yield "8-link modal chain (y, z modes)", gi.Model(gi.Chain([link] * 8))
    for name in ("fixed_base_fe_arm", "fixed_base_R_Pa_arm", "fixed_base_R_Pb_arm"):
        yield f"{name}.toml", load_case(CASES / f"{name}.toml").model
    for ne in (4, 8, 16):
        yield f"1-link FE arm, {ne} elements", gi.Model(gi.Chain([gi.Link(1.0, 1.0, 25.0, elements=ne)],
                                                               base=gi.FixedBase()))


def per_call_table():
    print(f"{'model':38s} {'N':>4s} {'off [us]':>9s} {'on [us]':>9s} {'on/off':>7s}")
    for name, model in models():
        off, on = with_stiffening(model, False), with_stiffening(model, True)
        q, qd = state(on)
        t_off = per_call_us(lambda: off.forward_dynamics(q, qd))
        t_on = per_call_us(lambda: on.forward_dynamics(q, qd))
        print(f"{name:38s} {model.n_dof:4d} {t_off:9.2f} {t_on:9.2f} {t_on / t_off:7.2f}")


def impact_times():
    for name in ("circle_two_link", "sphere_single_link"):
        case = load_case(CASES / f"{name}.toml")
        runs = {}
        for on in (False, True):
            c = dataclasses.replace(case, model=with_stiffening(case.model, on))
            t0 = time.process_time()
            res = c.simulate()
            runs[on] = ([r.time for r in res.impacts], time.process_time() - t0, res.status)
        print(f"{name}: first impact times [s], linear (shipped) | stiffened; CPU {runs[False][1]:.2f} | "
              f"{runs[True][1]:.2f} s; status {runs[False][2]} | {runs[True][2]}")
        for k, (a, b) in enumerate(zip(runs[False][0][:6], runs[True][0][:6])):
            print(f"  impact {k + 1}: {a:.9f} | {b:.9f}   (difference {b - a:+.3e} s)")


if __name__ == "__main__":
    per_call_table()
    impact_times()
