"""Restitution study: a rigid rod dropped flat on a floor, first bounce height against e^2 h.

Shows: a plain Python loop over the coefficient of restitution (there is no
sweep API; a loop is all it takes), a rigid link (a Link without modes), a
floor gi.Plane, and reading the first impact out of Result.impacts. The rod
falls flat, so both ends strike together (one impact, two contacts) and the
mass centre rebounds to e^2 h.

Run:   python examples/restitution_study.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 0.6 s; well under a second of CPU per run)
       GIBBSIMPACT_EXAMPLE_OUT    unused (no files are written)
The bounce height is the highest sample of the rod's axis after the impact
(samples every 0.1 ms, so within ~1e-8 m of the apex); if t_end ends a run
before its apex, it is the ballistic projection y + v^2 / (2 g) of the state
just after the impact.
"""

import os

import numpy as np

import gibbsimpact as gi

T_END = min(0.6, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
G, H = 9.81, 0.2  # gravity [m/s^2], drop height of the rod's axis [m]

# A rigid rod: no modes. j_x > 0 only so that the spin of a straight single link about its axis is defined.
rod = gi.Link(length=1.0, mass_per_length=2.0, EI=1.0, rotary_inertia=(1e-4, 0.0, 0.0))
model = gi.Model(gi.Chain([rod]), gravity=(0.0, -G, 0.0))
floor = gi.Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0))
t1 = np.sqrt(2 * H / G)
print(f"rod dropped flat from h = {H} m; closed form: impact at sqrt(2h/g) = {t1:.6f} s, bounce to e^2 h")
print(f"t_end = {T_END:g} s\n")
print(f"{'e':>4} {'t_impact [s]':>13} {'contacts':>9} {'impulse [N s]':>14} {'bounce [m]':>12} "
      f"{'e^2 h [m]':>10} {'rel. error':>11} {'from':>10}")

for e in (1.0, 0.8, 0.6):
    res = gi.simulate(model, model.state(X2=H), np.zeros(model.n_dof), (0.0, T_END), walls=[floor],
                      restitution=e, rtol=1e-10, atol=1e-12, output_dt=1e-4)
    if not res.impacts:
        print(f"{e:>4.1f}  no impact before t_end = {T_END:g} s (first impact at {t1:.3f} s)")
        continue
    imp = res.impacts[0]
    k = np.searchsorted(res.t, imp.time, side="right")  # first sample after the impact
    before_next = res.t < (res.impacts[1].time if len(res.impacts) > 1 else np.inf)
    after = (res.t >= imp.time) & before_next
    y_after, v_after = res.q[k, 1], res.qdot[k, 1]
    apex_time = imp.time + v_after / G
    if res.t[-1] >= apex_time:
        bounce, source = res.q[after, 1].max(), "trajectory"
    else:
        bounce, source = y_after + v_after**2 / (2 * G), "projection"
    expected = e**2 * H
    err = abs(bounce - expected) / expected
    print(f"{e:>4.1f} {imp.time:>13.9f} {len(imp.joints):>9d} {imp.impulses.sum():>14.9f} {bounce:>12.9f} "
          f"{expected:>10.6f} {err:>11.2e} {source:>10}")
    assert abs(imp.time - t1) < 1e-8 and imp.joints == (1, 2)
    assert abs(imp.impulses.sum() - 2.0 * (1 + e) * np.sqrt(2 * G * H)) < 1e-8  # m (1 + e) v1, m = 2 kg
    assert err < 1e-6, f"bounce height off for e = {e}"
