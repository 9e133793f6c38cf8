"""A telescoping flexible arm: a motor swings link 1, link 2 slides through a guide at its tip.

Shows: gi.FixedPrismatic (a Pb joint: d_2 is the length of link 2 protruding
from the guide; only that part bends, on stretching finite elements), joint
inputs by name (a torque [N m] on theta_1, a force [N] on d_2), the joint
limit as an end stop (joint_limit="impact"), the energy audit of a driven run,
the figures of the joint variables and tip deflections, and the force of the end
stop while it holds link 2 (contact_forces.png, Result.stop_forces [N]).

The actuator pushes link 2 out against gravity until it hits the outer end stop
(d_max = 0.6 m) and bounces off it (e = 0.5); every end-stop impact is an
ImpactRecord with wall == (-1,).

Run:   python examples/telescoping_arm.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 1 s)
       GIBBSIMPACT_EXAMPLE_OUT    folder for the figures (default: a new temp dir)
"""

import os
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

import gibbsimpact as gi  # noqa: E402

T_END = min(1.0, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="gibbsimpact_telescope_"))
OUT.mkdir(parents=True, exist_ok=True)

link1 = gi.Link(length=1.0, mass_per_length=1.0, EI=25.0, elements=2, geometric_stiffening=False)
link2 = gi.Link(length=0.7, mass_per_length=0.5, EI=4.0, elements=2, geometric_stiffening=False)
robot = gi.Model(gi.Chain([link1, link2],
                          joints=[gi.Revolute(), gi.FixedPrismatic(angle=0.0, range=(0.2, 0.6))],
                          base=gi.FixedBase(position=(0.0, 0.0), angle=0.0)),
                 gravity=(0.0, -9.81, 0.0))
print(f"N = {robot.n_dof}:", " ".join(robot.coordinate_names))

inputs = {
    "theta_1": lambda t, q, qdot: 6.0 + 2.0 * np.sin(2 * np.pi * t),  # N m: about holds the arm up, and swings it
    "d_2": lambda t, q, qdot: 1.5,                                     # N: pushes link 2 out of its guide
}
q0 = robot.state(theta_1=0.2, d_2=0.35)
res = gi.simulate(robot, q0, np.zeros(robot.n_dof), (0.0, T_END), inputs=inputs, joint_limit="impact",
                  joint_restitution=0.5, rtol=1e-8, atol=1e-10, output_dt=2e-3)
print(f"t_end = {T_END:g} s  status = {res.status}  {res.nfev} RHS  {res.wall_time:.2f} s wall")
print(f"  {res.message}")
# v_before, v_after: the velocity along the stop's normal n = grad g (for d_max: -d_2_dot), < 0 approaching.
for rec in res.impacts[:8]:
    what = f"end stop of joint {rec.joints[0]}" if rec.wall == (-1,) else f"O{rec.joints[0]} on wall {rec.wall[0] + 1}"
    print(f"  t = {rec.time:.6f} s  {what}: normal velocity {rec.v_before[0]:+.4f} -> {rec.v_after[0]:+.4f} m/s")
if len(res.impacts) > 8:
    print(f"  ... {len(res.impacts)} end-stop impacts in all")

E = res.energy().total
W_in = res.work[:, 0]
lost = sum(r.energy_before.total - r.energy_after.total for r in res.impacts)
print(f"energy: E(end) - E(start) = {E[-1] - E[0]:.6f} J; work of the inputs {W_in[-1]:.6f} J; "
      f"lost in the end stops {lost:.6f} J; power balance in flight {res.energy_error:.2e}")
d = res.q[:, robot.coordinate_names.index("d_2")]
print(f"d_2 in [{d.min():.4f}, {d.max():.4f}] m (range 0.2 ... 0.6 m)")
for name in ("angles", "deflection", "configurations", "contact_forces"):  # contact_forces: the end-stop forces
    fig = res.plot(name)
    if fig is not None:
        fig.savefig(OUT / f"{name}.png", dpi=80)
print(f"figures in {OUT}")
