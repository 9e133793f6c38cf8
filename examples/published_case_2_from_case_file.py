"""Published case 2 from its case file: one flexible link thrown inside a sphere.

Shows: gi.load_case on cases/sphere_single_link.toml, Case.simulate with a
t_end override, Result.save (result.npz) and Result.to_csv (timeseries.csv,
impacts.csv), then gi.load_result and a check that the result read back is
identical (trajectory, impacts, status, energies).

Run:   python examples/published_case_2_from_case_file.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default: the file's 1.0 s, about 5-10 s of CPU)
       GIBBSIMPACT_EXAMPLE_OUT    folder for result.npz and the CSV files (default: a new temp dir)
Reference (t_end = 1 s): O1 at 0.540052 s, O2 at 0.661352 s, O1 at 0.775988 s;
total energy 1.807549 J throughout.
"""

import csv
import os
import tempfile
from pathlib import Path

import numpy as np

import gibbsimpact as gi

CASE = Path(__file__).resolve().parent.parent / "cases" / "sphere_single_link.toml"
OUT = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="gibbsimpact_case2_"))

case = gi.load_case(CASE)
t_end = min(case.t_span[1], float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
print(f"{case.name}: {case.description}")
print("coordinates:", " ".join(case.model.coordinate_names), "| walls:", case.walls)

res = case.simulate(t_end=t_end)
print(f"\nt_end = {t_end:g} s  status = {res.status}  {len(res.impacts)} impacts  {res.wall_time:.2f} s wall")
for i, imp in enumerate(res.impacts, start=1):
    print(f"  impact {i}: t = {imp.time:.6f} s  joints {imp.joints}  impulse {imp.impulses[0]:.6f} N s  "
          f"v_n {imp.v_before[0]:+.5f} -> {imp.v_after[0]:+.5f} m/s")
E = res.energy()
print(f"total energy {E.total[0]:.6f} J -> {E.total[-1]:.6f} J, energy_error {res.energy_error:.2e}")

# Save, write CSV, read back.
npz = res.save(OUT / "result.npz", metadata={"case": case.name, "t_end": t_end})
files = res.to_csv(OUT)
back, meta = gi.load_result(npz, with_metadata=True)
print(f"\nwrote {npz} ({npz.stat().st_size} bytes) and", ", ".join(str(p) for p in files.values()))
print("metadata read back:", meta)

same = (np.array_equal(back.t, res.t) and np.array_equal(back.q, res.q) and np.array_equal(back.qdot, res.qdot)
        and back.status == res.status and len(back.impacts) == len(res.impacts)
        and all(a.time == b.time and a.joints == b.joints and np.array_equal(a.impulses, b.impulses)
                and np.array_equal(a.qdot_after, b.qdot_after) for a, b in zip(res.impacts, back.impacts))
        and np.array_equal(back.energy().total, E.total))
print("load_result gives back the same result:", same)
assert same, "NPZ round trip is not exact"

with open(files["timeseries"], newline="") as fh:
    rows = list(csv.DictReader(fh))
print(f"timeseries.csv: {len(rows)} rows, columns {list(rows[0])[:6]} ...")
assert float(rows[-1]["t_s"]) == res.t[-1] and float(rows[-1]["total_J"]) == E.total[-1]
