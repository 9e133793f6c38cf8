"""Compilation: signatures, variants, lazy groups, numba's on-disk cache, notices.

The entry point called from Python gets explicit signatures (C-contiguous
float64 / int64 arrays): each compiled once, then frozen (no silent recompiles
for other types). Every entry point is linked and optimised with all the code it
calls, so fewer entry points compile faster. Helpers are compiled for the types
their callers use, those marked ``layout.inline`` as part of their callers; called from
Python they run uncompiled.

Three variants of the one source, told apart by the types of the last two
arguments (pris, ends), each None or an int64 (1): ``pris`` None for chains
whose joints are all revolute, ``ends`` None for chains whose link ends are all
rigid (rigid links, clamped-clamped modes: E = Trans(l e_x)). ``x is None`` is
known while numba compiles, so it removes the prismatic branches (_pa_step,
_pb_step, _pb_moments, _extra_points, the second twists) and the moving-end
path (Rodrigues: rodrigues_directional, _conjugate, _apply_local) before they
are typed: the published chains compile neither. Each variant compiles on its
first use.

numba's on-disk cache (NUMBA_CACHE_DIR, else the package's __pycache__, else the user-wide
cache; none on a read-only install without either: then it compiles without caching) keeps
one index per compiled function, stamped with the hash of that function's file. The kernel's
helpers live in other files and are compiled into their callers, so every kernel function's
index is stamped with ``source_key()``, the hash of every kernel/*.py source, instead
(``_kernel_cache``); the probe for a warm cache (``_cache_is_warm``) reads the index
through the same function, hence with the same key.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import os
import sys
import threading
import time
import types
from pathlib import Path

import numpy as np

from .contact import contact_terms, event_gaps, friction_solve
from .disk_cache import locked_saves
from .entry import kernel
from .frames import chain_frames
from .jacobian import state_jacobian
from .layout import layout
from .radau import radau_step
from .linalg import sym_solve

#: The kernel's folder: every .py file in it goes into the cache key (source_key).
KERNEL_DIR = Path(__file__).resolve().parent
#: The kernel's stage modules, whose functions numba compiles.
_STAGES = ("layout", "mat4", "frames", "moments", "assemble", "linalg", "observables", "entry", "contact",
           "jacobian", "radau")
#: Helpers called from more than one function, compiled as their own dispatchers.
_SHARED = ("chain_frames",)
_A1, _A2, _I1 = "float64[::1]", "float64[:, ::1]", "int64[::1]"
#: The states and forces the entry point only reads: typed read-only, so that a read-only array
#: (e.g. Case.q0) is taken as it is, and a writable one converts to it at no cost (~0.02 us).
_R1 = "Array(float64, 1, 'C', readonly=True)"
#: The variants (pris, ends): the values of the entry point's last two arguments.
RIGID_ENDS, REVOLUTE, PRISMATIC = (None, None), (None, 1), (1, 1)
_VARIANT_NAME = {RIGID_ENDS: "revolute joints and rigid link ends", REVOLUTE: "revolute joints",
                 PRISMATIC: "prismatic joints"}
_VARIANT_COST = {RIGID_ENDS: "about 15-20 s", REVOLUTE: "about 20-25 s", PRISMATIC: "about 30 s"}
_ENTRY_SIG = f"float64({_A1}, {_I1}, {_R1}, {_R1}, {_R1}, int64, {{}}, {{}}, {_A1})"
#: The Jacobian entry point (jacobian.state_jacobian), per variant as the kernel; compiled on first use.
_JACOBIAN_SIG = f"float64({_A1}, {_I1}, {_R1}, {_R1}, {_R1}, {{}}, {{}}, {_A1})"
#: The compiled Radau IIA step (radau.radau_step), per variant as the kernel; compiled on first use.
_RADAU_SIG = (f"float64({_A1}, {_I1}, {_A2}, {_A2}, {_A2}, {_A1}, {_A2}, {_A1}, {_A1}, {_A2}, {_A2}, {_I1}, "
              f"complex128[:, ::1], {_I1}, {_A2}, {_A2}, {_A1}, {_A1}, {_A1}, {{}}, {{}})")
#: What the notice of a variant entry point calls it, and its cost.
_VARIANT_ENTRIES = {"state_jacobian": (_JACOBIAN_SIG,
                                         "the Jacobian of the dynamics (first implicit run; 10-20 s of CPU)"),
                    "radau_step": (_RADAU_SIG, "the compiled Radau step (first implicit run; 20-40 s of CPU)")}
#: Entry points apart from the kernel, compiled on first use: their signatures ...
_LAZY = {"contact_terms": f"{_A1}({_A1}, {_I1}, {_A1}, int64[:, ::1], {_I1}, {_A2}, int64)",
         "sym_solve": f"{_A1}({_A2}, {_A1})",
         "event_gaps": f"{_A1}({_A1}, int64, {_I1}, {_A2}, {_A2}, int64[:, ::1], float64)",
         "friction_solve": f"{_A1}({_A2}, {_A2}, float64[:, :, ::1], {_A2}, {_A2}, {_A2}, {_A1}, {_A1}, {_A1}, "
                           f"{_I1}, {_A2}, float64)"}
#: ... in groups compiled together (a contact phase needs both of its entries), with what the
#: notice calls them and when they are needed.
_LAZY_GROUP = {"contact_terms": "resting", "sym_solve": "resting", "friction_solve": "friction",
               "event_gaps": "events"}
_LAZY_NOTICE = {"resting": ("the resting-contact code", "first contact phase"),
                "friction": ("the frictional resting-contact code", "first contact phase with friction"),
                "events": ("the wall-gap code", "first run with walls")}


def _signature_args(v) -> tuple:
    """numba type names of the last two arguments of variant v."""
    return tuple("none" if x is None else "int64" for x in v)


_state = {"ready": set(), "cached": None, "seconds": {}, "kernel": None, "jitted": False, "lazy": {},
          "dispatchers": {}}
#: The plain-Python functions that get dispatchers of their own (the entry points and _SHARED).
_PY_FUNCTIONS = {"kernel": kernel, "chain_frames": chain_frames, "contact_terms": contact_terms,
                 "sym_solve": sym_solve, "event_gaps": event_gaps, "friction_solve": friction_solve,
                 "state_jacobian": state_jacobian, "radau_step": radau_step}
_PY_KERNEL = kernel  # the plain-Python entry point (the kernel modules' ``kernel`` becomes the compiled one)
_lock = threading.Lock()
NOTICE_AFTER_S = 1.0


def variant(idat) -> tuple:
    """The kernel variant for a packed model: PRISMATIC if any joint is prismatic, else
    REVOLUTE if some link end moves with its modes, else RIGID_ENDS."""
    return PRISMATIC if idat[4] else (REVOLUTE if idat[5] else RIGID_ENDS)


def _stage_modules() -> list:
    """The kernel's stage modules (_STAGES), already imported by this one."""
    return [importlib.import_module(f"{__package__}.{m}") for m in _STAGES]


