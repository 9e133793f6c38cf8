"""Command line: both published cases run end to end and reproduce their first impacts;
every output file is written; `show` describes the model; exit codes 0 / 2 / 3."""

from __future__ import annotations

import io as _io
import math
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.cli import commands as cli
from gibbsimpact.io import result_files as gio
from gibbsimpact import load_result
from gibbsimpact.plotting.figures import FIGURES
from conftest import PB_DROP_CASE, TIGHT_DOP853_ARGS, ZENO

CASES = Path(__file__).resolve().parents[2] / "cases"

# A rigid link dropped flat on a plane with e = 0.5: the bounce intervals halve,
# so with zeno_interval_s = 0.05, zeno_count = 3 and accumulation = "stop" the run
# stops (status zeno) after the 4th impact, at t ~ 0.124 s.



def nonblank(path):
    import matplotlib.image as mpimg

    img = mpimg.imread(path)
    return img.ndim == 3 and float(img[..., :3].std()) > 0.01


#: The package's one-time compile notices on stderr ("compiling ... ...", "... ready in 13.3 s ..."): whether a
#: test's process compiles a kernel variant depends on which tests ran before it in that worker, so they are no
#: part of a command's error output.
COMPILE_NOTICE = re.compile(r"^gibbsimpact: (compiling .*\.\.\.|.*ready in [0-9.]+ s.*)\n", re.M)


def run_main(argv, capsys):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, COMPILE_NOTICE.sub("", err)


@pytest.fixture(scope="module")
def case1_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("case1")
    # Default tolerances of the case (rtol 1e-10): impact times are compared with the reference.
    code = cli.main(["run", str(CASES / "circle_two_link.toml"), "--out", str(out), "--t-end", "0.5", "--quiet"])
    return code, out


@pytest.fixture(scope="module")
def case2_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("case2")
    code = cli.main(["run", str(CASES / "sphere_single_link.toml"), "--out", str(out), "--t-end", "0.6", "--quiet"])
    return code, out


@pytest.mark.parametrize("which", ["case1_out", "case2_out"])
def test_run_writes_every_file(which, request):
    code, out = request.getfixturevalue(which)
    assert code == 0
    for name in ("timeseries.csv", "impacts.csv", "summary.json", "result.npz"):
        assert (out / name).stat().st_size > 0, name
    for name in FIGURES:
        assert nonblank(out / f"{name}.png"), name
    assert not (out / "animation.gif").exists()


def test_case1_reproduces_first_impacts(case1_out):
    code, out = case1_out
    s = json.loads((out / "summary.json").read_text())
    assert s["case"] == "circle_two_link" and s["status"] == "finished"
    assert s["t_final_s"] == 0.5
    assert s["impact_joints"] == [[2], [1, 3]]
    np.testing.assert_allclose(s["impact_times_s"], [0.451524, 0.474918], atol=1e-6)
    assert s["energy_initial_J"]["total"] == pytest.approx(-4.905, abs=1e-9)
    assert s["energy_final_J"]["total"] == pytest.approx(-4.905, abs=1e-6)
    assert s["settings"]["rtol"] == 1e-10 and s["settings"]["output_dt"] == 1e-3
    assert "matplotlib" in s["versions"]
    cols = gio.read_csv(out / "impacts.csv")
    assert cols["joint"].tolist() == [2, 1, 3]
    res, meta = load_result(out / "result.npz", with_metadata=True)
    assert meta["case"] == "circle_two_link" and "circle" in meta["case_toml"]
    assert len(res.impacts) == 2 and res.t[-1] == 0.5


def test_case2_reproduces_first_impact(case2_out):
    code, out = case2_out
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "finished" and s["impact_joints"] == [[1]]
    np.testing.assert_allclose(s["impact_times_s"], [0.540052], atol=1e-6)
    assert s["energy_initial_J"]["total"] == pytest.approx(1.807549, abs=5e-7)
    assert s["model"]["n_odes"] == 16


def test_run_default_output_directory_and_report(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--t-end", "0.05", "--no-plots",
                               "--rtol", "1e-8", "--atol", "1e-10", "--output-dt", "0.01"], capsys)
    assert code == 0 and err == ""
    d = tmp_path / "out" / "circle_two_link"
    assert (d / "summary.json").exists() and not (d / "angles.png").exists()
    assert "status: finished" in out and "0 impacts" not in err
    s = json.loads((d / "summary.json").read_text())
    assert s["settings"]["rtol"] == 1e-8 and s["settings"]["output_dt"] == 0.01
    assert gio.read_csv(d / "timeseries.csv")["t_s"].tolist() == pytest.approx([0.0, 0.01, 0.02, 0.03, 0.04, 0.05])


def test_quiet_prints_nothing(tmp_path, capsys):
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--t-end", "0.01", "--no-plots", "--quiet",
                               "--out", tmp_path], capsys)
    assert code == 0 and out == "" and err == ""


def test_stopped_early_exit_3_keeps_results_and_animates(tmp_path, capsys):
    case = tmp_path / "zeno.toml"
    case.write_text(ZENO)
    code, out, err = run_main(["run", case, "--out", tmp_path / "o", "--animate", "--quiet"], capsys)
    assert code == 3
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gibbsimpact: error: simulation stopped early (zeno)")
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["status"] == "zeno" and s["n_impacts"] == 4
    assert all(j == [1, 2] for j in s["impact_joints"])
    assert nonblank(tmp_path / "o" / "configurations.png")
    from PIL import Image

    with Image.open(tmp_path / "o" / "animation.gif") as im:
        assert im.n_frames > 1


