"""Newton's law against the compliant (Hunt-Crossley) law on the flexible arm of issue 26, across the mesh.

The arm: one link, l = 1 m, mu = 1 kg/m, EI = 1e4 N m^2, on a pivot at (0, 0.5) m, released horizontal onto a
floor Y = 0 with e = 0.5 (started here 1 mm above the floor with the rigid rod's speed, omega^2 = 3 g sin|theta| / l).
With Newton's law the tip's impulse halves with every doubling of elements and the collision breaks into
micro-impacts (docs/theory.md §11.4); with the compliant law (gi.Plane(..., stiffness=1e4), docs/theory.md §11.5)
the episode's impulse and effective restitution (angular momentum about the pivot after over before, gravity
removed: Result.episodes) converge, to the rigid rod's as EI grows.

Run:   python examples/compliant_vs_newton_arm.py     (n_e = 1, 2, 4: about two minutes of CPU)
Env:   GIBBSIMPACT_EXAMPLE_T_END  set: a short check (n_e = 1, 2, and t_end capped by it; default 0.06 s)
       GIBBSIMPACT_EXAMPLE_OUT    folder for the figure (default: a new temporary folder)
"""

import os
import tempfile
import time
import warnings

import numpy as np

import gibbsimpact as gi

QUICK = "GIBBSIMPACT_EXAMPLE_T_END" in os.environ
T_END = min(0.06, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="compliant_arm_")
ELEMENTS = (1, 2) if QUICK else (1, 2, 4)
EI, G = 1e4, 9.81
LAWS = {
    "Newton": gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.5),
    "compliant": gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.5, stiffness=1e4, exponent=1.5),
}


def arm(elements):
    """The arm (0 elements: the rigid rod) and its state with the tip 1 mm above the floor."""
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, EI, elements=elements)], base=gi.FixedBase((0.0, 0.5))),
                     gravity=(0.0, -G, 0.0))
    s = 0.5 - 1e-3  # l sin|theta|
    q, qd = np.zeros(model.n_dof), np.zeros(model.n_dof)
    q[model.theta_index[0]], qd[model.theta_index[0]] = -np.arcsin(s), -np.sqrt(3.0 * G * s)
    return model, q, qd


rows = {law: [] for law in LAWS}
print(f"arm of issue 26, EI = {EI:g} N m^2, e = 0.5, t_end = {T_END:g} s\n")
print(f"{'law':>9} {'n_e':>4} {'impacts':>8} {'episodes':>8} {'impulse [N s]':>14} {'e_eff':>8} {'CPU [s]':>8}")
for law, floor in LAWS.items():
    for ne in (0,) + ELEMENTS:
        model, q0, qd0 = arm(ne)
        started = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", gi.ValidityWarning)  # Newton's law at an FE tip: the point of this script
            res = gi.simulate(model, q0, qd0, (0.0, T_END), walls=[floor])
        ep = res.episodes[0]
        rows[law].append((ne, ep.impulse, ep.restitution))
        print(f"{law:>9} {ne if ne else 'rigid':>4} {len(res.impacts):>8} {len(res.episodes):>8} {ep.impulse:>14.5f} "
              f"{ep.restitution:>8.5f} {time.process_time() - started:>8.1f}")

# The rigid rod under Newton's law rebounds with e exactly; the compliant rod with its own e_eff.
assert abs(rows["Newton"][0][2] - 0.5) < 1e-9
if not QUICK:
    rigid = rows["compliant"][0][2]
    assert all(abs(e - rigid) < 0.02 for _, _, e in rows["compliant"][1:]), rows["compliant"]

import matplotlib  # noqa: E402

matplotlib.use(os.environ.get("MPLBACKEND", "Agg"))
import matplotlib.pyplot as plt  # noqa: E402

fig, axes = plt.subplots(1, 2, figsize=(10, 4))
for law, marker in (("Newton", "o"), ("compliant", "s")):
    ne, impulse, e_eff = np.array(rows[law][1:]).T
    axes[0].plot(ne, impulse, marker=marker, label=f"{law} (FE arm)")
    axes[1].plot(ne, e_eff, marker=marker, label=f"{law} (FE arm)")
    for ax, value in zip(axes, rows[law][0][1:]):
        ax.axhline(value, ls="--", lw=0.8, color=ax.lines[-1].get_color(), label=f"{law}, rigid rod")
axes[0].set(xscale="log", xlabel="elements n_e", ylabel="episode impulse [N s]")
axes[1].set(xscale="log", xlabel="elements n_e", ylabel="effective restitution e_eff")
for ax in axes:
    ax.set_xticks(ELEMENTS, [str(n) for n in ELEMENTS])
    ax.set_xticks([], minor=True)  # no stray log-axis minor label ("3 x 10^0") between the meshes
    ax.legend(fontsize=8)
fig.suptitle(f"arm of issue 26 on a floor, e = 0.5, EI = {EI:g} N m$^2$: Newton's law against Hunt-Crossley "
             "(k = 1e4 N/m$^{1.5}$)")
fig.tight_layout()
os.makedirs(OUT, exist_ok=True)
path = os.path.join(OUT, "compliant_vs_newton_arm.png")
fig.savefig(path, dpi=110)
print(f"\nfigure: {path}")
