"""Rigid bodies attached to links (model/bodies.py, docs/theory.md §6.8): validation, the link
tables, and the clamped cantilever with a tip body against its frequency equation."""

import numpy as np
import pytest
import scipy.optimize as so

import gibbsimpact as gi
from gibbsimpact.model.shapes import link_integrals


@pytest.mark.parametrize("kwargs, word", [
    (dict(mass=0.0), "mass"),
    (dict(mass=1.0, center=(0, 0)), "center"),
    (dict(mass=1.0, inertia=(1.0, 1.0, 3.0)), "triangle"),
    (dict(mass=1.0, inertia=(-1.0, 1.0, 1.0)), "triangle"),
    (dict(mass=1.0, inertia=[[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]), "symmetric"),
    (dict(mass=1.0, at=-0.1), "at"),
])
def test_bad_body_names_the_argument(kwargs, word):
    with pytest.raises(ValueError, match=word):
        gi.RigidBody(**kwargs)


def test_link_resolves_and_checks_its_bodies():
    lk = gi.Link(0.8, 1.0, 1.0, bodies=[gi.RigidBody(1.0), gi.RigidBody(0.5, at=0.0)])
    assert [b.at for b in lk.bodies] == [0.8, 0.0]
    with pytest.raises(ValueError, match="beyond the link's length"):
        gi.Link(0.8, 1.0, 1.0, bodies=[gi.RigidBody(1.0, at=0.9)])
    with pytest.raises(ValueError, match="RigidBody"):
        gi.Link(0.8, 1.0, 1.0, bodies=[1.0])
    # On a bending link only an axial offset and the link axis as a principal axis fit the tables.
    with pytest.raises(ValueError, match=r"center=\(c_x, 0, 0\)"):
        gi.Link(0.8, 1.0, 1.0, elements=2, bodies=[gi.RigidBody(1.0, center=(0.0, 0.1, 0.0))])
    with pytest.raises(ValueError, match="J_xy = J_xz = 0"):
        gi.Link(0.8, 1.0, 1.0, elements=2, bodies=[gi.RigidBody(1.0, inertia=[[2, 0.1, 0], [0.1, 2, 0], [0, 0, 2]])])
    with pytest.raises(ValueError, match="FixedPrismatic"):
        gi.Chain([gi.Link(1.0, 1.0, 1.0, bodies=[gi.RigidBody(1.0)])], joints=[gi.FixedPrismatic(range=(0.2, 1.0))],
                 base=gi.FixedBase())


def test_body_adds_its_pseudo_inertia_to_a_rigid_link():
    # P_b = m (X, c_y, c_z, 1)(...)^T + [[Sigma, 0], [0, 0]], Sigma = tr(J)/2 I - J, X = x_a + c_x
    J = np.array([[0.3, 0.02, -0.01], [0.02, 0.5, 0.03], [-0.01, 0.03, 0.6]])
    b = gi.RigidBody(2.0, center=(0.1, -0.2, 0.05), inertia=J, at=0.4)
    bare, loaded = link_integrals(gi.Link(1.0, 3.0, 1.0)), link_integrals(gi.Link(1.0, 3.0, 1.0, bodies=[b]))
    r = np.array([0.5, -0.2, 0.05, 1.0])
    P = 2.0 * np.outer(r, r)
    P[:3, :3] += 0.5 * np.trace(J) * np.eye(3) - J
    np.testing.assert_allclose(loaded.P0 - bare.P0, P, rtol=0, atol=1e-14)
    np.testing.assert_allclose(loaded.m_r0 - bare.m_r0, 2.0 * r, rtol=0, atol=1e-14)
    assert loaded.mass - bare.mass == pytest.approx(2.0, abs=1e-13)


# ---------------------------------------------------------------------------------------------
# Clamped cantilever with a tip body: W = A(cos bx - cosh bx) + B(sin bx - sinh bx) (clamped at 0),
# tip conditions EI W'' = omega^2 J_t W', EI W''' = -omega^2 m_t W; J_t = 0 gives the frequency
# equation 1 + cos b cosh b + (m_t/(mu l)) b (cos b sinh b - sin b cosh b) = 0.
# ---------------------------------------------------------------------------------------------

L, MU, EI = 1.0, 2.0, 5.0


def _tip_determinant(beta, m_t, J_t):
    b = beta / L
    w2 = EI * b ** 4 / MU
    c, s, ch, sh = np.cos(beta), np.sin(beta), np.cosh(beta), np.sinh(beta)
    W, W1 = np.array([c - ch, s - sh]), b * np.array([-s - sh, c - ch])
    W2, W3 = b ** 2 * np.array([-c - ch, -s - sh]), b ** 3 * np.array([s - sh, -c - ch])
    return np.linalg.det(np.array([EI * W2 - w2 * J_t * W1, EI * W3 + w2 * m_t * W]))


def _exact_first_frequency(m_t, J_t):
    betas = np.linspace(0.3, 3.0, 541)
    f = [_tip_determinant(b, m_t, J_t) for b in betas]
    k = next(i for i in range(len(betas) - 1) if f[i] * f[i + 1] < 0)
    beta = so.brentq(_tip_determinant, betas[k], betas[k + 1], args=(m_t, J_t), xtol=1e-15, rtol=1e-15)
    return beta ** 2 * np.sqrt(EI / (MU * L ** 4))


def test_tip_determinant_is_the_published_tip_mass_equation():
    for ratio in (0.0, 0.5, 2.0):
        def published(b):
            return 1 + np.cos(b) * np.cosh(b) + ratio * b * (np.cos(b) * np.sinh(b) - np.sin(b) * np.cosh(b))
        beta = so.brentq(published, 0.3, 1.9, xtol=1e-15)
        assert _exact_first_frequency(ratio * MU * L, 0.0) == pytest.approx(beta ** 2 * np.sqrt(EI / (MU * L ** 4)),
                                                                            rel=1e-12)


def _tip_link(m_t, J_t, J_x=0.0, **disc):
    # A body symmetric about the link axis at the tip: J = (J_x, J_t, J_t) about its centre, whose
    # bending inertia J_t turns with the section (docs/theory.md §6.8); J_x (its spin) does not enter.
    return gi.Link(L, MU, EI, bodies=[gi.RigidBody(m_t, inertia=(J_x, J_t, J_t))], **disc)


@pytest.mark.parametrize("J_t, J_x", [(0.0, 0.0), (0.1 * MU * L ** 3, 0.0), (0.1 * MU * L ** 3, 0.1 * MU * L ** 3)],
                         ids=["mass", "axial rod", "sphere"])
def test_fe_cantilever_with_tip_body_converges_at_fourth_order(J_t, J_x):
    # Hermite cubics: omega error ~ C h^4; n_e = 8 -> 16 divides it by 2^4 = 16 (measured 16.0 and
    # 16.0), and the Richardson value omega_16 + (omega_16 - omega_8)/15 is exact to O(h^6) ~ 1e-10.
    m_t = 0.5 * MU * L
    exact = _exact_first_frequency(m_t, J_t)
    w8, w16 = (link_integrals(_tip_link(m_t, J_t, J_x, elements=n)).first_frequency for n in (8, 16))
    e8, e16 = w8 / exact - 1, w16 / exact - 1
    assert 0 < e16 < e8 and 15.0 < e8 / e16 < 17.0
    assert e16 < 2e-8
    assert abs((w16 + (w16 - w8) / 15) / exact - 1) < 1e-9


def test_modal_cantilever_with_tip_mass_converges():
    # Clamped-free modes of the bare beam have zero shear at the tip, so a tip mass (a shear jump)
    # converges only algebraically: measured error ~ n^-3 (1.8e-5 at 8 modes, 2.3e-6 at 16).
    m_t = 0.5 * MU * L
    exact = _exact_first_frequency(m_t, 0.0)
    errors = [link_integrals(_tip_link(m_t, 0.0, modes=[gi.Mode("clamped-free", "y", k + 1) for k in range(n)]))
              .first_frequency / exact - 1 for n in (4, 8, 16)]
    assert all(e > 0 for e in errors) and errors[0] > 6 * errors[1] > 36 * errors[2]
    assert errors[2] < 3e-6


def test_kernel_mass_matrix_carries_the_tip_body():
    # The kernel's elastic block of M at q = 0 (clamped arm, theta fixed) equals the tables' M_dd,
    # and its stiffness (dV/ddelta, no gravity, linear in delta) K: the same frequency.
    lk = _tip_link(0.5 * MU * L, 0.1 * MU * L ** 3, 0.05 * MU * L ** 3, elements=4)
    model = gi.Model(gi.Chain([lk], base=gi.FixedBase()), gravity=(0.0, 0.0, 0.0))
    idx = model.delta_index[0]
    M = model.mass_matrix(np.zeros(model.n_dof))[np.ix_(idx, idx)]
    ld = model.link_data[0]
    np.testing.assert_allclose(M, ld.M_dd, rtol=0, atol=1e-13 * np.abs(ld.M_dd).max())
    K = np.array([model.potential_forces(np.eye(model.n_dof)[c])[idx] for c in idx]).T
    np.testing.assert_allclose(K, ld.K, rtol=0, atol=1e-12 * np.abs(ld.K).max())
