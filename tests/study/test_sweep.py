"""Parameter sweeps (gibbsimpact.sweep): the three execution routes (serial, process pool,
dask.distributed) give the same table and results bit for bit; an interrupted or partly
deleted sweep resumes with only the missing runs; failed runs are rows; bad key paths and
values are errors naming the key before any run; the command line's --vary and exit codes.

The 12-run grid varies the global restitution and the initial angle of link 1 of
cases/circle_two_link.toml up to t = 0.55 s (first impacts 0.431 ... 0.462 s); the run with
e = 0.5 and theta_1 = -36 deg stops early (zeno at 0.4937 s).
"""

from __future__ import annotations

import argparse
import csv
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.cli.sweep import add_parser, main, parse_vary
from gibbsimpact.study.sweep import RESULT_COLUMNS, expand_runs, run_id, sweep
from conftest import tight_dop853_text

CASE = Path(__file__).resolve().parents[2] / "cases" / "circle_two_link.toml"
GRID = {"restitution": [0.5, 0.75, 1.0], "initial.coordinates.theta_1_deg": [-36, -33, -30, -27]}
T_END = 0.55


def read_table(path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def without_wall_time(rows) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows]


def assert_same_results(a: Path, b: Path, rows):
    """The result files of every run in sweep folders a and b hold the same trajectory and impacts."""
    for r in rows:
        if not r["result"]:
            continue
        x, y = gi.load_result(a / r["result"]), gi.load_result(b / r["result"])
        for f in ("t", "q", "qdot", "phase"):
            assert np.array_equal(getattr(x, f), getattr(y, f)), (r["run"], f)
        assert [i.time for i in x.impacts] == [i.time for i in y.impacts]
        assert all(np.array_equal(i.impulses, j.impulses) for i, j in zip(x.impacts, y.impacts, strict=True))
        assert (x.status, x.message, x.nfev, x.energy_error) == (y.status, y.message, y.nfev, y.energy_error)


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    """The reference: the 12-run grid run serially in this process."""
    out = tmp_path_factory.mktemp("serial")
    res = sweep(CASE, GRID, out=out, t_end=T_END)
    return res, read_table(res.table)


# --------------------------------------------------------------------------
# Grid, key paths, run ids

def test_grid_order_last_key_fastest_and_explicit_lists():
    runs = expand_runs({"a": [1, 2], "b": ["x", "y", "z"], "c": 5})
    assert runs == [{"a": 1, "b": "x", "c": 5}, {"a": 1, "b": "y", "c": 5}, {"a": 1, "b": "z", "c": 5},
                    {"a": 2, "b": "x", "c": 5}, {"a": 2, "b": "y", "c": 5}, {"a": 2, "b": "z", "c": 5}]
    assert expand_runs({"gravity_m_per_s2": [[0, -9.81, 0], [0, -1.62, 0]]}) == [
        {"gravity_m_per_s2": [0, -9.81, 0]}, {"gravity_m_per_s2": [0, -1.62, 0]}]
    assert expand_runs([{"a": 1}, {"b": 2}]) == [{"a": 1}, {"b": 2}]
    assert expand_runs({"a": np.array([0.5, 1.0])}) == [{"a": 0.5}, {"a": 1.0}]
    with pytest.raises(TypeError, match="overrides"):
        expand_runs("restitution=0.5")


def test_serial_table_columns_rows_and_files(serial):
    res, rows = serial
    assert res.columns == ("run", "run_id", "restitution", "initial.coordinates.theta_1_deg", *RESULT_COLUMNS)
    assert len(rows) == 12 and res.n_run == 12 and res.n_skipped == 0
    assert [(float(r["restitution"]), int(r["initial.coordinates.theta_1_deg"])) for r in rows] == [
        (e, th) for e in GRID["restitution"] for th in GRID["initial.coordinates.theta_1_deg"]]
    # e = 0.5 at -36 deg: an accumulation at O1, then resting contact to t_end (status "zeno"
    # before resting contact existed).
    assert res.status_counts() == {"finished": 12} and res.all_finished
    assert gi.load_result(res.out / rows[0]["result"]).resting_time > 0.0
    assert len({r["run_id"] for r in rows}) == 12
    # The runs differ, and the flight before the first impact does not depend on e.
    assert len({(r["n_impacts"], r["energy_error"]) for r in rows}) > 6
    for k in range(4):
        assert rows[k]["first_impact_s"] == rows[k + 4]["first_impact_s"] == rows[k + 8]["first_impact_s"]
    for r in rows:
        back, meta = gi.load_result(res.out / r["result"], with_metadata=True)
        assert meta["run_id"] == r["run_id"] and r["result"] == f"runs/{r['run_id']}.npz"
        assert meta["overrides"]["restitution"] == float(r["restitution"])
        assert back.settings["restitution"] == float(r["restitution"])
        assert back.t[-1] == float(r["t_final_s"]) and len(back.impacts) == int(r["n_impacts"])
        assert float(r["first_impact_s"]) == back.impacts[0].time
        assert float(r["energy_error"]) == back.energy_error and int(r["nfev"]) == back.nfev
        assert float(r["wall_time_s"]) == back.wall_time
    # A run's row is the run of gi.load_case + case.simulate with the same keys.
    case = gi.load_case(CASE)
    direct = gi.case.case_from_dict({**case.source, "restitution": 0.75}).simulate(t_end=T_END)
    row = rows[6]  # e = 0.75, theta_1 = -30 deg: the case's own angle
    assert row["restitution"] == "0.75" and row["initial.coordinates.theta_1_deg"] == "-30"
    assert int(row["n_impacts"]) == len(direct.impacts) and float(row["first_impact_s"]) == direct.impacts[0].time
    assert int(row["nfev"]) == direct.nfev and float(row["energy_error"]) == direct.energy_error
    assert not list(res.out.glob("**/*.tmp"))


