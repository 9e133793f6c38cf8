"""Sweep restitution x link stiffness on published case 1, on two worker processes, then resume.

Shows: gibbsimpact.sweep.sweep over a grid of two case-file keys of
cases/circle_two_link.toml (the global `restitution` and `links[1].EI_N_m2`,
the bending stiffness of link 1; 3 x 3 = 9 runs) on a process pool; the tidy
table sweep.csv (one row per run) and the whole result of every run in
runs/<run id>.npz (gi.load_result); calling the same sweep again runs nothing,
because every result is already there. The shell equivalent:

    gibbsimpact sweep cases/circle_two_link.toml --vary restitution=0.5:1:3 \\
        --vary links.1.EI_N_m2=10,20,40 --workers 2 --t-end 0.6

Checks: for each stiffness the first impact comes at the same instant for every
e (the flight before it does not depend on e); with e = 1 the total energy
at the end equals the initial one (impacts conserve it, flight drift ~1e-10);
with e < 1 the impacts dissipate energy.

Run:   python examples/sweep_restitution_stiffness.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 0.6 s, first impacts at ~0.45 s; about 0.3 s
                                  of CPU per run, plus ~3 s to start the worker processes)
       GIBBSIMPACT_EXAMPLE_OUT    folder of the sweep (default: a new temp dir)
The process pool starts its workers with "spawn", which imports this script
again in each worker: the `if __name__ == "__main__":` guard is required.
"""

import os
import tempfile
from pathlib import Path

import gibbsimpact as gi
from gibbsimpact.study.sweep import sweep

CASE = Path(__file__).resolve().parent.parent / "cases" / "circle_two_link.toml"
T_END = min(0.6, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
GRID = {"restitution": [0.5, 0.75, 1.0], "links[1].EI_N_m2": [10.0, 20.0, 40.0]}


def main():
    out = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="gibbsimpact_sweep_")) / "sweep"
    print(f"{CASE.name}: t_end = {T_END:g} s, grid {GRID} (last key fastest), out {out}")
    res = sweep(CASE, GRID, workers=2, out=out, t_end=T_END)
    print(f"{len(res.rows)} runs ({res.n_run} run now, {res.n_skipped} already done): {res.status_counts()}")
    print(f"table {res.table}, columns: {', '.join(res.columns)}\n")

    print(f"{'EI_1 [N m^2]':>12} {'e':>5} {'status':>9} {'impacts':>8} {'first [s]':>10} "
          f"{'E0 [J]':>10} {'E_end - E0 [J]':>15} {'energy_error':>13}")
    for row in res.rows:
        result = gi.load_result(out / row["result"])
        E = result.energy().total
        first = f"{row['first_impact_s']:.6f}" if row["first_impact_s"] is not None else "-"
        print(f"{row['links[1].EI_N_m2']:>12g} {row['restitution']:>5g} {row['status']:>9} {row['n_impacts']:>8d} "
              f"{first:>10} {E[0]:>10.6f} {E[-1] - E[0]:>15.3e} {row['energy_error']:>13.2e}")
        if row["status"] != "finished":
            continue
        if row["restitution"] == 1.0:
            assert abs(E[-1] - E[0]) < 1e-6 * abs(E[0]), "e = 1 must conserve the energy"
        elif row["n_impacts"]:
            assert E[-1] < E[0], "impacts with e < 1 must dissipate energy"

    for ei in GRID["links[1].EI_N_m2"]:
        firsts = {r["first_impact_s"] for r in res.rows if r["links[1].EI_N_m2"] == ei}
        assert len(firsts) == 1, f"EI = {ei}: the first impact depends on e: {firsts}"
    if all(r["first_impact_s"] is None for r in res.rows):
        print(f"\nno impacts before t_end = {T_END:g} s (the first ones come at ~0.45 s)")

    again = sweep(CASE, GRID, workers=2, out=out, t_end=T_END)
    print(f"\nsame sweep again: {again.n_run} runs simulated, {again.n_skipped} read back from {out / 'runs'}")
    assert again.n_run == 0 and again.rows == res.rows


if __name__ == "__main__":
    main()
