"""``gibbsimpact show`` of a saved run: the report of ``run`` read back from result.npz (cli/report.py).

Two routes to one text: the report ``run`` prints from the Result in memory, and the one ``show`` prints
from the file; the numbers in it are case 1's published ones (cases/circle_two_link.toml: O2 at 0.451524 s,
O1 and O3 together at 0.474918 s, total energy -4.905 J throughout).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.cli import commands as cli
from gibbsimpact.simulation.auto import choose_method
from conftest import CLAMPED_CLAMPED_ROOTS, warning_run, welded_beam_model
from test_commands import CASES, run_main  # the command line in-process, compile notices dropped from stderr


@pytest.fixture(scope="module")
def case1_run(tmp_path_factory):
    """Case 1 to t = 0.5 s (two impacts) by ``run``: (its output folder, what it printed on stdout)."""
    import contextlib
    import io

    out = tmp_path_factory.mktemp("case1_report")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = cli.main(["run", str(CASES / "circle_two_link.toml"), "--out", str(out), "--t-end", "0.5",
                         "--no-plots"])
    assert code == 0
    return out, buf.getvalue()


def test_show_prints_the_run_report_of_a_saved_folder(case1_run, capsys):
    out, printed = case1_run
    code, text, err = run_main(["show", out], capsys)
    assert code == 0 and err == ""
    # The report run printed from memory, from "status:" to the cost line (which run follows with the files).
    live = printed[printed.index("status:"):].splitlines()
    live[-1] = live[-1].split("; ")[0]
    assert text.splitlines()[2:] == live
    assert text.startswith(f"saved run of case circle_two_link ({out / 'result.npz'})")
    assert "2 link(s), N = 9 coordinates, 1 wall(s); t = 0 -> 0.5 s" in text
    assert "status: finished" in text and "method: DOP853, rtol 1e-10, atol 1e-12\n" in text
    times = [float(t) for t in re.findall(r"impact \d: t = ([0-9.]+) s", text)]
    np.testing.assert_allclose(times, [0.451524, 0.474918], atol=1e-6)
    assert "s  O2\n" in text and "s  O1+O3\n" in text
    assert "energy: -4.905 J -> -4.905 J" in text and "energy audit [J]: inputs 0," in text


def test_show_reads_a_result_file_and_a_case_in_one_call(case1_run, capsys):
    out, _ = case1_run
    code, text, err = run_main(["show", out / "result.npz", CASES / "circle_two_link.toml"], capsys)
    assert code == 0 and err == ""
    saved, case = text.split("\n\ncase circle_two_link")
    assert saved.startswith("saved run of case circle_two_link") and "impact 2: t = 0.474918 s  O1+O3" in saved
    assert "initial energy:" in case


def test_show_names_the_method_auto_chose(tmp_path, capsys):
    """The reason printed is choose_method's for the case's model, initial state, span and tolerance."""
    code = cli.main(["run", str(CASES / "circle_two_link.toml"), "--out", str(tmp_path), "--t-end", "0.05",
                     "--method", "auto", "--no-plots", "--quiet"])
    assert code == 0
    case = gi.load_case(CASES / "circle_two_link.toml")
    method, why = choose_method(case.model, case.q0, (0.0, 0.05), np.inf, case.solver["rtol"])
    capsys.readouterr()
    code, text, err = run_main(["show", tmp_path], capsys)
    assert code == 0 and why.startswith(f"auto: {method}")
    assert f"method: {method}, rtol 1e-10, atol 1e-12; {why}\n" in text


def test_show_of_a_result_saved_from_python_has_no_case_name(case1_run, tmp_path, capsys):
    out, _ = case1_run
    res = gi.load_result(out / "result.npz")
    path = res.save(tmp_path / "mine.npz")
    code, text, err = run_main(["show", path], capsys)
    assert code == 0 and text.startswith(f"saved run ({path})")


def test_show_repeats_the_validity_warnings_the_run_issued(tmp_path, capsys):
    # A saved run's reader used to see none of the warnings its run gave (here: a link bent 0.15 l at t0,
    # Newton's law at a finite element's tip, a link spinning 3.2 omega_1): show now prints them on stderr, in
    # run's words, the messages simulate issued (conftest.warning_run).
    res, live = warning_run()
    path = res.save(tmp_path / "warned.npz")
    code, text, err = run_main(["show", path], capsys)
    assert code == 0 and text.startswith(f"saved run ({path})")
    assert err.splitlines() == [f"gibbsimpact: {path}: validity warning: {m}" for m in live] and len(live) == 3


@pytest.mark.parametrize("name, expected", [
    ("missing.npz", "RESULT: '{p}': no such file; give a result .npz or the output folder of a run"),
    ("garbage.npz", "RESULT: '{p}': not a readable gibbsimpact result"),
    ("plain.npz", "RESULT: '{p}': not a readable gibbsimpact result ({p} is not a gibbsimpact result (no 'meta' "
                  "entry))"),
])
def test_show_of_a_bad_result_file_is_exit_2_naming_it(name, expected, tmp_path, capsys):
    p = tmp_path / name
    if name == "garbage.npz":
        p.write_bytes(b"not a zip file")
    elif name == "plain.npz":
        np.savez(p, t=np.zeros(3))
    code, text, err = run_main(["show", p], capsys)
    assert code == 2 and text == ""
    assert err.startswith("gibbsimpact: error: " + expected.format(p=p))


@pytest.mark.parametrize("make, expected", [
    ("folder", "CASE.toml: '{p}' is a directory, not a case file, and holds no result.npz; give a case .toml, the "
               "output folder of a run (holding result.npz) or a result .npz"),
    ("summary.json", "CASE.toml|RESULT: '{p}' is a JSON file, not a case or a saved run; give the folder holding "
                     "it ('{d}') or its result.npz"),
    ("missing", "CASE.toml|RESULT: '{p}': no such file or folder; give a case .toml, the output folder of a run "
                "(holding result.npz) or a result .npz"),
])
def test_show_of_something_neither_a_case_nor_a_run_says_what_show_reads(make, expected, tmp_path, capsys):
    # a user's first guesses at a saved run (a folder of figures, the run's summary.json, a mistyped folder)
    # used to get the case-file error ("not valid TOML", "give the path of a case file"), which hid that
    # show reads saved runs too
    p = tmp_path / make
    if make == "folder":
        p.mkdir()
    elif make == "summary.json":
        p.write_text("{}")
    code, text, err = run_main(["show", p], capsys)
    assert code == 2 and text == ""
    assert err == "gibbsimpact: error: " + expected.format(p=p, d=tmp_path) + "\n"


def test_the_audit_line_of_a_run_with_a_cutoff_says_what_its_numerical_part_holds(case1_run):
    # With cutoff_frequency (set by hand, or by auto at a gap) Radau damps the modes above it after each impact
    # (case 1 with EI = 1e9 on link 1: numerical -10.5 J of |E| = 4.9 J); the audit line said only
    # "numerical -10.5 (Radau)", which reads as an integration error.
    from gibbsimpact.cli.report import run_report_lines

    res = gi.load_result(case1_run[0] / "result.npz")
    assert "cutoff" not in run_report_lines(res)[-2]
    res.settings["cutoff_frequency"] = 1.27e4
    audit = run_report_lines(res)[-2]
    assert audit.startswith("energy audit [J]: inputs 0,")
    assert audit.endswith("(DOP853, cutoff 1.27e+04 rad/s: mostly the energy of the modes above it (given by "
                          "impacts, inputs or the initial state), stepped over and damped; docs/theory.md §14.1)")


def test_the_report_of_a_run_with_a_cutoff_names_the_modes_it_steps_over(case1_run):
    # The cutoff's line used to give the frequency alone: a user could not tell which modes Radau's error
    # estimate left out. The line after the method names them: how many of the free-vibration modes at t0
    # lie above the cutoff, and the lowest of them.
    from gibbsimpact.cli.report import cutoff_line, run_report_lines

    res = gi.load_result(case1_run[0] / "result.npz")
    assert not any(line.startswith("cutoff") for line in run_report_lines(res))
    res.settings["cutoff_frequency"] = 1.27e4
    lines = run_report_lines(res)
    assert lines[1].startswith("method:") and lines[2] == cutoff_line(res.model, res.q[0], 1.27e4)
    # case 1: 9 coordinates, 3 rigid motions (free-flying, no gravity stiffness in X1, X2 and one angle), links'
    # modes near 150 rad/s: none above 1.27e4 rad/s = 2.02e3 Hz
    assert lines[2].startswith("cutoff 1.27e+04 rad/s (2.02e+03 Hz): none of the model's 6 free-vibration modes "
                               "at t0 lies above it (the highest 1")


def test_the_cutoff_line_counts_the_modes_above_it_against_the_beam_closed_form():
    # welded_beam_model: a clamped-clamped beam, omega_k = (beta_k l)^2 sqrt(EI / (mu l^4)), as given 54.80,
    # 137.05, 268.67 rad/s (Blevins' roots; the model's frequencies are these to 1e-8, test_stability)
    from gibbsimpact.cli.report import cutoff_line

    model = welded_beam_model()
    omega = np.array(CLAMPED_CLAMPED_ROOTS) ** 2 * np.sqrt(50.0 / (2.0 * 1.5**4))
    for cut, above in ((100.0, 2), (150.0, 1)):
        low = omega[3 - above]
        verb = "lies" if above == 1 else "lie"
        assert cutoff_line(model, model.state(), cut) == (
            f"cutoff {cut:.3g} rad/s ({cut / (2 * np.pi):.3g} Hz): {above} of the model's 3 free-vibration modes at "
            f"t0 {verb} above it, the lowest at {low:.4g} rad/s ({low / (2 * np.pi):.4g} Hz): Radau leaves them out "
            "of its error estimate and steps over them (their motion is not followed)")
    assert cutoff_line(model, model.state(), 300.0) == (
        f"cutoff 300 rad/s (47.7 Hz): none of the model's 3 free-vibration modes at t0 lies above it (the highest "
        f"{omega[2]:.4g} rad/s): none is stepped over")


def test_a_long_impact_list_points_to_where_every_impact_is(case1_run):
    # A result saved by Result.save has no impacts.csv beside it: the line names Result.impacts too.
    from gibbsimpact.cli.report import SHOWN_IMPACTS, run_report_lines

    res = gi.load_result(case1_run[0] / "result.npz")
    res.impacts = res.impacts * (SHOWN_IMPACTS // 2 + 1)
    n = len(res.impacts)
    lines = run_report_lines(res)
    assert f"  ... {n} impacts in all (a run folder's impacts.csv; Result.impacts)" in lines
    assert sum(line.startswith("  impact ") for line in lines) == SHOWN_IMPACTS


def test_run_report_names_a_links_span_points_as_the_figures_do():
    """An impact at a link's span is listed as 'link 1.2' (cell 2 of link 1: contacts.link_column_name, the name of
    the figures, episodes and contact_forces.csv), not as a joint 'O4' that the chain does not have (a 2-element
    beam, bowed 2 mm down at mid-span, dropped onto a floor: its span strikes first)."""
    import warnings

    from gibbsimpact.cli.report import run_report_lines

    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=2)
    model = gi.Model(gi.Chain([link], base="planar"), gravity=(0.0, -9.81, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, model.state(X2=0.003, delta_1_1=-0.002), np.zeros(model.n_dof), (0.0, 0.02),
                          walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=0.5)
    assert res.impacts and all(j > model.n_joints for r in res.impacts for j in r.joints)
    listed = [line for line in run_report_lines(res) if line.startswith("  impact ")]
    assert listed and all(line.split("s  ")[1] in ("link 1.1", "link 1.2", "link 1.1+link 1.2") for line in listed)