def test_run_id_is_the_case_run_whatever_the_spelling():
    case = gi.load_case(CASE)
    base = case.source
    with_ei = {**base, "links": [{**base["links"][0], "EI_N_m2": 25}, base["links"][1]]}
    same = {**base, "links": [{**base["links"][0], "EI_N_m2": 25.0}, base["links"][1]],
            "name": "other", "description": "text", "output": {"dpi": 300}}
    assert run_id(with_ei) == run_id(same) != run_id(base)
    assert len(run_id(base)) == 16
    # links.1.EI_N_m2 and links[1].EI_N_m2 are one key: the same run, so one sweep may not hold both.
    with pytest.raises(gi.CaseError, match=r"runs 1 and 2 run the same case"):
        sweep(case, [{"links.1.EI_N_m2": 25}, {"links[1].EI_N_m2": 25.0}], out="unused")
    with pytest.raises(gi.CaseError, match=r"links\[1\].EI_N_m2: set twice in one run"):
        sweep(case, [{"links.1.EI_N_m2": 25, "links[1].EI_N_m2": 25.0}], out="unused")


# --------------------------------------------------------------------------
# The three execution routes agree exactly

def test_process_pool_gives_the_serial_results(serial, tmp_path):
    ref, ref_rows = serial
    res = sweep(CASE, GRID, workers=2, out=tmp_path, t_end=T_END)
    rows = read_table(res.table)
    assert res.n_run == 12
    assert without_wall_time(rows) == without_wall_time(ref_rows)
    assert_same_results(ref.out, res.out, rows)


def test_dask_local_cluster_gives_the_serial_results(serial, tmp_path):
    distributed = pytest.importorskip("distributed")
    ref, ref_rows = serial
    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2,
                                  dashboard_address=None) as cluster:
        # An address, as on the command line: the sweep opens and closes its own client.
        res = sweep(CASE, GRID, scheduler=cluster.scheduler_address, out=tmp_path, t_end=T_END)
    rows = read_table(res.table)
    assert res.n_run == 12
    assert without_wall_time(rows) == without_wall_time(ref_rows)
    assert_same_results(ref.out, res.out, rows)


def test_unreachable_scheduler_is_an_error_before_anything_is_written(tmp_path):
    pytest.importorskip("distributed")
    import dask

    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}), pytest.raises(OSError, match="connect"):
        sweep(CASE, {"restitution": [1.0]}, scheduler="tcp://127.0.0.1:1", out=tmp_path / "s")
    assert not (tmp_path / "s").exists()


def test_dask_missing_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(ImportError, match=r'pip install "gibbsimpact\[dask\]"'):
        sweep(CASE, {"restitution": [0.5]}, scheduler="tcp://127.0.0.1:8786", out=tmp_path / "s")
    assert not (tmp_path / "s").exists()


# --------------------------------------------------------------------------
# Resume

