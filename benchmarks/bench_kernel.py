"""Speed of the dynamics kernel: per-call cost, scaling in n, simulate and cold start, in one run.

Every ratio below is measured in this same run, so it can be compared across
machines; absolute times depend on the machine (a shared 2-core one: timings
are the minimum of several repeats of a timeit-style loop, which is the least
disturbed estimate of a call's own cost). Sections (each a function; a section
that fails prints its error and the next one runs):

1. ``forward_dynamics`` per call [us] (Python call included) on a rigid,
   free-flying chain of n = 2 ... 32 thin rods (l = 1 m, mu = 1 kg/m, rotary
   inertia (j_x, j_y, j_z) = (5e-5, 2.5e-5, 2.5e-5) kg m, a rod of radius 1 cm),
   at a random bent state, against Pinocchio's ABA (``pin.aba``) on the same
   chain: a free-flyer root (the frame of link 1) and n-1 revolute-Z joints
   placed at (l, 0, 0) of the parent, each body of mass mu l with its centre
   at (l/2, 0, 0) and inertia about it diag(0, m l^2/12, m l^2/12) + l diag(j).
   The ``match`` column checks that the two are the same system: Pinocchio's
   q̈ against gibbsimpact's q̈ mapped to Pinocchio's velocities (body-frame twist
   of link 1, then the joint rates), v = G(q) qdot, a = G qddot + Gdot qdot
   (Gdot by a central difference); max relative difference, ~1e-11 measured.
   ``gi/pin`` is the ratio of the per-call times (targets: <= 5 for n = 2,
   <= 3 for n >= 4). Without Pinocchio (PyPI package ``pin``) that column is
   skipped.
2. The same chain with 1 mode per link (clamped-clamped, y) and with 2 modes
   per link (clamped-clamped y and z): per-call cost, and the growth exponent
   of the cost in n (least-squares slope of log cost against log n over
   n >= 4) for rigid, 1 mode and 2 modes (target <= 2).
3. Case 1 (cases/circle_two_link.toml, N = 9): ``forward_dynamics`` against the
   lambdified sympy equations of the test oracle, ``tests/reference/sympy_chain.py``
   (sympy.physics.mechanics' Kane equations, ``lambdify(cse=True)``, q̈ by
   ``np.linalg.solve``; the reference the issue names, target speed-up >= 20), and,
   for information, against the package's own symbolic route,
   ``gi.derive_equations(model).numeric().forward_dynamics`` (about twice as fast as
   the oracle's: one simplified expression per entry). The symbolic route is also timed on the rigid
   chains of section 1 for the small n whose derivation stays under ~30 s.
4. ``gi.simulate`` of case 1 (t_end = 1 s, rtol 1e-10, 4 impacts), warm (one
   run first, then the minimum of 3) in a subprocess, against the same run with
   the pre-numba kernel of commit 54f2dfd (a temporary git worktree, PYTHONPATH
   to its src/; if that commit is unavailable, the current code with
   NUMBA_DISABLE_JIT=1). That commit's case reader rejects keys added since
   (``geometric_stiffening``): it reads today's case 1 with them removed, after
   a check that each has the value that commit has built in (a linear beam,
   ``false``), and the two runs' impact times must agree to 1e-6 s.
   Targets: speed-up >= 12, warm wall time <= 0.15 s. Its code is
   benchmarks/bench_baseline.py; runs on its own with ``--only simulate`` (or
   ``python benchmarks/bench_baseline.py``).
5. Cold start: ``python -m gibbsimpact run cases/circle_two_link.toml
   --no-plots --out TMP`` in a subprocess with a fresh NUMBA_CACHE_DIR (CPU
   time of the child from getrusage, and wall time), then the same command
   again with the cache filled (wall). Targets: first run <= 20 s CPU, second
   run <= 1.5 s wall.
6. benchmarks/scaling.png: per-call cost against n, log-log, for gibbsimpact
   (rigid, 1 mode, 2 modes), Pinocchio and the symbolic route.
7. Prismatic joints: ``forward_dynamics`` per call on a planar 3-link chain on a
   fixed base with joints R, Pa, Pb (docs/theory.md §7.2, §7.3, §7.4), each link a
   Hermite finite-element beam of 4 elements (N = 3 + 3 x 8 = 27), next to the
   all-revolute chain R, R, R of the same links and elements (N = 27), and
   against the independent planar derivation tests/reference/planar_oracle.py
   (position map, forward-mode jets, Gauss quadrature in numpy; it shares no
   code with the package and is not written for speed) on both chains. Links:
   (l, mu, EI) = (1.0 m, 1.0 kg/m, 25 N m^2), (0.6, 0.8, 10), (0.5, 0.4, 4);
   Pa: carriage half-length c = 0.05 m, gamma = 0.5 rad, on link 1; Pb:
   gamma = -0.4 rad, through a guide at link 2's tip; base (0, 0), gravity -X2.
   State: theta_1 = 0.7 rad (R-R-R: theta = 0.7, -0.4, 0.3 rad); d_2 = 0.43 m
   (carriage contact points at 0.38 and 0.48 m, clear of link 1's nodes at
   0.25, 0.5 m), d_3 = 0.37 m; node deflections uniform in +-2 cm /
   +-0.05 rad, velocities N(0, 1). Every cost
   is measured as CPU time (time.process_time) and as wall time of each of
   ``repeats`` loops of ~budget s; minimum and median of the repeats are
   printed (the ratios use the CPU minima). ``match``: max|qddot_oracle -
   qddot| / max|qddot| at that state (1e-12 or less measured). Runs on its own with
   ``--only prismatic`` (no plot; ~15 s).

Usage:
    python benchmarks/bench_kernel.py [--quick] [--skip-cold] [--skip-simulate] [--repeats R]
    python benchmarks/bench_kernel.py --only prismatic [--quick] [--repeats R]
    python benchmarks/bench_kernel.py --only simulate [--quick]

``--quick`` is a smoke run: n = 2, 4, 8, 3 repeats of short loops, 1 timed
simulate run, sympy for n <= 4 only.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import timeit
import traceback
from functools import partial
from pathlib import Path

import numpy as np

import gibbsimpact as gi
from gibbsimpact.dynamics.gibbs_appell import forward_dynamics

ROOT = Path(__file__).resolve().parent.parent
CASE1 = ROOT / "cases" / "circle_two_link.toml"
PNG = Path(__file__).resolve().parent / "scaling.png"

LENGTH, MU, EI = 1.0, 1.0, 20.0
ROTARY = (5e-5, 2.5e-5, 2.5e-5)  # (j_x, j_y, j_z) [kg m]: a rod of radius 1 cm, mu = 1 kg/m
GRAVITY = (0.0, -9.81, 0.0)
MODE_SETS = {
    "rigid": (),
    "1 mode": (gi.Mode("clamped-clamped", "y"),),
    "2 modes": (gi.Mode("clamped-clamped", "y"), gi.Mode("clamped-clamped", "z")),
}
SYMPY_BUDGET_S = 30.0  # largest derivation (+ numeric()) time to attempt, estimated from the previous n


# -- helpers ------------------------------------------------------------------------------------------

def per_call_us(fn, repeats: int, budget: float) -> float:
    """Minimum over ``repeats`` loops of the time per call [us]; each loop runs for about ``budget`` s."""
    fn()  # warm: a compiled kernel compiles (or loads its cache) here
    timer = timeit.Timer(fn)
    number = 1
    while True:
        t = timer.timeit(number)
        if t >= budget or number >= 1 << 20:
            break
        number = max(number * 2, int(number * budget / max(t, 1e-9) * 1.1))
    return min(timer.repeat(repeat=repeats, number=number)) / number * 1e6


def chain_model(n: int, modes=()) -> gi.Model:
    link = gi.Link(length=LENGTH, mass_per_length=MU, EI=EI, modes=list(modes), rotary_inertia=ROTARY)
    return gi.Model(gi.Chain([link] * n), gravity=GRAVITY)


def random_state(model: gi.Model, seed: int = 0):
    """A random bent state: angles in +-1 rad (theta_0 in +-0.5, away from gimbal lock), deflections ~1 cm."""
    rng = np.random.default_rng(seed)
    N = model.n_dof
    names = model.coordinate_names
    q = rng.uniform(-1.0, 1.0, N)
    qd = rng.normal(size=N)
    for k, nm in enumerate(names):
        if nm.startswith("delta"):
            q[k] *= 0.01
            qd[k] *= 0.1
        elif nm == "theta_0":
            q[k] *= 0.5
    return q, qd


def slope(ns, ts, n_min=4) -> float:
    pts = [(n, t) for n, t in zip(ns, ts) if n >= n_min and t is not None and np.isfinite(t)]
    if len(pts) < 2:
        return float("nan")
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def verdict(ok) -> str:
    return "" if ok is None else ("ok" if ok else "MISS")


def fmt(v, spec="{:.1f}", width=9):
    s = "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else spec.format(v)
    return f"{s:>{width}}"


def section(title):
    print(f"\n== {title} " + "=" * max(0, 88 - len(title)), flush=True)


def _git(*args, check=True):
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, check=check)


def run_section(fn, *args):
    """Run one section; on failure print the error and return None so the next section runs."""
    try:
        return fn(*args)
    except Exception:  # noqa: BLE001 - a benchmark goes on after a failing section
        print(f"!! section {fn.__name__} failed:", flush=True)
        traceback.print_exc(file=sys.stdout)
        return None


# -- Pinocchio ----------------------------------------------------------------------------------------

def import_pinocchio():
    try:
        import pinocchio as pin
    except ImportError as exc:
        print(f"Pinocchio not installed ({exc}); its column is skipped. Install it with `pip install pin`.")
        return None
    return pin


def pinocchio_chain(pin, n: int):
    """Free-flyer + (n-1) revolute-Z joints, thin rods along local x, the same as chain_model(n) rigid."""
    m = MU * LENGTH
    I_c = np.diag([0.0, m * LENGTH**2 / 12.0, m * LENGTH**2 / 12.0]) + LENGTH * np.diag(ROTARY)
    inertia = pin.Inertia(m, np.array([LENGTH / 2.0, 0.0, 0.0]), I_c)
    pm = pin.Model()
    parent = 0
    for i in range(n):
        if i == 0:
            joint, place = pin.JointModelFreeFlyer(), pin.SE3.Identity()
        else:
            joint, place = pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([LENGTH, 0.0, 0.0]))
        parent = pm.addJoint(parent, joint, place, f"joint_{i + 1}")
        pm.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    pm.gravity = pin.Motion(np.array(GRAVITY), np.zeros(3))
    return pm, pm.createData()


def _rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i] = R[j, j] = c
    R[i, j], R[j, i] = -s, s
    return R


def _to_pinocchio(pin, q):
    """(q_pin, G) for gibbsimpact's rigid free-chain q: v_pin = G qdot (link-1 body twist, joint rates)."""
    a, b, c = q[3:6]
    R = _rot(0, a) @ _rot(1, b) @ _rot(2, c)
    qp = np.concatenate([q[:3], pin.Quaternion(R).coeffs(), q[6:]])  # coeffs: (x, y, z, w)
    N = q.size
    G = np.zeros((N, N))
    G[:3, :3] = R.T
    Rz, Ry = _rot(2, c), _rot(1, b)
    G[3:6, 3] = Rz.T @ Ry.T @ [1.0, 0.0, 0.0]  # body angular velocity of Rx(a) Ry(b) Rz(c)
    G[3:6, 4] = Rz.T @ [0.0, 1.0, 0.0]
    G[3:6, 5] = [0.0, 0.0, 1.0]
    G[6:, 6:] = np.eye(N - 6)
    return qp, G


