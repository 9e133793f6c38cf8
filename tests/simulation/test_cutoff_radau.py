"""scipy's Radau with the cutoff's error weights (simulation/cutoff_radau.py): the weights in closed form, the
phases that get it, and issue 27's stiff chain through its resting phase."""

import copy
import warnings
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.case import case_from_dict
from gibbsimpact.simulation.compiled_radau import radau5_tolerances
from gibbsimpact.simulation.cutoff_radau import CutoffRadau, velocity_weighted_atol

CASES = Path(__file__).resolve().parents[2] / "cases"


def test_velocity_weights_in_closed_form():
    """With N = 2, y = (q, qdot, W): atol + rtol |y| divided by w = min(1, h / 1 s) on qdot only, so that
    scale_v = (atol + rtol |y_v|) / h; nothing changes for h >= 1 s."""
    atol, rtol = np.array([1e-9, 2e-9, 3e-9, 4e-9, 5e-9]), 1e-6
    y = np.array([0.5, -1.0, 2.0, -3.0, 7.0])
    out = velocity_weighted_atol(atol, rtol, y, 2, 1e-3)
    np.testing.assert_allclose(out + rtol * np.abs(y), np.r_[(atol + rtol * np.abs(y))[:2],
                                                             (atol + rtol * np.abs(y))[2:4] / 1e-3,
                                                             atol[4] + rtol * 7.0], rtol=1e-14)
    np.testing.assert_array_equal(velocity_weighted_atol(atol, rtol, y, 2, 1.5), atol)


def test_radau5_tolerances_and_a_bad_size_named():
    """CutoffRadau holds scipy's Radau to rtol' = 0.1 rtol^(2/3), atol' = atol rtol' / rtol; an n_pos that does
    not fit y0 is refused naming it."""
    s = CutoffRadau(lambda t, y: -y, 0.0, np.ones(4), 1.0, n_pos=2, rtol=1e-6, atol=1e-9)
    r, a = radau5_tolerances(1e-6, 1e-9)
    assert s.rtol == pytest.approx(r, rel=1e-14) and np.allclose(s.atol_base, a, rtol=1e-14)
    with pytest.raises(ValueError, match="n_pos = 3"):
        CutoffRadau(lambda t, y: -y, 0.0, np.ones(4), 1.0, n_pos=3)


def _rod_runs(monkeypatch, cutoff):
    """The rigid rod of issue 26 (pivot 0.5 m above a floor with e = 0.5, friction 0.3) pushed down by a torque of
    1 N m, 1 s, with Radau (and the cutoff, if any) and with DOP853; the number of CutoffRadau solvers made."""
    from conftest import issue26_model

    made = []
    own = CutoffRadau.__init__

    def spy(self, *args, **kw):
        made.append(1)
        own(self, *args, **kw)

    monkeypatch.setattr(CutoffRadau, "__init__", spy)
    model = issue26_model(0)
    floor = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.5, friction=0.3)
    q0 = np.zeros(model.n_dof)
    kw = dict(walls=[floor], rtol=1e-8, atol=1e-10, output_dt=1e-3, inputs={"theta_1": -1.0})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        radau = gi.simulate(model, q0, np.zeros_like(q0), (0.0, 1.0), method="Radau", cutoff_frequency=cutoff, **kw)
        dop = gi.simulate(model, q0, np.zeros_like(q0), (0.0, 1.0), method="DOP853", **kw)
    return radau, dop, len(made)


@pytest.mark.slow
def test_resting_phases_under_a_cutoff_run_cutoff_radau_and_rest_where_the_geometry_says(monkeypatch):
    """With a cutoff the rod's resting phases (scipy's Radau: a contact phase) run CutoffRadau, and the rod comes
    to rest with its tip on the floor at sin theta = -0.5 m / 1 m (theta = -pi/6) to 1e-8 rad and after DOP853's
    resting time to 1e-4 s (measured 1e-5 s; the accumulation's last micro-impacts differ). Without a cutoff
    CutoffRadau is never made: method="Radau" is scipy's Radau there, as before."""
    radau, dop, made = _rod_runs(monkeypatch, 1e3)
    assert radau.status == dop.status == "finished" and made >= 1
    assert radau.settings["radau_phases"]["scipy"] == made
    assert radau.q[-1, 0] == pytest.approx(-np.pi / 6, abs=1e-8)
    assert radau.resting_time > 0.2 and abs(radau.resting_time - dop.resting_time) <= 1e-4
    assert _rod_runs(monkeypatch, None)[2] == 0