def test_interrupted_sweep_resumes_with_only_the_missing_runs(serial, tmp_path):
    _, ref_rows = serial
    seen = []

    def interrupt_after_four(row, done, total):
        seen.append(row["run"])
        if done == 4:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep(CASE, GRID, out=tmp_path, t_end=T_END, progress=interrupt_after_four)
    rows = read_table(tmp_path / "sweep.csv")  # written although interrupted
    assert [r["status"] for r in rows[4:]] == ["pending"] * 8 and seen == [1, 2, 3, 4]
    assert without_wall_time(rows[:4]) == without_wall_time(ref_rows[:4])
    assert len(list((tmp_path / "runs").glob("*.npz"))) == 4

    ran = []
    res = sweep(CASE, GRID, out=tmp_path, t_end=T_END, progress=lambda row, d, t: ran.append(row["run"]))
    assert (res.n_run, res.n_skipped) == (8, 4) and ran == list(range(5, 13))
    assert without_wall_time(read_table(res.table)) == without_wall_time(ref_rows)


def test_deleted_results_and_rows_are_redone_and_the_table_is_the_same(serial, tmp_path):
    ref, ref_rows = serial
    out = tmp_path / "sweep"
    shutil.copytree(ref.out, out)
    for r in (ref_rows[2], ref_rows[9]):
        (out / r["result"]).unlink()
    (out / "runs" / f"{ref_rows[5]['run_id']}.npz").write_bytes(b"not an npz")  # a damaged file is redone
    lines = (out / "sweep.csv").read_text().splitlines(keepends=True)
    (out / "sweep.csv").write_text("".join(lines[:5] + lines[6:]))  # drop the row of run 5

    ran = []
    res = sweep(CASE, GRID, out=out, t_end=T_END, progress=lambda row, d, t: ran.append(row["run"]))
    assert (res.n_run, res.n_skipped) == (3, 9) and sorted(ran) == [3, 6, 10]
    rows = read_table(res.table)
    assert without_wall_time(rows) == without_wall_time(ref_rows)
    redone = {3, 6, 10}
    assert [r for r in rows if int(r["run"]) not in redone] == [r for r in ref_rows if int(r["run"]) not in redone]

    # Nothing left to do: a third call runs nothing and writes the same table.
    again = sweep(CASE, GRID, out=out, t_end=T_END)
    assert (again.n_run, again.n_skipped) == (0, 12) and read_table(again.table) == rows


# --------------------------------------------------------------------------
# Failed runs are rows

def test_failed_runs_are_rows_and_the_sweep_goes_on(tmp_path, monkeypatch):
    runs = [
        {"initial.coordinates.theta_1_deg": 60},  # O3 starts outside the circle: invalid
        {"solver.max_impacts": 1},  # stops at the first impact
        {"restitution": 0.75},  # the simulation raises (below)
        {"restitution": 0.5},  # finishes
    ]
    real = gi.Case.simulate

    def simulate(self, **kw):
        if self.restitution == 0.75:
            raise RuntimeError("solver exploded")
        return real(self, **kw)

    monkeypatch.setattr(gi.Case, "simulate", simulate)
    res = sweep(CASE, runs, out=tmp_path, t_end=0.5)
    rows = read_table(res.table)
    assert [r["status"] for r in rows] == ["invalid", "max_impacts", "error", "finished"]
    assert res.columns[2:5] == ("initial.coordinates.theta_1_deg", "solver.max_impacts", "restitution")
    assert rows[0]["initial.coordinates.theta_1_deg"] == "60" and rows[0]["restitution"] == ""
    assert "initial: joint O3" in rows[0]["message"] and "outside walls[1]" in rows[0]["message"]
    assert rows[0]["result"] == "" and rows[0]["n_impacts"] == ""
    assert rows[1]["n_impacts"] == "1" and "max_impacts = 1" in rows[1]["message"]
    assert rows[2]["message"] == "RuntimeError: solver exploded" and rows[2]["result"] == ""
    assert rows[3]["result"] and int(rows[3]["n_impacts"]) >= 2

    # Runs without a result are retried, the others kept.
    monkeypatch.setattr(gi.Case, "simulate", real)
    again = sweep(CASE, runs, out=tmp_path, t_end=0.5)
    assert (again.n_run, again.n_skipped) == (2, 2)
    assert [r["status"] for r in again.rows] == ["invalid", "max_impacts", "finished", "finished"]


# --------------------------------------------------------------------------
# Bad keys and values: an error naming the key, before any run

