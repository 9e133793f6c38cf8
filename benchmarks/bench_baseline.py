"""Section 4 of bench_kernel.py: ``gi.simulate`` of case 1, warm, against the numpy kernel of commit 54f2dfd.

How it is measured is in bench_kernel.py's docstring (section 4). Runs on its own:

    python benchmarks/bench_baseline.py [--quick]

(``python benchmarks/bench_kernel.py --only simulate`` runs the same.)
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_kernel import CASE1, ROOT, _git, section, verdict

BASELINE_COMMIT = "54f2dfd"  # the last commit with the numpy kernel


# Run inside a child process: time gi.simulate on case 1, warm, and print one JSON line.
_SIMULATE_CHILD = r"""
import json, sys, time
import gibbsimpact as gi
case = gi.load_case(sys.argv[1])
repeats = int(sys.argv[2])
res = case.simulate()  # warm: compile / load caches
walls, cpus = [], []
for _ in range(repeats):
    t0, c0 = time.perf_counter(), time.process_time()
    res = case.simulate()
    walls.append(time.perf_counter() - t0)
    cpus.append(time.process_time() - c0)
print(json.dumps(dict(file=gi.__file__, wall=walls, cpu=cpus, impacts=len(res.impacts), nfev=res.nfev,
                      status=res.status, t_end=float(res.t[-1]), impact_times=[float(r.time) for r in res.impacts])))
"""


# What a run of case 1 costs at least while scipy steps it: the same chain integrated by
# solve_ivp (same method and tolerances, no events, no walls) with the bare compiled kernel
# as its right-hand side, per RHS evaluation; and simulate with joint contacts only.
_FLOOR_CHILD = r"""
import json, sys, time
import numpy as np
from scipy.integrate import solve_ivp
import gibbsimpact as gi
from gibbsimpact import kernel as K
case = gi.load_case(sys.argv[1])
repeats = int(sys.argv[2])
m = case.model
fdat, idat, zeros, v = m.kernel_data
N = m.n_dof
kern = K.compiled(v)
def f(t, y):
    out = K.output(idat, 1, K.JOB_SOLVE)
    kern(fdat, idat, y[:N], y[N:], zeros, K.JOB_SOLVE, *v, out)
    return out[3:3 + 2 * N]
kw = case.simulate_kwargs()
y0 = np.concatenate((case.q0, case.qdot0))
plain = []
for _ in range(repeats + 1):
    c0 = time.process_time()
    r = solve_ivp(f, (0.0, 1.0), y0, method=kw["method"], rtol=kw["rtol"], atol=kw["atol"])
    plain.append(time.process_time() - c0)
joints = []
for _ in range(repeats + 1):
    c0 = time.process_time()
    res = case.simulate(link_contacts=False)
    joints.append(time.process_time() - c0)
print(json.dumps(dict(per_rhs=min(plain[1:]) / r.nfev, plain_nfev=int(r.nfev), joints_cpu=min(joints[1:]),
                      joints_nfev=res.nfev, joints_impacts=len(res.impacts))))
"""


def _run_simulate_child(env, repeats, label, case=CASE1):
    p = subprocess.run([sys.executable, "-c", _SIMULATE_CHILD, str(case), str(repeats)], env=env, cwd=ROOT,
                       capture_output=True, text=True, timeout=1800, check=False)
    if p.returncode != 0:
        raise RuntimeError(f"{label} run failed (exit {p.returncode}):\n{p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


#: Case-file keys that commit BASELINE_COMMIT does not know (its reader rejects them), each with the value
#: that means what that commit does without it: its beams are linear (no foreshortening).
BASELINE_UNKNOWN_KEYS = {"geometric_stiffening": False}


def _toml_items(node):
    """Every (key, value) of a parsed TOML document, at any depth (tables, arrays of tables)."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield k, v
            yield from _toml_items(v)
    elif isinstance(node, list):
        for v in node:
            yield from _toml_items(v)


def baseline_case_text(text: str) -> str:
    """Case 1's TOML ``text`` as commit BASELINE_COMMIT reads it: the lines setting a key of
    BASELINE_UNKNOWN_KEYS removed, after checking that each sets the value that commit has built in (else the
    two runs would simulate different models, and ValueError says which key)."""
    import re
    import tomllib

    for key, value in _toml_items(tomllib.loads(text)):
        if key in BASELINE_UNKNOWN_KEYS and value != BASELINE_UNKNOWN_KEYS[key]:
            raise ValueError(f"{CASE1.name}: {key} = {value!r}, but commit {BASELINE_COMMIT} only simulates "
                             f"{key} = {BASELINE_UNKNOWN_KEYS[key]!r}: the baseline would be another model")
    line = re.compile(rf"^\s*({'|'.join(BASELINE_UNKNOWN_KEYS)})\s*=.*(\n|$)", re.M)
    out = line.sub("", text)
    if any(k in BASELINE_UNKNOWN_KEYS for k, _ in _toml_items(tomllib.loads(out))):
        raise ValueError(f"{CASE1.name}: a key of {sorted(BASELINE_UNKNOWN_KEYS)} is not on a line of its own; "
                         "the baseline cannot strip it")
    return out


