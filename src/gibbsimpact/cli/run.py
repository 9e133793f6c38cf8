"""``gibbsimpact run CASE.toml ...``: check every case and output folder, run the cases, write and report.

The files and their order are cli/outputs.py's; the exit codes cli/common.py's EXIT_CODES.
"""

from __future__ import annotations

import signal
import sys
import threading
import warnings
from contextlib import contextmanager
from pathlib import Path

from .common import (EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK, EXIT_OUTPUT, EXIT_STOPPED,
                     OPTION_NAMES, _error, _load, _worst)
from .outputs import Interrupts, write_outputs
from .report import run_report_lines

#: ``run`` warns before a run whose estimated CPU time exceeds this [s]: ten minutes.
WARN_CPU_SECONDS = 600.0


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def _sigterm_interrupts():
    """Inside the block SIGTERM raises KeyboardInterrupt("SIGTERM"), as Ctrl-C raises KeyboardInterrupt:
    gibbsimpact.simulate then stops the run with status "interrupted". The previous handler comes back after."""
    if not _main_thread():  # signal handlers can only be set there
        yield
        return

    def handler(signum, frame):
        raise KeyboardInterrupt("SIGTERM")

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _note(text: str) -> None:
    try:
        print(text, file=sys.stderr, flush=True)
    except (RuntimeError, OSError, ValueError):  # stderr busy or closed: the note is not essential
        pass


@contextmanager
def _writing_signals(out: Path):
    """While results are written: the first Ctrl-C or SIGTERM is held back (a note on stderr) while the data
    files are written, and drops the figure or animation being drawn (outputs.Interrupts); the next one
    raises KeyboardInterrupt and aborts the writing. Yields the Interrupts that write_outputs reads."""
    interrupts = Interrupts()
    if not _main_thread():
        yield interrupts
        return

    def handler(signum, frame):
        name = signal.Signals(signum).name
        interrupts.held.append(name)
        if len(interrupts.held) > 1:
            raise KeyboardInterrupt(name)
        _note(f"gibbsimpact: {name}: writing the data and summary.json into {out}, without the figures; "
              "send it again to abort the writing")
        if interrupts.abortable:
            raise KeyboardInterrupt(name)

    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield interrupts
    finally:
        for sig, h in previous.items():
            signal.signal(sig, h)


def _check_output(out: Path, label: str) -> int | None:
    """None when ``out`` exists (created here if needed) and takes files, else 2 after one error line."""
    from ..io.result_files import check_directory

    try:
        check_directory(out)
    except OSError as exc:
        return _error(f"{label}: cannot write into {out} ({exc.strerror or exc}); give a writable folder with --out",
                      EXIT_BAD_INPUT)
    return None


def _plan_runs(args, overrides) -> tuple:
    """(exit code, [(path, case, out, label)]): every case loaded and checked, its output folder chosen."""
    from ..case import CaseError

    several = len(args.case) > 1
    code, runs = EXIT_OK, []
    for path in args.case:
        case, bad = _load(path)
        if case is None:
            code = _worst(code, bad)
            continue
        problems = case.override_problems(names=OPTION_NAMES, **overrides)
        if problems:
            code = _worst(code, _error(str(CaseError(f"{path}: options" if several else "options", problems)),
                                       EXIT_BAD_INPUT))
            continue
        if args.out is None:
            out = case.output_directory
            label = f"output folder of {path} ({'[output] directory' if case.output.get('directory') else 'default'})"
        else:
            out = Path(args.out) / Path(path).stem if several else Path(args.out)
            label = f"--out {args.out}"
        runs.append((path, case, out, label))
    targets = {}
    for path, _, out, _ in runs:
        if out.resolve() in targets:
            code = _worst(code, _error(f"{targets[out.resolve()]} and {path} would both write into {out}; "
                                       "rename one of the case files or run them separately", EXIT_BAD_INPUT))
        targets.setdefault(out.resolve(), path)
    return code, runs


