"""method="auto" (gibbsimpact.simulation.auto) and the implicit path with the kernel's Jacobian."""

import copy
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.case import case_from_dict
from gibbsimpact.simulation.auto import FAST_GAP, STIFF_STEPS, auto_choice, choose_method, fast_mode_cutoff
from gibbsimpact.simulation.compiled_radau import radau5_tolerances
from gibbsimpact.simulation.stability import linearised_eigenvalues
from gibbsimpact.simulation.cost import estimate_cost

CASES = Path(__file__).resolve().parents[2] / "cases"


def _case1(EI=None):
    """Case 1 as shipped, or with EI_N_m2 = EI on link 1 (issue 27's stiff chain for EI = 1e9)."""
    case = gi.load_case(CASES / "circle_two_link.toml")
    if EI is None:
        return case
    src = copy.deepcopy(case.source)
    src["links"][0]["EI_N_m2"] = EI
    return case_from_dict(src, name=f"case1_EI{EI:g}")


def test_auto_keeps_case_1_explicit_and_takes_radau_for_a_stiff_link():
    # Case 1: omega_max = 156.6 rad/s, so DOP853 needs 26 steps a second for stability: explicit.
    case = _case1()
    method, why = choose_method(case.model, case.q0, (0.0, 1.0))
    assert method == "DOP853" and "156.6 rad/s" in why
    # EI = 1e9: the clamped-clamped mode of link 1 at 22.37 sqrt(EI / (mu l^4)) = 7.07e5 rad/s (the
    # chain's highest, coupled, 1.07e6 rad/s) needs |lambda| / 5.96 > 1e5 steps a second of DOP853.
    stiff = _case1(1e9)
    method, why = choose_method(stiff.model, stiff.q0, (0.0, 1.0))
    assert method == "Radau" and f"{STIFF_STEPS:.0e}" in why
    omega = float(why.split("mode at ")[1].split(" rad/s")[0])
    assert omega > 22.37 * np.sqrt(1e9)
    # ... but not over a span too short for the stability steps to matter, nor under a binding max_step.
    assert choose_method(stiff.model, stiff.q0, (0.0, 1e-3))[0] == "DOP853"
    assert choose_method(stiff.model, stiff.q0, (0.0, 1.0), max_step=1e-6)[0] == "DOP853"


def test_auto_takes_the_compiled_radau_at_loose_tolerances_on_a_stiff_enough_chain():
    """The R-Pb arm (n_stab = 366 a second >= 100): DOP853 at the case file's rtol 1e-8, Radau from rtol 1e-3
    (where the compiled Radau's steps are the longer ones: docs/benchmarks.md); case 1 (n_stab = 26) keeps
    DOP853 at any tolerance."""
    arm = gi.load_case(CASES / "fixed_base_R_Pb_arm.toml")
    assert choose_method(arm.model, arm.q0, (0.0, 1.0), rtol=1e-8)[0] == "DOP853"
    method, why = choose_method(arm.model, arm.q0, (0.0, 1.0), rtol=1e-2)
    assert method == "Radau" and "rtol = 0.01 >= 0.001" in why and "366 steps" in why
    assert choose_method(_case1().model, _case1().q0, (0.0, 1.0), rtol=1e-2)[0] == "DOP853"


def test_auto_says_what_it_chose_in_the_result_and_the_cost_estimate():
    stiff = _case1(1e9)
    res = stiff.simulate(t_end=0.1, method="auto")  # n_stab = 1.8e4: Radau
    assert res.status == "finished"
    assert res.settings["method"] == "Radau" and res.settings["method_choice"].startswith("auto: Radau")
    est = stiff.estimate_cost(t_end=0.1, method="auto")
    assert est.method == "Radau" and est.describe().startswith("auto: Radau")
    # ... and that it steps over the modes above the gap, where (the cost line of show and run prints describe()):
    cut = res.settings["cutoff_frequency"]
    assert 1e4 < cut < 2e4 and f"the modes above {cut:.3g} rad/s" in res.settings["method_choice"]
    assert f"the modes above {cut:.3g} rad/s" in est.describe()
    plain = _case1().simulate(t_end=0.01)
    assert plain.settings["method"] == "DOP853" and plain.settings["method_choice"] == ""
    with pytest.raises(ValueError, match="use one of .*auto"):
        stiff.simulate(t_end=0.01, method="automatic")
    with pytest.raises(ValueError, match="simulate method='automatic' must be a solve_ivp method or 'auto'"):
        gi.simulate(stiff.model, stiff.q0, stiff.qdot0, (0.0, 0.01), method="automatic")
    with pytest.raises(ValueError, match="estimate_cost method"):
        estimate_cost(stiff.model, stiff.q0, stiff.qdot0, (0.0, 0.01), method="automatic")


