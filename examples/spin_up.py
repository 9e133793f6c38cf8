"""The spin-up benchmark (issue 24): why a spinning flexible arm needs foreshortening.

A 10 m cantilever (mu = 1.2 kg/m, EI = 14 000 N m^2; Simo & Vu-Quoc 1986, Kane, Ryan &
Banerjee 1987) is clamped to a hub whose angle is prescribed: the speed rises smoothly from
0 to Omega_s = 6 rad/s in T_s = 15 s, then stays constant,

    theta(t) = (Omega_s/T_s) (t^2/2 + (T_s/2pi)^2 (cos(2pi t/T_s) - 1)),   t < T_s
             = Omega_s (t - T_s/2),                                        t >= T_s.

Omega_s is above the link's first bending frequency (3.80 rad/s). A beam with foreshortening
is stiffened by the centrifugal force: its tip deflects by ~0.58 m in the hub frame during
the spin-up and vibrates by millimetres afterwards. A linear beam (no foreshortening) has a
negative in-plane stiffness K - Omega^2 M once theta_dot passes 3.80 rad/s, and its tip runs
away (past 1000 m at t = 10.8 s).

The curves come from the independent Ritz reference tests/crosscheck/spinup_reference.py
(numpy/scipy only, no gibbsimpact code), which the package's own run is checked against.
``package_run`` is the same benchmark with the package (``gi.Link(...,
geometric_stiffening=...)`` and ``gi.simulate(..., prescribed={"theta_1": f})``); add its
curves to ``curves`` in ``main`` to draw the package next to the reference.

Run:   python examples/spin_up.py
Env:   GIBBSIMPACT_EXAMPLE_T_END  caps t_end [s] (default 30 s)
       GIBBSIMPACT_EXAMPLE_OUT    folder for the figure (default: a new temp dir)
"""

import os
import sys
import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "crosscheck"))
from spinup_reference import spinup_reference, spinup_summary  # noqa: E402

OMEGA_S, T_S = 6.0, 15.0                    # [rad/s], [s]
L, MU, EI = 10.0, 1.2, 14000.0              # [m], [kg/m], [N m^2]
T_END = min(30.0, float(os.environ.get("GIBBSIMPACT_EXAMPLE_T_END", "inf")))
OUT = Path(os.environ.get("GIBBSIMPACT_EXAMPLE_OUT") or tempfile.mkdtemp(prefix="gibbsimpact_spinup_"))


def reference_run(stiffened, t_end):
    """The Ritz reference (4 terms): its result dict (t [s], tip_deflection [m], ...) and CPU [s]."""
    start = time.process_time()
    r = spinup_reference(Omega_s=OMEGA_S, T_s=T_S, t_end=t_end, n=4, L=L, mu=MU, EI=EI,
                         foreshortening=stiffened)
    return r, time.process_time() - start


def package_run(stiffened, t_end, elements=4):
    """The same benchmark with gibbsimpact: t (k,) [s], v(L, t) in the hub frame (k,) [m], CPU [s].

    Foreshortening (gi.Link(..., geometric_stiffening=...)) and prescribed joint motion
    (gi.simulate(..., prescribed=...), the package's own spin-up profile). The link frame of a fixed-base R joint
    at the link's root is the hub frame, so v(L) is link 0's deflection at x = L.
    """
    import gibbsimpact as gi
    from gibbsimpact.model.shapes import link_deflection

    link = gi.Link(L, MU, EI, elements=elements, geometric_stiffening=stiffened)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase(position=(0.0, 0.0), angle=0.0)),
                     gravity=(0.0, 0.0, 0.0))
    zero = np.zeros(model.n_dof)
    start = time.process_time()
    res = gi.simulate(model, zero, zero, (0.0, t_end), prescribed={"theta_1": gi.profiles.spin_up(OMEGA_S, T_S)},
                      rtol=1e-10, atol=1e-12, output_dt=0.01)
    v = np.array([link_deflection(model, q, 0, [L])[0][0] for q in res.q])
    return res.t, v, time.process_time() - start


def figure(curves, path):
    """Linear (left) and stiffened (right) beam side by side: tip deflection in the hub frame.

    curves: {(beam, source): (t (k,) [s], v (k,) [m])} with beam "linear" | "stiffened" and
    source a legend label ("reference", "gibbsimpact", ...). The linear panel uses a
    symmetric-log axis (its deflection runs to 1000 m); both mark the end of the spin-up when the runs reach it.
    """
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharex=True, constrained_layout=True)
    t_last = max(t[-1] for t, _ in curves.values())
    axes[0].set_xlim(0.0, t_last)  # the time simulated (GIBBSIMPACT_EXAMPLE_T_END may end before T_S)
    for ax, beam in zip(axes, ("linear", "stiffened")):
        for (kind, source), (t, v) in curves.items():
            if kind == beam:
                ax.plot(t, v, lw=1.2, ls="-" if source == "reference" else "--", label=source)
        if T_S <= t_last:  # the end of the spin-up, when the run reaches it
            ax.axvline(T_S, color="0.6", lw=0.8, ls=":")
        ax.set_xlabel("t [s]")
        ax.set_title(f"{beam} beam" + (" (no foreshortening)" if beam == "linear" else
                                      " (foreshortening)"))
        ax.legend(loc="best")
    # a linear run goes on to 1e41 m; nothing past 1 km means anything. A short run (GIBBSIMPACT_EXAMPLE_T_END)
    # stays near 1 m: its limit follows the data so the curve fills the panel.
    peak = max(np.max(np.abs(v)) for (kind, _), (_, v) in curves.items() if kind == "linear")
    lim = min(1e4, 10.0 ** np.ceil(np.log10(max(peak, 1e-3) * 1.2)))
    if lim > 1.0:  # symmetric-log beyond 1 m; a short run's panel stays linear
        axes[0].set_yscale("symlog", linthresh=1.0)
    axes[0].set_ylim(-lim, lim)
    axes[0].set_ylabel("tip deflection v(L) in the hub frame [m]")
    fig.suptitle(f"spin-up to {OMEGA_S:g} rad/s in {T_S:g} s; L = {L:g} m, EI = {EI:g} N m$^2$")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    curves = {}
    for beam, stiffened in (("stiffened", True), ("linear", False)):
        r, cpu = reference_run(stiffened, T_END)
        curves[(beam, "reference")] = (r["t"], r["tip_deflection"])
        s = spinup_summary(r, T_S)
        print(f"{beam:9s} reference: reached t = {r['t'][-1]:6.2f} s of {T_END:g} s   "
              f"max |v(L)| during spin-up {s['peak']:10.4g} m   after {s['after']:.4g} m   "
              f"tip shortening {s['shortening']:.4g} m   CPU {cpu:.1f} s")
        # The linear beam runs away past 1000 m after ~11 s: its package run stops at 12 s.
        t, v, cpu = package_run(stiffened, T_END if stiffened else min(T_END, 12.0))
        curves[(beam, "gibbsimpact")] = (t, v)
        if stiffened:
            ref = np.interp(t, r["t"], r["tip_deflection"])
            print(f"{beam:9s} gibbsimpact (4 elements): max |v - v_ref| = "
                  f"{np.max(np.abs(v - ref)) / s['peak']:.2g} of the peak   CPU {cpu:.1f} s")
        else:
            print(f"{beam:9s} gibbsimpact (4 elements): max |v(L)| = {np.max(np.abs(v)):.3g} m by "
                  f"t = {t[-1]:.1f} s   CPU {cpu:.1f} s")
    OUT.mkdir(parents=True, exist_ok=True)
    path = OUT / "spin_up.png"
    figure(curves, path)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()