@pytest.mark.parametrize("overrides, key, message", [
    ({"links[3].EI_N_m2": [10]}, "links[3]", "no such entry: the case has 2 links"),
    ({"links.1.EI": [10]}, "links[1].EI", "unknown key"),
    ({"restitutoin": [0.5]}, "restitutoin", "unknown key (did you mean 'restitution'?)"),
    ({"restitution": [0.5, 1.5]}, "restitution", "must be in [0, 1] (1 = elastic, 0 = plastic), got 1.5"),
    ({"links.1.EI_N_m2": ["stiff"]}, "links[1].EI_N_m2", "expected a number, got the string 'stiff'"),
    ({"restitution.x": [1]}, "restitution", "not a table"),
    ({"walls.radius_m": [1]}, "walls", "give the entry number from 1, e.g. walls[1].radius_m"),
    ({"time.t_end_s": [0.5, -1.0]}, "time.t_end_s", "must be after t_start_s"),
])
def test_bad_key_or_value_is_an_error_naming_the_key_before_any_run(tmp_path, overrides, key, message):
    ran = []
    with pytest.raises(gi.CaseError) as info:
        sweep(CASE, overrides, out=tmp_path / "s", progress=lambda *a: ran.append(a))
    assert info.value.source == "overrides"
    assert any(p == key and message in m for p, m in info.value.problems), info.value.problems
    assert str(info.value).startswith(f"overrides: {key}: ")
    assert not ran and not (tmp_path / "s").exists()


def test_a_bad_value_has_the_message_of_a_case_file(tmp_path):
    text = CASE.read_text().replace("EI_N_m2 = 20.0", "EI_N_m2 = 1e300", 1)
    (tmp_path / "bad.toml").write_text(text)
    with pytest.raises(gi.CaseError) as in_file:
        gi.load_case(tmp_path / "bad.toml")
    with pytest.raises(gi.CaseError) as in_sweep:
        sweep(CASE, {"links.1.EI_N_m2": [1e300]}, out=tmp_path / "s")
    assert in_sweep.value.problems == in_file.value.problems


def test_bad_t_end_and_workers(tmp_path):
    with pytest.raises(gi.CaseError, match=r"options: t_end: must be after"):
        sweep(CASE, {"restitution": [1.0]}, t_end=-1.0, out=tmp_path / "s")
    with pytest.raises(ValueError, match="workers"):
        sweep(CASE, {"restitution": [1.0]}, workers=0, out=tmp_path / "s")
    assert not (tmp_path / "s").exists()