def test_implicit_and_explicit_runs_agree_on_a_stiff_chain():
    """Case 1 with EI = 1e6 on link 1 (omega_max 3.4e4 rad/s) through its first impact, Radau with the
    kernel's Jacobian against DOP853, both at rtol 1e-6, atol 1e-8: the joint coordinates agree within
    10 (rtol max|q| + atol) = 1e-5 (m, rad) and the impact times within that over the impact speed
    (4.43 m/s): 2.3e-6 s. (Measured: 7e-9 and equal to 1e-9 s.)"""
    stiff = _case1(1e6)
    kw = dict(t_end=0.46, rtol=1e-6, atol=1e-8, output_dt=1e-3)
    radau = stiff.simulate(method="Radau", **kw)
    dop = stiff.simulate(method="DOP853", **kw)
    assert radau.status == dop.status == "finished"
    assert len(radau.impacts) == len(dop.impacts) == 1
    tol_q = 10 * (1e-6 * np.abs(dop.q).max() + 1e-8)
    assert abs(radau.impacts[0].time - dop.impacts[0].time) <= tol_q / 4.43
    joints = [i for i, name in enumerate(stiff.model.coordinate_names) if not name.startswith("delta")]
    n = min(len(radau.t), len(dop.t))
    np.testing.assert_allclose(radau.t[:n], dop.t[:n], rtol=0, atol=1e-12)
    assert np.abs(radau.q[:n, joints] - dop.q[:n, joints]).max() <= tol_q
    # Fewer steps than the explicit method, which is held to |h lambda_max| <= 5.96 (and the Jacobian
    # replaced scipy's differences: about 8 right-hand sides a step, not 8 + 2N / (steps per Jacobian)).
    assert radau.n_steps < dop.n_steps


def test_energy_audit_splits_the_balance():
    """E(end) - E(t0) = inputs + damping_and_friction + impacts + numerical; an undriven chain with e = 1
    impacts has only the numerical part, and an implicit method's is a loss."""
    stiff = _case1(1e6)
    res = stiff.simulate(method="Radau", t_end=0.46, rtol=1e-6, atol=1e-8, output_dt=1e-3)
    audit = res.energy_audit()
    E = res.energy().total
    assert audit["inputs"] == audit["damping_and_friction"] == audit["impacts"] == 0.0
    assert audit["numerical"] == pytest.approx(E[-1] - E[0], rel=1e-9, abs=1e-12)
    assert audit["numerical"] < 0.0
    assert res.summary()["energy_audit_J"]["numerical"] == pytest.approx(audit["numerical"])


def test_implicit_method_through_impacts_and_resting_contact_with_friction():
    """The rigid rod of issue 26 on its pivot at height 0.5 m, pushed down by a torque onto a floor with
    e = 0.5 and friction 0.3: it bounces, its impacts accumulate and it rests with its tip on the floor,
    at sin theta = -0.5 / l (theta = -pi/6), with Radau as with DOP853 (the resting phases keep scipy's own
    differences for their constrained right-hand side). Same resting time to 1e-4 s (measured 7e-6 s)
    and the same energy audit to 1e-6 of the energy exchanged."""
    import warnings

    from conftest import issue26_model

    model = issue26_model(0)
    floor = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), restitution=0.5, friction=0.3)
    q0 = np.zeros(model.n_dof)
    runs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        for method in ("DOP853", "Radau"):
            runs[method] = gi.simulate(model, q0, np.zeros_like(q0), (0.0, 1.0), walls=[floor], method=method,
                                       rtol=1e-8, atol=1e-10, output_dt=1e-3,
                                       inputs={"theta_1": lambda t, q, qd: -1.0 + 0.5 * np.sin(20.0 * t)})
    dop, radau = runs["DOP853"], runs["Radau"]
    assert radau.status == dop.status == "finished"
    assert radau.resting_time > 0.2 and abs(radau.resting_time - dop.resting_time) <= 1e-4
    assert radau.q[-1, 0] == pytest.approx(-np.pi / 6, abs=1e-8)
    a, b = radau.energy_audit(), dop.energy_audit()
    scale = abs(b["inputs"]) + abs(b["impacts"])
    for key in ("inputs", "impacts"):
        assert abs(a[key] - b[key]) <= 1e-6 * scale