@pytest.fixture(scope="module")
def stiff_run():
    """Case 1 with EI_N_m2 = 1e9 on link 1 (issue 27) over its 1 s under method="auto", at most 1e5 right-hand
    sides (without CutoffRadau its resting phase at 0.675 s resolves the 1.07e6 rad/s mode: 1e-3 s in 1e5)."""
    src = copy.deepcopy(gi.load_case(CASES / "circle_two_link.toml").source)
    src["links"][0]["EI_N_m2"] = 1e9
    case = case_from_dict(src, name="case1_EI1e9")
    return case, case.simulate(t_end=1.0, method="auto", max_rhs_calls=100_000)


@pytest.mark.slow
def test_stiff_chain_finishes_its_second_through_resting_contact(stiff_run):
    """Issue 27's target: the run finishes its second, auto having taken Radau with the cutoff at the spectrum's
    gap; O1 rests on the circle (R = 1.5 m) for a while, and its resting phase ran scipy's Radau with the
    cutoff's weights (measured: 10 ms of resting, 2005 steps, 15,663 right-hand sides in all). DOP853 needs
    n_stab = 1 s x 1.07e6 rad/s / 5.96 = 1.8e5 steps for stability alone: the run takes fewer right-hand sides
    than that."""
    case, res = stiff_run
    assert res.status == "finished" and res.t[-1] == 1.0
    assert res.settings["method"] == "Radau" and 1e4 < res.settings["cutoff_frequency"] < 2e4
    assert res.settings["radau_scipy_why"] == {"a contact phase (resting pairs or held end stops)":
                                               res.settings["radau_phases"]["scipy"]}
    assert res.resting_time > 1e-3 and res.nfev < 1.8e5
    resting = np.any(res.contact_forces != 0.0, axis=(1, 2))
    X = res.q[resting][:, :2]  # O1 = (X1, X2): the free base's point
    np.testing.assert_allclose(np.hypot(X[:, 0], X[:, 1]), 1.5, atol=res.settings["contact_tol"])


@pytest.mark.slow
def test_stiff_chain_audit_numerical_part_is_the_energy_its_impacts_put_into_the_fast_mode(stiff_run):
    """The energy audit reports a numerical part, and it is what the stepped-over mode took: e = 1, no inputs,
    no damping, so every other part is 0 and numerical = E(1 s) - E(0); the L-stable steps damp link 1's
    1.07e6 rad/s mode after each impact, so -numerical is the sum over the impacts of that mode's kinetic
    energy after minus before (modal projection, computed apart from any stepper: conftest.fast_mode_energy,
    at the sample nearest each impact). Measured: -10.4949 J against 10.4949 J (7e-7 relative); to 1e-3 as
    the first impact's (tests/simulation/test_compiled_radau.py: the damped mode's remainder |R(h lambda)|
    <= 0.03 a step)."""
    from conftest import fast_mode_energy

    case, res = stiff_run
    audit = res.energy_audit()
    assert audit["inputs"] == audit["damping_and_friction"] == audit["impacts"] == 0.0
    E = res.energy().total
    assert audit["numerical"] == pytest.approx(E[-1] - E[0], rel=1e-9)
    put = 0.0
    for imp in res.impacts:
        q = res.q[np.argmin(np.abs(res.t - imp.time))]
        put += fast_mode_energy(case.model, q, imp.qdot_after) - fast_mode_energy(case.model, q, imp.qdot_before)
    assert put > 5.0 and audit["numerical"] == pytest.approx(-put, rel=1e-3)
    assert res.summary()["energy_audit_J"]["numerical"] == pytest.approx(audit["numerical"])