def cmd_run(args) -> int:
    """Check every case, its options and its output folder, then run the cases one after the other.

    Nothing runs unless every input is good (exit code 2). The exit code is then the
    worst of the runs; an interrupted run (130) ends the command.
    """
    overrides = {kw: getattr(args, kw) for kw in OPTION_NAMES if getattr(args, kw) is not None}
    code, runs = _plan_runs(args, overrides)
    if code != EXIT_OK:
        return code
    # Every output folder is created and takes a file before anything is simulated.
    for path, case, out, label in runs:
        bad = _check_output(out, label)
        if bad is not None:
            code = _worst(code, bad)
    if code != EXIT_OK:
        return code
    with _sigterm_interrupts():
        for path, case, out, _ in runs:
            code = _worst(code, _run_one(path, case, args, overrides, out))
            if code == EXIT_INTERRUPTED:
                break
    return code


def _run_one(path, case, args, overrides, out) -> int:
    t0, t1 = case.t_span[0], overrides.get("t_end", case.t_span[1])
    say = (lambda s: None) if args.quiet else (lambda s: print(s, flush=True))
    # A tqdm bar over simulated time on a terminal (simulate's progress=True).
    progress = True if not args.quiet and _isatty(sys.stderr) else None
    say(f"gibbsimpact: running {case.name}: t = {t0:g} -> {t1:g} s, N = {case.model.n_dof}, "
        f"{len(case.walls)} wall(s)")
    _say_cost(path, case, overrides, say)
    # Warnings of the run (numpy overflow, ...) are held back and summed up in one
    # line after the status or error line instead of interleaving with it.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")  # each kind once, not once per step
        try:
            code = _simulate_and_write(path, case, args, overrides, out, progress, say)
        except (KeyboardInterrupt, BrokenPipeError):
            raise
        except Exception as exc:  # noqa: BLE001 - one line instead of a traceback; the other cases still run
            code = _error(f"{path}: unexpected {type(exc).__name__}: {exc} (please report this)", EXIT_INTERNAL)
    # Validity warnings (model used outside its assumptions) each get their own line.
    from ..simulation.validity import ValidityWarning

    for w in caught:
        if issubclass(w.category, ValidityWarning):
            print(f"gibbsimpact: {path}: validity warning: {w.message}", file=sys.stderr)
    caught = [w for w in caught if not issubclass(w.category, ValidityWarning)]
    if caught:
        first = caught[0]
        print(f"gibbsimpact: warning: {len(caught)} kind(s) of warning during the run, the first: "
              f"{first.category.__name__}: {first.message} ({Path(first.filename).name}:{first.lineno}); "
              "check the results", file=sys.stderr)
    return code


def _say_cost(path, case, overrides, say) -> None:
    """The run's cost estimate on stdout (gibbsimpact.simulation.cost), and a warning on stderr, even with
    --quiet, when its CPU time exceeds WARN_CPU_SECONDS: what sets the step and what would shorten the run."""
    import numpy as np

    from ..dynamics.gibbs_appell import SingularMassMatrixError
    from ..simulation.cost import duration

    try:
        est = case.estimate_cost(**overrides)
    except (SingularMassMatrixError, ValueError, np.linalg.LinAlgError):
        return  # the run itself reports what is wrong with its initial state
    say(f"  {est.describe()}")
    if est.cpu_seconds is None or est.cpu_seconds <= WARN_CPU_SECONDS:
        return
    limited = any(overrides.get(kw, case.solver.get(kw)) is not None for kw in ("max_cpu_time", "max_rhs_calls"))
    rtol = "a larger --rtol will not shorten it" if est.binding.startswith("stability") else \
        "a larger --rtol shortens it"
    bound = "its limit will stop it (status budget_exceeded)" if limited else \
        "--max-cpu-time S stops it after S seconds, keeping what it computed"
    print(f"gibbsimpact: warning: {path}: this run may take {duration(est.cpu_seconds)} of CPU: about "
          f"{est.n_steps:.3g} steps of {est.method} for its highest frequency {est.omega_max:.4g} rad/s "
          f"({est.binding}); {rtol}, --method Radau is not bound by the stability limit, {bound}",
          file=sys.stderr, flush=True)


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _simulate_and_write(path, case, args, overrides, out, progress, say) -> int:
    """Simulate one case, write its files, report on stdout; the exit code of the run."""
    from ..dynamics.gibbs_appell import SingularMassMatrixError

    try:
        result = case.simulate(progress=progress, **overrides)
    except (SingularMassMatrixError, ValueError) as exc:
        return _error(f"{path}: {exc}", EXIT_BAD_INPUT)
    except KeyboardInterrupt as exc:
        return _error(f"interrupted ({exc or 'SIGINT'}) before the first step of {path}; nothing written",
                      EXIT_INTERRUPTED)

    plots = case.output["plots"] and not args.no_plots
    animate = case.output["animate"] or args.animate
    try:
        with _writing_signals(out) as interrupts:
            report = write_outputs(result, case, out, plots, animate, log=say, interrupts=interrupts,
                                   csv_every=args.csv_every)
    except KeyboardInterrupt as exc:
        return _error(f"interrupted ({exc}) while writing the results into {out}: the files there are complete, "
                      "the others missing (summary.json, written first, lists those that were still to come)",
                      EXIT_INTERRUPTED)
    _say_run(result, report, say)
    return _exit_code(result, report, interrupts.held)


