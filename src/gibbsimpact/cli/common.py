"""What every command of the command line shares: the exit codes, the error line, loading a CASE.toml argument."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_STOPPED, EXIT_OUTPUT, EXIT_INTERRUPTED = 0, 1, 2, 3, 4, 130
#: How bad an exit code is: with several case files the worst one is the command's.
_SEVERITY = {EXIT_OK: 0, EXIT_STOPPED: 1, EXIT_BAD_INPUT: 2, EXIT_OUTPUT: 3, EXIT_INTERNAL: 4, EXIT_INTERRUPTED: 5}

EXIT_CODES = """exit codes:
  0    every run finished
  1    unexpected error (please report it)
  2    bad input: case file, option, or an output folder that cannot be
       written (one line names every problem); nothing is simulated
  3    a simulation stopped early (zeno, max_impacts, penetration,
       joint_limit: a prismatic joint reached an end of its range, failed,
       callback_failed, budget_exceeded: --max-cpu-time or --max-rhs-calls
       used up); its results up to there are written
  4    the results of a run could not all be written into its output
       folder (disk full, quota, I/O error): summary.json and result.npz
       come first, and go to a temporary folder when the output folder
       refuses them; stderr names what was and was not written, and where
  130  interrupted by Ctrl-C or SIGTERM: the run stops with status
       "interrupted" and its data and summary.json up to there are
       written, not the figures
with several case files the worst code counts (130, 1, 4, 2, 3, 0: worst
first)"""

def _worst(a: int, b: int) -> int:
    return a if _SEVERITY.get(a, 3) >= _SEVERITY.get(b, 3) else b


def _error(msg: str, code: int) -> int:
    print(f"gibbsimpact: error: {msg}", file=sys.stderr)
    return code


def _float(text: str) -> float:
    # Only the syntax here; ranges are the case file's (case.RANGES), checked once the case is loaded.
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


#: Options that override a case-file key (Case.override_problems keyword: its name on the command line).
OPTION_NAMES = {"t_end": "--t-end", "rtol": "--rtol", "atol": "--atol", "output_dt": "--output-dt",
                "method": "--method", "max_cpu_time": "--max-cpu-time", "max_rhs_calls": "--max-rhs-calls"}


def add_rtol_option(parser) -> None:
    """``--rtol`` of ``run`` and ``sweep`` (checked against [solver] rtol's range once the case is loaded)."""
    parser.add_argument("--rtol", type=_float, help="relative tolerance (overrides [solver] rtol)")


def add_method_option(parser) -> None:
    """``--method`` of ``run`` and ``sweep``: a name of simulation.auto.METHODS (checked once the case is loaded)."""
    from ..simulation.auto import METHODS

    parser.add_argument("--method", metavar="METHOD",
                        help="scipy ODE solver, or auto (DOP853 or Radau from the highest frequency) (overrides "
                             "[solver] method): " + ", ".join(METHODS))


def add_limit_options(parser, what: str = "the run") -> None:
    """``--max-cpu-time`` and ``--max-rhs-calls`` of ``run`` and ``sweep``: limits of each run (status
    budget_exceeded, the results kept), checked against their [solver] keys' ranges once the case is loaded."""
    parser.add_argument("--max-cpu-time", type=_float, metavar="S",
                        help=f"stop {what} after S seconds of CPU time with status budget_exceeded, keeping "
                             "what it computed (overrides [solver] max_cpu_time_s)")
    parser.add_argument("--max-rhs-calls", type=_positive_int, metavar="N",
                        help=f"stop {what} after N right-hand-side evaluations, likewise (overrides [solver] "
                             "max_rhs_calls)")


_GIVE_A_CASE = "give the path of a case file (e.g. cases/circle_two_link.toml)"


def _load(path: str):
    """(case, None), or (None, exit code) after one error line naming the CASE.toml argument."""
    from ..case import CaseError, load_case

    p = Path(path)
    if not path:
        return None, _error(f"CASE.toml: '' is not a file; {_GIVE_A_CASE}", EXIT_BAD_INPUT)
    if p.is_dir():
        return None, _error(f"CASE.toml: {path!r} is a directory, not a case file; {_GIVE_A_CASE}", EXIT_BAD_INPUT)
    if not p.exists():
        return None, _error(f"CASE.toml: {path!r}: no such file; {_GIVE_A_CASE}", EXIT_BAD_INPUT)
    if not p.is_file():
        return None, _error(f"CASE.toml: {path!r} is not a regular file; {_GIVE_A_CASE}", EXIT_BAD_INPUT)
    try:
        return load_case(p), None
    except CaseError as exc:
        return None, _error(str(exc), EXIT_BAD_INPUT)
    except OSError as exc:
        return None, _error(f"CASE.toml: {path!r}: cannot read ({exc.strerror or exc})", EXIT_BAD_INPUT)


def _positive_int(text: str) -> int:
    try:
        k = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if k < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {k}")
    return k