def test_max_impacts_exit_3(tmp_path, capsys):
    text = (CASES / "circle_two_link.toml").read_text().replace("output_dt_s = 1e-3", "output_dt_s = 1e-2\nmax_impacts = 1")
    case = tmp_path / "c.toml"
    case.write_text(text)
    code, out, err = run_main(["run", case, "--out", tmp_path / "o", "--no-plots", "-q", "--rtol", "1e-8"], capsys)
    assert code == 3 and "(max_impacts)" in err
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["n_impacts"] == 1


def test_bad_case_exit_2_names_every_problem(tmp_path, capsys):
    text = (CASES / "circle_two_link.toml").read_text()
    text = text.replace("radius_m = 1.5", "radius_m = 0.5").replace("length_m = 1.0", "length_m = -1.0", 1)
    case = tmp_path / "bad.toml"
    case.write_text(text)
    code, out, err = run_main(["run", case, "--out", tmp_path / "o"], capsys)
    assert code == 2 and out == ""
    assert err.startswith("gibbsimpact: error: ") and "links[1].length_m: must be in [1e-6, 1e6] m" in err
    assert not (tmp_path / "o").exists()
    # A valid chain outside a too small wall.
    case.write_text((CASES / "circle_two_link.toml").read_text().replace("radius_m = 1.5", "radius_m = 0.5"))
    code, out, err = run_main(["show", case], capsys)
    assert code == 2
    assert "joint O1" in err and "joint O3" in err and "outside walls[1]" in err


def test_missing_file_and_bad_options_exit_2(tmp_path, capsys):
    code, out, err = run_main(["run", tmp_path / "none.toml"], capsys)
    assert code == 2 and err.strip() == (f"gibbsimpact: error: CASE.toml: '{tmp_path / 'none.toml'}': no such file; "
                                         "give the path of a case file (e.g. cases/circle_two_link.toml)")
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--t-end", "-1", "--out", tmp_path], capsys)
    assert code == 2 and err == "gibbsimpact: error: options: --t-end: must be after time.t_start_s = 0 s, got -1\n"
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--rtol", "-1", "--out", tmp_path], capsys)
    assert code == 2 and "--rtol: must be in [1e-13, 0.1]" in err
    with pytest.raises(SystemExit) as info:
        cli.main(["run", str(CASES / "circle_two_link.toml"), "--rtol", "small"])
    assert info.value.code == 2
    with pytest.raises(SystemExit) as info:
        cli.main([])
    assert info.value.code == 2


def test_csv_every_option(tmp_path, capsys):
    # timeseries.csv of every 10th sample (and the last); result.npz keeps them all.
    from gibbsimpact.io import result_files as io

    out = tmp_path / "o"
    code, _, _ = run_main(["run", CASES / "circle_two_link.toml", "--t-end", "0.05", "--no-plots", "--quiet",
                           "--csv-every", "10", "--out", out], capsys)
    assert code == 0
    res = gi.load_result(out / "result.npz")
    K = len(res.t)
    full = io.write_timeseries_csv(res, tmp_path / "full.csv").read_text().splitlines()
    part = (out / "timeseries.csv").read_text().splitlines()
    rows = list(range(0, K, 10)) + ([] if (K - 1) % 10 == 0 else [K - 1])
    assert K > 40 and part == [full[0]] + [full[1 + r] for r in rows]
    for bad in ("0", "x"):
        with pytest.raises(SystemExit) as info:
            cli.main(["run", str(CASES / "circle_two_link.toml"), "--csv-every", bad])
        assert info.value.code == 2
    assert "--csv-every" in capsys.readouterr().err


def test_show_describes_the_model(capsys):
    code, out, err = run_main(["show", CASES / "circle_two_link.toml"], capsys)
    assert code == 0
    assert "N = 9 generalised coordinates, 18 first-order ODEs" in out
    names = ["X1", "X2", "X3", "theta_-1", "theta_0", "theta_1", "theta_2", "delta_1_1", "delta_2_1"]
    rows = [ln.split()[1] for ln in out.splitlines() if ln[:4].strip().isdigit()]
    assert rows == names
    assert "omega = 100.056 rad/s" in out  # 4.73004^2 sqrt(20 / 1)
    assert "circle R=1.5 m centre (0, 0)" in out
    assert "total -4.905 J" in out
    gaps = [ln for ln in out.splitlines() if ln.strip().startswith("O")]
    assert len(gaps) == 3 and gaps[1].split()[-1] == "1"
    code, out, err = run_main(["show", CASES / "sphere_single_link.toml"], capsys)
    assert code == 0 and "16 first-order ODEs" in out and "mode 1 in z" in out and "1.80754863 J" in out