def pinocchio_match(pin, pm, pd, model, q, qd) -> float:
    """max |a_pin - (G qddot + Gdot qdot)| / max |a_pin|, with gibbsimpact's qddot at (q, qd)."""
    qdd = forward_dynamics(model, q, qd)
    qp, G = _to_pinocchio(pin, q)
    h = 1e-6
    Gdot = (_to_pinocchio(pin, q + h * qd)[1] - _to_pinocchio(pin, q - h * qd)[1]) / (2 * h)
    a_pin = np.array(pin.aba(pm, pd, qp, G @ qd, np.zeros(pm.nv)))
    a_map = G @ qdd + Gdot @ qd
    return float(np.abs(a_pin - a_map).max() / np.abs(a_pin).max())


# -- sections -----------------------------------------------------------------------------------------

def rigid_vs_pinocchio(cfg):
    """Section 1: rigid chains, gibbsimpact forward_dynamics against Pinocchio's ABA."""
    section("1. forward_dynamics per call, rigid free-flying chain of thin rods, against Pinocchio ABA")
    pin = import_pinocchio()
    if pin is not None:
        print(f"pinocchio {pin.__version__}: free-flyer + (n-1) revolute-Z, rods along x, same inertia")
    out = {"n": [], "N": [], "gi": [], "pin": [], "ratio": [], "match": []}
    print(f"{'n':>3} {'N':>4} {'gi[us]':>9} {'pin[us]':>9} {'gi/pin':>8} {'target':>7} {'':>5} {'match':>9}")
    for n in cfg.sizes:
        model = chain_model(n)
        q, qd = random_state(model, seed=n)
        t_gi = per_call_us(partial(forward_dynamics, model, q, qd), cfg.repeats, cfg.budget)
        t_pin = ratio = match = target = ok = None
        if pin is not None:
            pm, pd = pinocchio_chain(pin, n)
            qp, G = _to_pinocchio(pin, q)
            vp, tau = G @ qd, np.zeros(pm.nv)
            t_pin = per_call_us(partial(pin.aba, pm, pd, qp, vp, tau), cfg.repeats, cfg.budget)
            match = pinocchio_match(pin, pm, pd, model, q, qd)
            ratio = t_gi / t_pin
            target = 5.0 if n < 4 else 3.0
            ok = ratio <= target
        for k, v in zip(out, (n, model.n_dof, t_gi, t_pin, ratio, match)):
            out[k].append(v)
        print(f"{n:>3} {model.n_dof:>4} {fmt(t_gi)} {fmt(t_pin, '{:.2f}')} {fmt(ratio, '{:.2f}', 8)} "
              f"{fmt(target, '<= {:.0f}', 7)} {verdict(ok):>5} {fmt(match, '{:.1e}')}", flush=True)
    return out


