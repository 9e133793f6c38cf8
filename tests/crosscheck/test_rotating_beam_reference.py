"""The rotating-beam frequency reference against formulation.md §15's table (issue 24).

``rotating_beam_reference`` (shooting on the field equation) must reproduce §15's flapwise
frequencies, the closed-form non-rotating ones, and the in-plane shift
omega_bar_in^2 = omega_bar_flap^2 - lambda^2. A second route, the Ritz matrices of
``spinup_reference.RitzBeam`` (K + lambda^2 K_G [- lambda^2 M0]), must agree from above
(Rayleigh-Ritz gives upper bounds) and, without K_G, go unstable at lambda = 3.516.
"""

from __future__ import annotations

import numpy as np
import pytest
from rotating_beam_reference import rotating_beam_frequencies
from scipy.linalg import eigh
from scipy.optimize import brentq
from spinup_reference import RitzBeam

# formulation.md §15: lambda -> first two flapwise omega_bar (4 decimals, so +- 0.5e-4).
TABLE = {0: (3.5160, 22.0345), 1: (3.6816, 22.1810), 2: (4.1373, 22.6149),
         5: (6.4495, 25.4461), 10: (11.2023, 33.6404)}


@pytest.fixture(scope="module")
def shooting():
    return {lam: (rotating_beam_frequencies(lam, count=2),
                  rotating_beam_frequencies(lam, count=2, in_plane=True))
            for lam in TABLE}


def test_non_rotating_frequencies_are_the_clamped_free_closed_form(shooting):
    # omega_bar = beta^2 with cos(beta) cosh(beta) = -1 (bracketed roots near 1.875, 4.694).
    beta = [brentq(lambda b: np.cos(b) * np.cosh(b) + 1.0, a, b, xtol=1e-14)
            for a, b in ((1.5, 2.5), (4.0, 5.0))]
    np.testing.assert_allclose(shooting[0][0], np.square(beta), rtol=1e-10)


@pytest.mark.parametrize("lam", sorted(TABLE))
def test_flapwise_frequencies_reproduce_the_table(shooting, lam):
    flap = shooting[lam][0]
    np.testing.assert_allclose(flap, TABLE[lam], rtol=1e-4)
    # The table is rounded to 4 decimals: the reference must round to it.
    assert np.all(np.abs(flap - np.array(TABLE[lam])) <= 0.5e-4 + 1e-9)


@pytest.mark.parametrize("lam", sorted(TABLE))
def test_in_plane_is_flapwise_shifted_by_lambda_squared(shooting, lam):
    flap, in_plane = shooting[lam]
    np.testing.assert_allclose(in_plane ** 2, flap ** 2 - lam ** 2, rtol=1e-10)


@pytest.mark.parametrize("lam", sorted(TABLE))
def test_ritz_matrices_of_the_spinup_reference_bound_the_shooting_from_above(shooting, lam):
    # 8 polynomial terms: Ritz error ~1e-8 on omega_1, ~2e-7 on omega_2 (measured); an upper
    # bound, so the Ritz values must lie in [exact, exact (1 + 1e-6)].
    beam = RitzBeam(8, 1.0, 1.0, 1.0)
    for in_plane, exact in zip((False, True), shooting[lam]):
        ritz = np.sqrt(eigh(*beam.rotating_matrices(lam, in_plane)[::-1], eigvals_only=True)[:2])
        assert np.all(ritz >= exact * (1.0 - 1e-10))
        np.testing.assert_allclose(ritz, exact, rtol=1e-6)


def test_without_geometric_stiffness_the_in_plane_mode_goes_unstable_at_3_516():
    # K - Omega^2 M0 (no K_G): lowest eigenvalue changes sign at lambda = omega_bar_1 = 3.51602.
    beam = RitzBeam(8, 1.0, 1.0, 1.0)
    omega_1 = rotating_beam_frequencies(0.0, count=1)[0]

    def lowest(lam):
        return eigh(beam.K - lam ** 2 * beam.M0, beam.M0, eigvals_only=True)[0]

    assert lowest(omega_1 * (1 - 1e-6)) > 0.0 > lowest(omega_1 * (1 + 1e-6))
    # With K_G the same spin is stable far beyond (lambda = 10: omega_bar_in = 5.05).
    assert eigh(*beam.rotating_matrices(10.0)[::-1], eigvals_only=True)[0] > 0.0
