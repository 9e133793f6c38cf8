"""Parameter sweeps: one case, many overrides of its keys, one tidy table.

```python
from gibbsimpact.sweep import sweep
sw = sweep("cases/circle_two_link.toml",
           {"restitution": [0.5, 0.75, 1.0], "links[1].EI_N_m2": [10, 20, 40]},
           workers=2, out="out/my_sweep")
sw.table        # out/my_sweep/sweep.csv: one row per run
sw.rows[0]      # {"run": 1, "run_id": ..., "restitution": 0.5, ..., "status": "finished", ...}
```

and from the shell ``gibbsimpact sweep CASE.toml --vary restitution=0.5:1:6
--vary links.1.EI_N_m2=10,20,40 [--workers K] [--scheduler ADDRESS] [--method M]
[--rtol R] [--plot COLUMN]``.

Decisions
---------
* **Key paths are those of the case file** (docs/case-format.md) and of its
  messages: ``restitution``, ``time.t_end_s``, ``solver.rtol``,
  ``initial.coordinates.theta_1_deg``, ``links[1].EI_N_m2``,
  ``walls[1].radius_m``. Entries of arrays of tables are numbered from 1 and
  may also be written ``links.1.EI_N_m2`` (the shell form). There are no
  aliases: ``restitution`` *is* the path of the global coefficient (the
  top-level key); a wall's own one is ``walls[1].restitution``. Columns of the
  table and messages use the bracket form. A missing table on the way is
  created (``solver.rtol`` in a case without ``[solver]``); a missing entry of
  an array of tables (``links[3]`` of a two-link chain) is an error.
* **An override edits the parsed TOML table** (``Case.source``) and the result
  goes through the normal loader (``case_from_dict``), so a bad value gives the
  message a case file with that value would give.
* **Grid order**: a dict ``{key: values}`` is the full Cartesian product in the
  order the keys are given, the last key varying fastest (nested loops,
  ``itertools.product``). A value that is not a list, tuple or array is a single
  value; a vector key therefore takes a list of vectors
  (``{"gravity_m_per_s2": [[0, -9.81, 0], [0, -1.62, 0]]}``). A list of dicts
  is an explicit list of runs (keys may differ between runs; a key a run does
  not set keeps the case's value and its cell is empty).
* **Checked before any run**: the key paths, and every distinct (key, value)
  pair applied alone to the case: a problem the loader reports *at that key or
  below it* (unknown key, wrong type, out of range, too stiff a link ...) makes
  the sweep raise one :class:`~gibbsimpact.case.CaseError` (source
  ``"overrides"``) listing every such problem, before anything runs or is
  written. Problems of a combination, or elsewhere in the case (a joint
  outside a wall, a singular mass matrix), belong to the run: its row has
  status ``"invalid"`` and the loader's message. A run whose simulation raises
  has status ``"error"`` and ``"<ExceptionType>: <message>"``; a run that stops
  early keeps the simulator's status (``zeno``, ``max_impacts``,
  ``penetration``, ``failed``, ``budget_exceeded``...) and message. No failure loses the sweep.
* **Run id**: the first 16 hex digits of SHA-256 of the canonical JSON of the
  case actually run (the case table with the overrides applied, without
  ``name``, ``description`` and ``[output]``, which do not change the result, and the
  run's limits ``solver.max_cpu_time_s`` and ``solver.max_rhs_calls``, which only decide
  where a run too costly for them stops;
  integers that fit a double hashed as floats, so ``20`` and ``20.0`` are one
  run). The same run in two sweeps (or spelt ``links.1`` and ``links[1]``) has
  one id; editing the case file changes the ids of the runs it affects.
  Duplicate runs in one sweep are an error. The id does not cover the version
  of gibbsimpact: after an upgrade, remove ``runs/`` to recompute.
* **Files** (``out`` defaults to ``<case output directory>/sweep``, i.e.
  ``out/<case name>/sweep``): ``runs/<run id>.npz`` is the run's whole Result
  (``gi.load_result``; its metadata hold the run id, the overrides and the case
  table run), ``sweep.csv`` the table, ``sweep.parquet`` the same table when
  pyarrow is importable (a stale one is removed when it is not). Every file is
  written to a temporary file in its folder and moved into place with
  ``os.replace``, so a file present is complete.
* **Table**: one row per run in grid (or list) order: ``run`` (1-based),
  ``run_id``, one column per varied key, then ``status``, ``message``,
  ``n_impacts``, ``first_impact_s``, ``t_final_s``, the derived columns
  ``energy_lost_J``, ``max_impulse_N_s``, ``max_deflection_m``, then
  ``energy_error``, ``nfev``, ``wall_time_s``, ``result`` (each defined, with
  its unit, in study/table.py). Every row with a result is read back from its
  file, so a fresh row and a resumed row are the same text. ``sw.plot(column)``
  (:func:`plot_sweep`) draws a column over one or two varied keys into
  ``sweep_<column>.png``.
* **Options of every run**: ``t_end``, ``method``, ``rtol``, ``max_cpu_time``
  and ``max_rhs_calls`` set ``time.t_end_s``, ``solver.method``, ``solver.rtol``,
  ``solver.max_cpu_time_s`` and ``solver.max_rhs_calls`` of the case before the
  overrides, checked as ``gibbsimpact run`` checks its options of those names
  (Case.override_problems); they are part of every run's case (the first three
  of its id), not columns. A key both varied and set by an option is
  an error.
* **Limits**: ``max_cpu_time`` [s] and ``max_rhs_calls`` bound each run (status
  ``budget_exceeded``, its samples kept, a row like any other: the sweep goes on),
  so that one stiff point cannot stall a sweep. A run stopped by a CPU limit
  depends on the machine's speed: its row is not reproducible bit for bit.
* **Resume**: a run whose result file exists, reads back (``gi.load_result``)
  and carries its run id is not run again, unless it stopped with
  ``budget_exceeded`` under other limits than this sweep's (raise the limit and
  run the sweep again: only those runs run again). ``invalid`` and ``error`` rows
  have no result file and are retried. An interrupted sweep (Ctrl-C, an exception)
  still writes the table, with status ``"pending"`` for the runs not done.
* **Routes**: ``workers=1`` runs serially in this process; ``workers=K > 1`` on
  a ``concurrent.futures.ProcessPoolExecutor`` with the *spawn* start method
  (the same on every OS, and no fork of a process that may hold threads; a
  script that sweeps with workers needs ``if __name__ == "__main__":``; a
  single run left to do runs here);
  ``scheduler=`` (an address ``"tcp://host:8786"``, a ``distributed.Client``
  or anything ``distributed.Client`` accepts, e.g. a ``LocalCluster``) on
  dask.distributed, imported only then (``pip install "gibbsimpact[dask]"``)
  and reached before anything is written; ``workers`` is then the cluster's
  business. Every route calls the same
  module-level :func:`_run_task` with plain data (the case table of the run,
  its name and source) and gets plain data back (status and message, or the
  bytes of the NPZ file), so no model object crosses a process and remote
  workers need no shared file system (the client writes every file). Worker
  processes load the compiled kernel from numba's on-disk cache (the pool
  route compiles or loads it in this process first, so that the workers do
  not all compile it at once). The runs are deterministic, so the three routes
  give the same table bit for bit except ``wall_time_s``.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from numbers import Integral, Real
from pathlib import Path

from ..case import OVERRIDE_KEYS, Case, CaseError, case_from_dict, load_case
from ..case.keypaths import PathProblem, assign, resolve, within
from .table import (LIMIT_KEYS, RESULT_COLUMNS, RUNS_DIR, _row_from_file, _row_without_result, _write_atomic,
                    _write_csv, _write_parquet, plot_sweep, run_limits)

__all__ = ["SweepResult", "sweep", "expand_runs", "run_id", "plot_sweep", "TABLE_NAME", "PARQUET_NAME",
           "RUNS_DIR", "RESULT_COLUMNS"]

TABLE_NAME = "sweep.csv"
PARQUET_NAME = "sweep.parquet"
#: Statuses of a row besides those of a Result (gibbsimpact.simulation.status.STATUSES).
STATUS_INVALID = "invalid"  # the loader rejected the run's case (e.g. a joint outside a wall)
STATUS_ERROR = "error"  # the simulation raised, or the worker running it died
STATUS_PENDING = "pending"  # not run: the sweep was interrupted
#: Top-level case keys that do not change a run's result: left out of the run id.
_NOT_IN_RUN_ID = ("name", "description", "output")
_DASK_HINT = 'running a sweep on a dask cluster needs dask.distributed: pip install "gibbsimpact[dask]"'


@dataclass(frozen=True)
class SweepResult:
    """What :func:`sweep` returns.

    Attributes
    ----------
    out : Path, the sweep folder
    table : Path, ``out/sweep.csv``
    parquet : Path or None, ``out/sweep.parquet`` (None without pyarrow)
    columns : tuple of str, the table's columns
    rows : tuple of dict, one per run in sweep order, {column: value}; None for an empty cell
    n_run : int, runs simulated by this call
    n_skipped : int, runs whose result file was already there
    """

    out: Path
    table: Path
    parquet: Path | None
    columns: tuple
    rows: tuple
    n_run: int
    n_skipped: int

    @property
    def all_finished(self) -> bool:
        """True when every run reached its end time (status "finished")."""
        return all(r["status"] == "finished" for r in self.rows)

    def status_counts(self) -> dict:
        """{status: number of rows}, in order of first appearance."""
        counts = {}
        for r in self.rows:
            counts[r["status"]] = counts.get(r["status"], 0) + 1
        return counts

    def plot(self, column: str, x=None, lines=None, dpi: int = 120, save: bool = True):
        """Draw ``column`` against a varied key into ``out/sweep_<column>.png``: see :func:`plot_sweep`."""
        return plot_sweep(self, column, x=x, lines=lines, dpi=dpi, save=save)


# --------------------------------------------------------------------------
# Key paths and values

def _plain(value, key: str):
    """A value as TOML data: bool, int, float, str, or lists and tables of them (numpy scalars and arrays too)."""
    if isinstance(value, (bool, str)):
        return value
    if isinstance(value, Integral):
        return int(value)
    if isinstance(value, Real):
        return float(value)
    if isinstance(value, Mapping):
        return {str(k): _plain(v, key) for k, v in value.items()}
    if isinstance(value, (list, tuple)) or hasattr(value, "tolist"):
        v = value.tolist() if hasattr(value, "tolist") else value
        return [_plain(x, key) for x in v] if isinstance(v, list) else _plain(v, key)
    raise PathProblem(key, f"cannot set it to {type(value).__name__} {value!r}; give a number, a string, "
                           "a boolean or an array of them")


def _hashable(x):
    """x with integers that fit a double as floats (20 and 20.0 are one run) and keys sorted by json."""
    if isinstance(x, bool) or x is None or isinstance(x, str):
        return x
    if isinstance(x, int):
        return float(x) if abs(x) <= 2**53 else x
    if isinstance(x, float):
        return x
    if isinstance(x, dict):
        return {str(k): _hashable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_hashable(v) for v in x]
    return repr(x)


def _canonical_json(x) -> str:
    return json.dumps(_hashable(x), sort_keys=True, separators=(",", ":"), allow_nan=True)


def run_id(case_table: dict) -> str:
    """Stable id of one run: 16 hex digits of SHA-256 of the case table it runs.

    case_table : the parsed case (``Case.source``) with the run's overrides applied.
    ``name``, ``description``, ``[output]`` and the limits of [solver] are left out (they do not
    change the result, only where a run stops); integers that fit a double count as floats.
    """
    kept = {k: v for k, v in case_table.items() if k not in _NOT_IN_RUN_ID}
    if isinstance(kept.get("solver"), Mapping):
        kept["solver"] = {k: v for k, v in kept["solver"].items() if k not in LIMIT_KEYS}
    return hashlib.sha256(_canonical_json(kept).encode()).hexdigest()[:16]


def expand_runs(overrides) -> list[dict]:
    """The runs of a sweep, each {key path: value}, in sweep order.

    overrides : {key path: values} -- the Cartesian product in the order of the keys,
        the last varying fastest; a value that is no list, tuple or array is one value --
        or a list of {key path: value}, one per run.
    """
    if isinstance(overrides, Mapping):
        keys = list(overrides)
        values = []
        for k in keys:
            v = overrides[k]
            v = v.tolist() if hasattr(v, "tolist") else v
            values.append(list(v) if isinstance(v, (list, tuple)) else [v])
        return [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*values)]
    if isinstance(overrides, (list, tuple)) and all(isinstance(r, Mapping) for r in overrides):
        return [dict(r) for r in overrides]
    raise TypeError("overrides: give {key path: list of values} (a full grid) or a list of {key path: value} "
                    f"(one per run), got {type(overrides).__name__}")


def _with_overrides(base: dict, run: dict) -> dict:
    """A copy of the case table ``base`` with run = {canonical path: (tokens, value)} applied."""
    data = copy.deepcopy(base)
    for tokens, value in run.values():
        assign(data, tokens, copy.deepcopy(value))
    return data


def _canonical_runs(base: dict, runs: list) -> tuple[list, list]:
    """([{canonical path: (tokens, value)} per run], problems); problems are (path, message)."""
    problems, resolved, out = [], {}, []
    for run in runs:
        canon = {}
        for key, value in run.items():
            try:
                if key not in resolved:
                    resolved[key] = resolve(base, key)
                path, tokens = resolved[key]
                if path in canon:
                    raise PathProblem(path, f"set twice in one run (as {canon[path][2]!r} and {key!r})")
                canon[path] = (tokens, _plain(value, path), key)
            except PathProblem as exc:
                if (exc.path, exc.message) not in problems:
                    problems.append((exc.path, exc.message))
        out.append({p: (t, v) for p, (t, v, _) in canon.items()})
    return out, problems


def _value_problems(base: dict, runs: list, name: str) -> list:
    """Problems of every distinct (key, value) applied alone to the case, at that key or below it."""
    problems, seen = [], set()
    for run in runs:
        for path, (tokens, value) in run.items():
            sig = (path, _canonical_json(value))
            if sig in seen:
                continue
            seen.add(sig)
            try:
                case_from_dict(_with_overrides(base, {path: (tokens, value)}), name=name, source="overrides")
            except CaseError as exc:
                for p, m in exc.problems:
                    if within(p, path) and (p, m) not in problems:
                        problems.append((p, m))
    return problems


# --------------------------------------------------------------------------
# One run (executed by every route)

def _task_case(task: dict):
    """The Case of one run (raises CaseError): built from a copy of its case table."""
    return case_from_dict(copy.deepcopy(task["data"]), name=task["name"], source=task["source"], path=task["path"])


def _run_task(task: dict) -> dict:
    """Load and simulate one run; plain data in and out (what a worker process receives and returns).

    task : {"run_id", "data" (the case table of the run), "name", "source", "path", "overrides"}
    Returns {"run_id", "status", "message", "npz"}: status "result" with the bytes of the
    run's NPZ file (gi.load_result format), or "invalid" / "error" with a message.
    """
    rid = task["run_id"]
    try:
        case = _task_case(task)
    except CaseError as exc:
        return {"run_id": rid, "status": STATUS_INVALID, "message": str(exc), "npz": None}
    try:
        result = case.simulate()
        metadata = {"case": case.name, "case_source": task["source"], "run_id": rid,
                    "overrides": task["overrides"], "case_data": task["data"]}
        with tempfile.TemporaryDirectory(prefix="gibbsimpact_run_") as tmp:
            blob = result.save(Path(tmp) / f"{rid}.npz", metadata=metadata).read_bytes()
    except Exception as exc:  # noqa: BLE001 - a failed run is a row, never a lost sweep
        return {"run_id": rid, "status": STATUS_ERROR, "message": f"{type(exc).__name__}: {exc}", "npz": None}
    return {"run_id": rid, "status": "result", "message": "", "npz": blob}


def _execute_serial(tasks: list, pending: list, on_done) -> None:
    for i in pending:
        on_done(i, _run_task(tasks[i]))


def _failed(task: dict, exc: BaseException) -> dict:
    """The outcome of a run whose worker failed (died, was lost, could not be reached)."""
    return {"run_id": task["run_id"], "status": STATUS_ERROR,
            "message": f"the worker running it failed: {type(exc).__name__}: {exc}", "npz": None}


def _drain(completed, futures: dict, tasks: list, on_done) -> None:
    """Hand each finished future's outcome to on_done; a future that raised (a broken
    pool, a killed dask worker) is a failed run, i.e. a row, not a lost sweep."""
    for f in completed:
        i = futures[f]
        try:
            outcome = f.result()
        except Exception as exc:  # noqa: BLE001 - BrokenProcessPool, KilledWorker, ...: the run is a row
            outcome = _failed(tasks[i], exc)
        on_done(i, outcome)


def _kernel_variant(task: dict):
    """The kernel variant (gibbsimpact.kernel.variant) of a task's model; the prismatic one if
    the task's case is invalid (its run reports that itself)."""
    from ..kernel import PRISMATIC

    try:
        case = _task_case(task)
    except CaseError:
        return PRISMATIC
    return case.model.kernel_data[3]


