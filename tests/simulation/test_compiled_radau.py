"""The compiled Radau IIA stepper (kernel/radau.py, simulation/compiled_radau.py): closed forms, order,
agreement with scipy's Radau, events, impacts and the energy audit.

All of them share one compiled variant (case 1's: revolute joints and rigid link ends) and are marked
slow: the first use compiles the stepper (20-40 s of CPU, then numba's cache).
"""

import copy
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import gibbsimpact as gi
from gibbsimpact.case import case_from_dict
from gibbsimpact.kernel import radau as rk
from gibbsimpact.simulation.compiled_radau import CompiledRadau, LinearProgram, input_rows, slow_projector
from gibbsimpact.simulation.equations import Equations

CASES = Path(__file__).resolve().parents[2] / "cases"
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def case1():
    return gi.load_case(CASES / "circle_two_link.toml")


def _stiff_case1(EI):
    src = copy.deepcopy(gi.load_case(CASES / "circle_two_link.toml").source)
    src["links"][0]["EI_N_m2"] = EI
    return case_from_dict(src, name=f"case1_EI{EI:g}")


def _linear(A, y0, t_end, model, **kw):
    A = np.asarray(A, dtype=float)
    return solve_ivp(lambda t, y: A @ y, (0.0, t_end), y0, method=CompiledRadau, program=LinearProgram(A, model), **kw)


def test_transformation_constants_diagonalise_the_radau_iia_matrix():
    """T^-1 A_rk^-1 T = [[mu_r, 0, 0], [0, alpha, beta], [0, -beta, alpha]] with mu_r and alpha - i beta the
    constants of the step, for the Butcher matrix of three-stage Radau IIA in closed form; the dense output
    matrix P reproduces the stages (Z_i = sum_k Q_k c_i^k)."""
    s6 = 6 ** 0.5
    A = np.array([[(88 - 7 * s6) / 360, (296 - 169 * s6) / 1800, (-2 + 3 * s6) / 225],
                  [(296 + 169 * s6) / 1800, (88 + 7 * s6) / 360, (-2 - 3 * s6) / 225],
                  [(16 - s6) / 36, (16 + s6) / 36, 1 / 9]])
    np.testing.assert_allclose(A.sum(axis=1), rk.NODES, atol=1e-15)
    np.testing.assert_allclose(rk.TI_MAT @ rk.T_MAT, np.eye(3), atol=1e-14)
    a, b = rk.MU_COMPLEX.real, -rk.MU_COMPLEX.imag
    want = np.array([[rk.MU_REAL, 0, 0], [0, a, b], [0, -b, a]])
    np.testing.assert_allclose(rk.TI_MAT @ np.linalg.inv(A) @ rk.T_MAT, want, atol=1e-12)
    Z = np.random.default_rng(1).normal(size=(3, 4))
    V = rk.NODES[:, None] ** np.arange(1, 4)
    np.testing.assert_allclose(V @ (Z.T @ rk.DENSE_P).T, Z, atol=1e-13)


def test_linear_oscillator_to_the_requested_accuracy_and_as_scipy(case1):
    """y'' = -w^2 y, w = 10 rad/s, y(0) = 1, over 2 s (3.2 periods): |y - cos w t| <= rtol at every step end
    (the local errors are held to rtol |y| + atol, atol = rtol / 100, and add up over the ~3 periods with the
    safety factor 0.9 to below rtol: measured 1.6e-4 and 5.2e-7), the same number of steps and right-hand
    sides as scipy's Radau (the same method and control), and its trajectory within rtol of scipy's."""
    w = 10.0
    A = [[0.0, 1.0], [-w * w, 0.0]]
    for rtol in (1e-3, 1e-5):
        ours = _linear(A, [1.0, 0.0], 2.0, case1.model, rtol=rtol, atol=rtol / 100)
        ref = solve_ivp(lambda t, y: np.array(A) @ y, (0.0, 2.0), [1.0, 0.0], method="Radau", rtol=rtol,
                        atol=rtol / 100)
        assert ours.status == 0 and np.abs(ours.y[0] - np.cos(w * ours.t)).max() <= rtol
        assert ours.t.size == ref.t.size and ours.nfev == ref.nfev
        # to the tolerance, per component (measured 3e-5 and 3e-7 of the amplitudes 1 and w):
        assert np.all(np.abs(ours.y - ref.y).max(axis=1) <= rtol * np.abs(ref.y).max(axis=1))


