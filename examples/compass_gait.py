"""A passive compass-gait biped with flexible legs walking down a 1.5 degree slope (docs/walking.md).

Shows: a planar floating chain of two legs (hip mass on leg 1's tip) whose feet O1 and O3 are both
contact candidates, so stance and swing swap by themselves at every plastic heel strike; a sticking
stance foot (resting contact with friction 1); simulate's contact_filter (LeadFilter: a foot may
begin a contact only once it is 5 cm ahead of the other foot, past the scuff of straight legs);
the passive limit cycle as the fixed point of the Poincare map at heel strike (Newton), for rigid
legs and for legs that bend (clamped-clamped modes, EI = 50 N m^2, 5 % damping), converged in
the number of modes; then six steps from each fixed point, a table, a figure and an animation.

Run:   python examples/compass_gait.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 5.5 s: six steps); below one step the limit
                                  cycles are not searched (the case's rigid one is used); about 4 min
                                  of CPU in all
       GIBBSIMPACT_EXAMPLE_OUT    folder for the figure and the animation (default: a new temporary
                                  folder; docs/figures/ holds the ones of the docs)
"""

import os
import tempfile
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import gibbsimpact as gi
from gibbsimpact.plotting import animate
from gibbsimpact.simulation.contact_filter import LeadFilter

T_END = min(5.5, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="compass_gait_"))
EI, ZETA, MODES = 50.0, 0.05, (0, 1, 2, 3)  # 0 modes: rigid legs
SWEEP_EI = (20.0, 50.0, 200.0, 1000.0)  # [N m^2], 2 modes per leg
if T_END < 1.0:  # a smoke run (tests/docs/test_examples.py): rigid and one mode, no sweep
    MODES, SWEEP_EI = (0, 1), ()

case = gi.load_case(Path(__file__).resolve().parents[1] / "cases" / "compass_gait.toml")
ground, rule = case.walls[0], case.contact_filter
downhill = rule.direction


def biped(n_modes: int, EI: float = EI):
    """The case's biped with n_modes clamped-clamped y-modes per leg of stiffness EI [N m^2] (0: rigid)."""
    modes = [gi.Mode("clamped-clamped", "y", k) for k in range(1, n_modes + 1)]
    damping = ZETA if n_modes else 0.0
    leg1 = gi.Link(1.0, 5.0, EI, modes=modes, damping=damping, bodies=(gi.RigidBody(10.0),))
    leg2 = gi.Link(1.0, 5.0, EI, modes=modes, damping=damping)
    return gi.Model(gi.Chain([leg1, leg2], base="planar"), gravity=(0.0, -9.81, 0.0))


def walk(model, x, t_end, **kw):
    """simulate from x = (theta_1, theta_2, deltas, their rates): stance foot O1 at the origin, at rest."""
    n = model.n_dof - 2
    q0, qd0 = np.r_[0.0, 0.0, x[:n]], np.r_[0.0, 0.0, x[n:]]
    return gi.simulate(model, q0, qd0, (0.0, t_end), walls=[ground], restitution=0.0, link_contacts=False,
                       contact_filter=LeadFilter(model, [0, 2], downhill, rule.clearance), **kw)


def swapped(model, qd_after, q):
    """x of the next step: the chain re-rooted at the new stance foot O3 (legs swap, hip angle mirrored).

    theta_1' = theta_1 + theta_2 + pi, theta_2' = -theta_2; a clamped-clamped mode k read from the other
    end, x -> l - x with the link's y axis reversed, is (-1)^k times itself: delta'_k = (-1)^k delta_k.
    """
    n_m = (model.n_dof - 4) // 2
    sign = (-1.0) ** np.arange(1, n_m + 1)

    def one(v, angles):
        return np.r_[angles, sign * v[4 + n_m:], sign * v[4:4 + n_m]]
    angles = np.angle(np.exp(1j * np.array([q[2] + q[3] + np.pi, -q[3]])))  # in (-pi, pi], as the case's
    return np.r_[one(q, angles), one(qd_after, (qd_after[2] + qd_after[3], -qd_after[3]))]


def on_ground(model, x):
    """x with theta_2 set so that the swing foot O3 is on the slope (gap 0 to round-off): the section of
    the Poincare map is the heel strike, both feet down (secant iterations on the gap [m])."""
    x = np.array(x, dtype=float)

    def gap(theta_2):
        q = np.r_[0.0, 0.0, x[0], theta_2, x[2:model.n_dof - 2]]
        return float(ground.gap(model.joint_positions(q)[2:3])[0])
    a, b = x[1], x[1] + 1e-6
    ga, gb = gap(a), gap(b)
    for _ in range(20):
        if gb == ga or abs(gb) < 1e-14:
            break
        a, b, ga = b, b - gb * (b - a) / (gb - ga), gb
        gb = gap(b)
    x[1] = b + 1e-12  # above the slope by round-off, never below it
    return x


def step_map(model, x):
    """(x after the next heel strike, re-rooted; the strike's time [s] and step along the slope [m]), from x
    put on the section (on_ground)."""
    res = walk(model, on_ground(model, x), 2.0, max_impacts=1)
    r = res.impacts[-1]
    return swapped(model, r.qdot_after, res.q[-1]), r.time, r.points[np.argmax(r.impulses)] @ downhill


