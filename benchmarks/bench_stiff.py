"""Stiff chains: the implicit path (Radau with the kernel's Jacobian) and method="auto" against DOP853 (issue 27).

Every row is measured in this one run (CPU = process time, the minimum over --repeat runs), as
ratios to its reference in the same run:

* the two bundled prismatic arms over 1 s: DOP853 at the case's rtol 1e-8 (today's path) against
  auto at the case's settings and at looser tolerances (where it takes the compiled Radau), DOP853 and
  scipy's Radau at those; the error is the largest
  |joint coordinate - reference| (rad, m) over the second, against DOP853 at rtol 1e-11, atol 1e-13;
* an R-R-Pb arm (rigid link, 3 + 2 elements, a PD servo on the slide, a floor) over 1.5 s;
* case 1 with EI_N_m2 = 1e9 on link 1: DOP853 timed over its first 0.05 s and extrapolated to 1 s,
  against auto (Radau) over 1 s (its resting phase runs simulation.cutoff_radau), and with --dop853-until T
  the impact times of auto against DOP853's up to T (DOP853 costs ~160 s of CPU a simulated second there);
* case 1 as shipped over 1 s: DOP853 against auto (which keeps DOP853);
* scipy's Radau with its finite differences, with the kernel's Jacobian, and the compiled Radau (same run).

Usage: python benchmarks/bench_stiff.py [--repeat 3] [--quick] [--only SECTION] [--dop853-until T]  (--quick:
skips the 1e-11 references and the stiff case's long run; --only: arms, servo, stiff, shipped or jacobian)
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import time
from pathlib import Path

import numpy as np

import gibbsimpact as gi
from gibbsimpact.case import case_from_dict
from gibbsimpact.simulation.equations import Equations

ROOT = Path(__file__).resolve().parent.parent


def timed(case, repeat, **kw):
    """(Result, minimum CPU seconds over ``repeat`` runs) of case.simulate(**kw)."""
    best, res = np.inf, None
    for _ in range(repeat):
        t0 = time.process_time()
        res = case.simulate(**kw)
        best = min(best, time.process_time() - t0)
    return res, best


def joint_error(res, ref, model) -> float:
    """max |q_j(t) - q_j,ref(t)| over the joint coordinates (not the deltas), on the reference's samples."""
    joints = [i for i, name in enumerate(model.coordinate_names) if not name.startswith("delta")]
    return max(float(np.abs(np.interp(ref.t, res.t, res.q[:, j]) - ref.q[:, j]).max()) for j in joints)


def rr_pb_arm():
    """The R-R-Pb servo arm of issue 27: a rigid first link, the R-Pb arm's two flexible links behind it,
    the slide's PD servo, and a floor 1.8 m below the base (5 cm below the hanging tip)."""
    src = copy.deepcopy(gi.load_case(ROOT / "cases" / "fixed_base_R_Pb_arm.toml").source)
    src["links"].insert(0, {"length_m": 0.3, "mass_per_length_kg_per_m": 2.0, "EI_N_m2": 1e3})
    for inp in src["inputs"]:
        inp["coordinate"] = {"theta_1": "theta_2", "d_2": "d_3"}[inp["coordinate"]]
    src["inputs"].append({"coordinate": "theta_1", "kind": "pd", "target_deg": -90.0, "stiffness_N_m_per_rad": 200.0,
                          "damping_N_m_s_per_rad": 10.0})
    src["initial"]["coordinates"] = {"theta_1_deg": -90.0, "theta_2_deg": 0.0, "d_3_m": 0.45}
    src["walls"] = [{"type": "plane", "point_m": [0.0, -1.8, 0.0], "normal": [0.0, 1.0, 0.0]}]
    src["time"]["t_end_s"] = 1.5
    src["name"] = "R_R_Pb_servo_arm"
    return case_from_dict(src, name="R_R_Pb_servo_arm")


def stiff_case1():
    src = copy.deepcopy(gi.load_case(ROOT / "cases" / "circle_two_link.toml").source)
    src["links"][0]["EI_N_m2"] = 1e9
    return case_from_dict(src, name="case1_EI_1e9")


@contextlib.contextmanager
def scipy_radau():
    """method="Radau" runs scipy's Radau with the kernel's Jacobian in every phase (the path before the compiled
    stepper, and its fallback)."""
    own = Equations.phase_solver
    Equations.phase_solver = lambda self, method: None
    try:
        yield
    finally:
        Equations.phase_solver = own


