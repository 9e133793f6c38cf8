"""Probe: the same kernel source compiled ahead of time (numba.pycc) instead of by the JIT.

Not a feature of the package: the measurement behind the decision in issue 8's notes on the
second-run target (a warm `gibbsimpact run` of case 1 in <= 1.5 s wall). A JIT-compiled
process pays numba's import (~0.4 s) and its target initialisation when the first cached
function loads (~0.5 s) before any work; a module built by numba.pycc is a plain CPython
extension that does not import numba at all.

In a temporary directory this script

1. builds one extension holding the published chains' kernel variant (revolute joints,
   rigid link ends) and the event layer's ``event_gaps``, from ``gibbsimpact.kernel``'s
   own functions (CPU time of the build);
2. imports it in a fresh process and reports the import time and whether numba got imported;
3. compares q-double-dot of case 1 with the JIT kernel (bit for bit) and the time per call;
4. runs ``gibbsimpact run cases/circle_two_link.toml --no-plots`` in fresh processes with
   the package's entry points pointed at the extension (wall time, minimum of repeats),
   next to the same run with the JIT kernel and its warm numba cache.

numba.pycc is marked for deprecation (numba's "Deprecation Notices"; a replacement is
planned) and it links with the system C compiler, so a package route through it needs a
fallback to the JIT. Its wrappers do not check argument types: measured, a strided float64
array is read as if contiguous (wrong values) and a float32 one crashed the process, where
the JIT's dispatcher raises TypeError; every call would need a checked wrapper.
Usage: python benchmarks/aot_probe.py [--repeat R]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "cases" / "circle_two_link.toml"

BUILD = r"""
import sys, time
from numba.pycc import CC
from gibbsimpact import kernel as k
from gibbsimpact.kernel import compile as kc
kc._jit_helpers()
cc = CC("gi_aot_probe")
cc.output_dir = sys.argv[1]
cc.export("kernel_rigid", kc._ENTRY_SIG.format("none", "none"))(kc._PY_KERNEL)
cc.export("event_gaps", kc._LAZY["event_gaps"])(k.event_gaps.py_func)
t = time.process_time()
cc.compile()
print(time.process_time() - t)
"""

CHECK = r"""
import json, sys, time, timeit
t = time.perf_counter()
sys.path.insert(0, sys.argv[1])
import numpy as np
import gi_aot_probe
t_import = time.perf_counter() - t
numba_loaded = "numba" in sys.modules
import gibbsimpact as gi
from gibbsimpact import kernel as k
from gibbsimpact.dynamics.gibbs_appell import forward_dynamics
case = gi.load_case(sys.argv[2])
m, q, qd = case.model, case.q0.copy(), case.qdot0.copy() + 0.3
fdat, idat, zeros, v = m.kernel_data
N = q.size
out = k.output(idat, 1, k.JOB_SOLVE)
gi_aot_probe.kernel_rigid(fdat, idat, q, qd, zeros, k.JOB_SOLVE, None, None, out)
a = out[3 + N:3 + 2 * N]
b = forward_dynamics(m, q, qd)
jit = k.compiled(v)
per = lambda f: min(timeit.repeat(lambda: f(fdat, idat, q, qd, zeros, k.JOB_SOLVE, None, None, out), number=20000,
                                  repeat=7)) / 20000 * 1e6
print(json.dumps({"import_s": t_import, "numba_loaded": numba_loaded, "identical": bool(np.array_equal(a, b)),
                  "aot_us": per(gi_aot_probe.kernel_rigid), "jit_us": per(jit)}))
"""

RUN = r"""
import sys
if sys.argv[1] != "jit":
    sys.path.insert(0, sys.argv[1])
    import gi_aot_probe
    from gibbsimpact import kernel as k
    from gibbsimpact.kernel import compile as kc
    k.compiled = kc.compiled = lambda v=None: gi_aot_probe.kernel_rigid  # kc: for kernel.run
    k.lazy = lambda name: getattr(gi_aot_probe, name)
from gibbsimpact.cli import commands as cli
sys.argv = ["gibbsimpact", "run", sys.argv[2], "--no-plots", "--quiet", "--out", sys.argv[3]]
try:
    cli.main()
finally:
    print("numba loaded:", "numba" in sys.modules, file=sys.stderr)
"""


def wall(args) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", *args], check=True, capture_output=True, text=True)
    return time.perf_counter() - t


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per CLI measurement (minimum reported)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        build = subprocess.run([sys.executable, "-c", BUILD, tmp], check=True, capture_output=True, text=True)
        print(f"AOT build of the rigid-ends kernel and event_gaps: {float(build.stdout.split()[-1]):.1f} s CPU")
        check = json.loads(subprocess.run([sys.executable, "-c", CHECK, tmp, str(CASE)], check=True,
                                          capture_output=True, text=True).stdout.splitlines()[-1])
        print(f"import of the extension: {check['import_s'] * 1e3:.0f} ms with numpy; numba imported: "
              f"{check['numba_loaded']}; case 1 qddot identical to the JIT kernel's: {check['identical']}")
        print(f"per call: AOT {check['aot_us']:.2f} us, JIT {check['jit_us']:.2f} us")
        out = Path(tmp) / "out"
        wall([RUN, "jit", str(CASE), str(out)])  # warm: the JIT cache, the output folder
        times = {"jit": [], "aot": []}
        for _ in range(args.repeat):
            for kind, where in (("jit", "jit"), ("aot", tmp)):
                times[kind].append(wall([RUN, where, str(CASE), str(out)]))
        print(f"gibbsimpact run case 1 --no-plots, warm: JIT {min(times['jit']):.2f} s wall, "
              f"AOT {min(times['aot']):.2f} s wall (minimum of {args.repeat}; target 1.5 s)")


if __name__ == "__main__":
    main()
