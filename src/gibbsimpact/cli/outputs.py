"""The files of a ``gibbsimpact run``: the small essential ones first, each atomically, and an account of
what was written, what was not, and where the essential files went when the output folder refused them.

Order (docs/case-format.md, "Output files"): summary.json (a first version listing the files still to
come), result.npz (the whole Result, lossless), impacts.csv, episodes.csv, contact_forces.csv,
timeseries.csv (the largest data file), summary.json again, the figures, animation.gif, then
summary.json a last time, listing what was written. A full disk (case 1 for 1 s: timeseries.csv 496 kB, result.npz 91 kB,
summary.json 3 kB) thus still keeps the run; the CSV files and the figures can be made again from
result.npz. A run interrupted (Ctrl-C, SIGTERM) writes the data and summary.json, not the figures.
"""

from __future__ import annotations

import contextlib
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

#: Files ``gibbsimpact run`` may write into its output folder, besides <figure>.png for
#: every name in plotting.FIGURES and OPTIONAL_FIGURES. Before writing, a run removes those of them that are
#: there (an earlier run's), and nothing else.
OUTPUT_FILES = ("timeseries.csv", "impacts.csv", "episodes.csv", "contact_forces.csv", "summary.json",
                "result.npz", "animation.gif")
#: Written into a temporary folder (OutputReport.fallback) when the output folder refuses them.
ESSENTIAL_FILES = ("summary.json", "result.npz")


def output_names() -> tuple:
    """Every file name ``gibbsimpact run`` may write into an output folder."""
    from ..plotting.figures import FIGURES, OPTIONAL_FIGURES

    return OUTPUT_FILES + tuple(f"{k}.png" for k in FIGURES + OPTIONAL_FIGURES)


def clear_outputs(out: Path) -> list:
    """Remove from ``out`` the files of an earlier run: every name of output_names() and their
    leftover temporary files (io.atomic_path). Other files are kept. Returns the paths removed."""
    from ..io.result_files import TEMP_MARK

    removed = []
    for name in output_names():
        p = out / name
        for q in [p, *out.glob(f".{p.stem}.*{TEMP_MARK}{p.suffix}")]:
            if q.is_file() or q.is_symlink():
                q.unlink()
                removed.append(q)
    return removed


@dataclass
class Interrupts:
    """Ctrl-C or SIGTERM received while the results are written (the command line's signal handler fills it).

    held : names of the signals received ("SIGTERM", "SIGINT"), in order.
    abortable : True while a figure or the animation is drawn: the handler then raises KeyboardInterrupt
        at once, and write_outputs drops that file and the ones after it (the data files are written).
    """

    held: list = field(default_factory=list)
    abortable: bool = False


@dataclass
class OutputReport:
    """What write_outputs did.

    out : the output folder; written : names of the files written there, in order (summary.json included);
    paths : {key: Path} of every file written, in ``out`` or in ``fallback`` (keys: "summary", "result",
    "timeseries", "impacts", "episodes", "contact_forces", figure names, "animation");
    elsewhere : {name: why} of the essential files written into ``fallback`` instead of ``out``;
    failed : {name: reason} of files that could not be written anywhere;
    skipped : {name: reason} of files not attempted ("figures" for those not drawn);
    fallback : the temporary folder made for the essential files, or None.
    """

    out: Path
    written: list = field(default_factory=list)
    paths: dict = field(default_factory=dict)
    elsewhere: dict = field(default_factory=dict)
    failed: dict = field(default_factory=dict)
    skipped: dict = field(default_factory=dict)
    fallback: Path | None = None

    @property
    def complete(self) -> bool:
        """Every file of the run is in ``out``."""
        return not (self.failed or self.skipped or self.elsewhere)

    @property
    def lost(self) -> bool:
        """A file could not be written into ``out`` (failed, or an essential one went to ``fallback``)."""
        return bool(self.failed or self.elsewhere)

    def listing(self, pending=()) -> dict:
        """The ``output_files`` entry of summary.json: what is in the folder, what is not and why."""
        return {"complete": self.complete and not pending, "folder": str(self.out),
                "written": [n for n in self.written if n != "summary.json"],
                "written_elsewhere": {n: str(self.paths[_key(n)]) for n in self.elsewhere},
                "not_written": {**self.failed, **self.skipped}, "pending": list(pending)}


def _key(name: str) -> str:
    """Key of a file in OutputReport.paths: "result.npz" -> "result", "animation.gif" -> "animation"."""
    return Path(name).stem


def _write_file(report: OutputReport, name: str, write) -> None:
    """``write(path)`` the file ``name`` into report.out (write returns the path, or None when there is
    nothing to write); one of ESSENTIAL_FILES that cannot be written there goes to the fallback folder
    (a new temporary folder, the same for all the run's files), and stays there when written again."""
    reasons = []
    folders = [report.out] if name not in report.elsewhere else []
    folders += [None] if name in ESSENTIAL_FILES else []
    for folder in folders:
        try:
            if folder is None:
                report.fallback = report.fallback or Path(tempfile.mkdtemp(prefix="gibbsimpact-"))
                folder = report.fallback
            path = write(folder / name)
        except OSError as exc:
            reasons.append(f"{exc.strerror or exc} in {folder or 'a new temporary folder'}")
            if folder == report.out and name in report.written:  # its first version there would mislead
                report.written.remove(name)
                with contextlib.suppress(OSError):
                    (folder / name).unlink(missing_ok=True)
            continue
        report.failed.pop(name, None)
        if path is not None:
            report.paths[_key(name)] = path
            if folder != report.out:
                report.elsewhere.setdefault(name, reasons[0] if reasons else "")
            elif name not in report.written:
                report.written.append(name)
        return
    report.failed[name] = "; ".join(reasons)