def arm_rows(name, repeat, quick) -> list[str]:
    case = gi.load_case(ROOT / "cases" / f"{name}.toml") if isinstance(name, str) else name
    label = case.name
    t_end = 1.5 if label == "R_R_Pb_servo_arm" else 1.0
    ref = None if quick else case.simulate(t_end=t_end, method="DOP853", rtol=1e-11, atol=1e-13)
    base, c0 = timed(case, repeat, t_end=t_end, method="DOP853", rtol=1e-8, atol=1e-10)
    rows = []
    for what, kw in (("DOP853 rtol 1e-8 (reference)", dict(method="DOP853", rtol=1e-8, atol=1e-10)),
                     ("auto, rtol 1e-8", dict(method="auto", rtol=1e-8, atol=1e-10)),
                     ("DOP853 rtol 1e-4 atol 1e-6", dict(method="DOP853", rtol=1e-4, atol=1e-6)),
                     ("Radau rtol 1e-4 atol 1e-6 (compiled)", dict(method="Radau", rtol=1e-4, atol=1e-6)),
                     ("auto, rtol 1e-3 atol 1e-5", dict(method="auto", rtol=1e-3, atol=1e-5)),
                     ("DOP853 rtol 1e-2 atol 1e-4", dict(method="DOP853", rtol=1e-2, atol=1e-4)),
                     ("auto, rtol 1e-2 atol 1e-4", dict(method="auto", rtol=1e-2, atol=1e-4)),
                     ("auto, rtol 1e-2 atol 1e-4, cutoff_frequency 1e3 rad/s",
                      dict(method="auto", rtol=1e-2, atol=1e-4, cutoff_frequency=1e3)),
                     ("scipy's Radau rtol 1e-2 atol 1e-4", dict(method="Radau", rtol=1e-2, atol=1e-4))):
        if what.endswith("(reference)"):
            res, cpu = base, c0
        else:
            with scipy_radau() if what.startswith("scipy") else contextlib.nullcontext():
                res, cpu = timed(case, repeat, t_end=t_end, **kw)
        err = "" if ref is None else f"{joint_error(res, ref, case.model):.2e}"
        rows.append(f"| {label} {t_end:g} s | {what} → {res.settings['method']} | {res.status} | {res.n_steps} | "
                    f"{res.nfev} | {cpu:.3g} | {c0 / cpu:.2f} | {err} |")
    return rows


def stiff_rows(repeat, quick) -> list[str]:
    case = stiff_case1()
    head, c_head = timed(case, 1, t_end=0.05, method="DOP853")
    per_s = c_head / 0.05
    rows = [f"| case 1, EI 1e9 | DOP853 over 0.05 s, extrapolated to 1 s | {head.status} | {head.n_steps} | "
            f"{head.nfev} | {per_s:.3g} (1 s) | 1 | |"]
    first, c_first = timed(case, repeat, t_end=0.45, method="auto")
    rows.append(f"| case 1, EI 1e9 | auto → {first.settings['method']}, 0.45 s (before the impact) | {first.status} "
                f"| {first.n_steps} | {first.nfev} | {c_first:.3g} | {per_s * 0.45 / c_first:.0f} | |")
    settle, c_settle = timed(case, repeat, t_end=0.67, method="auto")
    rows.append(f"| case 1, EI 1e9 | auto → {settle.settings['method']}, 0.67 s (4 impacts, before O1 settles on the "
                f"wall) | {settle.status} | {settle.n_steps} | {settle.nfev} | {c_settle:.3g} | "
                f"{per_s * 0.67 / c_settle:.0f} | numerical {settle.energy_audit()['numerical']:.2g} J |")
    if not quick:
        for what, kw in ((f", cutoff {first.settings['cutoff_frequency']:.3g} rad/s (auto's)", {}),
                         (", cutoff_frequency 1e4 rad/s", dict(cutoff_frequency=1e4))):
            res, cpu = timed(case, repeat, t_end=1.0, method="auto", max_cpu_time=60.0, **kw)
            rows.append(f"| case 1, EI 1e9 | auto → {res.settings['method']}{what}, 1 s (max 60 s CPU) | {res.status} "
                        f"(t = {res.t[-1]:.4g} s) | {res.n_steps} | {res.nfev} | {cpu:.3g} | "
                        f"{per_s * float(res.t[-1]) / cpu:.2f} | numerical {res.energy_audit()['numerical']:.2g} J |")
    return rows


