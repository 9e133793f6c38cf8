"""Mode shapes: frequency roots, normalisation, orthogonality, closed-form frequencies."""

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.model.modes import frequency_root, shape

# Roots of cos z cosh z = +-1 (Blevins, Formulas for natural frequency and mode shape, table 8-1).
CC = [4.730040744862704, 7.853204624095838, 10.995607838001671, 14.137165491257464]
CF = [1.875104068711961, 4.694091132974175, 7.854757438237613, 10.995540734875467]


@pytest.mark.parametrize("kind,roots", [("clamped-clamped", CC), ("clamped-free", CF)])
def test_frequency_roots(kind, roots):
    for k, z in enumerate(roots, start=1):
        assert frequency_root(kind, k) == pytest.approx(z, rel=1e-13)


@pytest.mark.parametrize("kind", ["clamped-clamped", "clamped-free", "pinned-pinned"])
@pytest.mark.parametrize("number", [1, 2, 3, 4])
def test_normalisation_and_boundary_conditions(kind, number):
    l = 1.7
    m = gi.Mode(kind, "y", number)
    x = np.linspace(0, l, 20001)
    psi = shape(m, l, x)
    assert np.max(np.abs(psi)) == pytest.approx(1.0, abs=1e-7)  # grid max is below the true max
    first_max = np.flatnonzero(np.abs(psi) > np.max(np.abs(psi)) - 1e-6)[0]
    assert psi[first_max] > 0  # sign fixed at the first place the maximum is reached
    ends = {"clamped-clamped": [(0, 0), (0, 1), (l, 0), (l, 1)],
            "clamped-free": [(0, 0), (0, 1), (l, 2), (l, 3)],
            "pinned-pinned": [(0, 0), (0, 2), (l, 0), (l, 2)]}[kind]
    beta = m.beta_l / l
    for xe, d in ends:
        assert abs(shape(m, l, np.array([xe]), d)[0]) < 1e-9 * beta**d


@pytest.mark.parametrize("kind", ["clamped-clamped", "clamped-free"])
def test_modal_frequencies_match_closed_form(kind):
    # omega_k^2 = K_kk / M_kk from the model's modal blocks, uniform beam.
    l, mu, EI = 1.3, 2.1, 35.0
    modes = [gi.Mode(kind, "y", k) for k in range(1, 5)]
    model = gi.Model(gi.Chain([gi.Link(l, mu, EI, modes=modes)]))
    ld = model.link_data[0]
    omega = np.sqrt(np.diag(ld.K) / np.diag(ld.M_dd))
    expected = [gi.natural_frequency(m, l, mu, EI) for m in modes]
    np.testing.assert_allclose(omega, expected, rtol=1e-8)
    # Eigenfunctions are orthogonal in mass and stiffness.
    off = ld.M_dd - np.diag(np.diag(ld.M_dd))
    assert np.max(np.abs(off)) < 1e-12 * np.max(ld.M_dd)
    offk = ld.K - np.diag(np.diag(ld.K))
    assert np.max(np.abs(offk)) < 1e-9 * np.max(ld.K)


def test_mode_input_errors():
    with pytest.raises(ValueError, match="kind"):
        gi.Mode("clamped-sliding")
    with pytest.raises(ValueError, match="direction"):
        gi.Mode("clamped-clamped", "x")
    with pytest.raises(ValueError, match="number"):
        gi.Mode("clamped-clamped", "y", 0)
