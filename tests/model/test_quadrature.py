"""Convergence of the modal integrals: the default quadrature's error on M is < 1e-12."""

import numpy as np
import pytest

import gibbsimpact as gi


@pytest.mark.parametrize("kind", ["clamped-clamped", "clamped-free"])
def test_mass_matrix_quadrature_converged(kind, rng):
    modes = [gi.Mode(kind, "y", k) for k in range(1, 5)] + [gi.Mode(kind, "z", 4)]
    link = gi.Link(1.0, 1.0, 20.0, modes=modes, rotary_inertia=(1e-4, 1e-4, 1e-4))
    chain = gi.Chain([link, link])
    ref = gi.Model(chain, quadrature=(64, 24))
    coarse = {pq: gi.Model(chain, quadrature=pq) for pq in [(1, 4), (2, 6), (16, 16)]}
    errs = {pq: 0.0 for pq in coarse}
    for _ in range(3):
        q = rng.uniform(-0.5, 0.5, ref.n_dof)
        Mr = ref.mass_matrix(q)
        for pq, m in coarse.items():
            errs[pq] = max(errs[pq], np.linalg.norm(m.mass_matrix(q) - Mr) / np.linalg.norm(Mr))
    assert errs[(16, 16)] < 1e-12
    # Coarse rules are visibly wrong and improve with refinement, so the
    # comparison can detect a quadrature error (the reference is not just equal by construction).
    assert errs[(1, 4)] > 1e-6
    assert errs[(1, 4)] > errs[(2, 6)] > errs[(16, 16)]


@pytest.mark.parametrize("kind", ["clamped-clamped", "clamped-free"])
def test_modal_mass_closed_form(kind):
    # For these eigenfunctions int_0^l phi^2 dx = l when phi = cosh - cos - sigma (sinh - sin);
    # psi = C phi with C = 1/max|phi|, so int psi^2 = C^2 l.
    from gibbsimpact.model.modes import _normalisation

    l, mu = 1.0, 1.0
    for k in range(1, 5):
        model = gi.Model(gi.Chain([gi.Link(l, mu, 1.0, modes=[gi.Mode(kind, "y", k)])]))
        C = _normalisation(kind, k, l)
        assert model.link_data[0].M_dd[0, 0] == pytest.approx(C * C * l * mu, rel=1e-13)