def test_show_describes_a_root_welded_to_a_fixed_base(tmp_path, capsys):
    # Joint 1 a weld on a fixed base (a flexible link clamped at an angle): show stopped with a KeyError.
    case = tmp_path / "welded_root.toml"
    case.write_text('''name = "welded_root"
gravity_m_per_s2 = [0.0, -9.81, 0.0]
[time]
t_end_s = 0.1
[base]
type = "fixed"
position_m = [0.0, 0.6]
[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 25.0
elements = 2
element_directions = ["y"]
[links.joint]
type = "W"
angle_deg = -30.0
[[links]]
length_m = 0.6
mass_per_length_kg_per_m = 0.5
EI_N_m2 = 8.0
''')
    code, out, err = run_main(["show", case], capsys)
    assert code == 0, err
    assert "joint 1 welds link 1 to the base there (no coordinate)" in out
    assert "W (weld, no coordinate): link 1 fixed at -30 deg on the base" in out
    # N = theta_2 and link 1's four element coordinates (2 elements, deflection and slope at 2 nodes)
    assert "N = 5 generalised coordinates" in out


def test_progress_bar_only_on_a_terminal(tmp_path, monkeypatch):
    # The CLI asks simulate for its tqdm bar (progress=True) when stderr is a terminal and not --quiet.
    class Tty(_io.StringIO):
        def isatty(self):
            return True

    argv = ["run", str(CASES / "circle_two_link.toml"), "--t-end", "0.05", "--no-plots", "--out", str(tmp_path)]
    for stream, extra, shown in ((Tty(), [], True), (Tty(), ["--quiet"], False), (_io.StringIO(), [], False)):
        monkeypatch.setattr(sys, "stderr", stream)
        assert cli.main(argv + extra) == 0
        text = stream.getvalue()
        assert (("simulate: 100%" in text and "t = 0.05 / 0.05 s" in text and "impacts: 0" in text) if shown
                else text == ""), text