def _execute_pool(tasks: list, pending: list, on_done, workers: int) -> None:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from ..kernel import ensure_compiled

    # Compile (first use) or load the kernel's variant of these runs here once, so that the
    # workers load it from numba's on-disk cache instead of all compiling it at the same time.
    ensure_compiled(_kernel_variant(tasks[pending[0]]))
    pool = ProcessPoolExecutor(max_workers=min(workers, len(pending)),
                               mp_context=multiprocessing.get_context("spawn"))
    try:
        futures = {pool.submit(_run_task, tasks[i]): i for i in pending}
        _drain(as_completed(futures), futures, tasks, on_done)
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def _distributed():
    """The dask.distributed module; ImportError naming the extra that installs it."""
    try:
        import distributed
    except ImportError as exc:
        raise ImportError(_DASK_HINT) from exc
    return distributed


def _dask_client(scheduler):
    """(client, whether this sweep opened it)."""
    distributed = _distributed()
    if isinstance(scheduler, distributed.Client):
        return scheduler, False
    return distributed.Client(scheduler), True


def _execute_dask(tasks: list, pending: list, on_done, client) -> None:
    import distributed

    futures = {}
    try:
        futures = {client.submit(_run_task, tasks[i], pure=False): i for i in pending}
        _drain(distributed.as_completed(list(futures)), futures, tasks, on_done)
    finally:
        client.cancel([f for f in futures if not f.done()])


