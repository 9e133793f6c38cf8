"""``gibbsimpact sweep CASE.toml --vary KEY=SPEC ...``: the command line of gibbsimpact.study.sweep."""

from __future__ import annotations

import math
import re
import tomllib

from ..case import CaseError
from ..study.sweep import RUNS_DIR, sweep
from ..study.table import PLOT_COLUMNS, _cell, numeric_keys, plot_keys, plot_sweep, varied_keys
from .common import (EXIT_BAD_INPUT, EXIT_OK, EXIT_STOPPED, OPTION_NAMES, _error, _float, _load, _positive_int,
                     add_limit_options, add_method_option, add_rtol_option)

#: The options of ``gibbsimpact run`` that ``sweep`` takes too, set in every run (Case.override_problems keywords).
SWEEP_OPTIONS = ("t_end", "method", "rtol", "max_cpu_time", "max_rhs_calls")


class VaryError(ValueError):
    """A --vary option that cannot be read."""


def _split_list(spec: str) -> list[str]:
    """Split at commas outside brackets and quotes: '[0,0],[1,0]' -> ['[0,0]', '[1,0]']."""
    items, depth, quote, cur = [], 0, None, []
    for ch in spec:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        elif ch == "," and depth == 0:
            items.append("".join(cur).strip())
            cur = []
            continue
        cur.append(ch)
    items.append("".join(cur).strip())
    return items


