"""A rigid rimless wheel rolling down a 12 degree slope to McGeer's steady speed (docs/walking.md).

Shows: a tree (issue 28: gi.Chain(..., parents=..., attach=...)) of six rigid spokes welded to a hub
(gi.Weld: no coordinate), a hub RigidBody on the root spoke, plastic impacts (e = 0) of the feet (the
spokes' free ends) and feet that stick by friction; from three initial speeds the speed just before
each strike tends to McGeer's (1990) closed form, omega_end^2 (1 - r^2) = 4 m g l sin(alpha) sin(slope)
/ (I_c + m l^2), r = (I_c + m l^2 cos 2 alpha) / (I_c + m l^2) (tests/simulation/test_walking.py derives it).
Without trees in the installed package it prints the closed form only.

Run:   python examples/rimless_wheel.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 12 s: about 20 strikes)
       GIBBSIMPACT_EXAMPLE_OUT    folder for the figure and the animation (default: a new temporary
                                  folder; docs/figures/ holds the ones of the docs)
"""

import os
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import gibbsimpact as gi

T_END = min(12.0, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="rimless_wheel_"))
G, N, L, MU, M_HUB, I_HUB, SLOPE = 9.81, 6, 1.0, 0.1, 10.0, 0.5, np.radians(12.0)
ALPHA = np.pi / N                                # half the angle between spokes
m = M_HUB + N * MU * L                           # the whole wheel [kg]
I_c = I_HUB + N * MU * L ** 3 / 3                # about the hub, its centre of mass [kg m^2]
r = (I_c + m * L * L * np.cos(2 * ALPHA)) / (I_c + m * L * L)
omega_end = np.sqrt(4 * m * G * L * np.sin(ALPHA) * np.sin(SLOPE) / ((I_c + m * L * L) * (1 - r * r)))
print(f"rimless wheel: {N} spokes of {L:g} m, m = {m:g} kg, I_c = {I_c:g} kg m^2, slope {np.degrees(SLOPE):g} deg")
print(f"McGeer: r = {r:.6f}, steady speed before a strike {omega_end:.9f} rad/s, after {r * omega_end:.9f} rad/s")
if not hasattr(gi, "Weld"):
    print("this gibbsimpact has no trees (gi.Weld): the simulation needs issue 28's items 1-2")
    sys.exit(0)

hub_body = gi.RigidBody(M_HUB, inertia=(I_HUB / 2, I_HUB / 2, I_HUB), at=0.0)  # a disc
spokes = [gi.Link(L, MU, 1.0, bodies=(hub_body,))]
spokes += [gi.Link(L, MU, 1.0) for _ in range(N - 1)]
joints = [gi.Revolute()] + [gi.Weld(angle=2 * np.pi * k / N) for k in range(1, N)]
model = gi.Model(gi.Chain(spokes, joints=joints, parents=[-1] + [0] * (N - 1), attach=[None] + [0.0] * (N - 1),
                          base="planar"), gravity=(0.0, -G, 0.0))
ground = gi.Plane(point=(0.0, 0.0, 0.0), normal=(np.sin(SLOPE), np.cos(SLOPE), 0.0), friction=2.0)
down = ALPHA - SLOPE - np.pi / 2                 # spoke 1 (the front foot), hub -> foot, after a strike
hub = -L * np.array([np.cos(down), np.sin(down)])
fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(9.5, 3.4))
for omega0 in (1.2, 1.5, 1.8):
    v = -omega0 * np.array([-hub[1], hub[0]])
    res = gi.simulate(model, model.state(X1=hub[0], X2=hub[1], theta_1=down),
                      model.state(X1=v[0], X2=v[1], theta_1=-omega0), (0.0, T_END), walls=[ground],
                      restitution=0.0, link_contacts=False, output_dt=0.01)
    strikes = [rec for rec in res.impacts if np.any(rec.impulses > 0)]
    w = np.array([-rec.qdot_before[model.coordinate_names.index("theta_1")] for rec in strikes])
    print(f"omega0 = {omega0} rad/s: {res.status}, {len(w)} strikes; last speed before a strike "
          f"{w[-1] if len(w) else np.nan:.9f} rad/s (relative to McGeer {w[-1] / omega_end - 1 if len(w) else np.nan:+.1e})")
    ax.plot(np.arange(1, len(w) + 1), w, "o-", ms=3, label=f"$\\omega_0$ = {omega0} rad/s")
    ax_err.semilogy(np.arange(1, len(w) + 1), np.abs(w / omega_end - 1), "o-", ms=3)
ax.axhline(omega_end, color="k", lw=0.8, ls="--", label="McGeer (1990)")
ax.set(xlabel="strike", ylabel="speed before the strike [rad/s]")
ax_err.set(xlabel="strike", ylabel="|relative difference from McGeer|")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(OUT / "rimless_wheel_speed.png", dpi=90)
print(f"figure: {OUT / 'rimless_wheel_speed.png'}")
from gibbsimpact.plotting import animate  # noqa: E402

print(f"animation: {animate(res, OUT / 'rimless_wheel.gif', fps=15, speed=1.0, max_frames=120, dpi=60)}")