# --------------------------------------------------------------------------
# The sweep, step by step

def _base_case(case) -> Case:
    if isinstance(case, Case):
        if not case.source:
            raise ValueError("case: this Case has no case table (Case.source) to override; load it with "
                             "gi.load_case(path) or gi.case.case_from_dict(table)")
        return case
    return load_case(case)


def _check_route(workers, scheduler) -> None:
    """ValueError for a bad ``workers``; ImportError for a ``scheduler`` without dask.distributed."""
    if isinstance(workers, bool) or not isinstance(workers, Integral) or workers < 1:
        raise ValueError(f"workers: give a whole number >= 1 (1 runs serially), got {workers!r}")
    if scheduler is not None:  # before anything is written
        _distributed()


def _base_table(base_case: Case, options: dict) -> dict:
    """A copy of the case table with the options of every run set (``t_end``, ``method``, ``rtol``
    at their case-file keys, OVERRIDE_KEYS), checked as gibbsimpact run checks its options
    (Case.override_problems: a CaseError with source "options")."""
    given = {kw: v for kw, v in options.items() if v is not None}
    problems = base_case.override_problems(**given)
    if problems:
        raise CaseError("options", problems)
    base = copy.deepcopy(base_case.source)
    for kw, v in given.items():
        # Whole numbers stay integers (max_rhs_calls is an integer key); the run id counts 20 and 20.0 as one.
        v = int(v) if isinstance(v, Integral) else float(v) if isinstance(v, Real) else v
        assign(base, tuple(OVERRIDE_KEYS[kw].split(".")), v)
    return base


