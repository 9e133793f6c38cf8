"""A flexible arm on a fixed base, driven by a motor torque onto a floor (finite elements, damping).

Shows: gi.Link(..., elements=3, damping=0.01, geometric_stiffening=False) (Hermite finite elements, 1 %
stiffness-proportional damping), gi.FixedBase, a torque input given as a dict
{coordinate name: f(t, q, qdot)}, a floor with e = 0.5, and the energy audit:
Result.work holds the work of the inputs and of the damping, so
E(end) - E(start) = W_inputs + W_damping + (energy lost in the impacts), and
Result.energy_error is the power balance within the flight phases.

The tip strikes at ~0.19 s and chatters: the beam behind it keeps pressing, the
rebounds shrink geometrically and accumulate. Resting contact is not modelled
yet, so the run stops there with status "zeno" (everything up to that instant
is kept, and the audit covers it) - the same as cases/fixed_base_fe_arm.toml.

Run:   python examples/fixed_base_fe_arm.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 0.5 s)
       GIBBSIMPACT_EXAMPLE_OUT    folder for the figure (default: a new temp dir)
"""

import os
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import gibbsimpact as gi  # noqa: E402

T_END = min(0.5, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="gibbsimpact_arm_"))

arm = gi.Link(length=1.0, mass_per_length=1.0, EI=10.0, elements=3, damping=0.01, geometric_stiffening=False)
robot = gi.Model(gi.Chain([arm], base=gi.FixedBase(position=(0.0, 0.5), angle=0.0)), gravity=(0.0, -9.81, 0.0))
print(f"N = {robot.n_dof}:", " ".join(robot.coordinate_names))


def motor(t, q, qdot):
    """Motor torque on joint 1 [N m]: a push down that fades in over 50 ms."""
    return -2.0 * (1.0 - np.exp(-t / 0.05))


q0 = robot.state(theta_1=-0.2)  # straight, 0.2 rad below horizontal; the tip is 0.30 m above the floor
res = gi.simulate(robot, q0, np.zeros(robot.n_dof), (0.0, T_END), walls=[gi.Plane((0, 0, 0), (0, 1, 0))],
                  restitution=0.5, inputs={"theta_1": motor}, rtol=1e-8, atol=1e-10, output_dt=1e-3)
print(f"t_end = {T_END:g} s  status = {res.status}  {len(res.impacts)} impacts  {res.nfev} RHS  "
      f"{res.wall_time:.2f} s wall")
for i, imp in enumerate(res.impacts, start=1):
    print(f"  impact {i}: t = {imp.time:.6f} s  joint O{imp.joints[0]}  impulse {imp.impulses[0]:.6f} N s  "
          f"v_n {imp.v_before[0]:+.4f} -> {imp.v_after[0]:+.4f} m/s  "
          f"loss {imp.energy_before.total - imp.energy_after.total:.6f} J")

E = res.energy().total
W_in, W_damp = res.work[-1]
lost = sum(imp.energy_before.total - imp.energy_after.total for imp in res.impacts)
residual = (E[-1] - E[0]) - (W_in + W_damp - lost)
print("\nenergy audit [J]")
print(f"  E(start)            {E[0]: .9f}")
print(f"  E(end)              {E[-1]: .9f}")
print(f"  work of the motor   {W_in: .9f}")
print(f"  work of damping     {W_damp: .9f}")
print(f"  lost in impacts     {-lost: .9f}")
print(f"  residual            {residual: .2e}   (E(end) - E(start) - W - impacts)")
print(f"  energy_error        {res.energy_error: .2e}   (power balance within the flight phases)")
print(f"  status {res.status}: {res.message}")
assert res.status in ("finished", "zeno"), res.message
assert W_damp <= 0.0 and lost >= 0.0
assert abs(residual) < 1e-6 * max(1.0, abs(E[0])) and res.energy_error < 1e-6

fig, ax = plt.subplots(figsize=(6, 3.5))  # the audit as curves: E(t) - E(0) against the works
ax.plot(res.t, E - E[0], label="E(t) - E(0)")
ax.plot(res.t, res.work[:, 0], label="work of the motor")
ax.plot(res.t, res.work[:, 1], label="work of damping")
ax.set(xlabel="t [s]", ylabel="[J]", title="fixed-base FE arm: energy audit")
ax.legend()
fig.tight_layout()
fig.savefig(OUT / "fe_arm_energy_audit.png", dpi=100)
print("figure:", OUT / "fe_arm_energy_audit.png")
