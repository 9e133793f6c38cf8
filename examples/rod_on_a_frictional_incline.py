"""A rigid rod dropped onto a frictional incline: bounces, resting contact, stick or slide.

Shows: a wall with Coulomb friction (gi.Plane(..., friction=mu)), frictional impacts
(ImpactRecord.friction_impulses), the accumulation of bounces turning into resting contact
(Result.contact_forces, Result.friction_forces, Result.resting_time), and the two outcomes of
Coulomb's law on a slope of angle alpha: with mu > tan(alpha) the rod sticks, the wall carrying
m g cos(alpha) normal and m g sin(alpha) along the slope; with mu < tan(alpha) it slides down
with acceleration g (sin(alpha) - mu cos(alpha)).

Run:   python examples/rod_on_a_frictional_incline.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 1.5 s; a few seconds of CPU)
       GIBBSIMPACT_EXAMPLE_OUT    folder for the contact-force figures (default: a new temporary folder)
"""

import os
import tempfile

import numpy as np

import gibbsimpact as gi

T_END = min(1.5, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="incline_")
G, ALPHA, L, MU_L = 9.81, np.radians(20.0), 1.0, 2.0  # gravity, slope, rod length [m], mass per length [kg/m]
m = L * MU_L
n = np.array([-np.sin(ALPHA), np.cos(ALPHA), 0.0])  # the incline's normal, into the free side
up = np.array([np.cos(ALPHA), np.sin(ALPHA), 0.0])  # up the slope

# A rigid rod (no modes; j_x > 0 only so that its spin about its own axis is defined), released at rest
# 2 cm above the incline, parallel to it, tilted by 5 degrees more.
rod = gi.Link(length=L, mass_per_length=MU_L, EI=1.0, rotary_inertia=(1e-4, 0.0, 0.0))
model = gi.Model(gi.Chain([rod]), gravity=(0.0, -G, 0.0))
q0 = model.state(X1=n[0] * 0.02, X2=n[1] * 0.02, theta_1=ALPHA + np.radians(5.0))
print(f"rod of {m:g} kg dropped onto a {np.degrees(ALPHA):g} deg incline, e = 0.3, t_end = {T_END:g} s; "
      f"tan(alpha) = {np.tan(ALPHA):.3f}\n")

for mu in (0.6, 0.2):
    wall = gi.Plane(point=(0.0, 0.0, 0.0), normal=tuple(n), friction=mu)
    res = gi.simulate(model, q0, np.zeros(model.n_dof), (0.0, T_END), walls=[wall], restitution=0.3, output_dt=1e-3)
    print(f"mu = {mu}: {res.status}, {len(res.impacts)} impacts, resting for {res.resting_time:.3f} s of {T_END:g} s")
    if res.impacts:
        r = res.impacts[0]
        print(f"  first impact at {r.time:.4f} s: normal impulse {r.impulses[0]:.4f} N s, friction impulse "
              f"{np.linalg.norm(r.friction_impulses[0]):.4f} N s (<= mu x normal = {mu * r.impulses[0]:.4f})")
    N = res.contact_forces[-1, 0].sum()
    if N == 0.0:
        print("  not resting yet at t_end\n")
        continue
    Ft = res.friction_forces[-1, 0].sum(axis=0)
    print(f"  at t_end: normal force {N:.6f} N (m g cos a = {m * G * np.cos(ALPHA):.6f}), friction "
          f"{Ft @ up:+.6f} N up the slope", end="")
    if mu > np.tan(ALPHA):
        print(f" (m g sin a = {m * G * np.sin(ALPHA):.6f}: it sticks)")
    else:
        a = G * (np.sin(ALPHA) - mu * np.cos(ALPHA))
        v = -res.qdot[-1, :3] @ up  # O1's velocity down the slope (the rod moves as a whole)
        print(f" (mu N = {mu * N:.6f}: it slides); speed down the slope {v:.4f} m/s, "
              f"growing at g (sin a - mu cos a) = {a:.4f} m/s^2")
    fig = res.plot("contact_forces")
    path = os.path.join(OUT, f"contact_forces_mu{mu:g}.png")
    fig.savefig(path, dpi=90)
    print(f"  figure: {path}\n")
