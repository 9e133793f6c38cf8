"""The sweep table's derived columns (gibbsimpact.study.table), each against a second route from the
run's saved result file, and the sweep figure (plot_sweep).

The 2 x 2 sweep varies the restitution (0.75, 1) and the initial angle of link 1 (-33, -30 deg)
of cases/circle_two_link.toml up to t = 0.55 s: 3 to 5 impacts per run, one of them O1 and O3
together, no resting contact.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.gibbs_appell import energy, mass_matrix, momentum
from gibbsimpact.study.sweep import sweep
from gibbsimpact.study.table import PLOT_COLUMNS, RESULT_COLUMNS, plot_keys, plot_sweep

CASE = Path(__file__).resolve().parents[2] / "cases" / "circle_two_link.toml"
GRID = {"restitution": [0.75, 1.0], "initial.coordinates.theta_1_deg": [-33, -30]}
THETA = "initial.coordinates.theta_1_deg"


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    res = sweep(CASE, GRID, out=tmp_path_factory.mktemp("table"), t_end=0.55)
    assert res.all_finished
    return res, [gi.load_result(res.out / r["result"]) for r in res.rows]


def test_columns_keep_every_old_one_and_add_the_derived_ones():
    assert RESULT_COLUMNS == ("status", "message", "n_impacts", "first_impact_s", "t_final_s", "energy_lost_J",
                              "max_impulse_N_s", "max_deflection_m", "energy_error", "nfev", "wall_time_s", "result")


def test_energy_lost_is_the_energy_the_impacts_took(small):
    """E(t0) - E(t_end) from the first and last samples, and (second route) the sum of the kinetic
    energy each impact took, which it equals up to the flight drift: |drift| <= energy_error * scale
    in each of the n_impacts + 1 flight phases, scale <= max(|T| + |V_g| + |V_s| over the run, m |g| sum l)."""
    res, results = small
    for row, r in zip(res.rows, results, strict=True):
        assert r.resting_time == 0.0 and r.work is None  # no resting contact, inputs or damping
        first, last = energy(r.model, r.q[0], r.qdot[0]), energy(r.model, r.q[-1], r.qdot[-1])
        assert row["energy_lost_J"] == pytest.approx(first.total - last.total, rel=1e-12, abs=1e-12 * abs(first.total))
        taken = sum(i.energy_before.total - i.energy_after.total for i in r.impacts)
        E = r.energy()
        scale = max(np.max(np.abs(E.kinetic) + np.abs(E.gravity) + np.abs(E.strain)),
                    r.model.total_mass * 9.81 * sum(lk.length for lk in r.model.chain.links))
        assert abs(row["energy_lost_J"] - taken) <= (len(r.impacts) + 1) * r.energy_error * scale
    lost = {(row["restitution"], row[THETA]): row["energy_lost_J"] for row in res.rows}
    assert lost[0.75, -30] > 1.0 and lost[0.75, -33] > 1.0  # e < 1 loses joules, e = 1 only the drift
    assert abs(lost[1.0, -30]) < 1e-7 and abs(lost[1.0, -33]) < 1e-7


def test_max_impulse_is_the_largest_impulse_the_momentum_change_gives(small):
    """Second route: a frictionless impact changes the chain's linear momentum by sum_c Lambda_c n_c
    (docs/theory.md §11), so the impulses are the least-squares solution of N Lambda = L+ - L-
    (the normals of simultaneous contacts here are independent). The impact is a direct linear solve:
    its error is about cond(M) eps relative, the tolerance 100 cond(M) eps."""
    res, results = small
    for row, r in zip(res.rows, results, strict=True):
        largest = 0.0
        for rec in r.impacts:
            q = r.q[np.flatnonzero(r.t == rec.time)[0]]
            dL = momentum(r.model, q, rec.qdot_after)[0] - momentum(r.model, q, rec.qdot_before)[0]
            impulses = np.linalg.lstsq(np.asarray(rec.normals).T, dL, rcond=None)[0]
            tol = 100 * np.linalg.cond(mass_matrix(r.model, q)) * np.finfo(float).eps
            assert impulses == pytest.approx(rec.impulses, rel=tol)
            largest = max(largest, impulses.max())
        assert row["max_impulse_N_s"] == pytest.approx(largest, rel=tol)
        assert row["max_impulse_N_s"] == max(float(np.max(i.impulses)) for i in r.impacts)
    assert any(len(i.impulses) == 2 for r in results for i in r.impacts)  # a simultaneous impact was checked


def test_max_deflection_is_the_largest_modal_coordinate(small):
    """Second route, closed form: each link bends in its first clamped-clamped mode, normalised to
    max |psi| = 1 at mid-span (x = l/2, point 21 of the 41), so the largest deflection of any point
    is the largest |delta_i_1| over the samples."""
    res, results = small
    for row, r in zip(res.rows, results, strict=True):
        deltas = [k for k, name in enumerate(r.model.coordinate_names) if name.startswith("delta_")]
        assert len(deltas) == 2
        assert row["max_deflection_m"] == pytest.approx(np.abs(r.q[:, deltas]).max(), rel=1e-12)
        assert row["max_deflection_m"] > 0.04


def test_a_rigid_run_without_impacts_has_zero_impulse_and_deflection(tmp_path):
    rigid = {"links[1].modes": [], "links[2].modes": [],
             "initial.coordinates": {"X1_m": -0.8660254037844386, "theta_1_deg": -30.0, "theta_2_deg": 60.0}}
    res = sweep(CASE, [rigid], out=tmp_path, t_end=0.1)  # before the first impact
    (row,) = res.rows
    assert row["n_impacts"] == 0 and row["first_impact_s"] is None
    assert row["max_impulse_N_s"] == 0.0 and row["max_deflection_m"] == 0.0
    assert gi.load_result(res.out / row["result"]).model.n_dof == 7


def test_plot_sweep_draws_a_column_against_the_first_key_one_line_per_value_of_the_second(small):
    res, _ = small
    fig = res.plot("max_impulse_N_s")  # SweepResult.plot is plot_sweep
    assert (res.out / "sweep_max_impulse_N_s.png").stat().st_size > 1000
    (ax,) = fig.axes
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("restitution", "max_impulse_N_s")
    lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]
    assert [ln.get_label() for ln in lines] == [f"{THETA} = -33", f"{THETA} = -30"]
    for ln, theta in zip(lines, (-33, -30), strict=True):
        rows = [r for r in res.rows if r[THETA] == theta]
        assert list(ln.get_xdata()) == [0.75, 1.0]
        assert list(ln.get_ydata()) == [r["max_impulse_N_s"] for r in rows]
    # x and lines swapped on request; nothing written with save=False.
    fig = plot_sweep(res, "energy_lost_J", x=THETA, lines="restitution", save=False)
    assert fig.axes[0].get_xlabel() == THETA and not (res.out / "sweep_energy_lost_J.png").exists()
    assert [ln.get_label() for ln in fig.axes[0].get_lines()] == ["restitution = 0.75", "restitution = 1.0"]


@pytest.mark.parametrize("keys, column, kw, message", [
    (["a"], "status", {}, "column: 'status' cannot be drawn; give one of n_impacts"),
    (["a", "b", "c"], "nfev", {}, "this sweep varies 3 keys (a, b, c); a sweep figure draws a column over at most two"),
    (["a", "b"], "nfev", {"x": "z"}, "x: 'z' is not a varied key of this sweep; give one of a, b"),
    (["a", "b"], "nfev", {"x": "a", "lines": "a"}, "lines: 'a' is already x"),
    (["a", "b"], "nfev", {"numeric": []}, "x: no varied key has a number in every run"),
    (["m", "b"], "nfev", {"x": "m", "numeric": ["b"]}, "x: m does not have a number in every run"),
])
def test_plot_keys_errors_name_the_argument(keys, column, kw, message):
    with pytest.raises(ValueError) as info:
        plot_keys(keys, column, **kw)
    assert message in str(info.value)


def test_plot_keys_defaults():
    assert plot_keys(["a"], "nfev") == ("a", None)
    assert plot_keys(["a", "b"], "nfev") == ("a", "b")
    assert plot_keys(["m", "b"], "nfev", numeric=["b"]) == ("b", "m")  # strings (solver.method) become lines
    assert set(PLOT_COLUMNS) < set(RESULT_COLUMNS)
