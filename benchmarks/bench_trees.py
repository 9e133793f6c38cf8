"""Per-call cost of ``forward_dynamics`` on rigid trees: against the serial chain of as many links, and
against Pinocchio's ABA on the same tree (issue 28, Benchmark).

For n = 2 ... 32 rigid links (l = 1 m, mu = 1 kg/m, rotary inertia (5e-5, 2.5e-5, 2.5e-5) kg m:
the rods of bench_kernel.py), on a free base, gravity -X2, at one random state (angles in +-1
rad, theta_0 in +-0.5, qdot ~ N(0, 1)):

* chain: the serial chain ``gi.Chain(links)`` (N = n + 5);
* tree: a balanced binary tree, ``parents[i] = (i - 1) // 2``; a parent's first child sits on its
  tip on a plain revolute, its second at mid-span on a revolute whose axis is turned by
  Rx(pi/2) (``gi.Revolute(axis_rotation=...)``), so the tree is spatial (N = n + 5). Depth
  log2(n): the composite recursion touches fewer ancestors per coordinate than on the chain.

Columns, per call in microseconds of CPU time (``time.process_time``; the minimum over
``--repeats`` loops of ~``budget`` s each, bench_kernel.per_call_cpu_wall; the Python call
included on both sides): gibbsimpact's ``Model.forward_dynamics`` on the chain and on the tree,
their ratio, Pinocchio's ``pin.aba`` (preallocated data) on the same tree built by the
independent reference tests/crosscheck/tree_pinocchio.py (and on the chain), the ratios gi/pin,
and ``match``, the largest relative difference of the two qddot (round-off, ~1e-14). Without
trees in the package (``gi.Weld``, ``Chain(parents=)``: issue 28, branch tree28) the tree columns
of gibbsimpact print n/a and the rest runs. Results: docs/benchmarks.md, "Trees".
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests" / "crosscheck"))

from bench_kernel import LENGTH, MU, ROTARY, describe_environment, per_call_cpu_wall  # noqa: E402

try:
    import pinocchio as pin  # noqa: E402
    import tree_pinocchio as tp  # noqa: E402
    from test_tree_pinocchio import HAS_TREES, to_model  # noqa: E402
except ImportError as exc:  # Pinocchio is a bench/test extra
    sys.exit(f"bench_trees needs Pinocchio ({exc}): pip install pin")

GRAVITY = (0.0, -9.81, 0.0)
RX90 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # Rx(pi/2): z axis -> -y


def binary_tree(n: int, serial: bool = False) -> tp.Tree:
    """The n-link tree of the module docstring (or the serial chain), as the reference's description."""
    rods = tuple(tp.Rod(LENGTH, MU, ROTARY) for _ in range(n))
    if serial:
        return tp.Tree(rods, tuple(tp.Joint() for _ in rods), tuple(range(-1, n - 1)), (None,) * n, "free", GRAVITY)
    parents = tuple(-1 if i == 0 else (i - 1) // 2 for i in range(n))
    second = [i > 0 and i % 2 == 0 for i in range(n)]  # the second child of its parent
    joints = tuple(tp.Joint("R", 0.0, RX90 if s else None) for s in second)
    attach = tuple(0.5 * LENGTH if s else None for s in second)
    return tp.Tree(rods, joints, parents, attach, "free", GRAVITY)


def state(names: tuple, seed: int = 0):
    """q (angles in +-1 rad, theta_0 in +-0.5 rad, positions in +-0.5 m) and qdot ~ N(0, 1), shape (N,)."""
    rng = np.random.default_rng(seed)
    q = np.array([rng.uniform(-0.5, 0.5) if nm.startswith("X") or nm == "theta_0" else rng.uniform(-1, 1)
                  for nm in names])
    return q, rng.normal(size=len(names))


def time_pair(tree: tp.Tree, cfg, with_package: bool) -> dict:
    """Per-call CPU [us] of gibbsimpact and of pin.aba on ``tree``, and the relative qddot difference."""
    ref = tp.build_model(tree)
    q, qd = state(ref.names)
    data, qp, vp, tau = ref.model.createData(), q[ref.order].copy(), qd[ref.order].copy(), np.zeros(len(q))
    out = {"pin": per_call_cpu_wall(lambda: pin.aba(ref.model, data, qp, vp, tau), cfg.repeats, cfg.budget)["cpu_min"]}
    if with_package:
        model = to_model(tree)
        out["gi"] = per_call_cpu_wall(lambda: model.forward_dynamics(q, qd), cfg.repeats, cfg.budget)["cpu_min"]
        a_ref = tp.forward_dynamics(ref, q, qd)
        out["match"] = np.abs(model.forward_dynamics(q, qd) - a_ref).max() / np.abs(a_ref).max()
    return out


def run(cfg) -> list:
    print(f"{'n':>3} {'N':>4} | {'chain gi':>9} {'tree gi':>9} {'tree/chain':>10} | {'chain pin':>9} {'tree pin':>9} | "
          f"{'gi/pin chain':>12} {'gi/pin tree':>11} | {'match chain':>11} {'match tree':>10}   [us CPU per call]")
    rows = []
    for n in cfg.sizes:
        chain = time_pair(binary_tree(n, serial=True), cfg, True)
        tree = time_pair(binary_tree(n), cfg, HAS_TREES)
        row = {"n": n, "chain": chain, "tree": tree}
        rows.append(row)

        def f(v, spec="{:9.1f}"):
            return spec.format(v) if v is not None else f"{'n/a':>{len(spec.format(0.0))}}"

        tg = tree.get("gi")
        print(f"{n:3d} {n + 5:4d} | {f(chain['gi'])} {f(tg)} {f(tg and tg / chain['gi'], '{:10.2f}')} | "
              f"{f(chain['pin'])} {f(tree['pin'])} | {f(chain['gi'] / chain['pin'], '{:12.2f}')} "
              f"{f(tg and tg / tree['pin'], '{:11.2f}')} | {f(chain['match'], '{:11.1e}')} "
              f"{f(tree.get('match'), '{:10.1e}')}", flush=True)
    if not HAS_TREES:
        print("(no trees in this gibbsimpact: gi.Weld / Chain(parents=) missing; the tree columns of gibbsimpact are n/a)")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: n = 2, 4, 8, short loops")
    ap.add_argument("--repeats", type=int, default=None, help="timing loops per measurement; the minimum is reported")
    args = ap.parse_args(argv)
    cfg = argparse.Namespace(sizes=(2, 4, 8) if args.quick else (2, 4, 8, 16, 32),
                             repeats=args.repeats or (3 if args.quick else 7),
                             budget=0.02 if args.quick else 0.2)
    describe_environment()
    print(f"Pinocchio {pin.__version__}; sizes n = {cfg.sizes}; {cfg.repeats} repeats of ~{cfg.budget} s loops "
          "(minimum of CPU time reported)")
    return run(cfg)


if __name__ == "__main__":
    main()