def _plan(base_case: Case, base: dict, overrides, options: dict) -> tuple[list, list]:
    """(tasks, varied keys): one task per run (its case table, id and overrides), checked before any run.

    Raises CaseError: bad key paths and values (source "overrides"), no runs, duplicate runs,
    a key both varied and set by an option (source "options").
    """
    runs, problems = _canonical_runs(base, expand_runs(overrides))
    if not runs:
        raise CaseError("overrides", [("", "no runs: give at least one value or one run")])
    problems += _value_problems(base, runs, base_case.name)
    if problems:
        raise CaseError("overrides", problems)
    keys = list(dict.fromkeys(p for run in runs for p in run))
    twice = [(OVERRIDE_KEYS[kw], f"is varied and also set for every run by {kw}= (--{kw.replace('_', '-')} on the "
                                 "command line); give it one way")
             for kw, v in options.items() if v is not None and OVERRIDE_KEYS[kw] in keys]
    if twice:
        raise CaseError("options", twice)
    source = str(base_case.path) if base_case.path is not None else base_case.name
    tasks, first = [], {}
    for k, run in enumerate(runs):
        data = _with_overrides(base, run)
        rid = run_id(data)
        if rid in first:
            raise CaseError("overrides", [("", f"runs {first[rid] + 1} and {k + 1} run the same case "
                                              f"(run id {rid}); remove one")])
        first[rid] = k
        tasks.append({"run_id": rid, "data": data, "name": base_case.name, "source": source,
                      "path": str(base_case.path) if base_case.path is not None else None,
                      "overrides": {p: v for p, (_, v) in run.items()}})
    return tasks, keys


