"""The files of ``gibbsimpact run`` when the output folder cannot take them all (issue 23 item 1): the small
essential ones come first, summary.json and result.npz go to a temporary folder when the output folder
refuses them, stderr and summary.json say what was written and what was not, exit code 4; and when a
signal arrives while they are written (item 2): the data and summary.json first, the figures dropped."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.cli import commands as cli
from gibbsimpact.io import result_files as gio

CASES = Path(__file__).resolve().parents[2] / "cases"
CASE1 = CASES / "circle_two_link.toml"
REAL_ATOMIC_PATH = gio.atomic_path


def run_main(argv, capsys):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def files(d: Path) -> list:
    return sorted(p.name for p in d.iterdir())


class FakeDisk:
    """A file system of ``size`` bytes under ``root``, as io.atomic_path sees it: a file that does not fit
    beside the others (temporary files aside) raises OSError(ENOSPC), as a full disk does, and is removed."""

    def __init__(self, root: Path, size: int):
        self.root, self.size = root, size

    def used(self, replaced: Path) -> int:
        return sum(p.stat().st_size for p in self.root.rglob("*")
                   if p.is_file() and p != replaced and gio.TEMP_MARK not in p.name)

    @contextmanager
    def atomic_path(self, path):
        path = Path(path)
        with REAL_ATOMIC_PATH(path) as tmp:
            yield tmp
            if path.parent == self.root and self.used(path) + tmp.stat().st_size > self.size:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp))


@pytest.fixture
def disk(tmp_path, monkeypatch):
    """make(size) -> the output folder on a FakeDisk of that many bytes; the fallback goes to tmp_path/tmp."""
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path / "tmp"))

    def make(size):
        out = tmp_path / "out"
        out.mkdir()
        monkeypatch.setattr(gio, "atomic_path", FakeDisk(out, size).atomic_path)
        return out

    return make


def error_lines(err: str) -> list:
    return [ln for ln in err.splitlines() if ln.startswith("gibbsimpact: error: ")]


def test_full_disk_keeps_summary_and_result_exit_4(disk, capsys):
    # Case 1 for 1 s: summary.json 4 kB, result.npz 92 kB, impacts.csv 2 kB, timeseries.csv 496 kB.
    out = disk(400_000)
    code, stdout, err = run_main(["run", CASE1, "--t-end", "1", "--out", out], capsys)
    assert code == 4 == cli.EXIT_OUTPUT
    assert files(out) == ["episodes.csv", "impacts.csv", "result.npz", "summary.json"]  # and no temporary file
    res = gi.load_result(out / "result.npz")
    assert res.status == "finished" and res.t[-1] == 1.0 and len(res.impacts) == 4
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "finished" and s["n_impacts"] == 4
    assert s["output_files"] == {
        "complete": False, "folder": str(out), "written": ["result.npz", "impacts.csv", "episodes.csv"],
        "written_elsewhere": {},
        "not_written": {"timeseries.csv": f"No space left on device in {out}",
                        "figures": "a file could not be written (they would take the space summary.json needs)"},
        "pending": []}
    (line,) = error_lines(err)
    assert line.startswith(f"gibbsimpact: error: could not write every result into {out}; timeseries.csv not "
                           f"written (No space left on device in {out}); written there: summary.json, result.npz, "
                           "impacts.csv, episodes.csv; skipped: figures; the CSV files and figures can be made again from "
                           f"{out / 'result.npz'}")
    assert "status: finished" in stdout and "drawing figures" not in stdout
    assert list((out.parent / "tmp").iterdir()) == []  # no fallback needed


def test_result_npz_that_does_not_fit_goes_to_a_temporary_folder(disk, capsys):
    out = disk(40_000)  # summary.json, impacts.csv and episodes.csv fit, result.npz does not
    code, _, err = run_main(["run", CASE1, "--t-end", "1", "--out", out, "--no-plots"], capsys)
    assert code == 4
    assert files(out) == ["episodes.csv", "impacts.csv", "summary.json"]
    (fallback,) = (out.parent / "tmp").iterdir()
    assert fallback.name.startswith("gibbsimpact-") and files(fallback) == ["result.npz"]
    res = gi.load_result(fallback / "result.npz")
    assert res.t[-1] == 1.0 and len(res.impacts) == 4
    s = json.loads((out / "summary.json").read_text())
    assert s["output_files"]["written_elsewhere"] == {"result.npz": str(fallback / "result.npz")}
    assert s["output_files"]["written"] == ["impacts.csv", "episodes.csv"] and not s["output_files"]["complete"]
    (line,) = error_lines(err)
    assert (f"result.npz written to {fallback / 'result.npz'} instead (No space left on device in {out})"
            in line)


def test_nothing_fits_both_essential_files_in_the_temporary_folder(disk, capsys):
    out = disk(0)
    code, _, err = run_main(["run", CASE1, "--t-end", "0.1", "--out", out, "-q"], capsys)
    assert code == 4 and files(out) == []
    (fallback,) = (out.parent / "tmp").iterdir()
    assert files(fallback) == ["result.npz", "summary.json"]
    s = json.loads((fallback / "summary.json").read_text())
    assert s["t_final_s"] == 0.1 and s["output_files"]["written"] == []
    assert set(s["output_files"]["not_written"]) == {"impacts.csv", "episodes.csv", "timeseries.csv", "figures"}
    assert f"summary.json written to {fallback / 'summary.json'} instead" in err


def test_essential_files_come_first(tmp_path, capsys, monkeypatch):
    # The order of the writes, and what summary.json says while the others are still to come.
    seen = []
    real = gio.write_timeseries_csv

    def spy(result, path, *every):
        seen.append(sorted(p.name for p in path.parent.iterdir()))
        seen.append(json.loads((path.parent / "summary.json").read_text())["output_files"])
        return real(result, path, *every)

    import gibbsimpact.plotting.figures as figures

    plot_one = figures.plot_one

    def spy_figure(result, name, **kw):
        if name == "angles":  # the second summary.json: the data are written, the figures to come
            seen.append(json.loads((tmp_path / "summary.json").read_text())["output_files"])
        return plot_one(result, name, **kw)

    monkeypatch.setattr(gio, "write_timeseries_csv", spy)
    monkeypatch.setattr(figures, "plot_one", spy_figure)
    code, _, _ = run_main(["run", CASE1, "--t-end", "0.05", "--out", tmp_path, "-q"], capsys)
    assert code == 0
    assert seen[2]["written"] == ["result.npz", "impacts.csv", "episodes.csv", "timeseries.csv"]
    assert seen[2]["pending"] == ["figures"]
    assert seen[0] == ["episodes.csv", "impacts.csv", "result.npz", "summary.json"]
    # The first summary.json: written before every other file (those there now are complete: atomic).
    assert seen[1]["pending"] == ["result.npz", "impacts.csv", "episodes.csv", "timeseries.csv", "figures"]
    assert seen[1]["written"] == [] and not seen[1]["complete"]
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["output_files"]["complete"] and s["output_files"]["pending"] == []
    assert s["output_files"]["written"][:4] == ["result.npz", "impacts.csv", "episodes.csv", "timeseries.csv"]
    assert "angles.png" in s["output_files"]["written"] and "matplotlib" in s["versions"]


def test_exit_code_4_is_documented(capsys):
    with pytest.raises(SystemExit):
        cli.main(["run", "--help"])
    assert "  4    the results of a run could not all be written into its output" in capsys.readouterr().out
    assert "(130, 1, 4, 2, 3, 0: worst" in cli.EXIT_CODES
    docs = (CASES.parent / "docs" / "case-format.md").read_text()
    assert "`4` the results could not all be written" in docs


@pytest.mark.skipif(os.name != "posix" or os.geteuid() != 0, reason="mounting a tmpfs needs root")
def test_full_tmpfs_exit_4(tmp_path, capsys):
    # The reproducer on a real full file system: a 400 kB tmpfs.
    out = tmp_path / "small"
    out.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=400k", "tmpfs", str(out)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        code, _, err = run_main(["run", CASE1, "--t-end", "1", "--out", out / "out"], capsys)
        assert code == 4
        assert files(out / "out") == ["episodes.csv", "impacts.csv", "result.npz", "summary.json"]
        assert gi.load_result(out / "out" / "result.npz").t[-1] == 1.0
        assert "timeseries.csv not written (No space left on device" in err
    finally:
        subprocess.run(["umount", str(out)], check=True)


# -- a signal while the results are written (item 2) ---------------------------------------------------

def signal_in(monkeypatch, module, name, when, times=1):
    """Replace module.name by a function that sends SIGTERM to this process ``times`` times on call
    number ``when``, then does what the original does."""
    real, calls = getattr(module, name), []

    def send(*a, **kw):
        calls.append(1)
        if len(calls) == when:
            for _ in range(times):
                os.kill(os.getpid(), signal.SIGTERM)
        return real(*a, **kw)

    monkeypatch.setattr(module, name, send)


def test_signal_while_a_figure_is_drawn_drops_the_figures(tmp_path, capsys, monkeypatch):
    import gibbsimpact.plotting.figures as figures

    signal_in(monkeypatch, figures, "plot_one", when=2)  # while "modes" is drawn
    code, _, err = run_main(["run", CASE1, "--t-end", "0.05", "--out", tmp_path, "-q"], capsys)
    assert code == 130
    assert files(tmp_path) == ["angles.png", "episodes.csv", "impacts.csv", "result.npz", "summary.json",
                               "timeseries.csv"]
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["output_files"]["not_written"] == {"figures": "SIGTERM arrived while the results were written"}
    assert error_lines(err) == [f"gibbsimpact: error: interrupted (SIGTERM) while the results were written; they "
                                f"are in {tmp_path} except figures"]


def test_signal_while_the_data_are_written_holds_then_skips_the_figures(tmp_path, capsys, monkeypatch):
    signal_in(monkeypatch, gio, "write_timeseries_csv", when=1)
    code, _, err = run_main(["run", CASE1, "--t-end", "0.05", "--out", tmp_path, "-q"], capsys)
    assert code == 130
    assert files(tmp_path) == ["episodes.csv", "impacts.csv", "result.npz", "summary.json", "timeseries.csv"]
    ts = gio.read_csv(tmp_path / "timeseries.csv")
    assert np.array_equal(ts["t_s"], gi.load_result(tmp_path / "result.npz").t)  # complete
    assert "gibbsimpact: SIGTERM: writing the data and summary.json" in err


def test_second_signal_aborts_the_writing_and_the_first_summary_says_what_is_missing(tmp_path, capsys,
                                                                                      monkeypatch):
    signal_in(monkeypatch, gio, "write_timeseries_csv", when=1, times=2)
    code, _, err = run_main(["run", CASE1, "--t-end", "0.05", "--out", tmp_path, "-q"], capsys)
    assert code == 130 and "interrupted (SIGTERM) while writing the results" in err
    assert files(tmp_path) == ["episodes.csv", "impacts.csv", "result.npz", "summary.json"]  # no temporary file
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["output_files"]["pending"] == ["result.npz", "impacts.csv", "episodes.csv", "timeseries.csv", "figures"]
    assert not s["output_files"]["complete"]