def modes_scaling(cfg, rigid):
    """Section 2: 1 and 2 modes per link; growth exponent in n for rigid, 1 mode, 2 modes."""
    section("2. forward_dynamics per call with modes (clamped-clamped y; y and z), growth in n")
    out = {"n": list(cfg.sizes)}
    if rigid is not None and list(rigid["n"]) == list(cfg.sizes):
        out["rigid"] = rigid["gi"]
        out["N rigid"] = rigid["N"]
    for label, modes in MODE_SETS.items():
        if label in out:
            continue
        ts, Ns = [], []
        for n in cfg.sizes:
            model = chain_model(n, modes)
            q, qd = random_state(model, seed=n)
            ts.append(per_call_us(partial(forward_dynamics, model, q, qd), cfg.repeats, cfg.budget))
            Ns.append(model.n_dof)
        out[label], out[f"N {label}"] = ts, Ns
    labels = list(MODE_SETS)
    print(f"{'n':>3} " + " ".join(f"{'N':>4} {lb + '[us]':>13}" for lb in labels))
    for k, n in enumerate(cfg.sizes):
        print(f"{n:>3} " + " ".join(f"{out[f'N {lb}'][k]:>4} {fmt(out[lb][k], width=13)}" for lb in labels))
    out["exponent"] = {lb: slope(cfg.sizes, out[lb]) for lb in labels}
    print("growth exponent of cost in n (slope of log cost vs log n, n >= 4; target <= 2):")
    for lb, e in out["exponent"].items():
        print(f"  {lb:<8} {fmt(e, '{:.2f}', 6)}  {verdict(None if not np.isfinite(e) else e <= 2.0)}")
    return out