def test_default_folder_and_parquet(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = sweep(CASE, {"restitution": [1.0]}, t_end=0.05)
    assert res.out == Path("out") / "circle_two_link" / "sweep" and (res.out / "sweep.csv").is_file()
    try:
        import pyarrow.parquet as pq
    except ImportError:
        assert res.parquet is None
        return
    table = pq.read_table(res.parquet).to_pylist()
    assert [r["run_id"] for r in table] == [r["run_id"] for r in res.rows]
    assert table[0]["energy_error"] == res.rows[0]["energy_error"]


# --------------------------------------------------------------------------
# Command line

@pytest.mark.parametrize("option, key, values", [
    ("restitution=0.5:1:6", "restitution", [0.5, 0.6, 0.7, 0.8, 0.9, 1.0]),
    ("links.1.EI_N_m2=10,20,40", "links.1.EI_N_m2", [10, 20, 40]),
    ("initial.coordinates.theta_1_deg=-36:-27:4", "initial.coordinates.theta_1_deg", [-36.0, -33.0, -30.0, -27.0]),
    ("solver.method=RK45,\"DOP853\"", "solver.method", ["RK45", "DOP853"]),
    ("walls.1.center_m=[0, 0],[0.1,0]", "walls.1.center_m", [[0, 0], [0.1, 0]]),
    ("solver.max_step_s=inf,1e-3,.5", "solver.max_step_s", [float("inf"), 1e-3, 0.5]),
    ("restitution=0.7:0.7:1", "restitution", [0.7]),
])
def test_parse_vary(option, key, values):
    assert parse_vary(option) == (key, values)


@pytest.mark.parametrize("option", ["restitution", "=1,2", "restitution=", "restitution=0:1:0", "x=1,,2",
                                    "restitution=0:1:2.5"])
def test_parse_vary_errors(option):
    with pytest.raises(ValueError, match="--vary"):
        parse_vary(option)


def cli(*argv):
    p = argparse.ArgumentParser(prog="gibbsimpact")
    add_parser(p.add_subparsers(dest="command"))
    return main(p.parse_args(["sweep", *map(str, argv)]))


def test_cli_sweep_exit_codes(tmp_path, capsys):
    out = tmp_path / "ok"
    assert cli(CASE, "--vary", "restitution=0.5:1:2", "--vary", "links.1.EI_N_m2=10,20", "--t-end", 0.2,
               "--out", out) == 0
    captured = capsys.readouterr()
    rows = read_table(out / "sweep.csv")
    assert [(r["restitution"], r["links[1].EI_N_m2"]) for r in rows] == [
        ("0.5", "10"), ("0.5", "20"), ("1.0", "10"), ("1.0", "20")]
    assert "4 runs: 4 finished (4 run now, 0 already done)" in captured.out and not captured.err
    assert cli(CASE, "--vary", "restitution=0.5:1:2", "--vary", "links.1.EI_N_m2=10,20", "--t-end", 0.2,
               "--out", out, "--quiet") == 0
    assert capsys.readouterr().out == ""

    # A run that stops early: exit 3, every row still written.
    assert cli(CASE, "--vary", "solver.max_impacts=1,100", "--t-end", 0.5, "--out", tmp_path / "stop") == 3
    err = capsys.readouterr().err
    assert err.startswith("gibbsimpact: error: 1 of 2 runs did not finish (first: run 1, max_impacts")
    assert [r["status"] for r in read_table(tmp_path / "stop" / "sweep.csv")] == ["max_impacts", "finished"]


def test_a_stiff_point_with_a_limit_does_not_stall_the_sweep(tmp_path, capsys):
    """Issue 27: link 1 of the R-Pb arm at EI = 1e9 N m^2 needs ~1e7 right-hand sides per simulated second.
    With max_rhs_calls its run stops with status budget_exceeded and its samples, and every other point
    finishes. The limits are not part of the run ids: the sweep again with a larger limit runs only the
    point the first limit stopped."""
    pb = tmp_path / "fixed_base_R_Pb_arm.toml"  # with its DOP853 rtol 1e-8 settings (conftest.TIGHT_DOP853)
    pb.write_text(tight_dop853_text((CASE.parent / "fixed_base_R_Pb_arm.toml").read_text()))
    grid = {"links[1].EI_N_m2": [25.0, 1e9, 30.0]}
    res = sweep(pb, grid, out=tmp_path / "s", t_end=0.02, max_rhs_calls=20_000)
    assert [r["status"] for r in res.rows] == ["finished", "budget_exceeded", "finished"]
    stiff = res.rows[1]
    assert stiff["nfev"] == 20_000 and 0 < stiff["t_final_s"] < 0.02
    assert "max_rhs_calls = 20000 right-hand sides" in stiff["message"]
    kept = gi.load_result(res.out / stiff["result"])
    assert kept.status == "budget_exceeded" and kept.t.size > 1 and kept.t[-1] == stiff["t_final_s"]
    assert [r["t_final_s"] for r in res.rows[::2]] == [0.02, 0.02]
    again = sweep(pb, grid, out=tmp_path / "s", t_end=0.02, max_rhs_calls=20_000)
    assert (again.n_run, again.n_skipped) == (0, 3)
    larger = sweep(pb, grid, out=tmp_path / "s", t_end=0.02, max_rhs_calls=30_000)
    assert (larger.n_run, larger.n_skipped) == (1, 2)
    assert [r["run_id"] for r in larger.rows] == [r["run_id"] for r in res.rows]  # the ids ignore the limits
    assert larger.rows[1]["nfev"] == 30_000 and larger.rows[1]["t_final_s"] > stiff["t_final_s"]
    # The command line: the same limit, exit code 3 (a run did not finish), every row written.
    assert cli(pb, "--vary", "links.1.EI_N_m2=25,1e9", "--t-end", 0.02, "--max-rhs-calls", 20000, "--quiet",
               "--out", tmp_path / "c") == 3
    assert "(first: run 2, budget_exceeded:" in capsys.readouterr().err
    assert [r["status"] for r in read_table(tmp_path / "c" / "sweep.csv")] == ["finished", "budget_exceeded"]


@pytest.mark.parametrize("argv, message", [
    (["--vary", "links.3.EI_N_m2=10"], "gibbsimpact: error: --vary: links[3]: no such entry"),
    (["--vary", "restitution=0.5,2"], "gibbsimpact: error: --vary: restitution: must be in [0, 1]"),
    (["--vary", "restitution"], "gibbsimpact: error: --vary restitution: expected KEY=a:b:n or KEY=v1,v2,..."),
    (["--vary", "restitution=1", "--vary", "restitution=0.5"], "restitution is already varied"),
    (["--vary", "restitution=1", "--t-end", "-1"], "gibbsimpact: error: options: --t-end: must be after"),
])
def test_cli_bad_input_exit_2_before_any_run(tmp_path, capsys, argv, message):
    assert cli(CASE, *argv, "--out", tmp_path / "s") == 2
    captured = capsys.readouterr()
    assert message in captured.err and captured.err.startswith("gibbsimpact: error: ")
    assert not (tmp_path / "s").exists()


def test_cli_missing_case_exit_2(tmp_path, capsys):
    assert cli(tmp_path / "nope.toml", "--vary", "restitution=1") == 2
    assert "no such file" in capsys.readouterr().err
