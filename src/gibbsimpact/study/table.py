"""The table of a sweep: its columns, each run's row read from its result file, CSV, Parquet, figure.

Columns (one row per run, in sweep order): ``run`` (1-based), ``run_id``, one column per
varied key, then RESULT_COLUMNS:

============================  ====  ==========================================================
column                        unit  value, from the run's Result (``runs/<id>.npz``)
============================  ====  ==========================================================
``status``, ``message``             the Result's (or ``invalid`` / ``error`` / ``pending``)
``n_impacts``                       impacts (ImpactRecord): simultaneous contacts count once
``first_impact_s``            s     time of the first impact; empty without impacts
``t_final_s``                 s     last sample (where a run that stopped early stopped)
``energy_lost_J``             J     E(t_0) - E(t_end): total mechanical energy (kinetic +
                                    gravitational + strain, Result.energy()) at the first
                                    sample minus at the last one (see energy_lost)
``max_impulse_N_s``           N s   largest normal impulse Lambda of one contact in any
                                    impact; 0 without impacts (see max_impulse)
``max_deflection_m``          m     largest transverse deflection sqrt(v^2 + w^2) of any
                                    link point at any stored sample; 0 for rigid links
                                    (see max_deflection)
``energy_error``                    Result.energy_error (max relative drift in flight)
``nfev``                            right-hand-side evaluations
``wall_time_s``               s     the run's wall-clock time
``result``                          ``runs/<id>.npz``, relative to the table's folder
============================  ====  ==========================================================

A row without a result (invalid, error, pending) has only status and message. Numbers are
written as the shortest text that reads back to the same double; an empty cell is "no value".
Every row with a result is computed from its file, so a fresh row and a resumed row are the
same text; it is computed in the process that called sweep (a dask client too), whose
energy_lost_J evaluates the energy with the compiled kernel (loaded from numba's cache, compiled
on first use), and max_deflection_m costs about 30 us per sample and flexible link. :func:`plot_sweep` draws a numeric column over one or two varied keys.
"""

from __future__ import annotations

import json
from numbers import Real
from pathlib import Path

import numpy as np

from ..io.result_files import atomic_path
from ..model.model import link_deflection
from ..simulation.status import STATUS_BUDGET_EXCEEDED

RUNS_DIR = "runs"
#: [solver] keys of a run's limits: they decide where a run too costly for them stops, not its result.
LIMIT_KEYS = ("max_cpu_time_s", "max_rhs_calls")
#: Columns after ``run``, ``run_id`` and the varied keys.
RESULT_COLUMNS = ("status", "message", "n_impacts", "first_impact_s", "t_final_s", "energy_lost_J",
                  "max_impulse_N_s", "max_deflection_m", "energy_error", "nfev", "wall_time_s", "result")
#: The columns plot_sweep draws (numbers of every row with a result).
PLOT_COLUMNS = ("n_impacts", "first_impact_s", "t_final_s", "energy_lost_J", "max_impulse_N_s",
                "max_deflection_m", "energy_error", "nfev", "wall_time_s")
#: Points per link at which max_deflection evaluates the deflection: x_j = j l / 40, j = 0 ... 40.
DEFLECTION_POINTS = 41
#: Parquet types of the result columns (a varied key's type is inferred).
_INTEGER_COLUMNS = ("run", "n_impacts", "nfev")
_TEXT_COLUMNS = ("run_id", "status", "message", "result")


# --------------------------------------------------------------------------
# Derived columns

def energy_lost(result) -> float:
    """Energy lost over a run [J]: E(t_0) - E(t_end) of the first and last samples.

    E = kinetic + gravitational + strain energy (Result.energy(), docs/theory.md §5). Positive
    when energy left the chain: impacts with e < 1, friction, structural damping, the removal
    of the remaining normal velocity at an accumulation. It also holds the integration drift
    (bounded by Result.energy_error) and, with inputs, minus their work (Result.work).
    """
    total = result.energy().total
    return float(total[0] - total[-1])