def test_prescribed_motion_keeps_the_solvers_own_differences(monkeypatch):
    """A prescribed run's right-hand side is the partitioned one (simulation.equations), which the kernel's
    Jacobian does not model: Radau must not be handed it (Equations.phase_jacobian), and with its own
    differences agrees with DOP853 on the free coordinates to 10 (rtol max|q| + atol)."""
    from gibbsimpact.simulation.equations import Equations

    link = gi.Link(1.0, 1.0, 50.0, modes=[gi.Mode("clamped-free", "y")])
    model = gi.Model(gi.Chain([link, link], base=gi.FixedBase((0.0, 0.0))), gravity=(0.0, -9.81, 0.0))
    q0 = model.state(theta_1=-np.pi / 2, theta_2=1.2)
    spin = gi.profiles.constant_speed(-np.pi / 2, 2.0)
    kw = dict(prescribed={"theta_1": spin}, rtol=1e-8, atol=1e-10, output_dt=0.01)
    qd0 = model.state(theta_1=2.0)
    dop = gi.simulate(model, q0, qd0, (0.0, 0.3), method="DOP853", **kw)

    def refuse(self, t, y):
        raise AssertionError("the kernel's Jacobian was used for a prescribed run")

    monkeypatch.setattr(Equations, "jacobian", refuse)
    radau = gi.simulate(model, q0, qd0, (0.0, 0.3), method="Radau", **kw)
    assert radau.status == dop.status == "finished"
    assert np.abs(radau.q - dop.q).max() <= 10 * (1e-8 * np.abs(dop.q).max() + 1e-10)


def test_auto_steps_over_fast_modes_only_across_a_gap_in_the_spectrum():
    """auto's cutoff is sqrt(omega_lo omega_hi) at a gap omega_hi / omega_lo >= FAST_GAP of the chain's frequencies:
    case 1 with EI = 1e9 on link 1 (link 2's mode near 151 rad/s, link 1's at 1.07e6 > 22.37 sqrt(EI / (mu l^4)),
    the clamped-clamped closed form): a cutoff between them; the bundled cases (widest gaps 1-17) and a chain
    auto keeps explicit get none; a cutoff the user gives is kept."""
    stiff = _case1(1e9)
    c = auto_choice(stiff.model, stiff.q0, (0.0, 1.0))
    w = np.sort(np.unique(np.abs(linearised_eigenvalues(stiff.model, stiff.q0))))
    hi, lo = w[-1], w[-2]
    assert hi > 22.37 * np.sqrt(1e9) and hi / lo >= FAST_GAP
    assert c.method == "Radau" and c.cutoff_frequency == pytest.approx(np.sqrt(lo * hi), rel=1e-12)
    assert lo < c.cutoff_frequency < hi and "stepped over" in c.reason
    assert auto_choice(stiff.model, stiff.q0, (0.0, 1.0), cutoff_frequency=5e3).cutoff_frequency == 5e3
    for name in ("fixed_base_R_Pb_arm", "fixed_base_R_Pa_arm"):
        arm = gi.load_case(CASES / f"{name}.toml")
        c = auto_choice(arm.model, arm.q0, (0.0, 1.0), rtol=1e-2)
        assert c.method == "Radau" and c.cutoff_frequency is None and "stepped over" not in c.reason
    for path in sorted(CASES.glob("*.toml")):
        bundled = gi.load_case(path)
        assert fast_mode_cutoff(linearised_eigenvalues(bundled.model, bundled.q0)) == (None, ""), path.name
    case = _case1()
    assert auto_choice(case.model, case.q0, (0.0, 1.0)) == ("DOP853", choose_method(case.model, case.q0, (0.0, 1.0))[1],
                                                            None)


def test_radau5_tolerances_in_closed_form():
    """RADAU5's map: rtol' = 0.1 rtol^(2/3), atol' / rtol' = atol / rtol (1e-10 -> 2.154e-8; 1e-2 -> 4.64e-3)."""
    r, a = radau5_tolerances(1e-10, 1e-12)
    assert r == pytest.approx(0.1 * 10 ** (-20 / 3), rel=1e-14) and a == pytest.approx(r / 100, rel=1e-14)
    r, a = radau5_tolerances(1e-2, np.array([1e-4, 1e-3]))
    np.testing.assert_allclose(a / r, [1e-2, 1e-1], rtol=1e-14)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["fixed_base_R_Pb_arm", "fixed_base_R_Pa_arm"])
def test_prismatic_case_files_run_auto_within_1e_4_of_a_tight_reference(name):
    """The case files' own run (method auto, rtol 1e-2, atol 1e-4: the compiled Radau) keeps every joint
    coordinate within 1e-4 (rad, m) of DOP853 at rtol 1e-11, atol 1e-13 over the first 0.5 s (over 1 s:
    docs/benchmarks.md, 6.4e-5 and 4.0e-5)."""
    case = gi.load_case(CASES / f"{name}.toml")
    res = case.simulate(t_end=0.5)
    ref = case.simulate(t_end=0.5, method="DOP853", rtol=1e-11, atol=1e-13)
    assert res.status == ref.status == "finished" and res.settings["method"] == "Radau"
    joints = [i for i, c in enumerate(case.model.coordinate_names) if not c.startswith("delta")]
    for j in joints:
        assert np.abs(np.interp(ref.t, res.t, res.q[:, j]) - ref.q[:, j]).max() <= 1e-4
