"""The cost estimate before a run (gibbsimpact.simulation.cost): the methods' stability and error polynomials
against their closed forms, the linearised frequencies against beam theory and Rayleigh damping, and the
estimated steps against real runs (docs/benchmarks.md has the whole table)."""

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl

import gibbsimpact as gi
from gibbsimpact.case import case_from_dict
from gibbsimpact.model.modes import Mode, natural_frequency
from gibbsimpact.simulation.cost import estimate_cost
from gibbsimpact.simulation.stability import (error_estimate, linearised_eigenvalues, stability_function,
                                              stability_radius)

from conftest import TIGHT_DOP853

CASES = Path(__file__).resolve().parents[2] / "cases"


# -- the methods -------------------------------------------------------------------------------

def test_stability_functions_are_the_published_polynomials():
    """RK23 (3 stages, order 3): the Taylor polynomial of e^z to z^3; RK45 (Dormand-Prince 5(4), local
    extrapolation): to z^5, plus z^6 / 600 (Hairer & Wanner, Solving ODEs II, §IV.2);
    DOP853: e^z to order 8, |R(z) - e^z| <= |z|^9 / 9! for |z| <= 1/2."""
    rng = np.random.default_rng(27)
    for z in rng.normal(size=5) + 1j * rng.normal(size=5):
        taylor = [z ** k / math.factorial(k) for k in range(6)]
        assert stability_function("RK23", z) == pytest.approx(sum(taylor[:4]), rel=1e-14, abs=1e-14)
        assert stability_function("RK45", z) == pytest.approx(sum(taylor) + z ** 6 / 600, rel=1e-14, abs=1e-14)
    for z in (0.5, -0.5, 0.5j, 0.35 + 0.35j):
        assert abs(stability_function("DOP853", z) - np.exp(z)) <= abs(z) ** 9 / math.factorial(9)


def test_stability_radii_against_the_roots_of_the_polynomials():
    """Imaginary axis of RK23: |R(iy)|^2 = 1 - y^4/12 + y^6/36, so sqrt(3). Negative real axis: the first
    negative root of R(x) = -1 or R(x) = +1 (numpy.roots of the closed-form polynomials above), 2.5127 and
    3.3066. The radius
    counts |R| <= 1 + 1e-9 as stable, which moves a boundary crossed at slope d|R|/dr ~ 0.4 by ~3e-9."""
    assert stability_radius("RK23", math.pi / 2) == pytest.approx(math.sqrt(3), rel=1e-8)
    for method, coeffs in (("RK23", [1, 1, 1 / 2, 1 / 6]), ("RK45", [1, 1, 1 / 2, 1 / 6, 1 / 24, 1 / 120, 1 / 600])):
        roots = []
        for level in (-1.0, 1.0):
            c = np.array(coeffs, dtype=float)
            c[0] -= level  # R(x) - level = 0
            roots += [-r.real for r in np.roots(c[::-1]) if abs(r.imag) < 1e-9 and r.real < -1e-9]
        x = min(roots)
        assert stability_radius(method, math.pi) == pytest.approx(x, rel=1e-8)
    # DOP853's imaginary interval, the number the step estimate of an undamped chain rests on.
    r = stability_radius("DOP853", math.pi / 2)
    assert abs(stability_function("DOP853", 1j * r * 0.999)) <= 1 < abs(stability_function("DOP853", 1j * r * 1.001))
    assert r == pytest.approx(5.96, abs=0.01)


@pytest.mark.parametrize("method, order", [("RK23", 2), ("RK45", 4), ("DOP853", 7)])
def test_error_estimates_have_the_methods_orders(method, order):
    """scipy's error estimate of one step on y' = lambda y falls like |z|^(order + 1) (its error_estimator_order)."""
    z = 0.02j
    slope = math.log(error_estimate(method, z) / error_estimate(method, z / 2)) / math.log(2)
    assert slope == pytest.approx(order + 1, abs=0.05)


# -- the linearised chain ----------------------------------------------------------------------

def test_frequencies_of_a_pb_link_are_the_clamped_free_beams():
    """A link sliding through a guide (no gravity) bends as a beam clamped at the guide over its protruding
    length d: omega_k = (beta_k l)^2 sqrt(EI / (mu d^4)), 6 elements within 1e-4 for the lowest three."""
    L, mu, EI, d = 1.0, 0.7, 3.0, 0.6
    link = gi.Link(L, mu, EI, elements=6, geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], joints=[gi.FixedPrismatic(angle=0.0, range=(0.1, L))], base=gi.FixedBase()),
                     gravity=(0.0, 0.0, 0.0))
    lam = linearised_eigenvalues(model, model.state(d_1=d))
    omega = np.sort(np.abs(lam[lam.imag > 1e-6]))
    beam = [natural_frequency(Mode("clamped-free", "y", k), d, mu, EI) for k in (1, 2, 3)]
    assert omega[:3] == pytest.approx(beam, rel=2e-3)
    assert omega[0] == pytest.approx(beam[0], rel=1e-5)