def max_impulse(result) -> float:
    """Largest normal impulse [N s] of one contact in any impact: max over the impacts and their
    contacts of ImpactRecord.impulses (Lambda >= 0; an end stop's impulse is along its joint
    axis); friction impulses are not counted. 0.0 for a run without impacts."""
    return max((float(np.max(r.impulses)) for r in result.impacts if len(r.impulses)), default=0.0)


def max_deflection(result, n_points: int = DEFLECTION_POINTS) -> float:
    """Largest transverse deflection [m] of any link point over the stored samples.

        max over samples k, links i, x_j = j l_i / (n_points - 1) (j = 0 ... n_points - 1)
        of sqrt(v_i(x_j, q_k)^2 + w_i(x_j, q_k)^2)

    with (v, w) = model.link_deflection (in link i's own frame: the distance of the material
    point from the link's undeformed x axis; for a link in a FixedPrismatic guide only its
    protruding part bends). Samples are those of Result.t (the output grid and the instants
    before and after each impact): a peak between samples is not seen. 0.0 for rigid links.
    """
    largest = 0.0
    for i, link in enumerate(result.model.chain.links):
        if len(result.model.delta_index[i]) == 0:
            continue
        x = np.linspace(0.0, link.length, n_points)
        for q in result.q:
            largest = max(largest, float(np.max(np.hypot(*link_deflection(result.model, q, i, x)))))
    return largest


def result_columns(result, path: Path) -> dict:
    """{column: value} of RESULT_COLUMNS for a run's Result read from ``path`` (runs/<id>.npz)."""
    return {
        "status": result.status, "message": result.message, "n_impacts": len(result.impacts),
        "first_impact_s": float(result.impacts[0].time) if result.impacts else None,
        "t_final_s": float(result.t[-1]) if len(result.t) else None,
        "energy_lost_J": energy_lost(result) if len(result.t) else None,
        "max_impulse_N_s": max_impulse(result), "max_deflection_m": max_deflection(result),
        "energy_error": float(result.energy_error), "nfev": int(result.nfev),
        "wall_time_s": float(result.wall_time), "result": f"{RUNS_DIR}/{path.name}",
    }


def run_limits(case_table) -> dict:
    """{key of LIMIT_KEYS: its value, None when not set} of a run's case table (its [solver])."""
    solver = case_table.get("solver") if isinstance(case_table, dict) else None
    solver = solver if isinstance(solver, dict) else {}
    return {k: solver.get(k) for k in LIMIT_KEYS}


def _row_from_file(path: Path, rid: str, limits: dict | None = None):
    """The result columns of a run from its NPZ file, or None when it is missing, unreadable or another run's,
    or when it stopped with status budget_exceeded under other limits than ``limits`` (run_limits)."""
    from ..io.result_files import load_result

    if not path.is_file():
        return None
    try:
        res, meta = load_result(path, with_metadata=True)
    except Exception:  # noqa: BLE001 - a damaged file is a run still to do
        return None
    if not isinstance(meta, dict) or meta.get("run_id") != rid:
        return None
    if limits is not None and res.status == STATUS_BUDGET_EXCEEDED and run_limits(meta.get("case_data")) != limits:
        return None
    return result_columns(res, path)


def _row_without_result(status: str, message: str) -> dict:
    return {c: None for c in RESULT_COLUMNS} | {"status": status, "message": message}


# --------------------------------------------------------------------------
# Files

def _write_atomic(path: Path, write) -> Path:
    """Call write(binary file object) on a temporary file beside ``path`` and move it into place
    (io.atomic_path: synced, then os.replace; nothing left behind on an error)."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            write(fh)
    return path


def _cell(v) -> str:
    """Table text of a value: shortest round-trip text of a float, JSON for booleans and arrays, '' for None."""
    if v is None:
        return ""
    if isinstance(v, bool) or isinstance(v, (list, dict)):
        return json.dumps(v)
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _write_csv(path: Path, columns: list, rows: list) -> Path:
    import csv
    import io

    text = io.StringIO()
    w = csv.writer(text, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in columns])
    return _write_atomic(path, lambda fh: fh.write(text.getvalue().encode("utf-8")))


def _write_parquet(path: Path, columns: list, rows: list):
    """Write the table as Parquet when pyarrow is importable; otherwise remove a stale one and return None."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        path.unlink(missing_ok=True)
        return None
    types = {c: pa.float64() for c in RESULT_COLUMNS} | {c: pa.int64() for c in _INTEGER_COLUMNS} \
        | {c: pa.string() for c in _TEXT_COLUMNS}
    arrays = {}
    for c in columns:
        values = [r.get(c) for r in rows]
        if any(isinstance(v, (list, dict)) for v in values):
            values = [None if v is None else _cell(v) for v in values]
        try:
            arrays[c] = pa.array(values, type=types.get(c))  # a varied key: its type inferred
        except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError):  # mixed kinds in one column
            arrays[c] = pa.array([None if v is None else _cell(v) for v in values], type=pa.string())
    table = pa.table(arrays)
    return _write_atomic(path, lambda fh: pq.write_table(table, fh))