def _head(tasks: list, keys: list, k: int) -> dict:
    """The first cells of run k's row: run number, run id, the varied values (None: not set)."""
    return {"run": k + 1, "run_id": tasks[k]["run_id"], **{p: tasks[k]["overrides"].get(p) for p in keys}}


def _rows_found(tasks: list, keys: list, runs_dir: Path) -> list:
    """The row of every run whose result file is there (resume), None for a run still to do."""
    rows = []
    for k, t in enumerate(tasks):
        found = _row_from_file(runs_dir / f"{t['run_id']}.npz", t["run_id"], run_limits(t["data"]))
        rows.append(None if found is None else {**_head(tasks, keys, k), **found})
    return rows


def _open_route(scheduler, pending: list, runs_dir: Path):
    """(dask client or None, whether this sweep opened it), then the runs folder is made.

    The cluster is reached before anything is written: an unreachable scheduler is an
    error, not a table."""
    client, own_client = _dask_client(scheduler) if scheduler is not None and pending else (None, False)
    try:
        runs_dir.mkdir(parents=True, exist_ok=True)
    except BaseException:
        if own_client:
            client.close()
        raise
    return client, own_client


def _recorder(tasks: list, keys: list, rows: list, runs_dir: Path, progress, total: int):
    """(on_done(k, outcome), done): on_done writes run k's result file, fills rows[k] from it,
    appends k to done and reports to ``progress``."""
    done = []

    def on_done(k, outcome):
        rid = tasks[k]["run_id"]
        if outcome["status"] == "result":
            path = _write_atomic(runs_dir / f"{rid}.npz", lambda fh: fh.write(outcome["npz"]))
            found = _row_from_file(path, rid)
            row = found if found is not None else _row_without_result(
                STATUS_ERROR, f"the result file {path} does not read back")
        else:
            row = _row_without_result(outcome["status"], outcome["message"])
        rows[k] = {**_head(tasks, keys, k), **row}
        done.append(k)
        if progress is not None:
            progress(rows[k], len(done), total)

    return on_done, done