def simulate_vs_baseline(cfg):
    """Section 4: gi.simulate of case 1, warm, against the pre-numba kernel of commit 54f2dfd."""
    section(f"4. gi.simulate of case 1 (warm), current code against the numpy kernel of {BASELINE_COMMIT}")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src")] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    cur = _run_simulate_child(env, cfg.sim_repeats, "current")
    tmp = Path(tempfile.mkdtemp(prefix="gi_baseline_"))
    wt = tmp / "worktree"
    added = False
    try:
        have = _git("cat-file", "-e", f"{BASELINE_COMMIT}^{{commit}}", check=False).returncode == 0
        if have:
            r = _git("worktree", "add", "--detach", str(wt), BASELINE_COMMIT, check=False)
            added = r.returncode == 0
            if not added:
                print(f"git worktree add failed: {r.stderr.strip()}")
        case = CASE1
        if added:
            base_env = dict(os.environ, PYTHONPATH=str(wt / "src"))
            case = tmp / CASE1.name  # today's case 1 without the keys that commit does not know
            case.write_text(baseline_case_text(CASE1.read_text()))
            how = (f"commit {BASELINE_COMMIT} (worktree {wt}), case 1 without the key(s) "
                   f"{', '.join(f'{k} = {str(v).lower()}' for k, v in BASELINE_UNKNOWN_KEYS.items())}")
        else:
            print(f"commit {BASELINE_COMMIT} unavailable: the baseline is the current code with NUMBA_DISABLE_JIT=1")
            base_env = dict(env, NUMBA_DISABLE_JIT="1")
            how = "current code, NUMBA_DISABLE_JIT=1"
        base = _run_simulate_child(base_env, cfg.sim_repeats, "baseline", case)
        if added and not Path(base["file"]).resolve().is_relative_to(wt.resolve()):
            print(f"warning: the baseline imported {base['file']}, not the worktree")
    finally:
        if added:
            r = _git("worktree", "remove", "--force", str(wt), check=False)
            if r.returncode != 0:
                print(f"git worktree remove failed: {r.stderr.strip()}")
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"baseline: {how}")
    print(f"{'run':<10} {'wall[s]':>8} {'cpu[s]':>8} {'nfev':>6} {'impacts':>7} {'status':>9}  imported from")
    for label, r in (("current", cur), ("baseline", base)):
        print(f"{label:<10} {min(r['wall']):>8.3f} {min(r['cpu']):>8.3f} {r['nfev']:>6} {r['impacts']:>7} "
              f"{r['status']:>9}  {r['file']}")
    fl = subprocess.run([sys.executable, "-c", _FLOOR_CHILD, str(CASE1), str(cfg.sim_repeats)], env=env, cwd=ROOT,
                        capture_output=True, text=True, timeout=1800, check=False)
    floor = None
    if fl.returncode == 0:
        floor = json.loads(fl.stdout.strip().splitlines()[-1])
        print(f"joint contacts only (link_contacts=False): {floor['joints_cpu']:.3f} s CPU, nfev {floor['joints_nfev']}, "
              f"{floor['joints_impacts']} impacts")
        print(f"floor: scipy's {floor['plain_nfev']}-evaluation integration of the same chain without events, bare "
              f"kernel as RHS, costs {1e6 * floor['per_rhs']:.1f} us CPU per evaluation: {cur['nfev']} evaluations "
              f"= {floor['per_rhs'] * cur['nfev']:.3f} s before any event, impact or sample")
    else:
        print(f"floor measurement failed: {fl.stderr[-1000:]}")
    speedup = min(base["wall"]) / min(cur["wall"])
    warm = min(cur["wall"])
    print(f"speed-up baseline/current {speedup:.2f}x (target >= 12x) {verdict(speedup >= 12)}; "
          f"warm wall {warm:.3f} s (target <= 0.15 s) {verdict(warm <= 0.15)}")
    if cur["impacts"] != 4 or base["impacts"] != 4:
        print(f"note: case 1 should have 4 impacts (current {cur['impacts']}, baseline {base['impacts']})")
    elif "impact_times" in base:  # the same model: the impact times agree to the event tolerance
        dt = max(abs(a - b) for a, b in zip(cur["impact_times"], base["impact_times"]))
        print(f"same run: max |impact time, current - baseline| = {dt:.1e} s {verdict(dt <= 1e-6)}")
    return {"current": cur, "baseline": base, "speedup": speedup, "floor": floor}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one timed run each instead of the minimum of 3")
    args = ap.parse_args(argv)
    return simulate_vs_baseline(argparse.Namespace(sim_repeats=1 if args.quick else 3))


if __name__ == "__main__":
    main()