def test_stiff_linear_system_to_its_closed_form_in_few_steps(case1):
    """y' = A y with eigenvalues -1 and -1e6 (and a rotation coupling them): y(t) = expm(A t) y0. The L-stable
    method resolves the fast transient of y0 (~1e-5 s) and then follows the slow mode to rtol with steps far
    beyond the fast time constant: fewer than 200 steps over 5 s (measured 133, steps up to 0.1 s), where an
    explicit method would need 5e6 / 3.3 for stability alone."""
    S = np.array([[1.0, 0.3], [-0.2, 1.0]])
    A = S @ np.diag([-1.0, -1e6]) @ np.linalg.inv(S)
    y0 = np.array([1.0, 2.0])
    sol = _linear(A, y0, 5.0, case1.model, rtol=1e-6, atol=1e-9, dense_output=True)
    assert sol.status == 0 and sol.t.size < 200 and np.diff(sol.t).max() > 0.05
    for t in (0.5, 2.0, 5.0):
        exact = expm(A * t) @ y0
        assert np.abs(sol.sol(t) - exact).max() <= 1e-6 * np.abs(exact).max() + 1e-9 * 10


def test_order_five_with_fixed_steps(case1):
    """Halving a fixed step divides the global error of the oscillator by 2^5 = 32 (Radau IIA's classical order
    5): log2 of the ratio within 0.3 of 5 for h = 0.02 -> 0.01 s (h w = 0.2, 0.1: the asymptotic range)."""
    w = 10.0
    A = [[0.0, 1.0], [-w * w, 0.0]]
    errs = []
    for h in (0.02, 0.01):
        sol = _linear(A, [1.0, 0.0], 1.0, case1.model, rtol=1.0, atol=1.0, first_step=h, max_step=h)
        assert np.allclose(np.diff(sol.t)[:-1], h)
        errs.append(abs(sol.y[0, -1] - np.cos(w * 1.0)))
    assert abs(np.log2(errs[0] / errs[1]) - 5.0) <= 0.3


def test_slow_projector_removes_the_fast_modes_from_the_error_only():
    """Pf = I - (spectral projector on |lambda| > cutoff): Pf v = 0 for a fast eigenvector, Pf v = v for a slow
    one; no filter (0 rows) without a cutoff or a mode above it."""
    K = np.diag([100.0, 1e12])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-K, np.zeros((2, 2))]])
    Pf = slow_projector(A, 1e3)
    lam, V = np.linalg.eig(A)
    for k in range(4):
        want = 0.0 if abs(lam[k]) > 1e3 else 1.0
        np.testing.assert_allclose(Pf @ V[:, k], want * V[:, k], atol=1e-12)
    assert slow_projector(A, None).shape == (0, 0) and slow_projector(A, 1e7).shape == (0, 0)


def test_input_rows_compile_the_case_file_inputs_and_refuse_callables(case1):
    """The closed-form inputs of a case file become kernel rows (kind, k, a, b, c, d); a Python callable does
    not (that run's phases go to scipy's Radau)."""
    from gibbsimpact.dynamics.inputs import InputSpec, named_inputs

    m = case1.model
    specs = [InputSpec("theta_1", "sine", {"amplitude": 2.0, "frequency": 0.5}),
             InputSpec("theta_1", "pd", {"target": 0.1, "stiffness": 5.0, "damping": 1.0})]
    rows = input_rows(m, named_inputs(specs, m.coordinate_names))
    k = m.coordinate_names.index("theta_1")
    np.testing.assert_allclose(rows, [[rk.IN_SINE, k, 2.0, np.pi, 0.0, 0.0], [rk.IN_PD, k, 5.0, 0.1, 1.0, 0.0]])
    assert input_rows(m, {"theta_1": lambda t, q, qd: 1.0}) is None
    assert input_rows(m, None).shape == (0, 6)