def case1_vs_sympy(cfg):
    """Section 3: case 1, forward_dynamics against the test oracle's lambdified sympy equations (the
    target's reference) and against the package's own symbolic route."""
    section("3. case 1 (circle_two_link, N = 9): forward_dynamics against lambdified sympy equations")
    case = gi.load_case(CASE1)
    model, q, qd = case.model, case.q0.copy(), case.qdot0.copy()
    rng = np.random.default_rng(3)
    qd = qd + rng.normal(size=qd.size)  # the case starts at rest: give the velocity terms some work
    from bench_cases import symbolic_rhs  # the oracle of the same chain (puts tests/ on the path)

    t0 = time.perf_counter()
    oracle_fd = symbolic_rhs(model)
    t_oracle = time.perf_counter() - t0
    t0 = time.perf_counter()
    num = gi.derive_equations(model).numeric()
    t_derive = time.perf_counter() - t0
    a_gi = forward_dynamics(model, q, qd)
    err_o = float(np.abs(oracle_fd(q, qd) - a_gi).max() / np.abs(a_gi).max())
    err_s = float(np.abs(num.forward_dynamics(q, qd) - a_gi).max() / np.abs(a_gi).max())
    t_gi = per_call_us(partial(forward_dynamics, model, q, qd), cfg.repeats, cfg.budget)
    t_orc = per_call_us(partial(oracle_fd, q, qd), cfg.repeats, cfg.budget)
    t_sym = per_call_us(partial(num.forward_dynamics, q, qd), cfg.repeats, cfg.budget)
    speedup, speedup_pkg = t_orc / t_gi, t_sym / t_gi
    print(f"test oracle (sympy Kane, tests/reference/sympy_chain.py): derived in {t_oracle:.1f} s, qddot agree "
          f"to {err_o:.1e} (relative)")
    print(f"gi.derive_equations(model).numeric(): derived in {t_derive:.1f} s, qddot agree to {err_s:.1e}")
    print(f"gibbsimpact {t_gi:.2f} us/call, test oracle {t_orc:.1f} us/call: speed-up {speedup:.2f}x "
          f"(target >= 20x) {verdict(speedup >= 20)}")
    print(f"gibbsimpact {t_gi:.2f} us/call, gi.derive_equations numeric {t_sym:.1f} us/call: speed-up "
          f"{speedup_pkg:.2f}x (for information)")
    return {"gi": t_gi, "oracle": t_orc, "sympy": t_sym, "speedup": speedup, "speedup_package": speedup_pkg,
            "derive_s": t_derive, "oracle_derive_s": t_oracle}