def _helpers():
    """Every function defined in a stage module that gets no dispatcher of its own."""
    for mod in _stage_modules():
        for name, f in vars(mod).items():
            if isinstance(f, types.FunctionType) and f.__module__ == mod.__name__ and name not in _PY_FUNCTIONS:
                yield f


def _rebind(f, d):
    """Put the dispatcher d in the place of the function f in every kernel module that holds it
    under its name (and in the package), so that numba resolves calls to f as calls to d."""
    for mod in _stage_modules() + [sys.modules[__package__]]:
        if vars(mod).get(f.__name__) is f:
            setattr(mod, f.__name__, d)


def source_key(folder: Path = KERNEL_DIR) -> str:
    """The kernel's source key: sha256 (hex) of the names and bytes of every ``*.py`` file in
    ``folder`` (the kernel package), in name order; numba's on-disk cache is stamped with it."""
    h = hashlib.sha256()
    for path in sorted(Path(folder).glob("*.py")):
        data = path.read_bytes()
        h.update(f"{path.name}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()


def _kernel_cache(py_func):
    """numba's on-disk cache of ``py_func`` (numba.core.caching.FunctionCache), stamped with
    the kernel's source key instead of the hash of ``py_func``'s own file.

    numba keeps one index per function, stamped with its source file's hash, and loads nothing
    from an index whose stamp differs. It compiles the kernel's helpers into their callers from
    other files, so that stamp would miss an edit to a helper and load stale machine code: every
    compiled kernel function is stamped with source_key() (computed once per process) instead.
    Its saves are exclusive across processes (disk_cache.locked_saves), so that processes
    compiling two variants at once (pytest-xdist workers, sweep workers) keep both.
    Raises RuntimeError("cannot cache ...") where numba finds no cache location, or where its
    cache index no longer has the stamp and the methods this relies on (then nothing is cached).
    """
    from numba.core.caching import FunctionCache

    cache = FunctionCache(py_func)
    index = getattr(cache, "_cache_file", None)
    if not all(hasattr(index, a) for a in ("_source_stamp", "_index_path", "_load_index", "_save_index",
                                            "_save_data", "_data_name")):  # pragma: no cover - numba changed
        raise RuntimeError(f"cannot cache {py_func.__name__}: numba's cache index has no source stamp to key")
    index._source_stamp = _source_key_now()
    locked_saves(index)
    return cache


@functools.lru_cache(maxsize=1)
def _source_key_now() -> str:
    """source_key() of the kernel package, read once per process (the code it compiles is the
    code imported at start)."""
    return source_key()


def _jit_helpers():
    """Replace the kernel's entry points and shared helpers by numba dispatchers, and register
    every other helper to be compiled inside its callers (nothing compiled yet)."""
    try:
        import numba
        import numba.extending
    except ImportError:  # pragma: no cover - numba is a dependency
        import warnings

        warnings.warn("numba is not installed: gibbsimpact's kernel runs as plain Python (about 1000x "
                      "slower); install it with 'pip install numba'", RuntimeWarning, stacklevel=4)
        _state["cached"] = False
        return
    cached = True

    def jit(f):
        nonlocal cached
        d = numba.njit(nogil=True)(f)
        if cached and hasattr(d, "enable_caching"):  # (not with NUMBA_DISABLE_JIT: d is f)
            try:
                d._cache = _kernel_cache(f)  # what d.enable_caching() does, with the kernel's key
            except RuntimeError as exc:  # read-only install and no user cache directory
                if "cannot cache" not in str(exc):
                    raise
                cached = False
        return d

    dispatchers = _state["dispatchers"]
    # Called from several functions: one dispatcher compiles it once per variant (an overload
    # would be typed and lowered again for every caller).
    for name in _SHARED:
        dispatchers[name] = jit(_PY_FUNCTIONS[name])
    # Compiled inside the entry points that call them (no wrapper, no separate finalisation);
    # the parts of a split function (layout.inline) inlined into their callers before typing.
    for f in _helpers():
        if getattr(f, "kernel_inline", False):
            _rebind(f, numba.njit(inline="always", nogil=True)(f))
        else:
            numba.extending.register_jitable(f)
    dispatchers["kernel"] = jit(kernel)
    for name in (*_LAZY, *_VARIANT_ENTRIES):  # their own dispatchers: compiled on first use (lazy)
        dispatchers[name] = jit(_PY_FUNCTIONS[name])
    for name, d in dispatchers.items():
        _rebind(_PY_FUNCTIONS[name], d)
    _state["cached"] = cached


def _compile_variant(v):
    """Compile (or load from numba's cache) the entry point's signature of variant ``v``."""
    if not _state["jitted"]:
        _jit_helpers()
        _state["jitted"] = True
    d = _state["dispatchers"].get("kernel")
    if not hasattr(d, "disable_compile"):  # no numba
        return
    d.disable_compile(False)
    try:
        d.compile(_ENTRY_SIG.format(*_signature_args(v)))
    finally:
        d.disable_compile()


def compiled(v=PRISMATIC):
    """The entry point ``kernel`` with variant ``v`` compiled (or loaded) on first use.

    Call it as ``compiled(v)(fdat, idat, qs, qds, Q, job, *v, out)``, v = variant(idat), with
    out = ``output(idat, K, job)``; or let ``run`` do both.
    """
    f = _state["kernel"]
    if f is None or v not in _state["ready"]:
        ensure_compiled(v)
        f = _state["kernel"] = _state["dispatchers"].get("kernel", kernel)
    return f


@functools.lru_cache(maxsize=256)
def _output_size(n, N, K, job, npts) -> int:
    return int(layout(n, N, K, job, npts)[10])


def output(idat, K, job) -> np.ndarray:
    """An (uninitialised) output array of ``kernel`` for K states of the packed model idat and
    the JOB_* bits ``job``: layout(n, N, K, job, n + 1 + X)[10] float64 entries."""
    return np.empty(_output_size(int(idat[0]), int(idat[1]), int(K), int(job), int(idat[0] + 1 + idat[3])))


def run(v, fdat, idat, qs, qds, Q, job) -> np.ndarray:
    """The output of variant v of ``kernel`` (compiled on first use) for the K = qs.size / N
    states qs, qds (K N,), forces Q (N,) and the JOB_* bits ``job``, in a new array
    (``layout``). The arguments must have the entry point's types (``as_vector``)."""
    out = output(idat, qs.shape[0] // idat[1], job)
    if compiled(v)(fdat, idat, qs, qds, Q, job, v[0], v[1], out) < 0.0:  # pragma: no cover - sized above
        raise RuntimeError(f"kernel output of {out.size} entries does not fit its layout")
    return out


def lazy(name):
    """The entry point ``name`` of _LAZY (contact_terms, sym_solve, event_gaps), compiled (or
    loaded from numba's cache) on first use.

    They have their own dispatchers, so that a run that needs none of them (no walls, no
    resting contact) never compiles them; the first request compiles its group of
    _LAZY_GROUP (resting: ~3-6 s of CPU; events: ~1-2 s), with one notice on stderr when that
    takes more than NOTICE_AFTER_S. Call with contiguous arrays of the signature's types
    (resting.py, contacts.py).
    """
    f = _state["lazy"].get(name)
    if f is not None:
        return f
    with _lock:
        if name not in _state["lazy"]:
            if not _state["jitted"]:
                _jit_helpers()
                _state["jitted"] = True
            t0 = time.perf_counter()
            shown = []
            group = _LAZY_GROUP[name]
            what, when = _LAZY_NOTICE[group]

            def notice():
                shown.append(True)
                print(f"gibbsimpact: compiling {what} ({when}; a few seconds of CPU) ...", file=sys.stderr,
                      flush=True)

            timer = None if jit_disabled() else threading.Timer(NOTICE_AFTER_S, notice)
            if timer is not None:
                timer.daemon = True
                timer.start()
            try:
                for entry, sig in _LAZY.items():
                    if _LAZY_GROUP[entry] != group:
                        continue
                    d = _state["dispatchers"].get(entry, _PY_FUNCTIONS[entry])
                    if hasattr(d, "disable_compile"):
                        d.compile(sig)
                        d.disable_compile()
                    _state["lazy"][entry] = d
            finally:
                if timer is not None:
                    timer.cancel()
            if shown:
                print(f"gibbsimpact: {what} ready in {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    return _state["lazy"][name]


def jacobian_entry(v):
    """The entry point ``state_jacobian`` (kernel/jacobian.py) with variant ``v`` compiled (or loaded
    from numba's cache) on first use: only implicit runs need it (10-20 s of CPU, one notice on stderr).

    Call it as ``jacobian_entry(v)(fdat, idat, q, qd, Q, *v, out)`` with out of
    ``jacobian.jacobian_size(N)`` float64 entries.
    """
    return _variant_entry("state_jacobian", v)


def radau_entry(v):
    """The entry point ``radau_step`` (kernel/radau.py) with variant ``v`` compiled (or loaded from numba's
    cache) on first use: only runs with the compiled Radau method need it (20-40 s of CPU, one notice).

    Call it as ``radau_entry(v)(fdat, idat, fin, C, A, atol, Pf, y, f, J, LUr, pr, LUc, pc, Z, Qd, ynew, fnew,
    st, *v)`` (radau.radau_step's arguments).
    """
    return _variant_entry("radau_step", v)


def _variant_entry(name, v):
    """The dispatcher of the entry point ``name`` of _VARIANT_ENTRIES with variant v's signature compiled
    (or loaded from numba's cache), with a notice on stderr before a compile."""
    ready = _state["lazy"].get((name, v))
    if ready is not None:
        return ready
    ensure_compiled(v)  # the shared helpers and dispatchers exist from here on
    sig, what = _VARIANT_ENTRIES[name]
    with _lock:
        d = _state["dispatchers"].get(name, _PY_FUNCTIONS[name])
        if hasattr(d, "disable_compile"):
            t0 = time.perf_counter()
            if not _entry_cached(d, sig, v):
                print(f"gibbsimpact: compiling {what} ...", file=sys.stderr, flush=True)
            d.disable_compile(False)
            try:
                d.compile(sig.format(*_signature_args(v)))
            finally:
                d.disable_compile()
            _state["seconds"][(name, v)] = time.perf_counter() - t0
        _state["lazy"][(name, v)] = d
    return d


def _entry_cached(d, sig, v) -> bool:
    """True if numba's on-disk cache holds the signature sig of variant v of dispatcher d (no notice then)."""
    try:
        index = d._cache._cache_file._load_index()
        want = sig.format(*_signature_args(v)).replace(" ", "")
        return any(str(key[0]).replace(" ", "") == want for key in index)
    except Exception:  # no cache, numba internals changed
        return False


def _cache_is_warm(v):
    """True if numba's on-disk cache holds a valid entry of variant ``v`` (False: a
    compile is coming; None: cannot tell)."""
    try:
        # The index is stamped with the kernel's source key: a stale one loads as empty.
        index = _kernel_cache(_PY_KERNEL)._cache_file._load_index()
        # Keys: (signature text as compiled, codegen's magic tuple, ...).
        want = _ENTRY_SIG.format(*_signature_args(v)).replace(" ", "")
        return any(str(key[0]).replace(" ", "") == want for key in index)
    except Exception:  # no cache location, numba internals changed, JIT disabled ...
        return None


def ensure_compiled(v=PRISMATIC):
    """Compile variant ``v`` (RIGID_ENDS, REVOLUTE, PRISMATIC) of the kernel on first use (or
    load it from numba's cache); cheap afterwards.

    A one-line notice goes to stderr before a compile (15-30 s of CPU, _VARIANT_COST);
    loading from the cache (~0.5 s) is silent. If the cache state cannot be read, the
    notice appears once compiling has taken NOTICE_AFTER_S.
    """
    if v in _state["ready"]:
        return
    with _lock:
        if v in _state["ready"]:
            return
        t0 = time.perf_counter()
        shown = []
        what = _VARIANT_NAME[v]
        cost = _VARIANT_COST[v]

        def notice():
            shown.append(True)
            print(f"gibbsimpact: compiling the dynamics kernel for {what} (first use; {cost} of CPU) ...",
                  file=sys.stderr, flush=True)

        warm = None if jit_disabled() else _cache_is_warm(v)
        timer = None
        if warm is False:
            notice()
        elif warm is None and not jit_disabled():
            timer = threading.Timer(NOTICE_AFTER_S, notice)
            timer.daemon = True
            timer.start()
        try:
            _compile_variant(v)
        finally:
            if timer is not None:
                timer.cancel()
        _state["seconds"][v] = time.perf_counter() - t0
        _state["ready"].add(v)
        if shown:
            where = (" and cached for later runs" if _state["cached"] else
                     " (not cached: no writable cache directory; set NUMBA_CACHE_DIR to one)")
            print(f"gibbsimpact: kernel ready in {_state['seconds'][v]:.1f} s{where}", file=sys.stderr,
                  flush=True)


def jit_disabled() -> bool:
    """True when numba runs the kernel as plain Python (NUMBA_DISABLE_JIT=1)."""
    return os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")
