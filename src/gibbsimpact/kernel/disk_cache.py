"""numba's on-disk cache index, updated under an inter-process lock.

numba saves a compiled signature of a function in three steps: read the function's index (a
pickled dict signature key -> data file name), add the key with the first data-file number
not in the index, write the index, then the data file, each written to a temporary file and
renamed (atomic), but with no lock across the steps. Two processes that finish compiling two
signatures of one function at once (two pytest-xdist workers, two sweep workers on a cold cache,
each compiling another kernel variant) both read the same index and pick the same number: one
entry is lost, or the index names a data file that the other process then overwrote with its
own signature's code, which a later load would take for the wrong signature until the kernel's
source key changes (tests/kernel/test_compile.py shows both, unlocked). ``locked_saves`` makes
the read-modify-write exclusive (flock on ``<index>.lock`` beside the index) and writes the
data file before the index that names it, so that a reader never finds an entry whose data is
missing or another's. Without fcntl (Windows) it saves as numba does.
"""

from __future__ import annotations

import contextlib
import itertools

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no flock
    fcntl = None


@contextlib.contextmanager
def exclusive(path: str):
    """Hold an exclusive advisory lock (flock) on the file ``path`` (created if missing) for the
    block: one process (or one open file) at a time; a no-op where fcntl is missing."""
    if fcntl is None:  # pragma: no cover - Windows
        yield
        return
    with open(path, "ab") as f:
        fcntl.flock(f.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f.fileno(), fcntl.LOCK_UN)


def locked_saves(index):
    """Make ``index.save(key, data)`` of a numba cache index (numba.core.caching.IndexDataCacheFile)
    exclusive across processes; returns ``index``.

    Under the lock: read the index, take the key's data file name (or the first
    ``<base>.<number>.nbc`` not in the index), write the data, then the index naming it.
    """
    lock = index._index_path + ".lock"

    def save(key, data):
        with exclusive(lock):
            overloads = index._load_index()
            name = overloads.get(key)
            if name is None:
                taken = set(overloads.values())
                name = next(n for n in map(index._data_name, itertools.count(1)) if n not in taken)
            index._save_data(name, data)
            overloads[key] = name
            index._save_index(overloads)

    index.save = save
    return index