def impact_rows(t_until: float) -> list[str]:
    """Case 1 with EI = 1e9: the impacts of auto over 1 s beside DOP853's up to t_until [s] (one row each,
    matched in order; DOP853's CPU in the heading row)."""
    case = stiff_case1()
    auto = case.simulate(t_end=1.0, method="auto")
    ref, cpu = timed(case, 1, t_end=t_until, method="DOP853")
    rows = [f"| impacts to {t_until:g} s | DOP853 {ref.status}, {len(ref.impacts)} impacts, {cpu:.3g} s CPU; "
            f"auto {len(auto.impacts)} impacts over 1 s | | | | | | |"]
    for k in range(max(len(ref.impacts), sum(i.time <= t_until for i in auto.impacts))):
        a = auto.impacts[k] if k < len(auto.impacts) else None
        b = ref.impacts[k] if k < len(ref.impacts) else None
        cell = (lambda i: "–" if i is None else f"O{','.join(map(str, i.joints))} at {i.time:.6f} s")
        diff = "" if a is None or b is None else f"{a.time - b.time:+.2e} s"
        rows.append(f"| impact {k + 1} | auto {cell(a)} | DOP853 {cell(b)} | {diff} | | | | |")
    return rows


def shipped_rows(repeat) -> list[str]:
    case = gi.load_case(ROOT / "cases" / "circle_two_link.toml")
    a, ca = timed(case, repeat, t_end=1.0)
    b, cb = timed(case, repeat, t_end=1.0, method="auto")
    same = np.array_equal(a.q, b.q)
    return [f"| case 1 as shipped 1 s | DOP853 (reference) | {a.status} | {a.n_steps} | {a.nfev} | {ca:.3g} | 1 | |",
            f"| case 1 as shipped 1 s | auto → {b.settings['method']} (identical: {same}) | {b.status} | {b.n_steps} "
            f"| {b.nfev} | {cb:.3g} | {ca / cb:.2f} | |"]


def jacobian_rows(repeat) -> list[str]:
    """Radau on the R-Pb arm at rtol 1e-2: scipy's with its own differences (jac not passed), scipy's with the
    kernel's Jacobian, and the compiled stepper."""
    case = gi.load_case(ROOT / "cases" / "fixed_base_R_Pb_arm.toml")
    kw = dict(t_end=1.0, method="Radau", rtol=1e-2, atol=1e-4)
    res_c, c_c = timed(case, repeat, **kw)
    with scipy_radau():
        res_k, c_k = timed(case, repeat, **kw)
        own = Equations.phase_jacobian
        Equations.phase_jacobian = lambda self, method: None  # jac=None: scipy's own finite differences
        try:
            res_s, c_s = timed(case, repeat, **kw)
        finally:
            Equations.phase_jacobian = own
    return [f"| R_Pb arm 1 s | Radau, scipy's differences (reference) | {res_s.status} | {res_s.n_steps} | "
            f"{res_s.nfev} | {c_s:.3g} | 1 | |",
            f"| R_Pb arm 1 s | scipy's Radau, kernel's Jacobian | {res_k.status} | {res_k.n_steps} | {res_k.nfev} | "
            f"{c_k:.3g} | {c_s / c_k:.2f} | |",
            f"| R_Pb arm 1 s | compiled Radau | {res_c.status} | {res_c.n_steps} | {res_c.nfev} | "
            f"{c_c:.3g} | {c_s / c_c:.2f} | |"]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--only", choices=("arms", "servo", "stiff", "shipped", "jacobian"), help="one section only")
    p.add_argument("--dop853-until", type=float, default=None, metavar="T",
                   help="with the stiff section: auto's impact times against DOP853's up to T [s]")
    a = p.parse_args()
    sections = {"arms": lambda: arm_rows("fixed_base_R_Pb_arm", a.repeat, a.quick) + arm_rows("fixed_base_R_Pa_arm",
                                                                                                a.repeat, a.quick),
                "servo": lambda: arm_rows(rr_pb_arm(), 1, a.quick), "stiff": lambda: stiff_rows(a.repeat, a.quick),
                "shipped": lambda: shipped_rows(a.repeat), "jacobian": lambda: jacobian_rows(a.repeat)}
    print("| run | method | status | steps | RHS | CPU [s] | speed-up vs reference | joint error vs 1e-11 |")
    print("|---|---|---|---|---|---|---|---|")
    if a.dop853_until is not None:
        sections["impacts"] = lambda: impact_rows(a.dop853_until)
    for name, rows in sections.items():
        if a.only in (None, name) or (name == "impacts" and a.only == "stiff"):
            for r in rows():
                print(r, flush=True)


if __name__ == "__main__":
    main()
