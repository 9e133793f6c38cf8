"""The cost estimate on the command line (``show``'s ``cost:`` line, the start of ``run`` and its warning) and
the limits of a run (``--max-cpu-time``, ``--max-rhs-calls``, [solver] max_cpu_time_s / max_rhs_calls)."""

from __future__ import annotations

import json
from pathlib import Path

from gibbsimpact.cli import commands as cli
from gibbsimpact.cli.run import WARN_CPU_SECONDS
from conftest import TIGHT_DOP853_ARGS, tight_dop853_text

CASES = Path(__file__).resolve().parents[2] / "cases"


def run_main(argv, capsys):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def stiff_case(tmp_path) -> Path:
    """cases/fixed_base_R_Pb_arm.toml with link 1 4e7 times stiffer: omega_max 1.3e7 rad/s, hours of DOP853."""
    text = tight_dop853_text((CASES / "fixed_base_R_Pb_arm.toml").read_text())
    assert text.count("EI_N_m2 = 25.0") == 1
    path = tmp_path / "stiff_arm.toml"
    path.write_text(text.replace("EI_N_m2 = 25.0", "EI_N_m2 = 1e9"))
    return path


def test_show_states_the_cost(tmp_path, capsys):
    arm = tmp_path / "arm.toml"
    arm.write_text(tight_dop853_text((CASES / "fixed_base_R_Pb_arm.toml").read_text()))
    code, out, err = run_main(["show", arm], capsys)
    assert code == 0 and err == ""
    cost = [ln for ln in out.splitlines() if ln.startswith("cost: ")]
    assert len(cost) == 1
    assert cost[0].startswith("cost: highest frequency 2181 rad/s (period 0.00288 s); DOP853 over 2 s: about ")
    assert "steps" in cost[0] and "right-hand sides" in cost[0] and "(accuracy on the mode at 2181 rad/s)" in cost[0]


def test_run_states_the_cost_and_stops_at_its_rhs_limit(tmp_path, capsys):
    out = tmp_path / "out"
    code, text, err = run_main(["run", CASES / "fixed_base_R_Pb_arm.toml", "--out", out, "--no-plots",
                                "--max-rhs-calls", 2000, *TIGHT_DOP853_ARGS], capsys)
    assert code == 3  # stopped early
    lines = text.splitlines()
    assert lines[1].startswith("  highest frequency 2181 rad/s (period 0.00288 s); DOP853 over 2 s: about ")
    assert "status: budget_exceeded (the run used up its budget max_rhs_calls = 2000 right-hand sides" in text
    assert "simulation stopped early (budget_exceeded)" in err and "warning" not in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "budget_exceeded" and summary["nfev"] == 2000
    assert summary["settings"]["max_rhs_calls"] == 2000
    assert 0 < summary["t_final_s"] < 2.0 and summary["n_samples"] > 1  # what it computed is written


def test_run_warns_before_hours_and_the_cpu_limit_ends_it(tmp_path, capsys):
    """The stiff arm: a warning on stderr (also with --quiet) naming the estimate, the highest frequency and
    what to do; its CPU limit stops it with status budget_exceeded and writes what it computed."""
    out = tmp_path / "out"
    code, text, err = run_main(["run", stiff_case(tmp_path), "--out", out, "--no-plots", "--quiet",
                                "--max-cpu-time", 0.5], capsys)
    assert code == 3 and text == ""
    warning = [ln for ln in err.splitlines() if "warning" in ln]
    assert len(warning) == 1
    assert warning[0].startswith("gibbsimpact: warning: ") and "this run may take " in warning[0]
    assert "for its highest frequency 1.284e+07 rad/s" in warning[0]
    assert "--method Radau is not bound by the stability limit, its limit will stop it" in warning[0]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "budget_exceeded" and "max_cpu_time = 0.5 s of CPU" in summary["message"]
    assert WARN_CPU_SECONDS == 600.0


def test_limits_as_case_file_keys(tmp_path, capsys):
    """[solver] max_rhs_calls in the file does what --max-rhs-calls does; the option overrides it."""
    text = tight_dop853_text((CASES / "fixed_base_R_Pb_arm.toml").read_text()).replace(
        'joint_limit = "stop"', 'joint_limit = "stop"\nmax_rhs_calls = 1000')
    case = tmp_path / "limited.toml"
    case.write_text(text)
    code, _, err = run_main(["run", case, "--out", tmp_path / "a", "--no-plots", "--quiet"], capsys)
    assert code == 3
    assert json.loads((tmp_path / "a" / "summary.json").read_text())["nfev"] == 1000
    code, _, err = run_main(["run", case, "--out", tmp_path / "b", "--no-plots", "--quiet", "--max-rhs-calls", 1500],
                            capsys)
    assert code == 3 and json.loads((tmp_path / "b" / "summary.json").read_text())["nfev"] == 1500
    code, _, err = run_main(["run", case, "--out", tmp_path / "c", "--max-cpu-time", 0], capsys)
    assert code == 2 and "--max-cpu-time: must be in [0.001, 1e9] s" in err
