"""Flight phase: invariants, closed forms and a second route to h and dV/dq."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gibbsimpact as gi
from gibbsimpact.dynamics.gibbs_appell import momentum
from gibbsimpact.dynamics.kinematics import rodrigues

from conftest import random_state, two_link_circle_model


def spatial_chain(stiffening=False):
    """Three links, y and z clamped-free modes (so the end rotations are genuinely 3D); linear beams,
    or foreshortening ones (stiffening, formulation §15)."""
    a = gi.Link(1.0, 1.2, (15.0, 25.0), modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")],
                rotary_inertia=(2e-4, 1e-4, 1e-4), geometric_stiffening=stiffening)
    b = gi.Link(0.7, 0.8, 10.0, modes=[gi.Mode("clamped-clamped", "y"), gi.Mode("clamped-free", "z", 2)],
                geometric_stiffening=stiffening)
    c = gi.Link(0.5, 0.5, 8.0, modes=[gi.Mode("clamped-free", "y")], rotary_inertia=(1e-4, 0.0, 3e-4),
                geometric_stiffening=stiffening)
    return gi.Model(gi.Chain([a, b, c]))


MODELS = {"two_link_planar": two_link_circle_model, "spatial_three_link": spatial_chain,
          "spatial_three_link_stiffened": lambda: spatial_chain(stiffening=True)}


@pytest.mark.parametrize("name", MODELS)
def test_mass_matrix_symmetric_positive_definite(name, rng):
    model = MODELS[name]()
    for _ in range(10):
        q, _ = random_state(model, rng)
        M = model.mass_matrix(q)
        assert np.max(np.abs(M - M.T)) <= 1e-14 * np.max(np.abs(M))
        assert np.linalg.eigvalsh(M).min() > 0


def _lagrange_bias(model, q, qd, h=1e-6):
    """Second route: h = Mdot qdot - 1/2 d(qdot^T M qdot)/dq by central differences of M."""
    N = q.size
    dM = np.zeros((N, N, N))
    for k in range(N):
        e = np.zeros(N)
        e[k] = h
        dM[k] = (model.mass_matrix(q + e) - model.mass_matrix(q - e)) / (2 * h)
    Mdot = np.einsum("kij,k->ij", dM, qd)
    return Mdot @ qd - 0.5 * np.einsum("kij,i,j->k", dM, qd, qd)


@pytest.mark.parametrize("name", MODELS)
def test_bias_forces_match_lagrange_route(name, rng):
    model = MODELS[name]()
    for _ in range(3):
        q, qd = random_state(model, rng)
        h = model.bias_forces(q, qd)
        h_ref = _lagrange_bias(model, q, qd)
        assert np.linalg.norm(h - h_ref) <= 1e-7 * np.linalg.norm(h_ref)


@pytest.mark.parametrize("name", MODELS)
def test_potential_forces_are_gradient_of_energy(name, rng):
    model = MODELS[name]()
    q, qd = random_state(model, rng)
    dV = model.potential_forces(q)
    V = lambda q: model.energy(q, qd).gravity + model.energy(q, qd).strain
    step = 1e-6
    fd = np.array([(V(q + step * e) - V(q - step * e)) / (2 * step) for e in np.eye(q.size)])
    np.testing.assert_allclose(dV, fd, rtol=1e-7, atol=1e-8 * np.abs(fd).max())


def test_rodrigues_derivatives():
    rng = np.random.default_rng(3)
    for scale in (1e-9, 1e-3, 0.5, 2.0):  # series branch and closed-form branch
        phi = rng.normal(size=3) * scale
        R, dR, d2R = rodrigues(phi)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-15)
        h = 1e-6  # truncation error ~h^2, round-off ~1e-16/h
        for i in range(3):
            e = np.zeros(3)
            e[i] = h
            Rp, dRp, _ = rodrigues(phi + e)
            Rm, dRm, _ = rodrigues(phi - e)
            np.testing.assert_allclose(dR[i], (Rp - Rm) / (2 * h), atol=1e-8)
            np.testing.assert_allclose(d2R[i], (dRp - dRm) / (2 * h), atol=1e-7)
    # Planar case: Rot((0, 0, a)) is Rz(a).
    a = 0.37
    np.testing.assert_allclose(rodrigues([0, 0, a])[0], [[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]], atol=1e-16)


def _integrate(model, q, qd, t_end, rtol, atol=1e-12):
    N = model.n_dof
    f = lambda t, y: np.concatenate((y[N:], model.forward_dynamics(y[:N], y[N:])))
    sol = solve_ivp(f, (0, t_end), np.concatenate((q, qd)), method="DOP853", rtol=rtol, atol=atol, dense_output=True)
    assert sol.success
    return sol


def test_energy_conserved_two_link_with_gravity(rng):
    # Chain (a), initial velocity on every coordinate, 2 s of free flight, rtol 1e-11.
    model = two_link_circle_model()
    q = model.state(X1=0.1, X2=0.2, X3=-0.1, theta_m1=0.2, theta_0=-0.3, theta_1=0.5, theta_2=0.8,
                    delta_1_1=0.01, delta_2_1=-0.02)
    qd = np.array([0.3, 0.5, -0.2, 0.4, -0.3, 1.0, -1.5, 0.2, -0.1])
    sol = _integrate(model, q, qd, 2.0, rtol=1e-11)
    E = np.array([model.energy(y[:9], y[9:]).total for y in sol.y.T])
    parts = model.energy(q, qd)
    assert parts.strain > 0 and parts.kinetic > 0
    drift = np.max(np.abs(E - E[0])) / abs(E[0])
    assert drift <= 1e-8


def test_momentum_conserved_without_gravity():
    model = gi.Model(spatial_chain().chain, gravity=(0.0, 0.0, 0.0))
    rng = np.random.default_rng(7)
    q, qd = random_state(model, rng, delta=0.03)
    sol = _integrate(model, q, qd, 0.5, rtol=1e-11, atol=1e-13)
    L0 = model.linear_momentum(q, qd)
    H0 = model.angular_momentum(q, qd)
    for y in sol.y.T[:: max(1, sol.y.shape[1] // 20)]:
        Lq, Hq = model.linear_momentum(y[: q.size], y[q.size:]), model.angular_momentum(y[: q.size], y[q.size:])
        assert np.linalg.norm(Lq - L0) <= 1e-9 * np.linalg.norm(L0)
        assert np.linalg.norm(Hq - H0) <= 1e-9 * np.linalg.norm(H0)


def test_momentum_against_quadrature(rng):
    # L and H from the modal moments vs direct sampling of p(x), pdot(x) along each link.
    from gibbsimpact.dynamics.kinematics import frames
    from gibbsimpact.model.shapes import gauss_legendre
    from gibbsimpact.model.modes import shape

    model = spatial_chain()
    q, qd = random_state(model, rng)
    fr = frames(model, q, qd)
    L = np.zeros(3)
    H = np.zeros(3)
    for i, (link, ld) in enumerate(zip(model.chain.links, model.link_data)):
        x, w = gauss_legendre(link.length, 32, 16)
        idx = model.delta_index[i]
        r = np.zeros((x.size, 4))
        rd = np.zeros((x.size, 4))
        r[:, 0], r[:, 3] = x, 1.0
        for k, md in enumerate(link.modes):
            ax = {"y": 1, "z": 2}[md.direction]
            psi = shape(md, link.length, x)
            r[:, ax] += psi * q[idx[k]]
            rd[:, ax] += psi * qd[idx[k]]
        p = r @ fr.T[i].T
        pd = r @ fr.Td[i].T + rd @ fr.T[i].T
        mu = link.mass_per_length
        L += (w * mu) @ pd[:, :3]
        H += (w * mu) @ np.cross(p[:, :3], pd[:, :3])
        R = fr.T[i][:3, :3]
        from gibbsimpact.dynamics.gibbs_appell import _vee_skew
        H += R @ ld.J_body @ _vee_skew(R.T @ fr.Td[i][:3, :3])
    L2, H2, _ = momentum(model, q, qd)
    np.testing.assert_allclose(L2, L, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(H2, H, rtol=1e-12, atol=1e-13)


def test_rigid_single_link_is_thin_rod():
    l, mu, jx = 1.6, 2.5, 1e-3
    model = gi.Model(gi.Chain([gi.Link(l, mu, 1.0, rotary_inertia=(jx, 0.0, 0.0))]))
    m = mu * l
    M = model.mass_matrix(np.zeros(6))
    # At theta = 0 the rod lies along X1 from O1: coordinates X1 X2 X3, rotations about X1, X2, X3.
    expected = np.array([
        [m, 0, 0, 0, 0, 0],
        [0, m, 0, 0, 0, m * l / 2],
        [0, 0, m, 0, -m * l / 2, 0],
        [0, 0, 0, jx * l, 0, 0],
        [0, 0, -m * l / 2, 0, m * l**2 / 3, 0],
        [0, m * l / 2, 0, 0, 0, m * l**2 / 3],
    ])
    np.testing.assert_allclose(M, expected, rtol=1e-14, atol=1e-14)


def test_rigid_two_link_free_fall_keeps_shape():
    g = 9.81
    link = gi.Link(1.0, 1.0, 1.0)
    model = gi.Model(gi.Chain([link, gi.Link(0.6, 2.0, 1.0)]), gravity=(0.0, -g, 0.0))
    q = model.state(X1=0.1, X2=0.3, theta_1=0.4, theta_2=-1.1)
    v0 = np.array([0.7, 1.3, 0.0])
    qd = model.state(X1=v0[0], X2=v0[1])
    c0 = model.center_of_mass(q)
    sol = _integrate(model, q, qd, 1.0, rtol=1e-11)
    for t in (0.25, 0.5, 1.0):
        y = sol.sol(t)
        np.testing.assert_allclose(y[3:7], q[3:7], atol=1e-10)  # angles frozen
        np.testing.assert_allclose(y[10:14], 0.0, atol=1e-10)
        c = model.center_of_mass(y[:7])
        np.testing.assert_allclose(c, c0 + v0 * t + 0.5 * np.array([0, -g, 0]) * t * t, atol=1e-10)


def test_singular_mass_matrix_is_named():
    single = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 1.0)]))
    with pytest.raises(gi.SingularMassMatrixError, match="rotary_inertia"):
        single.forward_dynamics(np.zeros(6), np.zeros(6))
    chain = two_link_circle_model()
    q = chain.state(theta_0=np.pi / 2, theta_2=0.5)
    with pytest.raises(gi.SingularMassMatrixError, match="gimbal lock"):
        chain.forward_dynamics(q, np.zeros(9))


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(length=-1.0), "length"),
        (dict(length=0.0), "length"),
        (dict(mass_per_length=0.0), "mass_per_length"),
        (dict(EI=-2.0), "EI"),
        (dict(EI=(1.0, 2.0, 3.0)), "EI"),
        (dict(modes=["clamped-clamped"]), "modes"),
        (dict(rotary_inertia=(1.0, -1.0, 0.0)), "rotary_inertia"),
        (dict(rotary_inertia=(1.0, 0.0)), "rotary_inertia"),
    ],
)
def test_link_validation(kwargs, match):
    base = dict(length=1.0, mass_per_length=1.0, EI=1.0)
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        gi.Link(**base)


def test_state_shape_validation():
    model = two_link_circle_model()
    with pytest.raises(ValueError, match=r"q has shape \(8,\).*\(9,\)"):
        model.mass_matrix(np.zeros(8))
    with pytest.raises(ValueError, match="qdot has non-finite entries: theta_1"):
        q = np.zeros(9)
        qd = np.zeros(9)
        qd[5] = np.nan
        model.forward_dynamics(q, qd)
    with pytest.raises(ValueError, match="gravity"):
        gi.Model(model.chain, gravity=(0.0, -9.81))
    with pytest.raises(ValueError, match="unknown coordinate"):
        model.state(theta_7=1.0)


def test_non_uniform_link_matches_uniform_limit_and_moments():
    # mu(x) = 1 + x (l = 1): mass 1.5 kg, first moment int mu x = 1/2 + 1/3.
    link = gi.Link(1.0, lambda x: 1.0 + x, lambda x: 20.0 + 0 * x, modes=[gi.Mode("clamped-clamped", "y")])
    ld = gi.Model(gi.Chain([link])).link_data[0]
    assert ld.mass == pytest.approx(1.5, rel=1e-14)
    assert ld.m_r0[0] == pytest.approx(0.5 + 1.0 / 3.0, rel=1e-14)
    assert ld.P0[0, 0] == pytest.approx(1.0 / 3.0 + 0.25, rel=1e-14)
    with pytest.raises(ValueError, match="mass_per_length"):
        gi.Model(gi.Chain([gi.Link(1.0, lambda x: x - 0.5, 1.0)]))