def test_module_and_console_script(tmp_path):
    r = subprocess.run([sys.executable, "-m", "gibbsimpact", "show", str(CASES / "sphere_single_link.toml")],
                       capture_output=True, text=True)
    assert r.returncode == 0 and "sphere R=1 m" in r.stdout
    r = subprocess.run([sys.executable, "-m", "gibbsimpact", "run", str(tmp_path / "x.toml")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    exe = shutil.which("gibbsimpact")
    if exe is None:
        pytest.skip("console script not on PATH (package not installed)")
    r = subprocess.run([exe, "--version"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.startswith("gibbsimpact ")


# -- case files that used to crash or get through: exit 2, the key named, nothing before ----

# (id, text in circle_two_link.toml, replacement, key path named in the error)
ISSUE_FILES = [
    ("length_beyond_double", "length_m = 1.0", "length_m = 1" + "0" * 400, "links[1].length_m"),
    ("length_1e-300", "length_m = 1.0", "length_m = 1e-300", "links[1].length_m"),
    ("mode_number_1e12", "number = 1 }", "number = 1000000000000 }", "links[1].modes[1].number"),
    ("output_dt_1e-12", "output_dt_s = 1e-3", "output_dt_s = 1e-12", "solver.output_dt_s"),
    ("dpi_1e6", "animate = false", "animate = false\ndpi = 1000000", "output.dpi"),
    ("points_per_link_1e9", "animate = false", "animate = false\npoints_per_link = 1000000000",
     "output.points_per_link"),
    ("EI_1e300", "EI_N_m2 = 20.0", "EI_N_m2 = 1e300", "links[1].EI_N_m2"),
    ("rtol_1e308", "rtol = 1e-10", "rtol = 1e308", "solver.rtol"),
]


def issue_file(tmp_path, old, new):
    text = (CASES / "circle_two_link.toml").read_text()
    assert old in text
    path = tmp_path / "issue.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize("old,new,key", [f[1:] for f in ISSUE_FILES], ids=[f[0] for f in ISSUE_FILES])
def test_issue_files_exit_2_naming_the_key(tmp_path, capsys, old, new, key):
    import warnings

    path = issue_file(tmp_path, old, new)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code, out, err = run_main(["run", path, "--out", tmp_path / "o", "--no-plots", "-q"], capsys)
    assert code == 2 and out == "" and not caught, [str(w.message) for w in caught]
    assert err.count("\n") == 1 and err.startswith(f"gibbsimpact: error: {path}: {key}: ")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("which", ["length_beyond_double", "EI_1e300"])
def test_issue_files_stderr_of_the_process_is_the_error_line(tmp_path, which):
    # A separate process: what reaches the terminal, numpy warnings included.
    _, old, new, key = next(f for f in ISSUE_FILES if f[0] == which)
    path = issue_file(tmp_path, old, new)
    r = subprocess.run([sys.executable, "-m", "gibbsimpact", "run", str(path), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and r.stderr.startswith(f"gibbsimpact: error: {path}: {key}: ")
    assert "Warning" not in r.stderr


def test_empty_case_argument_exit_2(capsys):
    code, out, err = run_main(["run", ""], capsys)
    assert code == 2 and out == ""
    assert err == ("gibbsimpact: error: CASE.toml: '' is not a file; "
                   "give the path of a case file (e.g. cases/circle_two_link.toml)\n")


def test_directory_and_unreadable_case_exit_2(tmp_path, capsys, monkeypatch):
    code, out, err = run_main(["show", tmp_path], capsys)
    assert code == 2 and err.startswith(f"gibbsimpact: error: CASE.toml: '{tmp_path}' is a directory, not a case file")
    path = tmp_path / "locked.toml"
    path.write_text((CASES / "circle_two_link.toml").read_text())

    def denied(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "read_bytes", denied)  # chmod 000 does not stop root
    code, out, err = run_main(["run", path], capsys)
    assert code == 2 and err == f"gibbsimpact: error: CASE.toml: '{path}': cannot read (Permission denied)\n"


# Options out of their case-file range, and the sample limit with the case's output_dt_s = 1e-3 s.
BAD_OPTIONS = [
    (["--t-end", "1e10"], "--t-end: must be in [-1e9, 1e9] s"),
    (["--t-end", "nan"], "--t-end: must be in [-1e9, 1e9] s"),
    (["--t-end", "1e5"], "solver.output_dt_s: (--t-end - time.t_start_s) / solver.output_dt_s = 1e5 s / 0.001 s"),
    (["--rtol", "1e308"], "--rtol: must be in [1e-13, 0.1]"),
    (["--rtol", "1e-14"], "--rtol: must be in [1e-13, 0.1]"),
    (["--atol", "0"], "--atol: must be in [1e-20, 1]"),
    (["--atol", "inf"], "--atol: must be in [1e-20, 1]"),
    (["--output-dt", "0"], "--output-dt: must be in [1e-15, 1e9] s"),
    (["--output-dt", "1e-12"], "--output-dt: (time.t_end_s - time.t_start_s) / --output-dt = 1 s / 1e-12 s"),
]


@pytest.mark.parametrize("opts,message", BAD_OPTIONS, ids=[" ".join(o) for o, _ in BAD_OPTIONS])
def test_options_held_to_the_case_ranges(tmp_path, capsys, opts, message):
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--out", tmp_path / "o", *opts], capsys)
    assert code == 2 and out == "" and err == f"gibbsimpact: error: options: {message}" + err.split(message, 1)[1]
    assert err.count("\n") == 1 and not (tmp_path / "o").exists()


@pytest.mark.parametrize("kw,option", [("t_end", "--t-end"), ("rtol", "--rtol"), ("atol", "--atol"),
                                       ("output_dt", "--output-dt")])
def test_option_bounds_are_the_case_file_ranges(kw, option):
    from gibbsimpact import load_case
    from gibbsimpact.case import OVERRIDE_KEYS, RANGES

    case = load_case(CASES / "circle_two_link.toml")
    rng = RANGES[OVERRIDE_KEYS[kw]]
    # Room for the sample limit: 1e7 samples at the smallest interval; every step stored for any t_end.
    other = {"t_end": 1e-8} if kw == "output_dt" else {"output_dt": None}
    names = {kw: option}
    low = rng.low if kw != "t_end" else 1e-9  # t_end must also be after t_start = 0
    for inside in (low, rng.high):
        assert case.override_problems(names=names, **{**other, kw: inside}) == [], inside
    for outside in (math.nextafter(rng.low, -math.inf), math.nextafter(rng.high, math.inf)):
        problems = case.override_problems(names=names, **{**other, kw: outside})
        assert [p for p, _ in problems] == [option] and str(rng) in problems[0][1], problems


def test_run_warnings_are_summed_up_after_the_error_line(tmp_path, capsys, monkeypatch):
    from gibbsimpact.case import Case

    real = Case.simulate

    def overflowing(self, **kw):
        np.float64(1e308) * 10.0  # RuntimeWarning: overflow encountered in scalar multiply
        return real(self, **kw)

    monkeypatch.setattr(Case, "simulate", overflowing)
    case = tmp_path / "zeno.toml"
    case.write_text(ZENO)
    code, out, err = run_main(["run", case, "--out", tmp_path / "o", "--no-plots", "--quiet"], capsys)
    lines = err.splitlines()
    assert code == 3 and len(lines) == 2
    assert lines[0].startswith("gibbsimpact: error: simulation stopped early (zeno)")
    assert lines[1].startswith("gibbsimpact: warning: 1 kind(s) of warning during the run, the first: "
                               "RuntimeWarning: overflow encountered in scalar multiply (test_commands.py:")


def test_show_fixed_base_fe_arm(capsys):
    code, out, err = run_main(["show", CASES / "fixed_base_fe_arm.toml"], capsys)
    assert code == 0 and err == ""
    assert "N = 16 generalised coordinates, 32 first-order ODEs" in out
    assert "base: fixed at (0, 0.6, 0) m, angle 0 deg about X3" in out
    rows = [ln.split() for ln in out.splitlines() if ln[:4].strip().isdigit()]
    assert [r[1] for r in rows] == ["theta_1", "theta_2"] + [f"delta_1_{k}" for k in range(1, 9)] + \
        [f"delta_2_{k}" for k in range(1, 7)]
    assert [r[3] for r in rows[2:6]] == ["m", "rad", "m", "rad"]  # node deflections and slopes
    assert "4 Hermite cubic element(s) in y" in out and "3 Hermite cubic element(s) in y" in out
    # Lowest clamped-free frequency of link 1 against the beam's 1.87510^2 sqrt(25 / 1) = 17.5801 rad/s.
    assert "clamped-free omega = 17.5807 (beam 17.5801)" in out
    assert "damping ratio 0.002 in the first elastic mode" in out
    assert "inputs[1] on theta_1: sine Q = 8.7 - 3 sin(2 pi 1 Hz t + 0 deg) N m" in out
    assert "inputs[2] on theta_2: pd servo Q = 10 N m/rad * (target - theta_2)" in out
    # The motor's rotor on joint 1 (a hub: at the clamped root it leaves link 1's omega_1 as it was).
    assert ("bodies[1] (hub): m = 0.5 kg at x = 0 m, centre offset (0, 0, 0) m, inertia (J_xx, J_yy, J_zz) = "
            "(0.05, 0.05, 0.1) kg m^2") in out
    assert "with its bodies, clamped at its frame: omega_1 = 17.5807 rad/s" in out
    # The published free-flying cases say so, and have no inputs.
    code, out, err = run_main(["show", CASES / "circle_two_link.toml"], capsys)
    assert "base: free-flying" in out and "inputs: none" in out


def test_run_fixed_base_fe_arm_briefly(tmp_path, capsys):
    code, out, err = run_main(["run", CASES / "fixed_base_fe_arm.toml", "--out", tmp_path, "--t-end", "0.01",
                               "--no-plots", "--quiet"], capsys)
    # Nothing on stderr: the motor's hub inertia turns the arm smoothly (without it the motor spun link 1 up
    # to 0.785 times its first bending frequency within a millisecond, and the run warned: validity.SPIN_LIMIT).
    assert code == 0 and out == "" and err == ""
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["status"] == "finished" and s["model"]["coordinate_names"][:3] == ["theta_1", "theta_2", "delta_1_1"]
    assert s["settings"]["rtol"] == 1e-8 and s["n_impacts"] == 0
    # The motor does work, the damping takes some; the power balance holds.
    assert s["work_final_J"]["inputs"] != 0.0 and s["work_final_J"]["damping"] < 0.0
    assert s["max_relative_energy_error"] < 1e-9


def test_equations_prints_counts_and_writes_latex_and_python(tmp_path, capsys):
    code, out, err = run_main(["equations", CASES / "circle_two_link.toml", "--latex", tmp_path / "c1.tex",
                               "--python", tmp_path / "c1.py"], capsys)
    assert code == 0, err
    assert "N = 9 coordinates" in out and "method gibbs-appell" in out
    assert re.search(r"operations after CSE: \d+ adds, \d+ multiplications, \d+ function calls", out)
    assert (tmp_path / "c1.tex").read_text().startswith(r"\documentclass")
    # The written module computes the case's M: load it and compare with the model.
    import importlib.util

    spec = importlib.util.spec_from_file_location("c1_eqs", tmp_path / "c1.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    case = gi.load_case(CASES / "circle_two_link.toml")
    q = case.q0 + 0.1
    M = mod.mass_matrix(q)
    np.testing.assert_allclose(M, case.model.mass_matrix(q), rtol=1e-12, atol=1e-14)
    code, out, err = run_main(["equations", CASES / "circle_two_link.toml", "--latex", tmp_path / "no" / "x.tex"], capsys)
    assert code == 2 and "--latex" in err and "does not exist" in err


# -- --method, several case files, exit codes in --help, signal handlers -----------------------------

def test_method_option(tmp_path, capsys):
    from gibbsimpact.simulation.auto import METHODS as SOLVERS  # scipy's solvers and "auto"

    code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--method", "RK45", "--t-end", "0.02",
                               "--no-plots", "-q", "--out", tmp_path / "o"], capsys)
    assert code == 0
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["settings"]["method"] == "RK45"
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--method", "Euler", "--out", tmp_path / "p"],
                              capsys)
    # The names gi.simulate accepts, in its order, and nothing simulated or created.
    assert code == 2 and out == "" and not (tmp_path / "p").exists()
    assert err == f"gibbsimpact: error: options: --method: unknown method 'Euler'; use one of {', '.join(SOLVERS)}\n"
    with pytest.raises(ValueError, match=f"use one of {', '.join(SOLVERS)}$"):
        gi.load_case(CASES / "circle_two_link.toml").simulate(method="Euler")


def test_run_several_cases_each_into_its_folder_worst_exit_code(tmp_path, capsys):
    zeno = tmp_path / "zeno.toml"
    zeno.write_text(ZENO)
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", zeno, "--out", tmp_path / "o", "--t-end", "0.3",
                               "--no-plots"], capsys)
    assert code == 3  # the worst: one finished (0), one stopped early (3)
    assert out.count("gibbsimpact: running") == 2
    assert json.loads((tmp_path / "o" / "circle_two_link" / "summary.json").read_text())["status"] == "finished"
    assert json.loads((tmp_path / "o" / "zeno" / "summary.json").read_text())["status"] == "zeno"
    assert err.count("\n") == 1 and "(zeno)" in err and str(tmp_path / "o" / "zeno") in err
    # A bad file among them: nothing runs (every input is checked first), one line per problem.
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", tmp_path / "none.toml", "--out",
                               tmp_path / "q"], capsys)
    assert code == 2 and out == "" and err.count("\n") == 1 and not (tmp_path / "q").exists()
    # Two files with the same name would write into one folder.
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "zeno.toml").write_text(ZENO)
    code, out, err = run_main(["run", zeno, tmp_path / "b" / "zeno.toml", "--out", tmp_path / "r"], capsys)
    assert code == 2 and "would both write into" in err and not (tmp_path / "r").exists()