def _execute(tasks: list, pending: list, on_done, workers: int, client) -> None:
    """Run the pending tasks on dask (a client), a process pool (workers > 1) or here."""
    if not pending:
        return
    if client is not None:
        _execute_dask(tasks, pending, on_done, client)
    elif workers > 1 and len(pending) > 1:
        _execute_pool(tasks, pending, on_done, workers)
    else:
        _execute_serial(tasks, pending, on_done)


def _write_table(out: Path, columns: list, rows: list, tasks: list, keys: list) -> tuple:
    """(CSV path, Parquet path or None) of the table; a run not done is a "pending" row."""
    for k in range(len(rows)):
        if rows[k] is None:
            rows[k] = {**_head(tasks, keys, k), **_row_without_result(
                STATUS_PENDING, "not run: the sweep was interrupted; run it again to resume")}
    return _write_csv(out / TABLE_NAME, columns, rows), _write_parquet(out / PARQUET_NAME, columns, rows)


def sweep(case, overrides, workers: int = 1, out=None, scheduler=None, t_end: float | None = None,
          progress=None, method: str | None = None, rtol: float | None = None, max_cpu_time: float | None = None,
          max_rhs_calls: int | None = None) -> SweepResult:
    """Run one case many times with keys overridden; write every result and one table.

    Parameters
    ----------
    case : path of a case file, or a Case (from gi.load_case)
    overrides : {key path: list of values} (full grid, last key fastest) or a list of
        {key path: value} (one per run). Key paths as in the case file:
        ``restitution``, ``links[1].EI_N_m2`` (or ``links.1.EI_N_m2``), ``time.t_end_s``,
        ``initial.coordinates.theta_1_deg``; values in the key's unit.
    workers : int >= 1; 1 runs serially here, K > 1 on K spawned processes
    out : folder of the sweep (default ``<case output directory>/sweep``): ``sweep.csv``,
        ``sweep.parquet`` (with pyarrow), ``runs/<run id>.npz``
    scheduler : None, a dask.distributed address ``"tcp://host:port"``, a ``distributed.Client``
        or a cluster object: run on dask (then ``workers`` is ignored)
    t_end : float [s] or None: the end time of every run (sets ``time.t_end_s``)
    progress : callable(row, done, total) or None, called after each run simulated by this
        call (row: that run's table row)
    method, rtol : None, or the scipy solver (a name of simulation.flight.SOLVERS) and the
        relative tolerance of every run (set ``solver.method``, ``solver.rtol``). Like ``t_end``
        they are part of every run's case (and id), not columns.
    max_cpu_time, max_rhs_calls : None, or the limits of every run, CPU seconds and right-hand sides
        (set ``solver.max_cpu_time_s``, ``solver.max_rhs_calls``): a run that uses one up stops with
        status ``budget_exceeded`` and its samples, and the sweep goes on. Not part of the run ids:
        a run stopped by other limits is run again.

    Returns
    -------
    SweepResult (rows in sweep order; ``n_run``, ``n_skipped``); columns: study/table.py.

    Raises
    ------
    CaseError
        Before any run, for a bad key path or a value the case file would reject at that
        key (source ``"overrides"``), duplicate runs, or a bad ``t_end``, ``method``, ``rtol`` or
        limit, or one that sets a varied key (source ``"options"``).
    ImportError
        With a scheduler but without dask.distributed.
    """
    base_case = _base_case(case)
    _check_route(workers, scheduler)
    options = {"t_end": t_end, "method": method, "rtol": rtol, "max_cpu_time": max_cpu_time,
               "max_rhs_calls": max_rhs_calls}
    tasks, keys = _plan(base_case, _base_table(base_case, options), overrides, options)
    columns = ["run", "run_id", *keys, *RESULT_COLUMNS]
    out = Path(out) if out is not None else base_case.output_directory / "sweep"
    runs_dir = out / RUNS_DIR
    rows = _rows_found(tasks, keys, runs_dir)
    pending = [k for k, r in enumerate(rows) if r is None]
    client, own_client = _open_route(scheduler, pending, runs_dir)
    on_done, done = _recorder(tasks, keys, rows, runs_dir, progress, len(pending))
    try:
        _execute(tasks, pending, on_done, workers, client)
    finally:
        if own_client:
            client.close()
        # Also when interrupted: the table shows what is done and what is pending.
        table, parquet = _write_table(out, columns, rows, tasks, keys)
    return SweepResult(out=out, table=table, parquet=parquet, columns=tuple(columns), rows=tuple(rows),
                       n_run=len(done), n_skipped=len(tasks) - len(pending))
