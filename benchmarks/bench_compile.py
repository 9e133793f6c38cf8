"""Cold compile time of the kernel per variant and per lazy group, and forward_dynamics per call.

Measures one or more source trees side by side (``--src LABEL=PATH``, e.g. the code before and
after a change to the kernel), interleaved so that the load of a shared machine hits them alike:

* cold compile, per target: ``ensure_compiled(v)`` for the variants RIGID_ENDS, REVOLUTE and
  PRISMATIC, and ``lazy(entry)`` for the lazy groups (resting: contact_terms + sym_solve;
  friction: friction_solve; events: event_gaps). Each target runs in a new process with an
  empty NUMBA_CACHE_DIR; numba is warmed first by compiling a one-line function, so that the
  time is the kernel's own (not numba's first-use start-up). CPU time (time.process_time) of
  that one call, and its wall time;
* per call: ``forward_dynamics`` on case 1 (cases/circle_two_link.toml, N = 9, at q0 and
  qdot0 + N(0, 1) noise of seed 3, as bench_kernel.py section 3), in a new process with a
  warm cache: bench_kernel.per_call_cpu_wall (loops of ~0.2 s; min and median of the CPU times).

Every target runs ``--repeats`` times (default 2) per tree; min and median are printed, and the
ratio of each tree's CPU minimum to the first tree's.

Usage:
    python benchmarks/bench_compile.py --src before=/tmp/old/src --src after=src [--repeats 2]
        [--only RIGID_ENDS,resting,call] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
VARIANTS = ("RIGID_ENDS", "REVOLUTE", "PRISMATIC")
GROUPS = {"resting": "contact_terms", "friction": "friction_solve", "events": "event_gaps"}
TARGETS = VARIANTS + tuple(GROUPS) + ("call",)


def child(target: str) -> dict:
    """Run in the measuring process: compile ``target`` cold, or time forward_dynamics per call."""
    import numba

    numba.njit(lambda x: x + 1)(1)  # numba's own start-up, outside the timing
    from gibbsimpact import kernel as K

    if target == "call":
        sys.path.insert(0, str(HERE))
        import gibbsimpact as gi
        from bench_kernel import per_call_cpu_wall
        from gibbsimpact.dynamics.gibbs_appell import forward_dynamics

        case = gi.load_case(ROOT / "cases" / "circle_two_link.toml")
        q = case.q0.copy()
        qd = case.qdot0 + np.random.default_rng(3).normal(size=case.qdot0.size)
        forward_dynamics(case.model, q, qd)
        return per_call_cpu_wall(lambda: forward_dynamics(case.model, q, qd), 7, 0.2)
    c0, w0 = time.process_time(), time.perf_counter()
    if target in VARIANTS:
        K.ensure_compiled(getattr(K, target))
    else:
        K.lazy(GROUPS[target])
    return {"cpu": time.process_time() - c0, "wall": time.perf_counter() - w0, "file": K.__file__}


def measure(src: Path, target: str, cache: Path) -> dict:
    """One child process on the tree ``src`` with NUMBA_CACHE_DIR ``cache``."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(cache))
    p = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", target], env=env, cwd=ROOT,
                       capture_output=True, text=True, timeout=1800, check=False)
    if p.returncode != 0:
        raise RuntimeError(f"{target} on {src}: exit {p.returncode}\n{p.stderr[-2000:]}")
    out = json.loads(p.stdout.strip().splitlines()[-1])
    if "file" in out and not Path(out["file"]).resolve().is_relative_to(src.resolve()):
        raise RuntimeError(f"{target}: imported {out['file']}, not the tree {src}")
    return out


def run(srcs: dict, targets, repeats: int) -> dict:
    """{label: {target: [value per repeat]}}: CPU seconds of a cold compile, us per call."""
    res = {label: {t: [] for t in targets} for label in srcs}
    tmp = Path(tempfile.mkdtemp(prefix="gi_compile_"))
    try:
        for r in range(repeats):
            for label, src in srcs.items():
                for t in targets:
                    cache = tmp / f"{label}-{t}-{r}" if t != "call" else tmp / f"{label}-call"
                    out = measure(src, t, cache)
                    if t == "call" and not res[label][t]:
                        out = measure(src, t, cache)  # the first one compiled: time with a warm cache
                    res[label][t].append(out["cpu_min"] if t == "call" else out["cpu"])
                    print(f"repeat {r + 1}: {label:<8} {t:<10} {res[label][t][-1]:8.2f}", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return res


def report(res: dict, targets) -> None:
    labels = list(res)
    head = f"{'target':<11}" + "".join(f" {lb + ' min':>12} {'median':>8}" for lb in labels)
    head += "".join(f" {lb + '/' + labels[0]:>16}" for lb in labels[1:])
    print("\ncold compile: CPU s (new process, empty cache); call: forward_dynamics on case 1, CPU us per call")
    print(head)
    for t in targets:
        row = f"{t:<11}"
        for lb in labels:
            v = res[lb][t]
            row += f" {min(v):>12.2f} {float(np.median(v)):>8.2f}"
        for lb in labels[1:]:
            row += f" {min(res[lb][t]) / min(res[labels[0]][t]):>16.3f}"
        print(row)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", action="append", default=[], metavar="LABEL=PATH",
                    help="a source tree (the folder holding gibbsimpact/); repeat to compare; default: this src/")
    ap.add_argument("--repeats", type=int, default=2, help="runs per target and tree (min and median printed)")
    ap.add_argument("--only", default=",".join(TARGETS), help=f"comma-separated subset of {', '.join(TARGETS)}")
    ap.add_argument("--json", type=Path, default=None, help="also write the raw numbers here")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.child)))
        return None
    targets = [t for t in args.only.split(",") if t]
    bad = [t for t in targets if t not in TARGETS]
    if bad:
        ap.error(f"--only: unknown target(s) {bad}; choose from {', '.join(TARGETS)}")
    srcs = dict(s.split("=", 1) for s in args.src) if args.src else {"src": str(ROOT / "src")}
    srcs = {label: Path(p).resolve() for label, p in srcs.items()}
    res = run(srcs, targets, args.repeats)
    report(res, targets)
    if args.json:
        args.json.write_text(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