def _scipy_radau(monkeypatch):
    """Make every phase of method="Radau" run scipy's Radau (the fallback path) for this test."""
    monkeypatch.setattr(Equations, "phase_solver", lambda self, method: None)


def test_compiled_and_scipy_radau_agree_through_an_impact(monkeypatch):
    """Case 1 with EI = 1e5 on link 1 (omega_max ~1e4 rad/s) through its first impact, at rtol 1e-6,
    atol 1e-8: the same status and impacts (walls, joints), impact times within the joint tolerance
    10 (rtol max|q| + atol) over the impact speed 4.43 m/s, joint coordinates within that tolerance."""
    stiff = _stiff_case1(1e5)
    kw = dict(t_end=0.46, rtol=1e-6, atol=1e-8, output_dt=1e-3, method="Radau")
    ours = stiff.simulate(**kw)
    with monkeypatch.context() as mp:
        _scipy_radau(mp)
        ref = stiff.simulate(**kw)
    assert ours.status == ref.status == "finished"
    assert [(r.wall, r.joints) for r in ours.impacts] == [(r.wall, r.joints) for r in ref.impacts]
    tol_q = 10 * (1e-6 * np.abs(ref.q).max() + 1e-8)
    for a, b in zip(ours.impacts, ref.impacts):
        assert abs(a.time - b.time) <= tol_q / 4.43
    joints = [i for i, name in enumerate(stiff.model.coordinate_names) if not name.startswith("delta")]
    n = min(len(ours.t), len(ref.t))
    assert np.abs(ours.q[:n, joints] - ref.q[:n, joints]).max() <= tol_q


def test_events_located_at_the_same_times_as_the_scipy_path(monkeypatch, case1):
    """Case 1 as shipped over 1 s with method="Radau" at rtol 1e-8, atol 1e-10: every impact of the compiled
    path at the scipy path's time within 10 (rtol max|q| + atol) / 4.43 m/s (same walls and joints), and the
    same final status."""
    kw = dict(t_end=1.0, rtol=1e-8, atol=1e-10, method="Radau")
    ours = case1.simulate(**kw)
    with monkeypatch.context() as mp:
        _scipy_radau(mp)
        ref = case1.simulate(**kw)
    assert ours.status == ref.status and len(ours.impacts) == len(ref.impacts) >= 2
    # Every phase of the compiled run ran the compiled stepper (no resting contact, no callable input); the
    # patched run's none did.
    phases = ours.settings["radau_phases"]
    assert phases["scipy"] == 0 and phases["compiled"] >= len(ours.impacts) + 1
    assert "radau_phases" not in ref.settings
    tol_t = 10 * (1e-8 * np.abs(ref.q).max() + 1e-10) / 4.43
    for a, b in zip(ours.impacts, ref.impacts):
        assert (a.wall, a.joints) == (b.wall, b.joints) and abs(a.time - b.time) <= tol_t


def test_numerical_dissipation_of_an_undamped_stiff_chain_is_a_bounded_loss():
    """Case 1 with EI = 1e6 on link 1, undamped, e = 1, through its first impact with the compiled Radau at
    rtol 1e-6: the energy audit has only its numerical part, negative (an L-stable method damps what it
    steps over) and bounded by the energy put into motion, |E| <= 1e-3 m g h_drop ~ 4.9e-3 J (measured
    ~1e-7 J: the impact excites link 1's modes, which the steps resolve at this tolerance)."""
    stiff = _stiff_case1(1e6)
    res = stiff.simulate(t_end=0.46, rtol=1e-6, atol=1e-8, method="Radau")
    audit = res.energy_audit()
    assert audit["inputs"] == audit["damping_and_friction"] == audit["impacts"] == 0.0
    E = res.energy().total
    assert audit["numerical"] == pytest.approx(E[-1] - E[0], rel=1e-9, abs=1e-12)
    assert -4.9e-3 <= audit["numerical"] < 0.0