def sympy_scaling(cfg, rigid):
    """Section 3b: the symbolic route on the rigid chains of section 1, while derivation stays cheap."""
    section("3b. lambdified sympy equations on the rigid chains of section 1 (small n only)")
    out = {"n": [], "sympy": [], "derive_s": [], "gi": []}
    last = None
    print(f"{'n':>3} {'N':>4} {'derive[s]':>9} {'sympy[us]':>10} {'gi[us]':>9} {'sympy/gi':>9}")
    for n in cfg.sizes:
        if n > cfg.sympy_n_max:
            break
        # estimate from the previous size (cost grows ~n^2 or faster); stop before the budget
        if last is not None and last[1] * (n / last[0]) ** 2.5 > SYMPY_BUDGET_S:
            print(f"(stopping: deriving n = {n} would take more than ~{SYMPY_BUDGET_S:.0f} s)")
            break
        model = chain_model(n)
        q, qd = random_state(model, seed=n)
        t0 = time.perf_counter()
        num = gi.derive_equations(model).numeric()
        t_derive = time.perf_counter() - t0
        last = (n, t_derive)
        t_sym = per_call_us(partial(num.forward_dynamics, q, qd), cfg.repeats, cfg.budget)
        t_gi = None
        if rigid is not None and n in rigid["n"]:
            t_gi = rigid["gi"][rigid["n"].index(n)]
        else:
            t_gi = per_call_us(partial(forward_dynamics, model, q, qd), cfg.repeats, cfg.budget)
        for k, v in zip(out, (n, t_sym, t_derive, t_gi)):
            out[k].append(v)
        print(f"{n:>3} {model.n_dof:>4} {t_derive:>9.1f} {fmt(t_sym, width=10)} {fmt(t_gi)} "
              f"{fmt(t_sym / t_gi, '{:.2f}')}", flush=True)
    return out


def cold_start(cfg):
    """Section 5: `python -m gibbsimpact run` with an empty, then a filled NUMBA_CACHE_DIR."""
    section("5. cold start: python -m gibbsimpact run case 1 --no-plots, fresh NUMBA_CACHE_DIR, then again")
    tmp = Path(tempfile.mkdtemp(prefix="gi_cold_"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp / "numba_cache"))
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src")] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    runs = []
    try:
        for k, label in enumerate(("first (cold cache)", "second (warm cache)")):
            cmd = [sys.executable, "-m", "gibbsimpact", "run", str(CASE1), "--no-plots", "--out", str(tmp / f"out{k}")]
            r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            p = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True, timeout=1800, check=False)
            wall = time.perf_counter() - t0
            r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
            if p.returncode != 0:
                print(f"{label}: exit {p.returncode}\n{p.stderr[-2000:]}")
            runs.append((label, cpu, wall, p.returncode))
        cache_files = sum(1 for f in (tmp / "numba_cache").rglob("*") if f.is_file()) if (tmp / "numba_cache").exists() else 0
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{'run':<20} {'cpu[s]':>7} {'wall[s]':>8} {'exit':>5}")
    for label, cpu, wall, rc in runs:
        print(f"{label:<20} {cpu:>7.2f} {wall:>8.2f} {rc:>5}")
    (_, cpu1, wall1, _), (_, cpu2, wall2, _) = runs
    print(f"numba cache files written: {cache_files}")
    # What a second run cannot avoid: importing the libraries and loading the cached kernel.
    code = ("import json, time; t0 = time.perf_counter(); import numpy, scipy.integrate, numba; "
            "t1 = time.perf_counter(); import gibbsimpact as gi; from gibbsimpact import kernel as K; "
            "t2 = time.perf_counter(); K.ensure_compiled(K.RIGID_ENDS); t3 = time.perf_counter(); "
            "print(json.dumps([t1 - t0, t2 - t1, t3 - t2]))")
    p = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=env["PYTHONPATH"]), cwd=ROOT,
                       capture_output=True, text=True, timeout=600, check=False)
    if p.returncode == 0:
        libs, own, load = json.loads(p.stdout.strip().splitlines()[-1])
        print(f"second-run floor (wall): import numpy + scipy.integrate + numba {libs:.2f} s, the rest of "
              f"gibbsimpact {own:.2f} s, load the cached kernel {load:.2f} s: {libs + own + load:.2f} s")
    print(f"first run {cpu1:.2f} s CPU (target <= 20 s) {verdict(cpu1 <= 20)}; compile + cache estimate "
          f"(first - second CPU) {cpu1 - cpu2:.2f} s; second run {wall2:.2f} s wall (target <= 1.5 s) "
          f"{verdict(wall2 <= 1.5)}")
    return {"cpu_first": cpu1, "wall_first": wall1, "cpu_second": cpu2, "wall_second": wall2}


