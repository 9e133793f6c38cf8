"""``gibbsimpact sweep``'s options besides --vary (gibbsimpact.cli.sweep): --method and --rtol reach
every run and are checked as ``gibbsimpact run`` checks them; --plot draws a column of the table.
(--vary, the routes and the exit codes: tests/study/test_sweep.py.)"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest

import gibbsimpact as gi
from gibbsimpact.cli import commands as cli

CASE = Path(__file__).resolve().parents[2] / "cases" / "circle_two_link.toml"


#: The package's one-time compile notices on stderr ("compiling ... ...", "... ready in 13.3 s ..."): whether a
#: test's process compiles a kernel variant depends on which tests ran before it in that worker, so they are no
#: part of a command's error output.
COMPILE_NOTICE = re.compile(r"^gibbsimpact: (compiling .*\.\.\.|.*ready in [0-9.]+ s.*)\n", re.M)


def run_main(argv, capsys):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, COMPILE_NOTICE.sub("", err)


def read_table(path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_method_and_rtol_reach_every_run(tmp_path, capsys):
    """The case runs DOP853 at rtol 1e-10; with --method RK45 --rtol 1e-6 every run's result records
    those settings, takes fewer right-hand-side evaluations, and is another run (another id)."""
    sweep = ["sweep", CASE, "--vary", "restitution=0.5,1", "--t-end", "0.2", "-q"]
    assert run_main([*sweep, "--out", tmp_path / "case"], capsys)[0] == 0
    assert run_main([*sweep, "--out", tmp_path / "opt", "--method", "RK45", "--rtol", "1e-6"], capsys)[0] == 0
    case_rows, rows = read_table(tmp_path / "case" / "sweep.csv"), read_table(tmp_path / "opt" / "sweep.csv")
    for base, row in zip(case_rows, rows, strict=True):
        before, r = gi.load_result(tmp_path / "case" / base["result"]), gi.load_result(tmp_path / "opt" / row["result"])
        assert (before.settings["method"], before.settings["rtol"]) == ("DOP853", 1e-10)
        assert (r.settings["method"], r.settings["rtol"]) == ("RK45", 1e-6)
        assert int(row["nfev"]) < int(base["nfev"]) and row["run_id"] != base["run_id"]
    assert list(rows[0]) == list(case_rows[0])  # options are no columns


@pytest.mark.parametrize("option", [["--method", "Euler"], ["--rtol", "-1"], ["--method", "rk45"]])
def test_bad_method_or_rtol_has_the_message_of_run(tmp_path, capsys, option):
    code, _, run_err = run_main(["run", CASE, *option, "--out", tmp_path / "run"], capsys)
    assert code == 2
    code, _, sweep_err = run_main(["sweep", CASE, "--vary", "restitution=1", *option, "--out", tmp_path / "s"], capsys)
    assert code == 2 and sweep_err == run_err and run_err.startswith(f"gibbsimpact: error: options: {option[0]}: ")
    assert not (tmp_path / "s").exists()


def test_an_option_that_sets_a_varied_key_is_an_error(tmp_path, capsys):
    code, _, err = run_main(["sweep", CASE, "--vary", "solver.rtol=1e-8,1e-9", "--rtol", "1e-6",
                             "--out", tmp_path / "s"], capsys)
    assert code == 2 and err.startswith("gibbsimpact: error: options: solver.rtol: is varied and also set for "
                                        "every run by rtol= (--rtol on the command line)")
    assert not (tmp_path / "s").exists()


def test_plot_draws_each_column_into_the_sweep_folder(tmp_path, capsys):
    code, out, err = run_main(["sweep", CASE, "--vary", "solver.method=RK45,DOP853", "--vary", "restitution=0.5,1",
                               "--t-end", "0.5", "--plot", "energy_lost_J", "--plot", "nfev", "--out", tmp_path], capsys)
    assert code == 0 and not err
    for column in ("energy_lost_J", "nfev"):
        assert f"figure: {tmp_path / f'sweep_{column}.png'}" in out
        assert (tmp_path / f"sweep_{column}.png").stat().st_size > 1000


@pytest.mark.parametrize("argv, message", [
    (["--vary", "restitution=0.5,1", "--plot", "status"], "--plot status: column: 'status' cannot be drawn"),
    (["--vary", "restitution=0.5,1", "--vary", "links.1.EI_N_m2=10,20", "--vary", "time.t_end_s=0.1,0.2",
      "--plot", "nfev"], "--plot nfev: this sweep varies 3 keys"),
    (["--vary", "solver.method=RK45,DOP853", "--plot", "nfev"], "--plot nfev: x: no varied key has a number"),
])
def test_bad_plot_exit_2_before_any_run(tmp_path, capsys, argv, message):
    code, _, err = run_main(["sweep", CASE, *argv, "--out", tmp_path / "s"], capsys)
    assert code == 2 and err.startswith(f"gibbsimpact: error: {message}")
    assert not (tmp_path / "s").exists()