def test_auto_steps_over_the_stiff_mode_an_impact_excites_and_the_audit_holds_its_energy():
    """Case 1 with EI = 1e9 on link 1 to 0.47 s, through its first impact (O2 at 0.451524 s, as DOP853: free fall
    before it): the impact puts 2.38 J into link 1's mode at 1.07e6 rad/s (5 m/s). auto takes Radau with the
    cutoff at the spectrum's gap (1.27e4 rad/s), steps over that mode and damps it: the run finishes in under
    200 steps (measured 61; resolving the mode takes ~4e-8 s steps) and the energy audit's numerical part is
    minus that mode's energy, computed apart from any stepper (modal projection of the post-impact velocity):
    measured 1 - 5e-6; the slow motion's own share is held to rtol' |E| ~ 1e-6 J and the damped mode's
    remainder to |R(h lambda)| <= 0.03 a step, hence 1e-3. Without the velocity weighting the run stalls at
    the impact (measured: 0.4536 s in 1e5 right-hand sides)."""
    from conftest import fast_mode_energy

    stiff = _stiff_case1(1e9)
    res = stiff.simulate(t_end=0.47, method="auto", max_rhs_calls=20000)
    assert res.status == "finished" and res.settings["method"] == "Radau" and res.n_steps < 200
    assert 1e4 < res.settings["cutoff_frequency"] < 2e4 and "stepped over" in res.settings["method_choice"]
    (imp,) = res.impacts
    assert abs(imp.time - 0.451524) < 1e-6
    q = res.q[np.argmin(np.abs(res.t - imp.time))]
    e_fast = fast_mode_energy(stiff.model, q, imp.qdot_after)
    assert e_fast > 1.0
    assert res.energy_audit()["numerical"] == pytest.approx(-e_fast, rel=1e-3)


def test_slow_projector_of_a_free_flying_chain_from_the_stiffness_block():
    """On case 1 with EI = 1e9 (zero eigenvalues of rigid motion, a mode at 1.07e6 rad/s) Pf is a projector
    (Pf Pf = Pf), removes the fast mode shapes v of d qddot/d q from positions and velocities, (v, 0) and (0, v),
    and keeps the slow ones: to 1e-9 of |Pf| (round-off of a 9 x 9 eigenproblem with |mu| up to 1e12). Taken
    from J's 18 x 18 eigenvectors instead, |Pf| was 1e9 and the filter made X2's error (docs/theory.md §14.1)."""
    from gibbsimpact.dynamics.jacobian import acceleration_jacobian
    stiff = _stiff_case1(1e9)
    N = stiff.model.n_dof
    A = acceleration_jacobian(stiff.model, stiff.q0, np.zeros(N)).A
    J = np.block([[np.zeros((N, N)), np.eye(N)], [A, np.zeros((N, N))]])
    Pf = slow_projector(J, 1.27e4)
    big = np.abs(Pf).max()
    assert big < 1e5
    np.testing.assert_allclose(Pf @ Pf, Pf, atol=1e-9 * big)
    mu, V = np.linalg.eig(A)
    for k in range(N):
        v = np.real_if_close(V[:, k])
        for y in (np.r_[v, 0 * v], np.r_[0 * v, v]):
            want = 0.0 if abs(mu[k]) > 1.27e4 ** 2 else 1.0
            np.testing.assert_allclose(Pf @ y, want * y, atol=1e-9 * big)
