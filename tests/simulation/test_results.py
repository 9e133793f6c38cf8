"""Result's energy balance, twice: per flight phase (each phase from its own start) and over the whole run
(from t0 to the end, the impacts with e = 1 included), each against a computation from the samples alone."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi

CASES = Path(__file__).resolve().parents[2] / "cases"
EPS = np.finfo(float).eps


def balance(res):
    """E - W at every sample (K,) [J], from res.energy() and res.work."""
    E = res.energy().total
    return E - res.work.sum(axis=1) if res.work is not None else E


def per_phase_from_samples(res, floor):
    """max over the phases p of max |B(t) - B(start of p)| / scale_p, B = E - W, from the samples of each phase."""
    E, B = res.energy(), balance(res)
    W = res.work.sum(axis=1) if res.work is not None else np.zeros_like(B)
    worst = 0.0
    for p in range(len(res.impacts) + 1):
        k = np.flatnonzero(res.phase == p)
        s = k[0]
        scale = max(abs(E.total[s]), abs(E.kinetic[s]) + abs(E.gravity[s]) + abs(E.strain[s]),
                    np.max(np.abs(W[k] - W[s])), floor)
        worst = max(worst, np.max(np.abs(B[k] - B[s])) / scale)
    return worst


def drift_of_the_phases(res):
    """Sum over the phases of B(end of phase) - B(start of phase) [J]: the run's balance error without the
    energy jumps of the impacts (a second route, by phase, to a run whose impacts dissipate by design)."""
    B = balance(res)
    return sum(B[res.phase == p][-1] - B[res.phase == p][0] for p in range(len(res.impacts) + 1))


@pytest.fixture(scope="module")
def case1_3s():
    # Case 1 (e = 1) over 3 s: 13 impacts, every one of which should conserve E.
    return gi.load_case(CASES / "circle_two_link.toml").simulate(t_end=3.0)


def test_whole_run_energy_error_is_the_drift_from_the_first_to_the_last_sample(case1_3s):
    res = case1_3s
    E = res.energy().total
    # Case 1: two links of l = 1 m, mu = 1 kg/m, |g| = 9.81 m/s^2: m |g| sum l = 2 * 9.81 * 2 J, |E0| = 4.905 J.
    scale = max(abs(E[0]), 2.0 * 9.81 * 2.0)
    assert res.energy_scale == pytest.approx(scale, rel=4 * EPS)
    # The recorder adds one term per phase and per impact; each rounds to within 2 eps |E|.
    tol = 2 * EPS * abs(E[0]) * (2 * len(res.impacts) + 2)
    assert len(res.impacts) == 13 and all(np.all(r.restitution == 1.0) for r in res.impacts)
    assert res.energy_error_whole_run_J == pytest.approx(E[-1] - E[0], abs=tol)
    assert res.energy_error_whole_run == pytest.approx(abs(E[-1] - E[0]) / scale, abs=tol / scale)
    # The impacts' part (e = 1: should be zero) is in it: the phases alone give another number.
    impacts = sum(r.energy_after.total - r.energy_before.total for r in res.impacts)
    assert res.energy_error_whole_run_J == pytest.approx(drift_of_the_phases(res) + impacts, abs=tol)


def test_per_phase_energy_error_is_unchanged(case1_3s):
    res = case1_3s
    assert res.energy_error_per_phase == res.energy_error
    assert res.energy_error == pytest.approx(per_phase_from_samples(res, floor=2.0 * 9.81 * 2.0), rel=1e-12)


@pytest.mark.parametrize("name,kw", [("circle_two_link.toml", {"t_end": 3.0, "restitution": 0.8}),
                                     ("fixed_base_fe_arm.toml", {"t_end": 0.5175})],
                         ids=["e=0.8", "driven_damped_e=0.6"])
def test_whole_run_energy_error_leaves_out_what_impacts_dissipate(name, kw):
    # With e < 1 the impacts take energy away by design (case 1 with e = 0.8: 20.8 J in 3 s): the
    # error of the run is the sum of the phases' balance errors, the work of inputs and damping counted.
    # (The arm to 0.5175 s: 5 impacts, ending before they accumulate at 0.517582 s, after which a resting
    # projection dissipates within a phase, which this second route, phase by phase, does not see.)
    res = gi.load_case(CASES / name).simulate(**kw)
    B = balance(res)
    assert len(res.impacts) >= 4 and abs(B[-1] - B[0]) > 1e-3
    tol = 4 * EPS * float(np.max(np.abs(B)) + np.max(np.abs(res.energy().total))) * (len(res.impacts) + 2)
    assert res.energy_error_whole_run_J == pytest.approx(drift_of_the_phases(res), abs=tol)
    assert res.energy_error_whole_run <= 1e-8  # what it is for: a bound on the integration error


def test_repr_names_both_energy_errors(case1_3s):
    text = repr(case1_3s)
    assert (f"energy_error_whole_run = {case1_3s.energy_error_whole_run:.2e}, "
            f"energy_error_per_phase = {case1_3s.energy_error:.2e}") in text