def limit_cycle(model, x, tol=1e-9, h=1e-7):
    """The fixed point x* = P(x*) of the step map by Newton's method (finite-difference Jacobian)."""
    for _ in range(8):
        r = step_map(model, x)[0] - x
        if np.abs(r).max() < tol:
            break
        J = np.column_stack([(step_map(model, x + h * e)[0] - x - h * e - r) / h for e in np.eye(x.size)])
        x = x - np.linalg.lstsq(J, r, rcond=None)[0]
    return x, np.abs(r).max()


def strikes(res):
    """(periods [s], step lengths along the slope [m]) of the heel strikes of a run."""
    hits = [r for r in res.impacts if np.any(r.impulses > 0)]
    t = np.array([r.time for r in hits])
    s = np.array([r.points[np.argmax(r.impulses)] @ downhill for r in hits])
    return np.diff(np.r_[0.0, t]), np.diff(np.r_[0.0, s])


def gait(model, x):
    """(x on the limit cycle (Newton when T_END >= 1 s), |P(x) - x|, the Result of a run of T_END from it, its
    CPU time [s])."""
    residual = np.nan
    if T_END >= 1.0:
        x, residual = limit_cycle(model, x)
    x = on_ground(model, x)
    start = time.process_time()
    res = walk(model, x, T_END, output_dt=0.01)
    return x, residual, res, time.process_time() - start


def more_modes(x, n):
    """x of n modes per leg with one more mode per leg, at rest: (theta, delta_1, delta_2) and their rates."""
    return np.concatenate([np.r_[h[:2 + n], 0.0, h[2 + n:], 0.0] for h in np.split(x, 2)])


def report(label, residual, res, cpu):
    """One row of the table; (mean period [s], mean step [m]) of the run, or None without a strike."""
    period, step = strikes(res)
    if not len(period):
        return None
    defl = max((np.abs(res.q[:, idx]).max() for idx in res.model.delta_index if idx.size), default=0.0)
    print(f"{label:>18} {residual:9.1e} {len(period):4d} {period.mean():11.6f} {step.mean():10.6f} "
          f"{step.mean() / period.mean():11.6f} {1e3 * defl:10.3f} {cpu:8.1f}")
    return period.mean(), step.mean()


print(f"compass gait on a 1.5 deg slope, t_end = {T_END:g} s; bending legs: damping {ZETA:g}\n")
print(f"{'legs':>18} {'|P(x)-x|':>9} {'hits':>4} {'period [s]':>11} {'step [m]':>10} {'speed [m/s]':>11} "
      f"{'|delta| mm':>10} {'CPU [s]':>8}")
x = np.r_[case.q0[2:], case.qdot0[2:]]
runs, rows, cycles = {}, {}, {}
for n in MODES:  # convergence in the number of modes at EI
    cycles[n], residual, runs[n], cpu = gait(biped(n), x)
    rows[n] = report("rigid" if n == 0 else f"EI {EI:g}, {n} mode(s)", residual, runs[n], cpu)
    x = more_modes(cycles[n], n)
sweep = {}
for ei in SWEEP_EI:  # how stiffness changes the gait, 2 modes per leg
    _, residual, res, cpu = gait(biped(2, ei), cycles[2])
    sweep[ei] = report(f"EI {ei:g}, 2 modes", residual, res, cpu)

if SWEEP_EI and rows[0] is not None and all(v is not None for v in sweep.values()):
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9.5, 3.5))
    ei = np.array(SWEEP_EI)
    ax1.semilogx(ei, [100 * (sweep[e][0] / rows[0][0] - 1) for e in ei], "o-", label="step period")
    ax1.semilogx(ei, [100 * (sweep[e][1] / rows[0][1] - 1) for e in ei], "s-", label="step length")
    ax1.axhline(0.0, color="k", lw=0.6)
    ax1.set(xlabel="leg bending stiffness EI [N m$^2$] (2 modes per leg)", ylabel="change from rigid legs [%]")
    ax1.legend(fontsize=8)
    res = runs[MODES[-1]]
    for i, name in enumerate(("leg 1", "leg 2")):
        ax2.plot(res.t, 1e3 * res.q[:, res.model.delta_index[i][0]], label=f"{name}: first mode")
    for t in (r.time for r in res.impacts if np.any(r.impulses > 0)):
        ax2.axvline(t, color="0.7", lw=0.6)
    ax2.set(xlabel="t [s] (grey: heel strikes)", ylabel="modal amplitude [mm]")
    ax2.legend(fontsize=8)
    fig.suptitle(f"compass gait on its limit cycle, bending legs ($\\zeta$ = {ZETA:g}); right: EI = {EI:g} N m$^2$, "
                 f"{MODES[-1]} modes", fontsize=10)
    fig.tight_layout()
    fig.savefig(OUT / "compass_gait_steps.png", dpi=90)
    plt.close(fig)
    print(f"\nfigure: {OUT / 'compass_gait_steps.png'}")
gif = animate(runs[MODES[-1]], OUT / "compass_gait.gif", fps=15, speed=1.0, max_frames=90, dpi=60)
print(f"animation: {gif}")