def test_show_several_cases(tmp_path, capsys):
    code, out, err = run_main(["show", CASES / "circle_two_link.toml", tmp_path / "none.toml",
                               CASES / "sphere_single_link.toml"], capsys)
    assert code == 2 and err.count("\n") == 1 and "none.toml" in err
    assert [ln.split()[1] for ln in out.splitlines() if ln.startswith("case ")] == ["circle_two_link",
                                                                                   "sphere_single_link"]
    code, out, err = run_main(["show", CASES / "circle_two_link.toml", CASES / "sphere_single_link.toml"], capsys)
    assert code == 0 and err == "" and "\n\ncase sphere_single_link" in out


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"]])
def test_help_lists_the_exit_codes(capsys, argv):
    with pytest.raises(SystemExit) as info:
        cli.main(argv)
    assert info.value.code == 0
    out = capsys.readouterr().out
    for line in ("  0    every run finished", "  1    unexpected error", "  2    bad input",
                 "  3    a simulation stopped early", "  130  interrupted by Ctrl-C or SIGTERM"):
        assert line in out, line
    if argv[0] == "run":
        assert "--method METHOD" in out and "RK45, DOP853" in out


def test_signal_handlers_are_restored(tmp_path, capsys):
    import signal

    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    code, _, _ = run_main(["run", CASES / "circle_two_link.toml", "--t-end", "0.01", "--no-plots", "-q",
                           "--out", tmp_path], capsys)
    assert code == 0 and (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before


def test_sigterm_during_a_run_in_process_exit_130(tmp_path, capsys, monkeypatch):
    # What the handler does, without a second process: SIGTERM inside simulate -> status interrupted, 130.
    import importlib
    import os
    import signal

    from gibbsimpact.case import Case

    gsim = importlib.import_module("gibbsimpact.simulation.simulate")
    clock = gsim.Clock
    monkeypatch.setattr(gsim, "Clock", lambda progress: clock(progress, every=0.0))  # report at every RHS
    real = Case.simulate

    def terminated(self, progress=None, **kw):
        def progress_and_term(t, n):
            if t > 0.01:
                os.kill(os.getpid(), signal.SIGTERM)

        return real(self, progress=progress_and_term, **kw)

    monkeypatch.setattr(Case, "simulate", terminated)
    code, _, err = run_main(["run", CASES / "circle_two_link.toml", "--t-end", "0.3", "--no-plots", "-q",
                             "--out", tmp_path], capsys)
    assert code == 130
    assert err.startswith("gibbsimpact: error: simulation stopped early (interrupted): stopped by SIGTERM at t = ")
    res = gi.load_result(tmp_path / "result.npz")
    assert res.status == "interrupted" and 0.0 < res.t[-1] < 0.3


# -- prismatic joints --------------------------------------------------------

# A rigid rod hanging from a guide at the base origin (Pb): it slides out under gravity and
# reaches d_max = 0.5 m at t = sqrt(2 * 0.3 / 9.81) = 0.2473 s; joint_limit = "stop" ends the run there.
PB_DROP = 'name = "pb_drop"\n' + PB_DROP_CASE + """
[solver]
rtol = 1e-10
atol = 1e-12
joint_limit = "stop"
"""


def test_show_lists_the_joints(capsys):
    code, out, err = run_main(["show", CASES / "fixed_base_R_Pb_arm.toml"], capsys)
    assert code == 0 and err == ""
    assert "N = 12 generalised coordinates, 24 first-order ODEs" in out
    assert ("joints:\n  joint 1: R (revolute): link 1 turns by theta_1 about z at the base\n"
            "  joint 2: Pb (fixed prismatic): link 2 slides through a guide at the tip of link 1, turned 0 deg from "
            "its tangent; d_2 (the length protruding from the guide) in [0.25, 0.75] m, 0.45 m at t0\n") in out
    rows = [ln.split() for ln in out.splitlines() if ln[:4].strip().isdigit()]
    assert [r[1] for r in rows[:3]] == ["theta_1", "d_2", "delta_1_1"] and rows[1][2:4] == ["0.45", "m"]
    assert "2 stretching Hermite cubic element(s) on the protruding length in y" in out
    # Link 2 bends as a clamped-free beam of length d_2 = 0.45 m: 1.8751^2 sqrt(2 / (0.5 * 0.45^4)) = 34.7261 rad/s.
    assert "clamped-free omega at the protruding length d_2 = 0.45 m = 34.7429 (beam 34.7261)" in out
    assert "omega ~ 1/d^2: the highest is 6980 rad/s at d_min = 0.25 m" in out
    assert "inputs[2] on d_2: sine Q = -3.9 + 6 sin(2 pi 0.5 Hz t + 0 deg) N" in out
    assert "inputs[3] on d_2: pd servo Q = 50 N/m * (target - d_2) - 4 N s/m * d_2_dot, target 0.45 m" in out
    assert "joint_limit = stop" in out
    code, out, err = run_main(["show", CASES / "fixed_base_R_Pa_arm.toml"], capsys)
    assert code == 0 and ("  joint 2: Pa (sliding prismatic): a carriage of half-length c = 0.04 m runs along link 1, "
                          "link 2 fixed to it at 90 deg; d_2 (the carriage centre's position along link 1) in "
                          "[0.1, 0.9] m, 0.6 m at t0\n") in out
    code, out, err = run_main(["show", CASES / "fixed_base_fe_arm.toml"], capsys)
    assert "joints: all revolute" in out


def test_show_prismatic_joint_1_and_planar_base(tmp_path, capsys):
    case = tmp_path / "drop.toml"
    case.write_text(PB_DROP)
    code, out, err = run_main(["show", case], capsys)
    assert code == 0
    assert "angle -90 deg about X3; joint 1 is a guide at the base origin that link 1 slides through" in out
    assert "joint 1: Pb (fixed prismatic): link 1 slides through a guide at the base origin, at 0 deg to the base " \
           "x axis; d_1 (the length protruding from the guide) in [0.1, 0.5] m, 0.2 m at t0" in out
    planar = (CASES / "fixed_base_fe_arm.toml").read_text().replace('type = "fixed"\nposition_m = [0.0, 0.6]',
                                                                    'type = "planar"')
    planar = planar.replace("angle_deg = 0.0                # link 1 along X1 at theta_1 = 0\n", "")
    planar = planar.split("[[walls]]")[0] + "\n[time]\nt_end_s = 0.1\n"  # no floor, inputs, ...: links only
    case.write_text(planar)
    code, out, err = run_main(["show", case], capsys)
    assert code == 0, err
    assert "base: free-flying in the X1-X2 plane (O1 at X1, X2; link 1 turned by theta_1 about X3)" in out
    rows = [ln.split() for ln in out.splitlines() if ln[:4].strip().isdigit()]
    assert [r[1] for r in rows[:4]] == ["X1", "X2", "theta_1", "theta_2"]


def test_run_R_Pb_arm_briefly(tmp_path, capsys):
    code, out, err = run_main(["run", CASES / "fixed_base_R_Pb_arm.toml", "--out", tmp_path, "--t-end", "0.02",
                               "--no-plots", "--quiet", *TIGHT_DOP853_ARGS], capsys)
    assert code == 0 and out == "" and err == ""
    for name in ("timeseries.csv", "impacts.csv", "summary.json", "result.npz"):
        assert (tmp_path / name).stat().st_size > 0, name
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["status"] == "finished" and s["t_final_s"] == 0.02 and s["n_impacts"] == 0
    assert s["model"]["coordinate_names"][:3] == ["theta_1", "d_2", "delta_1_1"]
    assert s["settings"]["joint_limit"] == "stop" and s["settings"]["rtol"] == 1e-8
    assert s["work_final_J"]["inputs"] != 0.0 and s["max_relative_energy_error"] < 1e-9
    cols = gio.read_csv(tmp_path / "timeseries.csv")
    assert cols["d_2_m"][0] == 0.45 and 0.44 < cols["d_2_m"][-1] < 0.46


def test_joint_limit_stops_the_run_exit_3(tmp_path, capsys):
    case = tmp_path / "drop.toml"
    case.write_text(PB_DROP)
    code, out, err = run_main(["run", case, "--out", tmp_path / "o", "--no-plots", "--quiet"], capsys)
    assert code == 3 and out == ""
    assert err.startswith("gibbsimpact: error: simulation stopped early (joint_limit): joint 1 reached its limit "
                          "d_1 <= d_max = 0.5 m at t = 0.24730968")
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["status"] == "joint_limit" and s["t_final_s"] == pytest.approx(math.sqrt(0.6 / 9.81), rel=1e-8)


def test_exit_codes_list_joint_limit(capsys):
    assert "joint_limit" in cli.EXIT_CODES and "joint_limit" in cli.__doc__
    with pytest.raises(SystemExit):
        cli.main(["run", "--help"])
    assert "joint_limit: a prismatic joint reached an end of its range" in capsys.readouterr().out


def test_run_reports_the_whole_run_and_the_per_phase_energy_error(tmp_path, capsys):
    # Issue 23 item 4: the drift of the run (J, relative, and the scale), then the largest of one phase.
    code, out, _ = run_main(["run", CASES / "circle_two_link.toml", "--t-end", "0.5", "--no-plots",
                             "--out", tmp_path], capsys)
    assert code == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    (line,) = [ln for ln in out.splitlines() if ln.startswith("energy: ")]
    assert line.endswith(f"energy drift over the whole run {s['energy_error_whole_run_J']:.3g} J (relative "
                         f"{s['relative_energy_error_whole_run']:.2e} of the scale {s['energy_scale_J']:.4g} J); "
                         f"max per flight phase {s['relative_energy_error_max_per_phase']:.2e} (relative)")
    E = s["energy_final_J"]["total"] - s["energy_initial_J"]["total"]  # e = 1: the whole-run drift
    # One term per phase and per impact, each rounding within a few eps |E0|.
    tol = 4 * np.finfo(float).eps * 4.905 * (2 * s["n_impacts"] + 2)
    assert s["energy_error_whole_run_J"] == pytest.approx(E, abs=tol)


def test_run_says_what_method_auto_chose_and_where_the_energy_went(tmp_path, capsys):
    """issue 27: with --method auto the cost line at the start of run says which method and why (case 1:
    DOP853, 26 stability steps a second), summary.json keeps it, and the report splits the energy balance."""
    code, out, err = run_main(["run", CASES / "circle_two_link.toml", "--method", "auto", "--t-end", "0.02",
                               "--no-plots", "--out", tmp_path / "o"], capsys)
    assert code == 0
    # n_stab = 0.02 s x 156.6 rad/s / 5.96 (DOP853's stability radius on the imaginary axis) = 0.53
    assert "  auto: DOP853, DOP853 needs 0.52" in out
    assert "steps over 0.02 s for stability alone on the mode at 156.6 rad/s (< 1e+04)" in out
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["settings"]["method"] == "DOP853" and s["settings"]["method_choice"].startswith("auto: DOP853")
    audit = s["energy_audit_J"]
    assert audit["inputs"] == audit["damping_and_friction"] == audit["impacts"] == 0.0
    assert f"energy audit [J]: inputs 0, damping and friction 0, impacts 0, numerical {audit['numerical']:.3g}" in out

_AT_GIMBAL_LOCK = """
name = "lock"
gravity_m_per_s2 = [0.0, 0.0, 0.0]
[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 1.0  # a rigid link (no modes) still needs it
rotary_inertia_kg_m = [1e-4, 1e-4, 1e-4]
[initial.coordinates]
theta_0_deg = 90.0
[initial.velocities]
theta_0_rad_per_s = 1.0
theta_1_rad_per_s = 0.5
[time]
t_end_s = 0.01
"""


def test_run_report_names_the_recharts(tmp_path, capsys):
    """A free base started at theta_0 = 90 deg re-charts at t0 (theory §2.1): the run report says so, and
    that the base angles jump there, so the jump in timeseries.csv is not read as a fault."""
    (tmp_path / "lock.toml").write_text(_AT_GIMBAL_LOCK)
    code, out, err = run_main(["run", tmp_path / "lock.toml", "--no-plots", "--out", tmp_path / "o"], capsys)
    assert code == 0
    assert "1 re-chart of the free base at t = 0 s: theta_-1, theta_0, theta_1 jump there" in out
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["base_recharts"][0]["time_s"] == 0.0


def test_run_report_counts_the_actuators_work_in_the_energy_audit(tmp_path, capsys):
    """A link whose hub follows a point-to-point move ([[prescribed]]): the run report's energy audit names the
    actuators' work, and the audit's parts add up to E(end) - E(t0) written in summary.json."""
    case = tmp_path / "hub.toml"
    case.write_text('name = "hub"\ngravity_m_per_s2 = [0.0, -9.81, 0.0]\n[base]\ntype = "fixed"\n'
                    '[[links]]\nlength_m = 1.0\nmass_per_length_kg_per_m = 1.0\nEI_N_m2 = 50.0\n'
                    'modes = [{ kind = "clamped-free" }]\n'
                    '[[prescribed]]\ncoordinate = "theta_1"\nprofile = "point_to_point"\n'
                    'q_a_rad = 0.0\nq_b_rad = 1.0\nt_a_s = 0.0\nt_b_s = 0.2\n[time]\nt_end_s = 0.3\n')
    code, out, err = run_main(["run", case, "--no-plots", "--out", tmp_path / "o"], capsys)
    assert code == 0
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    audit = s["energy_audit_J"]
    assert audit["actuators"] == s["work_final_J"]["actuators"] > 1.0  # lifting the link by 1 rad: > 1 J
    assert sum(audit.values()) == pytest.approx(s["energy_final_J"]["total"] - s["energy_initial_J"]["total"],
                                                abs=1e-9 * s["energy_scale_J"])
    assert f"actuators {audit['actuators']:.4g}, impacts 0," in out
    # show names the prescribed coordinate and its profile with units (before, it said nothing of it).
    code, out, err = run_main(["show", case], capsys)
    assert code == 0
    assert ("prescribed (the coordinate follows its profile; its actuator supplies the effort):\n"
            "  theta_1: point_to_point: q_a = 0 rad, q_b = 1 rad, t_a = 0 s, t_b = 0.2 s\n") in out


def test_show_describes_an_obstacle_and_its_gaps(tmp_path, capsys):
    """show on case 1 plus an obstacle post of R = 0.1 m at (0, -1.2): the wall is named an obstacle, and the
    gaps are |p - c| - R: 0.6 m for O2 at (0, -0.5), sqrt(0.75 + 1.44) - 0.1 m for O1 and O3 at (-+0.866, 0)."""
    case = tmp_path / "post.toml"
    case.write_text((CASES / "circle_two_link.toml").read_text()
                    + '\n[[walls]]\ntype = "circle"\nradius_m = 0.1\ncenter_m = [0.0, -1.2]\ninside = false\n')
    code, out, err = run_main(["show", case], capsys)
    assert code == 0
    assert "walls[2]: circle R=0.1 m centre (0, -1.2) (obstacle: the chain stays outside)" in out
    gaps = [ln.split()[-1] for ln in out.splitlines() if ln.strip().startswith("O")]
    assert [float(g) for g in gaps] == pytest.approx([math.sqrt(0.75 + 1.44) - 0.1, 0.6, math.sqrt(0.75 + 1.44) - 0.1],
                                                     abs=1e-5)