def _say_run(result, report, say) -> None:
    """The report of a run on stdout (cli/report.py's run_report_lines), then the files written."""
    lines = run_report_lines(result)
    lines[-1] += f"; {len(report.written)} files in {report.out}"
    for line in lines:
        say(line)
    if "figures" in report.skipped and not report.lost:
        say(f"figures not drawn ({report.skipped['figures']}); to draw them: python -c \"import gibbsimpact as gi; "
            f"gi.load_result('{report.out / 'result.npz'}').plot(directory='{report.out}')\"")


def _lost_files(report) -> str:
    """One line: what could not be written into the output folder, what was, where the essential files went."""
    parts = [f"could not write every result into {report.out}"]
    parts += [f"{name} written to {report.paths[Path(name).stem]} instead ({why})"
              for name, why in report.elsewhere.items()]
    parts += [f"{name} not written ({why})" for name, why in report.failed.items()]
    parts.append(f"written there: {', '.join(report.written) or 'nothing'}")
    if report.skipped:
        parts.append(f"skipped: {', '.join(report.skipped)}")
    if "result" in report.paths:
        parts.append(f"the CSV files and figures can be made again from {report.paths['result']} "
                     "(gi.load_result(...).to_csv(folder), .plot(directory=folder))")
    return "; ".join(parts)


def _exit_code(result, report, held) -> int:
    """The exit code of a run whose results were written, after an error line on stderr for each thing that
    went wrong: 4 a file could not be written into the output folder, 130 interrupted, 3 stopped early; the
    worst counts (common._worst), 0 when none did."""
    from ..simulation.status import STATUS_FINISHED, STATUS_INTERRUPTED

    codes, out = [EXIT_OK], report.out
    if report.lost:
        codes.append(_error(_lost_files(report), EXIT_OUTPUT))
    written = "what could be written is in" if report.lost else "partial results written to"
    if result.status == STATUS_INTERRUPTED:
        codes.append(_error(f"simulation stopped early ({result.status}): {result.message}; {written} {out}",
                            EXIT_INTERRUPTED))
    elif held:
        left = "complete" if report.complete else f"in {out} except {', '.join(report.skipped) or 'the files above'}"
        codes.append(_error(f"interrupted ({held[0]}) while the results were written; they are {left}"
                            + (f" in {out}" if report.complete else ""), EXIT_INTERRUPTED))
    elif result.status != STATUS_FINISHED:
        codes.append(_error(f"simulation stopped early ({result.status}): {result.message}; {written} {out}",
                            EXIT_STOPPED))
    code = EXIT_OK
    for c in codes:
        code = _worst(code, c)
    return code