def test_damped_eigenvalues_are_rayleighs():
    """Stiffness-proportional damping C = beta K: every mode of (K, M) (K the model's assembled stiffness, M at
    q0, scipy.linalg.eigh) has the eigenvalues of lambda^2 + beta omega^2 lambda + omega^2 = 0."""
    zeta = 0.02
    link = gi.Link(1.0, 1.0, 25.0, elements=4, element_directions=("y",), damping=zeta, geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase()), gravity=(0.0, 0.0, 0.0))
    q0 = model.state(theta_1=0.3)
    lam = linearised_eigenvalues(model, q0)
    ld = model.link_data[0]
    beta = 2 * zeta / math.sqrt(sl.eigh(ld.K, ld.M_dd, eigvals_only=True)[0])
    w2 = sl.eigh(model.stiffness_matrix, gi.Model.mass_matrix(model, q0), eigvals_only=True)
    expected = np.concatenate([np.roots([1.0, beta * w, w]) for w in w2 if w > 1e-6])
    assert np.abs(lam).max() == pytest.approx(np.abs(expected).max(), rel=1e-6)
    for e in expected:
        assert np.min(np.abs(lam - e)) <= 1e-6 * abs(e)


# -- against real runs -------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["fixed_base_R_Pb_arm", "fixed_base_R_Pa_arm"])
def test_estimate_of_the_prismatic_arms_within_a_factor_two(name):
    """The shipped stiff prismatic arms (finite-element links, 2000-2600 rad/s), 0.5 s as shipped: estimated
    steps and right-hand sides within a factor 2 of the run's. The factor: the step follows the highest
    mode's accuracy, which goes as its amplitude to the power 1/8 for DOP853, so an amplitude off by 256
    would double it; rejected steps add 10-30 % (measured 1.3-1.6 and 1.05-1.3)."""
    case = gi.load_case(CASES / f"{name}.toml")
    est = case.estimate_cost(t_end=0.5, **TIGHT_DOP853)
    res = case.simulate(t_end=0.5, **TIGHT_DOP853)
    assert res.status == "finished"
    assert 0.5 <= est.n_steps / res.n_steps <= 2.0, (est, res.n_steps)
    assert 0.5 <= est.n_rhs / res.nfev <= 2.0, (est, res.nfev)
    assert est.n_steps >= res.t[-1] / est.h_stability  # the stability limit is a lower bound


def test_estimate_of_a_stiff_arm_bounds_the_steps():
    """The R-Pb arm with link 1 4e7 times stiffer (omega_max 1.3e7 rad/s): DOP853 needs at least the steps of
    its stability limit and at most 3 times them; the estimate is within a factor 3 of the run (docs/
    benchmarks.md: 1.5 - 2.7 over such spans, its highest mode is excited less than assumed)."""
    case = gi.load_case(CASES / "fixed_base_R_Pb_arm.toml")
    data = copy.deepcopy(case.source)
    data["links"][0]["EI_N_m2"] = 1e9
    stiff = case_from_dict(data, name="stiff")
    est = stiff.estimate_cost(t_end=5e-4, **TIGHT_DOP853)
    res = stiff.simulate(t_end=5e-4, **TIGHT_DOP853)
    assert est.omega_max > 1e7
    n_stable = 5e-4 / est.h_stability
    assert n_stable <= res.n_steps <= 3 * n_stable
    assert 1 / 3 <= est.n_steps / res.n_steps <= 3


def test_implicit_methods_are_not_estimated():
    case = gi.load_case(CASES / "circle_two_link.toml")
    est = case.estimate_cost(method="Radau")
    assert est.n_steps is None and est.cpu_seconds is None and est.omega_max > 100
    assert "Radau: steps not estimated (Radau is implicit" in est.describe()


def test_estimate_cost_takes_simulates_keywords_only():
    case = gi.load_case(CASES / "circle_two_link.toml")
    kw = case.simulate_kwargs()
    with pytest.raises(ValueError, match="estimate_cost rtoll: not a keyword of simulate"):
        estimate_cost(**kw, rtoll=1e-6)
    with pytest.raises(ValueError, match="estimate_cost method='RK4'"):
        estimate_cost(**{**kw, "method": "RK4"})


def test_stability_limit_of_an_undamped_mode_whose_eigenvalue_has_a_round_off_real_part():
    """Case 1 with EI = 1e9 on link 1: eig gives its highest (undamped) mode at 1.07e6 rad/s a real part of
    +3.7e-11 (round-off). Its stability limit still binds: h_stability = r(pi/2) / omega_max with
    r(pi/2) = 5.96 for DOP853 (it was 0.039 s, the limit of the next mode, when that mode was skipped)."""
    case = gi.load_case(CASES / "circle_two_link.toml")
    data = copy.deepcopy(case.source)
    data["links"][0]["EI_N_m2"] = 1e9
    est = case_from_dict(data, name="stiff").estimate_cost(t_end=1.0)
    assert est.h_stability == pytest.approx(stability_radius("DOP853", np.pi / 2) / est.omega_max, rel=1e-6)


def test_the_cost_of_a_run_that_starts_at_gimbal_lock_is_that_of_its_start_chart():
    # theta_0 = pi/2: the given chart's M is singular (`gibbsimpact show` died with LinAlgError); a run
    # re-charts the base at t0 (theory §2.1). Without gravity and at rest the frequencies do not depend on
    # the orientation: they are those of the link at theta_0 = 0.3 rad, where the chart is regular.
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")], rotary_inertia=(1e-4, 1e-4, 1e-4))
    model = gi.Model([link], gravity=(0.0, 0.0, 0.0))
    q0 = model.state(theta_0=np.pi / 2)
    est = estimate_cost(model, q0, np.zeros(model.n_dof), (0.0, 0.01))
    lam = linearised_eigenvalues(model, model.state(theta_0=0.3))   # the same state in a regular chart
    assert est.omega_max == pytest.approx(float(np.abs(lam).max()), rel=1e-9)
