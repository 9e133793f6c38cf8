"""Applied generalised forces (inputs) and structural damping: closed forms and the power balance."""

import numpy as np
import pytest
import scipy.linalg as sl

import gibbsimpact as gi
from gibbsimpact.dynamics.forces import damping_matrix
from gibbsimpact.model.modes import natural_frequency

from conftest import random_state


def rigid_rod(l=1.0, mu=2.0, jz=0.0):
    return gi.Model(gi.Chain([gi.Link(l, mu, 1.0, rotary_inertia=(1e-4, 0.0, jz))]), gravity=(0.0, 0.0, 0.0))


def test_constant_axial_force_accelerates_a_rod_uniformly():
    # A force F along the rod's axis at O1: pure translation, X1 = F t^2 / (2 m).
    F, model = 3.0, rigid_rod()
    m = model.total_mass
    res = gi.simulate(model, model.state(), model.state(), (0.0, 1.0), inputs={"X1": F})
    assert res.status == "finished", res.message
    np.testing.assert_allclose(res.q[:, 0], F * res.t**2 / (2 * m), rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(res.q[:, 5], 0.0, atol=1e-12)
    # Work = F X1 = kinetic energy.
    np.testing.assert_allclose(res.work[:, 0], F * res.q[:, 0], rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(res.work[:, 1], 0.0)
    assert res.energy_error < 1e-10


def test_time_varying_torque_spins_a_rod_about_its_centre():
    # A pure torque tau(t) = a sin(w t) on theta_1 of a free rod: the mass centre stays,
    # theta_ddot = tau / I_c, I_c = m l^2 / 12 + l j_z.
    l, mu, jz, a, w = 1.0, 2.0, 0.01, 0.5, 3.0
    model = rigid_rod(l, mu, jz)
    Ic = mu * l**3 / 12 + l * jz
    res = gi.simulate(model, model.state(), model.state(), (0.0, 2.0),
                      inputs={"theta_1": lambda t, q, qd: a * np.sin(w * t)}, rtol=1e-11, atol=1e-13)
    theta = a / (Ic * w) * (res.t - np.sin(w * res.t) / w)
    np.testing.assert_allclose(res.q[:, 5], theta, rtol=1e-9, atol=1e-12)
    c = np.array([model.center_of_mass(q) for q in res.q])
    np.testing.assert_allclose(c, np.tile(c[0], (len(c), 1)), atol=1e-10)


def test_power_balance_of_a_driven_damped_flexible_chain(rng):
    # E(t) - E(0) - W(t) = 0 to integration accuracy: inputs on joints, a feedback
    # force on a modal coordinate, damping on both links, gravity on.
    cc = gi.Mode("clamped-clamped", "y")
    link = gi.Link(1.0, 1.0, 20.0, modes=[cc], damping=0.05)
    fe = gi.Link(0.8, 0.8, 12.0, elements=2, damping=0.02)
    model = gi.Model(gi.Chain([link, fe]), gravity=(0.0, -9.81, 0.0))
    q, qd = random_state(model, rng, delta=0.01, speed=0.3)
    inputs = {
        "theta_2": lambda t, q, qd: 0.3 * np.sin(5 * t) - 0.1 * qd[6],
        "delta_1_1": lambda t, q, qd: -2.0 * q[7],
        "X2": 9.81 * model.total_mass,  # holds the chain up against gravity on average
    }
    res = gi.simulate(model, q, qd, (0.0, 0.15), inputs=inputs, rtol=1e-11, atol=1e-13)
    assert res.status == "finished", res.message
    assert res.energy_error < 1e-9
    # Damping only dissipates; the inputs did real work.
    assert np.all(np.diff(res.work[:, 1]) <= 1e-15)
    assert res.work[-1, 1] < 0 and abs(res.work[-1, 0]) > 1e-3
    E = res.energy().total
    scale = np.max(np.abs(np.array(res.energy()[:3])).sum(axis=0))
    np.testing.assert_allclose(E - E[0], res.work.sum(axis=1), atol=1e-9 * scale)
    # Without the work term the balance is far from closed: the test can fail.
    assert np.max(np.abs(E - E[0])) > 1e3 * 1e-9 * scale


def test_damping_ratio_of_the_links_first_mode():
    # C = beta K with beta = 2 zeta / omega_1: the link's own (clamped) modal system
    # M_dd x'' + C x' + K x = 0 has damping ratio zeta in its first mode, and
    # zeta omega_k / omega_1 in mode k (stiffness-proportional damping).
    zeta = 0.03
    modes = [gi.Mode("clamped-free", "y", k) for k in (1, 2)]
    link = gi.Link(1.2, 0.9, 14.0, modes=modes, damping=zeta)
    model = gi.Model(gi.Chain([link]), gravity=(0, 0, 0))
    idx = model.delta_index[0]
    C = damping_matrix(model)[np.ix_(idx, idx)]
    ld = model.link_data[0]
    w1 = natural_frequency(modes[0], 1.2, 0.9, 14.0)
    np.testing.assert_allclose(C, 2 * zeta / w1 * ld.K, rtol=1e-10)
    m = len(idx)
    A = np.block([[np.zeros((m, m)), np.eye(m)],
                  [-np.linalg.solve(ld.M_dd, ld.K), -np.linalg.solve(ld.M_dd, C)]])
    lam = sl.eigvals(A)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    omega = np.abs(lam)
    ratios = -lam.real / omega
    np.testing.assert_allclose(omega[0], w1, rtol=1e-9)
    np.testing.assert_allclose(ratios, zeta * omega / w1, rtol=1e-9)


def test_bad_inputs_name_the_problem():
    model = rigid_rod()
    q = model.state()
    with pytest.raises(ValueError, match="unknown coordinate 'theta_9'"):
        gi.simulate(model, q, q, (0, 1), inputs={"theta_9": 1.0})
    with pytest.raises(ValueError, match="6 finite numbers"):
        gi.simulate(model, q, q, (0, 1), inputs=np.ones(3))
    with pytest.raises(ValueError, match=r"inputs\['X1'\] failed when called at the initial state"):
        gi.simulate(model, q, q, (0, 1), inputs={"X1": lambda t, q, qd: 1 / 0})
    with pytest.raises(ValueError, match="must be a finite number or a callable"):
        gi.simulate(model, q, q, (0, 1), inputs={"X1": "fast"})
    with pytest.raises(ValueError, match="one finite number"):
        gi.simulate(model, q, q, (0, 1), inputs={"X1": lambda t, q, qd: np.nan})
    with pytest.raises(ValueError, match="damping"):
        gi.Link(1.0, 1.0, 1.0, damping=0.1)  # rigid link: nothing to damp
    with pytest.raises(ValueError, match="damping"):
        gi.Link(1.0, 1.0, 1.0, modes=[gi.Mode("clamped-free")], damping=-0.1)