def plot(cfg, results):
    """Section 6: benchmarks/scaling.png, per-call cost against n (log-log)."""
    section("6. plot")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 6))
    modes, rigid, sym = results.get("modes"), results.get("rigid"), results.get("sympy")
    drawn = 0
    styles = {"rigid": "o-", "1 mode": "s-", "2 modes": "^-"}
    for lb in MODE_SETS:
        src = modes if modes and lb in modes else ({"n": rigid["n"], lb: rigid["gi"]} if rigid and lb == "rigid" else None)
        if src:
            e = modes["exponent"][lb] if modes else slope(src["n"], src[lb])
            ax.plot(src["n"], src[lb], styles[lb], label=f"gibbsimpact, {lb} (slope {e:.2f})")
            drawn += 1
    if rigid and any(t is not None for t in rigid["pin"]):
        ns = [n for n, t in zip(rigid["n"], rigid["pin"]) if t is not None]
        ts = [t for t in rigid["pin"] if t is not None]
        ax.plot(ns, ts, "kd--", label=f"Pinocchio ABA, rigid (slope {slope(ns, ts):.2f})")
        drawn += 1
    if sym and sym["n"]:
        ax.plot(sym["n"], sym["sympy"], "x:", color="tab:red",
                label=f"lambdified sympy, rigid, n <= {max(sym['n'])} only (derivation cost)")
        drawn += 1
    if not drawn:
        print("nothing to plot (sections 1-3 failed)")
        plt.close(fig)
        return None
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("links n")
    ax.set_ylabel("forward dynamics per call [µs] (min of repeats)")
    ax.set_title(f"free-flying chain of rods, {cfg.kernel_label}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)
    fig.tight_layout()
    fig.savefig(PNG, dpi=120)
    plt.close(fig)
    print(f"wrote {PNG}")
    return PNG


# -- section 7: prismatic joints ----------------------------------------------------------------------

# (l, mu, EI) of the three links, 4 Hermite elements each; joint parameters of section 7 (docstring).
PRISMATIC_LINKS = ((1.0, 1.0, 25.0), (0.6, 0.8, 10.0), (0.5, 0.4, 4.0))
PRISMATIC_ELEMENTS = 4
PA = {"gamma": 0.5, "c": 0.05, "range": (0.1, 0.9)}
PB = {"gamma": -0.4, "range": (0.2, 0.5)}
PRISMATIC_JOINTS = {"R-Pa-Pb": ("R", "Pa", "Pb"), "R-R-R": ("R", "R", "R")}
PRISMATIC_STATE = {"R": (0.7, -0.4, 0.3), "Pa": (None, 0.43, None), "Pb": (None, None, 0.37)}  # by position


def planar_chain(kinds):
    """(gibbsimpact Model, planar oracle, q, qdot) of the section-7 chain with joint kinds ``kinds``."""
    sys.path.insert(0, str(ROOT / "tests"))
    from reference.planar_oracle import PlanarChain, link

    links, joints, ref = [], [], []
    for (l, mu, ei), kind in zip(PRISMATIC_LINKS, kinds):
        # geometric_stiffening=False: the oracle is the linear beam (and a Pb link refuses foreshortening)
        links.append(gi.Link(length=l, mass_per_length=mu, EI=ei, elements=PRISMATIC_ELEMENTS, geometric_stiffening=False))
        if kind == "R":
            joints.append(gi.Revolute())
            ref.append(link("R", l, mu, ei, PRISMATIC_ELEMENTS))
        elif kind == "Pa":
            joints.append(gi.SlidingPrismatic(angle=PA["gamma"], half_length=PA["c"], range=PA["range"]))
            ref.append(link("Pa", l, mu, ei, PRISMATIC_ELEMENTS, gamma=PA["gamma"], c=PA["c"]))
        else:
            joints.append(gi.FixedPrismatic(angle=PB["gamma"], range=PB["range"]))
            ref.append(link("Pb", l, mu, ei, PRISMATIC_ELEMENTS, gamma=PB["gamma"]))
    chain = gi.Chain(links, joints=joints, base=gi.FixedBase((0.0, 0.0), 0.0))
    model = gi.Model(chain, gravity=GRAVITY)
    orc = PlanarChain(ref, base=(0.0, 0.0, 0.0), gravity=GRAVITY[:2])
    if orc.coordinate_names != tuple(model.coordinate_names):
        raise RuntimeError(f"oracle coordinates {orc.coordinate_names} != {model.coordinate_names}")
    rng = np.random.default_rng(7)
    joint_q = [PRISMATIC_STATE[kind][i] for i, kind in enumerate(kinds)]
    n_el = model.n_dof - len(kinds)
    defl = np.ravel([(rng.uniform(-0.02, 0.02), rng.uniform(-0.05, 0.05)) for _ in range(n_el // 2)])
    q = np.concatenate([np.array(joint_q, dtype=float), defl])
    qd = rng.normal(size=model.n_dof)
    return model, orc, q, qd


def per_call_cpu_wall(fn, repeats: int, budget: float) -> dict:
    """Per-call cost [us] of ``repeats`` loops of ~``budget`` s: min and median of CPU and of wall time."""
    fn()
    number, t = 1, 0.0
    while True:  # calibrate the loop length on wall time
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        t = time.perf_counter() - t0
        if t >= budget or number >= 1 << 20:
            break
        number = max(number * 2, int(number * budget / max(t, 1e-9) * 1.1))
    cpu, wall = [], []
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        for _ in range(number):
            fn()
        wall.append((time.perf_counter() - w0) / number * 1e6)
        cpu.append((time.process_time() - c0) / number * 1e6)
    return {"cpu_min": min(cpu), "cpu_med": float(np.median(cpu)), "wall_min": min(wall),
            "wall_med": float(np.median(wall)), "calls": number}


def prismatic_chains(cfg):
    """Section 7: 3-link R-Pa-Pb chain (4 elements per link) against R-R-R and the planar oracle."""
    section("7. forward_dynamics per call, planar 3-link FE chain (4 elements/link): R-Pa-Pb vs R-R-R, "
            "planar oracle")
    print("fixed base; (l, mu, EI) = " + ", ".join(f"({l:g}, {mu:g}, {ei:g})" for l, mu, ei in PRISMATIC_LINKS)
          + f"; Pa c = {PA['c']:g} m, gamma = {PA['gamma']:g}; Pb gamma = {PB['gamma']:g}")
    print(f"per call [us]: min / median of {cfg.repeats} loops of ~{cfg.budget} s, CPU (process_time) and wall")
    out = {}
    head = (f"{'chain':<8} {'N':>3} {'gi cpu min':>10} {'med':>7} {'wall min':>9} {'oracle cpu min':>14} "
            f"{'med':>8} {'wall min':>9} {'oracle/gi':>9} {'match':>8}")
    print(head)
    for label, kinds in PRISMATIC_JOINTS.items():
        model, orc, q, qd = planar_chain(kinds)
        a_gi = forward_dynamics(model, q, qd)
        a_ref = orc.forward_dynamics(q, qd)
        match = float(np.abs(a_ref - a_gi).max() / np.abs(a_gi).max())
        t_gi = per_call_cpu_wall(partial(forward_dynamics, model, q, qd), cfg.repeats, cfg.budget)
        t_orc = per_call_cpu_wall(partial(orc.forward_dynamics, q, qd), cfg.repeats, cfg.budget)
        ratio = t_orc["cpu_min"] / t_gi["cpu_min"]
        out[label] = {"N": model.n_dof, "gi": t_gi, "oracle": t_orc, "ratio": ratio, "match": match}
        print(f"{label:<8} {model.n_dof:>3} {t_gi['cpu_min']:>10.1f} {t_gi['cpu_med']:>7.1f} "
              f"{t_gi['wall_min']:>9.1f} {t_orc['cpu_min']:>14.0f} {t_orc['cpu_med']:>8.0f} "
              f"{t_orc['wall_min']:>9.0f} {ratio:>9.0f} {match:>8.1e}", flush=True)
    if len(out) == 2:
        p, r = out["R-Pa-Pb"], out["R-R-R"]
        out["prismatic_over_revolute"] = p["gi"]["cpu_min"] / r["gi"]["cpu_min"]
        print(f"R-Pa-Pb / R-R-R (same links, elements, N): gibbsimpact {out['prismatic_over_revolute']:.2f}x "
              f"(median {p['gi']['cpu_med'] / r['gi']['cpu_med']:.2f}x), planar oracle "
              f"{p['oracle']['cpu_min'] / r['oracle']['cpu_min']:.2f}x")
    return out


# -- main ---------------------------------------------------------------------------------------------

def describe_environment():
    head = _git("rev-parse", "--short", "HEAD", check=False).stdout.strip() or "?"
    has_kernel = (ROOT / "src" / "gibbsimpact" / "kernel.py").exists()
    model = chain_model(2)
    forward_dynamics(model, *random_state(model))  # imports whatever kernel dynamics uses
    if "gibbsimpact.kernel" in sys.modules:
        label = "compiled kernel (gibbsimpact.kernel in use)"
        if os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0"):
            label += ", NUMBA_DISABLE_JIT set"
    elif has_kernel:
        label = "numpy kernel (kernel.py present but not used yet)"
    else:
        label = "numpy kernel (no kernel.py)"
    try:
        import numba

        nb = f"numba {numba.__version__}"
    except ImportError:
        nb = "numba not installed"
    print(f"gibbsimpact {gi.__version__} from {Path(gi.__file__).parent}, HEAD {head}, {label}; {nb}; "
          f"numpy {np.__version__}; python {sys.version.split()[0]}; {os.cpu_count()} cores")
    return label


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: n = 2, 4, 8, few short repeats")
    ap.add_argument("--skip-cold", action="store_true", help="skip section 5 (cold start)")
    ap.add_argument("--skip-simulate", action="store_true", help="skip section 4 (simulate against the baseline)")
    ap.add_argument("--repeats", type=int, default=None, help="timing loops per measurement; the minimum is reported")
    ap.add_argument("--only", choices=("prismatic", "simulate"), default=None,
                    help="run one section on its own (no plot): prismatic = section 7, simulate = section 4")
    args = ap.parse_args(argv)
    cfg = argparse.Namespace(
        sizes=(2, 4, 8) if args.quick else (2, 4, 8, 16, 32),
        repeats=args.repeats or (3 if args.quick else 7),
        budget=0.02 if args.quick else 0.2,  # seconds per timing loop
        sim_repeats=1 if args.quick else 3,
        sympy_n_max=4 if args.quick else 16,
    )
    cfg.kernel_label = describe_environment()
    if args.only == "prismatic":
        print(f"{cfg.repeats} repeats of ~{cfg.budget} s loops per timing")
        return {"prismatic": run_section(prismatic_chains, cfg)}
    if args.only == "simulate":
        from bench_baseline import simulate_vs_baseline

        return {"simulate": run_section(simulate_vs_baseline, cfg)}
    print(f"sizes n = {cfg.sizes}; {cfg.repeats} repeats of ~{cfg.budget} s loops per timing (minimum reported)")
    results = {}
    results["rigid"] = run_section(rigid_vs_pinocchio, cfg)
    results["modes"] = run_section(modes_scaling, cfg, results["rigid"])
    results["case1"] = run_section(case1_vs_sympy, cfg)
    results["sympy"] = run_section(sympy_scaling, cfg, results["rigid"])
    if args.skip_simulate:
        print("\n(section 4 skipped: --skip-simulate)")
    else:
        from bench_baseline import simulate_vs_baseline  # section 4 lives in its own file

        results["simulate"] = run_section(simulate_vs_baseline, cfg)
    if args.skip_cold:
        print("\n(section 5 skipped: --skip-cold)")
    else:
        results["cold"] = run_section(cold_start, cfg)
    results["prismatic"] = run_section(prismatic_chains, cfg)
    run_section(plot, cfg, results)
    return results


if __name__ == "__main__":
    main()