# --------------------------------------------------------------------------
# The figure

def varied_keys(columns) -> list:
    """The varied keys of a table's columns: those between ``run_id`` and RESULT_COLUMNS."""
    return [c for c in columns if c not in ("run", "run_id") and c not in RESULT_COLUMNS]


def numeric_keys(keys, values) -> list:
    """The keys whose values are all real numbers (no booleans): the keys a figure can have as x.

    values : callable(key) -> the values of that key over the runs (None where a run does not set it)
    """
    return [k for k in keys if all(isinstance(v, Real) and not isinstance(v, bool) for v in values(k))]


def plot_keys(keys, column: str, x=None, lines=None, numeric=None) -> tuple:
    """(x, lines) of plot_sweep for a sweep varying ``keys``; ValueError naming the argument and the fix.

    numeric : the keys whose values are all numbers (numeric_keys; None: every key). Defaults:
    x the first numeric key (other than ``lines``), lines the other key when two are varied.
    """
    if column not in PLOT_COLUMNS:
        raise ValueError(f"column: {column!r} cannot be drawn; give one of {', '.join(PLOT_COLUMNS)}")
    keys = list(keys)
    if len(keys) > 2:
        raise ValueError(f"this sweep varies {len(keys)} keys ({', '.join(keys)}); a sweep figure draws a column "
                         "over at most two (x and lines): plot a sweep of one or two keys")
    numeric = keys if numeric is None else list(numeric)
    for name, key in (("x", x), ("lines", lines)):
        if key is not None and key not in keys:
            raise ValueError(f"{name}: {key!r} is not a varied key of this sweep; give one of {', '.join(keys)}")
    x = x if x is not None else next((k for k in numeric if k != lines), None)
    if x is None:
        raise ValueError("x: no varied key has a number in every run; a sweep figure needs one for its horizontal axis")
    if x not in numeric:
        raise ValueError(f"x: {x} does not have a number in every run; draw against a key of numbers "
                         "(a key of strings or arrays can be lines=)")
    if lines is None and len(keys) == 2:
        lines = next(k for k in keys if k != x)
    if x == lines:
        raise ValueError(f"lines: {lines!r} is already x; give another varied key or none")
    return x, lines


def plot_sweep(result, column: str, x=None, lines=None, dpi: int = 120, save: bool = True):
    """Draw one column of a sweep's table against a varied key: ``<out>/sweep_<column>.png``.

    result : SweepResult (gi.sweep's return value)
    column : a name of PLOT_COLUMNS, e.g. "energy_lost_J", "max_impulse_N_s"
    x : varied key on the horizontal axis (its values numbers); default the first varied key
        whose values are all numbers
    lines : varied key drawn as one line per value; default the other varied key, if any
    dpi : resolution of the PNG file; save : False draws without writing the file

    Returns the matplotlib Figure (plotting.sweep.plot_column: rows without a value are
    left out, runs that did not finish are open markers).
    """
    from ..io.result_files import save_figure
    from ..plotting.sweep import plot_column

    keys = varied_keys(result.columns)
    numeric = numeric_keys(keys, lambda k: [r.get(k) for r in result.rows])
    x, lines = plot_keys(keys, column, x, lines, numeric)
    fig = plot_column(result.rows, column, x, lines, title=f"{column} of the sweep in {result.out}")
    if save:
        save_figure(fig, Path(result.out) / f"sweep_{column}.png", dpi)
    return fig