def _value(text: str):
    """One value of a --vary list: a TOML value (10 -> int, 1e-3, inf, true, [0, 1], "RK45"), else a
    number, else the bare text as a string (RK45)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def parse_vary(option: str) -> tuple[str, list]:
    """``KEY=SPEC`` of ``--vary`` -> (key, values).

    SPEC is ``a:b:n`` (n values from a to b evenly spaced, both ends included,
    rounded to 15 significant digits so that 0.5:1:6 gives 0.5, 0.6, ..., 1.0) or a
    comma list of values (``10,20,40``; ``RK45,DOP853``; ``[0,0],[0.1,0]``).
    """
    key, eq, spec = option.partition("=")
    key, spec = key.strip(), spec.strip()
    if not eq or not key or not spec:
        raise VaryError(f"--vary {option}: expected KEY=a:b:n or KEY=v1,v2,... "
                        "(e.g. restitution=0.5:1:6 or links.1.EI_N_m2=10,20,40)")
    m = re.fullmatch(r"([^:,\[\]]+):([^:,\[\]]+):([^:,\[\]]+)", spec)
    if m:
        try:
            a, b = float(m.group(1)), float(m.group(2))
            n = int(m.group(3))
        except ValueError:
            raise VaryError(f"--vary {option}: a:b:n needs numbers a, b and a whole number n >= 1") from None
        if n < 1 or not (math.isfinite(a) and math.isfinite(b)):
            raise VaryError(f"--vary {option}: a:b:n needs finite a, b and a whole number n >= 1")
        if n == 1:
            return key, [a]
        # x_k = a + k (b - a) / (n - 1), the last exactly b (numpy.linspace's rule).
        step = (b - a) / (n - 1)
        return key, [float(f"{a + k * step:.15g}") for k in range(n - 1)] + [b]
    items = _split_list(spec)
    if any(not s for s in items):
        raise VaryError(f"--vary {option}: an empty value in the list")
    return key, [_value(s) for s in items]


def add_parser(subparsers):
    """Register the ``sweep`` subcommand on an argparse subparsers object; returns its parser."""
    s = subparsers.add_parser(
        "sweep", help="run a case over a grid of key values; one table of the runs",
        description="Run CASE for every combination of the --vary values (the last varying fastest) and write "
                    "sweep.csv (one row per run: its values, status, impacts, energy lost, largest impulse, "
                    "largest deflection, energy error, wall time, result file) and runs/<run id>.npz. Runs "
                    "already in the output folder are not run again.",
        epilog="Exit codes: 0 every run finished, 2 bad input, 3 some run stopped early or failed.")
    s.add_argument("case", metavar="CASE.toml", help="case file")
    s.add_argument("--vary", action="append", required=True, metavar="KEY=SPEC",
                   help="a case-file key and its values: KEY=a:b:n (n values from a to b) or KEY=v1,v2,...; "
                        "repeat for a grid, e.g. --vary restitution=0.5:1:6 --vary links.1.EI_N_m2=10,20,40")
    s.add_argument("--workers", type=_positive_int, default=1, metavar="K",
                   help="processes running the sweep (default 1: in this process)")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help='run on a dask.distributed cluster, e.g. tcp://host:8786 (pip install "gibbsimpact[dask]")')
    s.add_argument("--out", metavar="DIR",
                   help="sweep folder (default: <[output] directory, else out/<case name>>/sweep)")
    s.add_argument("--t-end", type=_float, metavar="T", help="end time of every run in s (overrides [time] t_end_s)")
    add_method_option(s)
    add_rtol_option(s)
    add_limit_options(s, "each run")
    s.add_argument("--plot", action="append", metavar="COLUMN", default=[],
                   help="draw a column of the table against the first varied key of numbers (one line per value "
                        "of the other key) into sweep_<COLUMN>.png; repeat for several: " + ", ".join(PLOT_COLUMNS))
    s.add_argument("--quiet", "-q", action="store_true", help="no line per run and no report on stdout")
    return s


def _describe_values(row: dict, keys) -> str:
    return " ".join(f"{k}={_cell(row[k])}" for k in keys if row.get(k) is not None)


def _grid(args) -> dict:
    """{key: values} of the --vary options (VaryError for a bad one or a key given twice)."""
    grid = {}
    for option in args.vary:
        key, values = parse_vary(option)
        if key in grid:
            raise VaryError(f"--vary {option}: {key} is already varied; give all its values in one --vary")
        grid[key] = values
    return grid


def _check(args, case, grid: dict):
    """The error line of the first bad option (2 returned), or None: the options of every run
    (--t-end, --method, --rtol as ``run`` checks them) and --plot (a column and at most two keys)."""
    options = {kw: getattr(args, kw) for kw in SWEEP_OPTIONS if getattr(args, kw) is not None}
    problems = case.override_problems(names=OPTION_NAMES, **options)
    if problems:
        return _error(str(CaseError("options", problems)), EXIT_BAD_INPUT)
    for column in args.plot:
        try:
            plot_keys(grid, column, numeric=numeric_keys(grid, grid.get))
        except ValueError as exc:
            return _error(f"--plot {column}: {exc}", EXIT_BAD_INPUT)
    return None


def _progress(say):
    """The progress callback of the sweep: one line per run done."""
    def progress(row, done, total):
        varied = varied_keys(row)
        impacts = f", {row['n_impacts']} impacts" if row["n_impacts"] is not None else ""
        took = f", {row['wall_time_s']:.2f} s" if row["wall_time_s"] is not None else ""
        say(f"  [{done}/{total}] run {row['run']} ({row['run_id']}) {_describe_values(row, varied)}: "
            f"{row['status']}{impacts}{took}")

    return progress


def _draw(result, columns, dpi: int, say) -> int | None:
    """Draw each --plot column of the sweep into sweep_<column>.png; 2 after an error line, else None."""
    for column in columns:
        try:
            plot_sweep(result, column, dpi=dpi)
        except (ValueError, OSError) as exc:
            return _error(f"--plot {column}: {exc}", EXIT_BAD_INPUT)
        say(f"figure: {result.out / f'sweep_{column}.png'}")
    return None


def main(args) -> int:
    """Run ``gibbsimpact sweep`` from parsed arguments (add_parser); returns the exit code.

    0 every run finished; 2 bad input (case file, --vary, options, --plot, output folder,
    dask missing or unreachable); 3 some run stopped early, was invalid or failed
    (the table, every result and the figures are still written).
    """
    case, code = _load(args.case)
    if case is None:
        return code
    try:
        grid = _grid(args)
    except VaryError as exc:
        return _error(str(exc), EXIT_BAD_INPUT)
    bad = _check(args, case, grid)
    if bad is not None:
        return bad
    say = (lambda s: None) if args.quiet else (lambda s: print(s, flush=True))
    route = (f"on the dask scheduler {args.scheduler}" if args.scheduler else
             f"on {args.workers} processes" if args.workers > 1 else "in this process")
    say(f"gibbsimpact: sweep of {case.name} over {', '.join(grid)}, {route}")
    try:
        result = sweep(case, grid, workers=args.workers, out=args.out, scheduler=args.scheduler,
                       t_end=args.t_end, progress=_progress(say), method=args.method, rtol=args.rtol,
                       max_cpu_time=args.max_cpu_time, max_rhs_calls=args.max_rhs_calls)
    except CaseError as exc:
        if exc.source == "overrides":
            exc = CaseError("--vary", exc.problems)
        return _error(str(exc), EXIT_BAD_INPUT)
    except ImportError as exc:
        return _error(str(exc), EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        return _error("interrupted; the runs done are kept: run the same command again to resume", 130)
    except OSError as exc:
        where = f"scheduler {args.scheduler}" if args.scheduler else "the output folder"
        return _error(f"{where}: {exc.strerror or exc}", EXIT_BAD_INPUT)
    return _report(result, args, case, say)


def _report(result, args, case, say) -> int:
    """The summary lines and figures of a finished sweep; its exit code (0, or 3 when a run did not finish)."""
    counts = result.status_counts()
    say(f"{len(result.rows)} runs: " + ", ".join(f"{n} {s}" for s, n in counts.items())
        + f" ({result.n_run} run now, {result.n_skipped} already done)")
    say(f"table: {result.table}" + (f" and {result.parquet}" if result.parquet else "")
        + f"; results in {result.out / RUNS_DIR}")
    bad = _draw(result, args.plot, case.output["dpi"], say)
    if bad is not None:
        return bad
    if not result.all_finished:
        bad = [r for r in result.rows if r["status"] != "finished"]
        first = bad[0]
        return _error(f"{len(bad)} of {len(result.rows)} runs did not finish (first: run {first['run']}, "
                      f"{first['status']}: {first['message']}); see {result.table}", EXIT_STOPPED)
    return EXIT_OK
