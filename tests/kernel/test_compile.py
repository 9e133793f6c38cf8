"""numba's on-disk cache of the kernel is keyed on every kernel source file (kernel/compile.py).

numba stamps each compiled function's cache index with the hash of that function's own file;
the kernel compiles helpers from other files into its entry points, so the kernel stamps every
index with ``source_key()``, the hash of all of kernel/*.py. Checked here: the key changes
when any one kernel file changes (and only then), the probe for a warm cache reads the index
with that key, and, end to end, an edit to a helper in another file than its entry point is
compiled instead of loaded stale from the cache; and saves into one index from two processes at
once keep every entry (kernel/disk_cache.py).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

import gibbsimpact as gi
from gibbsimpact.kernel import compile as _kc
from gibbsimpact.kernel.disk_cache import fcntl, locked_saves

needs_jit = pytest.mark.skipif(_kc.jit_disabled(), reason="NUMBA_DISABLE_JIT is set: nothing is compiled")


def test_source_key_changes_with_every_kernel_file(tmp_path):
    copy = tmp_path / "kernel"
    shutil.copytree(_kc.KERNEL_DIR, copy, ignore=shutil.ignore_patterns("__pycache__"))
    key = _kc.source_key(copy)
    assert key == _kc.source_key(_kc.KERNEL_DIR) == _kc._source_key_now()
    files = sorted(copy.glob("*.py"))
    assert {p.name for p in files} >= {"layout.py", "mat4.py", "frames.py", "moments.py", "assemble.py", "linalg.py",
                                       "entry.py", "contact.py", "compile.py", "__init__.py"}
    for path in files:  # one character more in any one file gives another key
        text = path.read_text()
        path.write_text(text + " ")
        assert _kc.source_key(copy) != key, path.name
        path.write_text(text)
    assert _kc.source_key(copy) == key
    (copy / "notes.txt").write_text("not a source file\n")
    assert _kc.source_key(copy) == key
    (copy / "extra.py").write_text("")  # a new module is a source file
    assert _kc.source_key(copy) != key


def test_the_cache_and_its_probe_share_the_key():
    pytest.importorskip("numba")
    try:
        cache = _kc._kernel_cache(_kc._PY_KERNEL)
    except RuntimeError as exc:
        pytest.skip(f"numba has no cache location here: {exc}")
    assert cache._cache_file._source_stamp == _kc.source_key()
    assert cache._cache_file.save.__qualname__.startswith(locked_saves.__name__)  # saves under the lock


# One frictionless pair (mu = 0) on M = diag(2, 3) kg, W = (1, 1): friction_solve's constraint
# matrix is W^T M^-1 W = 5/6 and its right-hand side -(c + W^T qf) = -2 with qf = (1, 1), so
# lambda = -2.4 N, solved by _svd_solve (kernel/linalg.py) inside friction_solve (kernel/contact.py).
_FRICTION_SCRIPT = r"""
import json
import numpy as np
from gibbsimpact import kernel as k
Z = np.zeros((1, 3))
r = k.lazy("friction_solve")(np.diag([2.0, 3.0]), np.ones((2, 1)), np.zeros((1, 3, 2)), Z, Z, Z, np.zeros(1),
                             np.ones(2), np.zeros(1), np.zeros(1, dtype=np.int64), Z, 1e-6)
print(json.dumps({"file": k.__file__, "lambda": float(r[2])}))
"""


def _friction_lambda(site: Path, cache: Path) -> float:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PYTHON"))}
    env.update(PYTHONPATH=str(site), NUMBA_CACHE_DIR=str(cache))
    run = subprocess.run([sys.executable, "-c", _FRICTION_SCRIPT], check=False, env=env, cwd=site,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert Path(out["file"]).resolve().is_relative_to(site.resolve())
    return out["lambda"]


@needs_jit
def test_an_edited_helper_in_another_file_is_compiled_not_loaded_stale(tmp_path):
    site = tmp_path / "site"
    shutil.copytree(Path(gi.__file__).resolve().parent, site / "gibbsimpact",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    cache = tmp_path / "numba_cache"
    assert _friction_lambda(site, cache) == pytest.approx(-2.4, rel=1e-14)
    assert list(cache.rglob("contact.friction_solve-*.nbi")), "friction_solve was not cached"
    # _svd_solve returns twice its solution: an edit to linalg.py only, not to contact.py.
    linalg = site / "gibbsimpact" / "kernel" / "linalg.py"
    text = linalg.read_text()
    edited, count = re.subn(r"(def _svd_solve\(.*?\n    )return x\n", r"\1return 2.0 * x\n", text, count=1,
                            flags=re.S)
    assert count == 1, "the last line of _svd_solve is no longer 'return x': update this test"
    linalg.write_text(edited)
    assert _friction_lambda(site, cache) == pytest.approx(-4.8, rel=1e-14)


def _save_many(index_dir: str, writer: int, count: int, lock: bool):
    """``count`` saves of the signatures (writer, i) by one process's view of a kernel index."""
    from numba.core.caching import IndexDataCacheFile

    index = IndexDataCacheFile(index_dir, "kernel-1.py311", "stamp")
    if lock:
        locked_saves(index)
    for i in range(count):
        index.save((writer, i), (writer, i, "machine code"))


@pytest.mark.skipif(fcntl is None, reason="no flock here: saves are unlocked, as numba's own")
def test_concurrent_saves_of_two_variants_keep_every_entry(tmp_path):
    # Two pytest-xdist workers (or sweep workers) compiling two variants of one function on a cold
    # cache both save into its one index. numba's read-modify-write of the index is unlocked: run
    # unlocked, this test lost 4-17 entries of 200 in five runs here, and left some naming another
    # signature's data. Two threads save 100 signatures each through their own index object, as two
    # processes would.
    pytest.importorskip("numba")
    threads = [threading.Thread(target=_save_many, args=(str(tmp_path), w, 100, True)) for w in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    from numba.core.caching import IndexDataCacheFile

    index = IndexDataCacheFile(str(tmp_path), "kernel-1.py311", "stamp")
    entries = index._load_index()
    assert set(entries) == {(w, i) for w in range(2) for i in range(100)}
    assert len(set(entries.values())) == 200  # one data file each
    assert all(index.load(key) == (*key, "machine code") for key in entries)
