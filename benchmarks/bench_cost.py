"""The cost estimate before a run (gibbsimpact.simulation.cost) against the run itself.

For each bundled case (cases/*.toml, with its own settings) and a few stiff or
re-tuned variants: the highest frequency omega_max of the linearised free
motion at q0, the estimated accepted steps, right-hand sides and CPU seconds,
what binds the step (stability or accuracy of which mode), and the measured
steps, right-hand sides and CPU seconds of the run; the last columns are the
ratios estimated / measured, and what an accepted step of the run costs besides its
right-hand sides in bare scipy steps (the constant cost.STEP_OVERHEAD). CPU is process time, so other processes on a busy
machine disturb it little.

Variants (``--variants``): case fixed_base_R_Pb_arm with EI_N_m2 = 1e9 on link 1
over 2 ms (the issue-27 stiff chain: stability-limited), fixed_base_R_Pb_arm with
RK45 over 0.5 s, with rtol 1e-6 over 1 s.

Usage: python benchmarks/bench_cost.py [--variants] [--cases NAME ...]
"""

from __future__ import annotations

import argparse
import copy
import time
from pathlib import Path

import gibbsimpact as gi
from gibbsimpact.case import case_from_dict
from gibbsimpact.simulation.cost import estimate_cost, step_seconds

ROOT = Path(__file__).resolve().parent.parent
#: The prismatic arms as their rows were measured: DOP853 at rtol 1e-8 (their files run method auto, an implicit
#: method without a step estimate, since 2026-11-27).
TIGHT_DOP853 = {"method": "DOP853", "rtol": 1e-8, "atol": 1e-10}


def variants():
    """(label, case, overrides of Case.simulate) of the stiff and re-tuned runs."""
    pb = gi.load_case(ROOT / "cases" / "fixed_base_R_Pb_arm.toml")
    stiff = copy.deepcopy(pb.source)
    stiff["links"][0]["EI_N_m2"] = 1e9
    return [("R_Pb, EI_1 = 1e9", case_from_dict(stiff, name="stiff"), {**TIGHT_DOP853, "t_end": 0.002}),
            ("R_Pb, RK45", pb, {**TIGHT_DOP853, "t_end": 0.5, "method": "RK45"}),
            ("R_Pb, rtol 1e-6", pb, {**TIGHT_DOP853, "t_end": 1.0, "rtol": 1e-6})]


def measure(label, case, overrides) -> str:
    """One table row: the estimate, the run, their ratios."""
    kw = case.simulate_kwargs(**overrides)
    est = estimate_cost(kw["model"], kw["q0"], kw["qdot0"], kw["t_span"], method=kw.get("method", "DOP853"),
                        rtol=kw.get("rtol", 1e-10), atol=kw.get("atol", 1e-12), output_dt=kw.get("output_dt"),
                        max_step=kw.get("max_step", float("inf")), inputs=kw["inputs"])
    start = time.process_time()
    res = case.simulate(**overrides)
    cpu = time.process_time() - start
    # What one accepted step costs besides its right-hand sides, in bare scipy steps (cost.STEP_OVERHEAD).
    overhead = (cpu - res.nfev * est.rhs_seconds) / (res.n_steps * step_seconds(est.method, len(res.q[0]) * 2))
    binds = est.binding.replace("limit of the mode at", "@").replace("accuracy on the mode at", "accuracy @")
    return (f"| {label} | {est.omega_max:.4g} | {est.n_steps:.3g} | {est.n_rhs:.3g} | {est.cpu_seconds:.3g} | "
            f"{binds} | {res.n_steps} | {res.nfev} | {cpu:.3g} | {est.n_steps / res.n_steps:.2f} | "
            f"{est.n_rhs / res.nfev:.2f} | {est.cpu_seconds / cpu:.2f} | {overhead:.1f} |")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", nargs="*", help="case names (default: every cases/*.toml)")
    p.add_argument("--variants", action="store_true", help="also the stiff and re-tuned variants")
    args = p.parse_args()
    paths = sorted((ROOT / "cases").glob("*.toml"))
    runs = [(path.stem, gi.load_case(path), {}) for path in paths if not args.cases or path.stem in args.cases]
    runs = [(name, case, TIGHT_DOP853 if case.solver.get("method") == "auto" else kw) for name, case, kw in runs]
    if args.variants:
        runs += variants()
    for _, case, _ in runs[:1]:
        case.simulate(t_end=case.t_span[0] + 1e-6)  # the kernels compiled or loaded before any timing
    print("| run | omega_max [rad/s] | est. steps | est. RHS | est. CPU [s] | binds | steps | RHS | CPU [s] | "
          "steps ratio | RHS ratio | CPU ratio | step overhead |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for label, case, overrides in runs:
        print(measure(label, case, overrides), flush=True)


if __name__ == "__main__":
    main()
