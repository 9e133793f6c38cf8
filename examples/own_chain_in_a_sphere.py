"""Your own chain: three flexible links (y and z modes) thrown inside a sphere, no gravity.

Shows: a spatial free-flying chain of your own (N = 14 coordinates), placing its
mass centre with Model.center_of_mass, and two invariants of impacts on a sphere
with e = 1 and no gravity: every wall impulse points at the centre, so the
angular momentum about the centre is conserved through the impacts (and so is
the energy). Prints the impacts and the drift of both.

Run:   python examples/own_chain_in_a_sphere.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 0.6 s, about 10-20 s of CPU)
       GIBBSIMPACT_EXAMPLE_OUT    unused (no files are written)
"""

import os

import numpy as np

import gibbsimpact as gi

T_END = min(0.6, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
R = 1.0  # sphere radius [m]

r = 0.01  # round cross-section: rotary inertia mu r^2 (1/2, 1/4, 1/4) per length
link = gi.Link(length=0.5, mass_per_length=1.0, EI=(5.0, 5.0),
               modes=[gi.Mode("clamped-clamped", "y"), gi.Mode("clamped-clamped", "z")],
               rotary_inertia=(r * r / 2, r * r / 4, r * r / 4))
model = gi.Model(gi.Chain([link, link, link]), gravity=(0.0, 0.0, 0.0))
print(f"N = {model.n_dof}:", " ".join(model.coordinate_names))

# A bent, twisted zig-zag; shift it so that its mass centre sits at (0.1, 0, 0).
q0 = model.state(theta_m1=0.4, theta_0=0.3, theta_1=0.2, theta_2=1.0, theta_3=-0.9,
                 delta_1_1=0.01, delta_2_2=-0.01)
q0[:3] += np.array([0.1, 0.0, 0.0]) - model.center_of_mass(q0)
# Thrown towards +X1 and +X2 while spinning and vibrating.
qdot0 = model.state(X1=2.5, X2=1.5, X3=-0.5, theta_1=3.0, theta_2=-2.0, theta_3=2.5,
                    delta_1_1=0.3, delta_3_2=-0.2)

res = gi.simulate(model, q0, qdot0, (0.0, T_END), walls=[gi.Sphere(radius=R)], restitution=1.0,
                  rtol=1e-10, atol=1e-12)
print(f"t_end = {T_END:g} s  status = {res.status}  {len(res.impacts)} impacts  "
      f"{res.nfev} RHS  {res.wall_time:.2f} s wall")
for i, imp in enumerate(res.impacts, start=1):
    print(f"  impact {i}: t = {imp.time:.6f} s  joints {imp.joints}  impulses {np.round(imp.impulses, 6)} N s  "
          f"rounds {imp.rounds}")

H0 = model.angular_momentum(q0, qdot0, about=np.zeros(3))
H = np.array([model.angular_momentum(q, qd, about=np.zeros(3)) for q, qd in zip(res.q, res.qdot)])
drift_H = np.max(np.linalg.norm(H - H0, axis=1)) / np.linalg.norm(H0)
E = res.energy().total
drift_E = np.max(np.abs(E - E[0])) / abs(E[0])
P = np.array([model.linear_momentum(q, qd) for q, qd in zip(res.q, res.qdot)])
print(f"angular momentum about the centre H0 = {np.round(H0, 6)} kg m^2/s")
print(f"  max |H(t) - H0| / |H0| = {drift_H:.2e}   (conserved through impacts on a sphere)")
print(f"  energy: max |E(t) - E0| / E0 = {drift_E:.2e}   (E0 = {E[0]:.6f} J)")
print(f"  linear momentum is not conserved by impacts: |p| {np.linalg.norm(P[0]):.4f} -> "
      f"{np.linalg.norm(P[-1]):.4f} kg m/s")
assert res.status == "finished", res.message
assert drift_H < 1e-8 and drift_E < 1e-8