def _data_files(result, case, report: OutputReport, pending: list, csv_every: int = 1) -> list:
    """[(name, write(path) -> Path)] of the data files, in the order they are written; csv_every: every K-th
    sample (and the last) in the per-sample CSV files (io.result_files.sample_rows)."""
    from ..io.result_files import (has_contact_forces, save_result, write_contact_forces_csv, write_episodes_csv,
                                   write_impacts_csv, write_summary_json, write_timeseries_csv)

    source = case.path.read_text() if case.path is not None and case.path.exists() else None
    later = lambda: [n for n in pending if n != "summary.json"]  # noqa: E731
    files = [("summary.json", lambda p: write_summary_json(result, p, case, report.listing(later()))),
             ("result.npz", lambda p: save_result(result, p, metadata={"case": case.name, "case_toml": source})),
             ("impacts.csv", lambda p: write_impacts_csv(result, p)),
             ("episodes.csv", lambda p: write_episodes_csv(result, p))]
    if has_contact_forces(result):
        files.append(("contact_forces.csv", lambda p: write_contact_forces_csv(result, p, csv_every)))
    files.append(("timeseries.csv", lambda p: write_timeseries_csv(result, p, csv_every)))
    return files


def _skip_reason(result, report: OutputReport, interrupts: Interrupts) -> str | None:
    """Why the figures and the animation are not drawn (any more), or None."""
    if result.status == "interrupted":
        return "the run was interrupted"
    if interrupts.held:
        return f"{interrupts.held[0]} arrived while the results were written"
    if report.lost:
        return "a file could not be written (they would take the space summary.json needs)"
    return None


def _write_drawing(report: OutputReport, name: str, write, interrupts: Interrupts) -> None:
    """Write a figure or the animation; the first signal while it is drawn drops it (a second one aborts)."""
    interrupts.abortable = True
    try:
        _write_file(report, name, write)
    except KeyboardInterrupt:
        if len(interrupts.held) != 1:
            raise
    finally:
        interrupts.abortable = False


def _write_figures(result, case, report: OutputReport, interrupts: Interrupts, log) -> None:
    """Draw and save every figure of plotting.FIGURES (and OPTIONAL_FIGURES the run has), one at a time."""
    from ..io.result_files import save_figure
    from ..plotting.figures import FIGURES, OPTIONAL_FIGURES, plot_one

    for k, name in enumerate(FIGURES + OPTIONAL_FIGURES):
        reason = _skip_reason(result, report, interrupts)
        if reason is not None:
            report.skipped["figures"] = reason
            return
        if k == 0:
            log("drawing figures ...")

        def write(path, name=name):
            fig = plot_one(result, name, case_name=case.name, n_points=case.output["points_per_link"])
            # None: a figure the run has nothing for (modes of rigid links, contact forces without contact)
            return None if fig is None else save_figure(fig, path, case.output["dpi"])

        _write_drawing(report, f"{name}.png", write, interrupts)


def _write_animation(result, case, report: OutputReport, interrupts: Interrupts, log) -> None:
    """animation.gif (plotting.animate), unless the figures were skipped."""
    from ..io.result_files import atomic_path
    from ..plotting.figures import animate as make_animation

    reason = _skip_reason(result, report, interrupts)
    if reason is not None:
        report.skipped["animation.gif"] = reason
        return
    log("writing animation.gif ...")

    def write(path):
        with atomic_path(path) as tmp:
            make_animation(result, tmp, fps=case.output["animation_fps"], speed=case.output["animation_speed"],
                           n_points=case.output["points_per_link"], case_name=case.name)
        return path

    _write_drawing(report, "animation.gif", write, interrupts)


def write_outputs(result, case, out: Path, plots: bool, animate: bool, log=None,
                  interrupts: Interrupts | None = None, csv_every: int = 1) -> OutputReport:
    """Write every output file of a run into ``out``, the small essential ones first; returns an OutputReport.

    First removes the files an earlier run left there (clear_outputs). Then, each file atomically
    (io.atomic_path): summary.json (its ``output_files`` lists the files still pending), result.npz,
    impacts.csv, episodes.csv, contact_forces.csv (when some pair rested), timeseries.csv, summary.json
    again (when figures or the animation follow), the figures, animation.gif, and summary.json a last time. A file
    that cannot be written (an OSError: disk full, quota, I/O error) is recorded, not raised: summary.json and result.npz then go to a temporary folder (report.fallback),
    the other data files are still tried, and the figures and the animation are skipped, as they are
    when the run was interrupted or a signal arrives while the results are written (``interrupts``).
    A KeyboardInterrupt (the second signal) aborts the writing; no temporary file stays behind.
    csv_every : K >= 1, every K-th sample (and the last) in timeseries.csv and contact_forces.csv.
    """
    log = log or (lambda s: None)
    interrupts = interrupts if interrupts is not None else Interrupts()
    out = Path(out)
    report = OutputReport(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        clear_outputs(out)
    except OSError as exc:  # every file will fail there too; the essential ones go to the fallback
        report.failed["(output folder)"] = f"{exc.strerror or exc} in {out}"
    pending = []
    data = _data_files(result, case, report, pending, csv_every)
    pending += [name for name, _ in data] + (["figures"] if plots else []) + (["animation.gif"] if animate else [])
    for name, write in data:
        _write_file(report, name, write)
        pending.remove(name)
    if pending:  # the data are written: say so before the figures, which take longest
        _write_file(report, "summary.json", data[0][1])
    if plots:
        _write_figures(result, case, report, interrupts, log)
        pending.remove("figures")
    if animate:
        _write_animation(result, case, report, interrupts, log)
        pending.remove("animation.gif")
    # Again, with what was written: it records the matplotlib version when figures were drawn.
    _write_file(report, "summary.json", data[0][1])
    return report
