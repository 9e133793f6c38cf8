"""Outputs that cannot be lost: Ctrl-C / SIGTERM during a run (a real process) leaves a readable partial
result with status "interrupted"; gi.simulate keeps everything computed when interrupted; an unwritable
output folder fails before simulating; no stale files; every file is written atomically."""

from __future__ import annotations

import importlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.cli import commands as cli
from gibbsimpact.io import result_files as gio

CASES = Path(__file__).resolve().parents[2] / "cases"
gsim = importlib.import_module("gibbsimpact.simulation.simulate")


def run_main(argv, capsys):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def temp_files(d: Path) -> list:
    return sorted(p.name for p in d.iterdir() if gio.TEMP_MARK in p.name)


# -- a real process stopped by SIGINT (Ctrl-C) or SIGTERM ------------------------------------------

@pytest.mark.skipif(os.name != "posix", reason="POSIX signals")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_during_a_cli_run_writes_the_partial_result(tmp_path, sig):
    # Warm numba's cache here, so the child loads the kernel (~0.5 s) instead of compiling it (~20 s).
    gi.load_case(CASES / "sphere_single_link.toml").simulate(t_end=0.01)
    out = tmp_path / "out"
    t_end = 100.0  # ~60 s of computation: the signal comes long before the end
    # `python -m gibbsimpact run ...`, with Python's own Ctrl-C handler installed first: a shell that
    # starts the tests in the background may have made the process ignore SIGINT, and Python would too.
    main = ("import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
            "runpy.run_module('gibbsimpact', run_name='__main__', alter_sys=True)")
    proc = subprocess.Popen(
        [sys.executable, "-c", main, "run", str(CASES / "sphere_single_link.toml"), "--out", str(out),
         "--t-end", str(t_end), "--output-dt", "0.01", "--no-plots"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    watchdog = threading.Timer(120.0, proc.kill)
    watchdog.start()
    try:
        first = proc.stdout.readline()  # printed once the case (and the kernel) is loaded, just before simulating
        assert first.startswith("gibbsimpact: running sphere_single_link"), first
        time.sleep(1.5)  # integrating by now
        proc.send_signal(sig)
        stdout, stderr = proc.communicate(timeout=100)
    finally:
        watchdog.cancel()
        proc.kill()
    assert proc.returncode == 130, (stdout, stderr)
    error = [ln for ln in stderr.splitlines() if ln.startswith("gibbsimpact: error:")]
    assert len(error) == 1 and error[0].startswith("gibbsimpact: error: simulation stopped early (interrupted): "
                                                   f"stopped by {'SIGTERM' if sig == signal.SIGTERM else 'Keyboard'}")
    assert f"partial results written to {out}" in error[0]
    assert "status: interrupted" in stdout
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "interrupted"
    res = gi.load_result(out / "result.npz")
    assert res.status == "interrupted" and 0.0 < res.t[-1] < t_end
    assert s["t_final_s"] == res.t[-1] and s["n_impacts"] == len(res.impacts)
    assert np.all(np.diff(res.t) >= 0) and res.q.shape == (res.t.size, res.model.n_dof)
    ts = gio.read_csv(out / "timeseries.csv")
    assert np.array_equal(ts["t_s"], res.t)
    assert sorted(p.name for p in out.iterdir()) == ["episodes.csv", "impacts.csv", "result.npz", "summary.json",
                                                     "timeseries.csv"]


@pytest.mark.skipif(os.name != "posix", reason="POSIX signals")
def test_sigterm_writes_data_and_summary_without_figures_within_the_grace_period(tmp_path):
    # Issue 23 item 2: after SIGTERM the CLI drew every figure (27.8 s after 9 s of case 1) and a scheduler
    # that kills 10 s after SIGTERM (docker stop) left no summary.json. Now: the data, summary.json, exit.
    gi.load_case(CASES / "circle_two_link.toml").simulate(t_end=0.01)  # the kernel cached for the child
    out = tmp_path / "out"
    main = ("import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
            "runpy.run_module('gibbsimpact', run_name='__main__', alter_sys=True)")
    proc = subprocess.Popen([sys.executable, "-c", main, "run", str(CASES / "circle_two_link.toml"), "--out",
                             str(out), "--t-end", "300"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    watchdog = threading.Timer(120.0, proc.kill)
    watchdog.start()
    try:
        assert proc.stdout.readline().startswith("gibbsimpact: running circle_two_link")
        time.sleep(1.5)  # a few simulated seconds, thousands of samples: minutes of figures before the fix
        sent = time.perf_counter()
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=100)
        took = time.perf_counter() - sent
    finally:
        watchdog.cancel()
        proc.kill()
    assert proc.returncode == 130, (stdout, stderr)
    assert took < 10.0, took  # docker stop's grace period
    assert sorted(p.name for p in out.iterdir()) == ["episodes.csv", "impacts.csv", "result.npz", "summary.json",
                                                     "timeseries.csv"]
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "interrupted" and s["output_files"]["not_written"] == {"figures": "the run was interrupted"}
    assert s["output_files"]["written"] == ["result.npz", "impacts.csv", "episodes.csv", "timeseries.csv"]
    assert gi.load_result(out / "result.npz").t[-1] == s["t_final_s"] > 0.0
    assert "drawing figures" not in stdout and "figures not drawn (the run was interrupted)" in stdout


# -- gi.simulate: an interrupt returns what was computed ---------------------------------------------

def interrupt_after(t_stop):
    """A progress callback that raises KeyboardInterrupt once the solver passes t_stop (as Ctrl-C would)."""
    fired = []

    def progress(t, n_impacts):
        if t > t_stop and not fired:
            fired.append(t)
            raise KeyboardInterrupt

    return progress


def assert_consistent(res):
    K, N = res.t.size, res.model.n_dof
    assert res.q.shape == res.qdot.shape == (K, N) and res.phase.shape == (K,)
    assert np.all(np.diff(res.t) >= 0)
    E = res.energy()  # the cache the run handed over, one value per sample
    assert E.total.shape == (K,)
    E_again = gi.Result(model=res.model, walls=res.walls, t=res.t, q=res.q, qdot=res.qdot, phase=res.phase,
                        impacts=res.impacts, status=res.status, message=res.message).energy()
    np.testing.assert_allclose(E.total, E_again.total, rtol=1e-12, atol=1e-12)
    assert res.phase[-1] == len(res.impacts)
    if res.work is not None:
        assert res.work.shape == (K, 2)


@pytest.mark.parametrize("output_dt", [1e-3, None], ids=["output_dt", "every_step"])
def test_interrupt_keeps_the_phase_under_way(monkeypatch, output_dt):
    # The first impact of this case is at 0.540052 s: stopping at 0.3 s is inside the first flight phase.
    case = gi.load_case(CASES / "sphere_single_link.toml")
    full = case.simulate(t_end=0.6, output_dt=output_dt)
    clock = gsim.Clock
    monkeypatch.setattr(gsim, "Clock", lambda progress: clock(progress, every=0.0))  # report at every RHS
    res = case.simulate(t_end=0.6, output_dt=output_dt, progress=interrupt_after(0.3))
    assert res.status == "interrupted" and not res.success
    assert res.message.startswith("stopped by KeyboardInterrupt (Ctrl-C) at t = ")
    assert 0.3 - 0.05 < res.t[-1] < 0.54 and res.impacts == []
    assert_consistent(res)
    # What it kept is what the whole run computed, sample by sample (the last one may be off the grid).
    n = res.t.size - 1
    assert np.array_equal(res.t[:n], full.t[:n]) and np.array_equal(res.q[:n], full.q[:n])
    assert res.n_steps > 0 and res.energy_error < 1e-8


def test_interrupt_of_a_driven_run_keeps_the_work(monkeypatch):
    case = gi.load_case(CASES / "fixed_base_fe_arm.toml")
    clock = gsim.Clock
    monkeypatch.setattr(gsim, "Clock", lambda progress: clock(progress, every=0.0))
    res = case.simulate(t_end=0.2, progress=interrupt_after(0.05))
    assert res.status == "interrupted" and 0.04 < res.t[-1] < 0.2
    assert_consistent(res)
    assert res.work is not None and res.work[-1, 0] != 0.0 and res.energy_error < 1e-8


def test_interrupt_between_phases_keeps_impacts_and_samples(monkeypatch):
    # A KeyboardInterrupt in the impact stage (after one impact), and one while a finished phase is recorded.
    case = gi.load_case(CASES / "sphere_single_link.toml")
    full = case.simulate(t_end=0.7)
    import gibbsimpact.simulation.stages as gstages  # the impact stage's solve

    real_stage = gstages.solve_impact
    calls = []

    def stage(*a, **kw):
        calls.append(1)
        if len(calls) == 3:  # the initial check, impact 1, then impact 2
            raise KeyboardInterrupt
        return real_stage(*a, **kw)

    monkeypatch.setattr(gstages, "solve_impact", stage)
    res = case.simulate(t_end=0.7)
    assert res.status == "interrupted" and len(res.impacts) == 1
    assert res.t[-1] == full.impacts[1].time and np.array_equal(res.t, full.t[:res.t.size])
    assert_consistent(res)
    monkeypatch.setattr(gstages, "solve_impact", real_stage)

    import gibbsimpact.simulation.recorder as grec  # the recorder's stage evaluates the energies of a phase

    real_energies = grec.energies
    n = []

    def energies(*a, **kw):
        n.append(1)
        if len(n) == 3:  # while the phase that ends at impact 2 is recorded (the 2nd one only left the band)
            raise KeyboardInterrupt
        return real_energies(*a, **kw)

    monkeypatch.setattr(grec, "energies", energies)
    res = case.simulate(t_end=0.7)
    assert res.status == "interrupted" and len(res.impacts) == 1
    assert res.t[-1] == full.impacts[1].time  # the phase was kept although its recording was interrupted
    assert_consistent(res)


def test_progress_true_shows_a_tqdm_bar(capsys):
    case = gi.load_case(CASES / "circle_two_link.toml")
    case.simulate(t_end=0.02)
    assert capsys.readouterr().err == ""  # the default stays silent
    res = case.simulate(t_end=0.02, progress=True)
    err = capsys.readouterr().err
    assert res.success and "simulate: 100%" in err and "t = 0.02 / 0.02 s" in err and "impacts: 0" in err
    seen = []
    case.simulate(t_end=0.02, progress=lambda t, n: seen.append((t, n)))
    assert seen[-1] == (0.02, 0)
    with pytest.raises(ValueError, match=r"simulate progress='yes' must be None, True .* or a callable"):
        case.simulate(t_end=0.02, progress="yes")


# -- the output folder ----------------------------------------------------------------------------

@pytest.fixture
def no_simulation(monkeypatch):
    from gibbsimpact.case import Case

    def refuse(self, **kw):
        raise AssertionError("simulated although the output folder is unusable")

    monkeypatch.setattr(Case, "simulate", refuse)


def test_unwritable_out_fails_before_simulating(tmp_path, capsys, no_simulation):
    # chmod does not stop root: a folder below a regular file can never be created.
    afile = tmp_path / "afile"
    afile.write_text("not a folder")
    for target, reason in ((afile / "out", "Not a directory"), (afile, "it is a file, not a folder")):
        code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--out", target, "--no-plots"], capsys)
        assert code == 2 and out == ""
        assert err == (f"gibbsimpact: error: --out {target}: cannot write into {target} ({reason}); "
                       "give a writable folder with --out\n")
    # With several case files no run starts either.
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", CASES / "sphere_single_link.toml",
                               "--out", afile / "out"], capsys)
    assert code == 2 and out == "" and err.count("\n") == 2 and "sphere_single_link (Not a directory)" in err


def test_out_is_created_and_probed_before_simulating(tmp_path, capsys, monkeypatch):
    from gibbsimpact.case import Case

    out = tmp_path / "a" / "b" / "c"
    seen = {}
    real = Case.simulate

    def spy(self, **kw):
        seen["exists"] = out.is_dir()
        seen["entries"] = list(out.iterdir())
        return real(self, **kw)

    monkeypatch.setattr(Case, "simulate", spy)
    code, _, _ = run_main(["run", CASES / "circle_two_link.toml", "--out", out, "--t-end", "0.01", "--no-plots",
                           "-q"], capsys)
    assert code == 0 and seen == {"exists": True, "entries": []}  # the probe file is gone again


def test_no_stale_files_and_unknown_files_kept(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    stale = ["angles.png", "trajectory.png", "animation.gif", "contact_forces.csv", "summary.json",
             f".timeseries.deadbeef{gio.TEMP_MARK}.csv"]
    mine = ["notes.txt", "my_figure.png", "impacts.csv.bak"]
    for name in stale + mine:
        (out / name).write_text("from before")
    code, _, _ = run_main(["run", CASES / "circle_two_link.toml", "--out", out, "--t-end", "0.01", "--no-plots",
                           "-q"], capsys)
    assert code == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["timeseries.csv", "impacts.csv", "episodes.csv", "summary.json", "result.npz"] + mine)
    assert all((out / name).read_text() == "from before" for name in mine)
    assert json.loads((out / "summary.json").read_text())["status"] == "finished"


def test_stale_files_of_a_run_with_figures_are_removed(tmp_path, capsys):
    # A real run with figures and the animation, then one without: only the second run's files stay.
    case = tmp_path / "c.toml"
    case.write_text((CASES / "circle_two_link.toml").read_text().replace("output_dt_s = 1e-3", "output_dt_s = 1e-2"))
    out = tmp_path / "o"
    code, _, _ = run_main(["run", case, "--out", out, "--t-end", "0.05", "--animate", "-q"], capsys)
    assert code == 0 and (out / "angles.png").exists() and (out / "animation.gif").exists()
    from gibbsimpact.plotting.figures import FIGURES

    assert {p.name for p in out.iterdir()} == {"timeseries.csv", "impacts.csv", "episodes.csv", "summary.json",
                                               "result.npz", "animation.gif"} | {f"{k}.png" for k in FIGURES}
    code, _, _ = run_main(["run", case, "--out", out, "--t-end", "0.02", "--no-plots", "-q"], capsys)
    assert code == 0
    assert sorted(p.name for p in out.iterdir()) == ["episodes.csv", "impacts.csv", "result.npz", "summary.json",
                                                     "timeseries.csv"]
    assert gi.load_result(out / "result.npz").t[-1] == 0.02


# -- atomic files -----------------------------------------------------------------------------------

def half_savez(file, *args, **kwds):
    Path(file).write_bytes(b"PK\x03\x04 half an archive")
    raise FAILURE["exc"]


def half_text(self, data, *args, **kwds):
    REAL_WRITE_TEXT(self, data[: len(data) // 2])
    raise FAILURE["exc"]


def failing_fmt(x):
    FAILURE["calls"] += 1
    if FAILURE["calls"] > 30:  # the first row(s) are written, then it fails
        raise FAILURE["exc"]
    return repr(float(x))


FAILURE = {"exc": None, "calls": 0}
REAL_WRITE_TEXT = Path.write_text
WRITERS = [  # file, writer, (object, attribute) to replace by a writer that fails half-way
    ("result.npz", gio.save_result, (np, "savez_compressed", half_savez)),
    ("summary.json", gio.write_summary_json, (Path, "write_text", half_text)),
    ("timeseries.csv", gio.write_timeseries_csv, (gio, "_fmt", failing_fmt)),
    ("impacts.csv", gio.write_impacts_csv, (gio, "_fmt", failing_fmt)),
]


@pytest.mark.parametrize("failure", [OSError(28, "No space left on device"), KeyboardInterrupt("SIGTERM")],
                         ids=["disk_full", "interrupt"])
@pytest.mark.parametrize("name,write,patch", WRITERS, ids=[w[0] for w in WRITERS])
def test_a_failed_write_leaves_the_old_file(tmp_path, monkeypatch, name, write, patch, failure):
    case = gi.load_case(CASES / "circle_two_link.toml")
    res = case.simulate(t_end=0.48, rtol=1e-8, atol=1e-10, output_dt=0.01)  # two impacts: impacts.csv has rows
    path = tmp_path / name
    write(res, path)
    before = path.read_bytes()
    FAILURE.update(exc=failure, calls=0)
    monkeypatch.setattr(patch[0], patch[1], patch[2])
    with pytest.raises(type(failure)):
        write(res, path)
    monkeypatch.undo()
    assert path.read_bytes() == before and temp_files(tmp_path) == []


def test_atomic_path_keeps_the_suffix_and_the_permissions(tmp_path):
    target = tmp_path / "fig.png"
    with gio.atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".png" and tmp.name.startswith(".fig.")
        assert not tmp.exists() and not target.exists()
        tmp.write_bytes(b"png")
    assert target.read_bytes() == b"png" and temp_files(tmp_path) == []
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask  # as a plain open() would create it


def test_check_directory(tmp_path):
    d = gio.check_directory(tmp_path / "x" / "y")
    assert d.is_dir() and list(d.iterdir()) == []
    (tmp_path / "f").write_text("")
    with pytest.raises(NotADirectoryError):
        gio.check_directory(tmp_path / "f" / "y")
    with pytest.raises(FileExistsError, match="it is a file, not a folder"):
        gio.check_directory(tmp_path / "f")
