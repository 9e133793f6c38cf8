"""Published case 1: two flexible links released inside a circle (planar, e = 1).

Shows: building the case study of cases/circle_two_link.toml directly in Python
(gi.Link / gi.Chain / gi.Model / gi.Circle), the impact table, the energy check
(e = 1 and no damping: the total energy stays at its initial value through the
impacts) and the figures of the paper.

Run:   python examples/published_case_1.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 1.0 s, about 3-6 s of CPU)
       GIBBSIMPACT_EXAMPLE_OUT    folder for the figures (default: a new temp dir)
Reference (t_end = 1 s): O2 at 0.451524 s, O1+O3 at 0.474918 s, O2 at 0.506715 s,
O2 at 0.890135 s; total energy -4.905 J throughout.
"""

import os
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

import gibbsimpact as gi  # noqa: E402

T_END = min(1.0, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="gibbsimpact_case1_"))

# Each link: l = 1 m, mu = 1 kg/m, EI = 20 N m^2, first clamped-clamped mode in y.
link = gi.Link(length=1.0, mass_per_length=1.0, EI=20.0,
               modes=[gi.Mode("clamped-clamped", direction="y")], rotary_inertia=(0.0, 0.0, 0.0), geometric_stiffening=False)
model = gi.Model(gi.Chain([link, link]), gravity=(0.0, -9.81, 0.0))
print("coordinates:", " ".join(model.coordinate_names))

# Released from rest in a "V": O1 at (-cos 30deg, 0), link 1 at -30deg, link 2 at +60deg relative.
q0 = model.state(X1=-np.cos(np.pi / 6), theta_1=-np.pi / 6, theta_2=np.pi / 3)
qdot0 = np.zeros(model.n_dof)
res = gi.simulate(model, q0, qdot0, (0.0, T_END), walls=[gi.Circle(radius=1.5, center=(0.0, 0.0))],
                  restitution=1.0, rtol=1e-10, atol=1e-12, method="DOP853", output_dt=1e-3)

print(f"\nt_end = {T_END:g} s  status = {res.status}  ({res.message})")
print(f"{res.nfev} right-hand sides, {res.n_steps} steps, {res.wall_time:.2f} s wall")
print(f"\n{'#':>2} {'time [s]':>10} {'joints':>8} {'impulses [N s]':>24} {'v_n before':>12} {'v_n after':>12}")
for i, imp in enumerate(res.impacts, start=1):
    joints = ",".join(f"O{j}" for j in imp.joints)
    imps = " ".join(f"{x:.6f}" for x in imp.impulses)
    vb = " ".join(f"{x:+.4f}" for x in imp.v_before)
    va = " ".join(f"{x:+.4f}" for x in imp.v_after)
    print(f"{i:>2} {imp.time:>10.6f} {joints:>8} {imps:>24} {vb:>12} {va:>12}")

E = res.energy()
drift = np.max(np.abs(E.total - E.total[0]))
print(f"\ntotal energy: start {E.total[0]:.9f} J, end {E.total[-1]:.9f} J, max |drift| {drift:.2e} J")
print(f"energy_error (largest relative drift in a flight phase): {res.energy_error:.2e}")
assert res.status == "finished", res.message
assert drift < 1e-7 * abs(E.total[0]), "e = 1 and no damping: the energy must be conserved"

figs = res.plot(kinds=["angles", "energy", "configurations"], directory=OUT, case_name="case 1")
print("figures:", ", ".join(str(OUT / f"{k}.png") for k in figs))
