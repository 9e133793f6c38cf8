"""The chain linearised at a state (gibbsimpact.simulation.stability): its free-vibration frequencies against the
closed form of a beam."""

from __future__ import annotations

import numpy as np

import gibbsimpact as gi
from gibbsimpact.simulation.stability import free_vibration_frequencies
from conftest import CLAMPED_CLAMPED_ROOTS, welded_beam_model


def test_free_vibration_frequencies_of_a_welded_beam_are_the_closed_form():
    EI, mu, length = 50.0, 2.0, 1.5
    model = welded_beam_model(EI, mu, length)
    omega = free_vibration_frequencies(model, model.state())
    # omega_k = (beta_k l)^2 sqrt(EI / (mu l^4)); the mass and stiffness integrals are quadratures, ~1e-10
    expected = np.array(CLAMPED_CLAMPED_ROOTS) ** 2 * np.sqrt(EI / (mu * length**4))
    np.testing.assert_allclose(omega, expected, rtol=1e-8)


def test_free_vibration_frequencies_count_a_rigid_motion_as_zero():
    # a pendulum-free chain (no gravity) on a revolute joint: one zero, then the pinned beam's modes
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")], geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase()), gravity=(0.0, 0.0, 0.0))
    omega = free_vibration_frequencies(model, model.state())
    assert omega.shape == (2,) and omega[0] < 1e-6 * omega[1]
    # the joint frees the rotation: the beam's mode stiffens by the coupling (M's Schur complement is smaller)
    assert omega[1] > CLAMPED_CLAMPED_ROOTS[0] ** 2 * np.sqrt(20.0)
