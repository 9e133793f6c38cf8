"""Two-route cross-check: gibbsimpact against an independent sympy derivation.

The oracle (``tests/reference/sympy_chain.py``) shares no code with the package:
it builds the chain with ``sympy.physics.mechanics`` frames, computes its own
mode shapes and exact modal integrals with mpmath, forms Kane's equations
(continuum -> dynamically equivalent particles, see ``derive``) and lambdifies
M(q) and forcing(q, qdot).  The first group of tests checks the oracle itself
against closed forms and a second symbolic route (Lagrange); the second group
compares the package with it at random states:

    ||M_pkg - M_ref|| / ||M_ref|| <= 1e-9,   ||qdd_pkg - qdd_ref|| / ||qdd_ref|| <= 1e-9
"""
from __future__ import annotations

import numpy as np
import pytest

try:
    from reference.sympy_chain import (
        RefLink, RefMode, beta_l, derive, modal_integrals, reference_model,
    )
except ImportError:  # tests/ collected as a package
    from tests.reference.sympy_chain import (
        RefLink, RefMode, beta_l, derive, modal_integrals, reference_model,
    )

RTOL = 1e-9
N_STATES = 6
GRAVITY = (0.0, -9.81, 0.0)

# Each link: (length, mass_per_length, (EI_y, EI_z), [(bc, direction), ...], (j_x, j_y, j_z))
CHAINS = {
    # (a) the published planar case: two identical links, one clamped-clamped y-mode each
    "a_two_links_planar": [
        (1.0, 1.0, (20.0, 20.0), [("clamped-clamped", "y")], (0.0, 0.0, 0.0)),
        (1.0, 1.0, (20.0, 20.0), [("clamped-clamped", "y")], (0.0, 0.0, 0.0)),
    ],
    # (b) one link, y- and z-mode, EI_y != EI_z, distinct rotary inertia
    "b_one_link_y_and_z": [
        (0.8, 1.3, (15.0, 25.0), [("clamped-clamped", "y"), ("clamped-clamped", "z")],
         (2e-3, 1e-3, 1.5e-3)),
    ],
    # (c) three different links; clamped-free modes on links 1 and 3, so the
    # joint transform E_1 carries a tip deflection and a tip rotation Rz(v'(l))
    "c_three_links_mixed": [
        (1.0, 1.0, (20.0, 20.0), [("clamped-free", "y")], (1e-3, 2e-3, 3e-3)),
        (0.7, 1.5, (12.0, 18.0), [("clamped-clamped", "y")], (0.0, 0.0, 0.0)),
        (1.2, 0.8, (30.0, 25.0), [("clamped-free", "y")], (5e-4, 0.0, 0.0)),
    ],
}
EXPECTED_N = {"a_two_links_planar": 9, "b_one_link_y_and_z": 8, "c_three_links_mixed": 11}


def ref_links(spec):
    return tuple(
        RefLink(length=l, mu=mu, EI_y=EI[0], EI_z=EI[1],
                modes=tuple(RefMode(bc, d) for bc, d in modes), rotary_inertia=tuple(j))
        for l, mu, EI, modes, j in spec
    )


def random_states(n_links, n_dof, seed, n=N_STATES):
    """q, qdot with th_m1, th_0 clearly non-zero, |th_0| < 1.2, delta ~ 0.05."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = np.empty(n_dof)
        q[:3] = rng.normal(size=3)
        q[3] = rng.choice([-1, 1]) * rng.uniform(0.3, 1.5)  # th_m1
        q[4] = rng.choice([-1, 1]) * rng.uniform(0.2, 1.1)  # th_0
        q[5:5 + n_links] = rng.uniform(-np.pi, np.pi, n_links)
        q[5 + n_links:] = 0.05 * rng.normal(size=n_dof - 5 - n_links)
        qdot = rng.normal(size=n_dof)
        yield q, qdot


def rel(a, b):
    return np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(b)


@pytest.fixture(scope="module", params=sorted(CHAINS))
def chain(request):
    name = request.param
    return name, CHAINS[name], reference_model(ref_links(CHAINS[name]), GRAVITY)


# --------------------------------------------------------------------------
# The oracle itself
# --------------------------------------------------------------------------


def test_oracle_beta_roots_and_mode_normalisation():
    assert float(beta_l("clamped-clamped", 1)) == pytest.approx(4.730040744862704, abs=1e-14)
    assert float(beta_l("clamped-free", 1)) == pytest.approx(1.875104068711961, abs=1e-14)
    mu, EI_y, EI_z, l = 1.3, 15.0, 25.0, 0.8
    link = RefLink(l, mu, EI_y, EI_z, (RefMode("clamped-clamped", "y"), RefMode("clamped-free", "z")))
    mi = modal_integrals(link)
    cc, cf = mi.shapes
    # max |psi| = 1, positive, at l/2 (clamped-clamped) and at l (clamped-free)
    assert float(cc.x_max) == pytest.approx(l / 2, abs=1e-12)
    assert float(cc.psi(l / 2)) == pytest.approx(1.0, abs=1e-14)
    assert float(cf.x_max) == pytest.approx(l, abs=1e-12)
    assert float(cf.psi(l)) == pytest.approx(1.0, abs=1e-14)
    # unnormalised phi: int phi^2 = l  =>  int mu psi^2 = mu l / phi_max^2
    assert mi.S[0, 0] == pytest.approx(mu * l * float(cc.C) ** 2, rel=1e-13)
    assert mi.S[1, 1] == pytest.approx(mu * l * float(cf.C) ** 2, rel=1e-13)
    # Rayleigh quotient = eigenvalue: K/S = EI beta^4 / mu (EI_z for y, EI_y for z)
    for k, (EI, bl) in enumerate([(EI_z, 4.730040744862704), (EI_y, 1.875104068711961)]):
        assert mi.K[k, k] / mi.S[k, k] == pytest.approx(EI * bl**4 / (mu * l**4), rel=1e-12)
    assert mi.K[0, 1] == 0.0
    # clamped-clamped: psi(l) = psi'(l) = 0; clamped-free: psi(l) = 1
    assert mi.end_value[0] == 0.0 and mi.end_slope[0] == 0.0
    assert mi.end_value[1] == pytest.approx(1.0, abs=1e-14)


def test_oracle_rigid_rod_closed_form():
    """One link, no modes: thin rod of mass m, first moment m l/2, I = m l^2/3 at the end."""
    l, mu, j = 0.8, 1.3, (2e-3, 1e-3, 1.5e-3)
    ref = reference_model((RefLink(l, mu, 1.0, 1.0, (), j),), GRAVITY)
    m = mu * l
    M = ref.mass_matrix(np.zeros(6))
    M_exp = np.zeros((6, 6))
    M_exp[:3, :3] = m * np.eye(3)
    M_exp[3, 3] = l * j[0]  # about the rod axis only the rotary inertia
    M_exp[4, 4] = m * l**2 / 3 + l * j[1]
    M_exp[5, 5] = m * l**2 / 3 + l * j[2]
    M_exp[1, 5] = M_exp[5, 1] = m * l / 2  # th_1 (about z) moves points along +y
    M_exp[2, 4] = M_exp[4, 2] = -m * l / 2  # th_0 (about y) moves points along -z
    np.testing.assert_allclose(M, M_exp, atol=1e-14)
    # free fall, and centripetal force of a spin about z
    np.testing.assert_allclose(ref.forward_dynamics(np.zeros(6), np.zeros(6)),
                               [0, -9.81, 0, 0, 0, 0], atol=1e-13)
    qdot = np.array([0, 0, 0, 0, 0, 2.0])
    f = ref.forcing(np.zeros(6), qdot)
    np.testing.assert_allclose(f, [m * 4.0 * l / 2, -9.81 * m, 0, 0, 0, -9.81 * m * l / 2], atol=1e-13)


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _trans(p):
    T = np.eye(4)
    T[:3, 3] = p
    return T


def test_oracle_kinematics_match_4x4_products(chain):
    """Joint points O_1..O_(n+1) of the sympy frames = the 4x4 product of formulation.md sec. 2."""
    name, spec, ref = chain
    links = ref_links(spec)
    ints = [modal_integrals(lk) for lk in links]
    n = len(links)
    for q, _ in random_states(n, ref.n_dof, seed=11, n=3):
        T = _trans(q[:3]) @ _rx(q[3]) @ _ry(q[4]) @ _rz(q[5])
        pts, k0 = [], 5 + n
        for i, (lk, mi) in enumerate(zip(links, ints)):
            d = q[k0:k0 + len(lk.modes)]
            k0 += len(lk.modes)
            y = [k for k, m in enumerate(lk.modes) if m.direction == "y"]
            z = [k for k, m in enumerate(lk.modes) if m.direction == "z"]
            v, w = mi.end_value[y] @ d[y], mi.end_value[z] @ d[z]
            vs, ws = mi.end_slope[y] @ d[y], mi.end_slope[z] @ d[z]
            pts.append(T[:3, 3])
            E = _trans([lk.length, v, w]) @ _rz(vs) @ _ry(-ws)  # one of vs, ws is 0
            T = T @ E
            if i + 1 < n:
                T = T @ _rz(q[6 + i])
        pts.append(T[:3, 3])
        np.testing.assert_allclose(ref.joint_points(q), np.array(pts), atol=1e-13)


def test_oracle_mass_matrix_is_the_modal_quadratic_form(chain):
    """1/2 qdot^T M qdot (Kane particles) = T written directly with the modal integrals."""
    name, spec, ref = chain
    assert ref.n_dof == EXPECTED_N[name]
    for q, qdot in random_states(len(spec), ref.n_dof, seed=5):
        M = ref.mass_matrix(q)
        np.testing.assert_allclose(M, M.T, atol=1e-13)
        assert np.linalg.eigvalsh(M).min() > 0
        assert 0.5 * qdot @ M @ qdot == pytest.approx(ref.kinetic_energy(q, qdot), rel=1e-12)


def test_oracle_kane_equals_lagrange():
    """Second symbolic route: LagrangesMethod on L = T - V (chain b, 3D, rotary inertia)."""
    links = ref_links(CHAINS["b_one_link_y_and_z"])
    kane = reference_model(links, GRAVITY)
    lagrange = reference_model(links, GRAVITY, method="lagrange")
    for q, qdot in random_states(1, kane.n_dof, seed=7, n=4):
        assert rel(kane.mass_matrix(q), lagrange.mass_matrix(q)) < 1e-12
        assert rel(kane.forcing(q, qdot), lagrange.forcing(q, qdot)) < 1e-12


def test_oracle_conserves_energy():
    """E = T + V constant along the oracle's own ODE (chain c, 0.2 s)."""
    from scipy.integrate import solve_ivp

    ref = reference_model(ref_links(CHAINS["c_three_links_mixed"]), GRAVITY)
    n = ref.n_dof
    q0, qdot0 = next(random_states(3, n, seed=3, n=1))

    def rhs(t, y):
        return np.concatenate([y[n:], ref.forward_dynamics(y[:n], y[n:])])

    sol = solve_ivp(rhs, (0.0, 0.2), np.concatenate([q0, qdot0]), method="DOP853",
                    rtol=1e-11, atol=1e-11)
    assert sol.success
    E = np.array([ref.energy(y[:n], y[n:]) for y in sol.y.T])
    T0 = ref.kinetic_energy(q0, qdot0)
    assert np.abs(E - E[0]).max() < 1e-8 * max(abs(E[0]), T0)


# --------------------------------------------------------------------------
# gibbsimpact against the oracle
# --------------------------------------------------------------------------


def _import_gibbsimpact():
    try:
        import gibbsimpact
    except ModuleNotFoundError as exc:  # only a missing package is a skip
        if exc.name == "gibbsimpact":
            pytest.skip("gibbsimpact is not importable")
        raise
    return gibbsimpact


def package_model(spec):
    gi = _import_gibbsimpact()
    links = [
        gi.Link(length=l, mass_per_length=mu, EI=EI,
                modes=[gi.Mode(bc, direction=d) for bc, d in modes], rotary_inertia=j)
        for l, mu, EI, modes, j in spec
    ]
    return gi.Model(gi.Chain(links), gravity=GRAVITY)


@pytest.fixture(scope="module")
def models(chain):
    name, spec, ref = chain
    return name, package_model(spec), ref


def test_package_coordinates(models):
    name, pkg, ref = models
    assert pkg.n_dof == ref.n_dof == EXPECTED_N[name]
    assert len(pkg.coordinate_names) == pkg.n_dof


def test_package_mass_matrix_matches_oracle(models):
    name, pkg, ref = models
    n_links = len(CHAINS[name])
    for q, _ in random_states(n_links, ref.n_dof, seed=2024):
        M_ref = ref.mass_matrix(q)
        M_pkg = np.asarray(pkg.mass_matrix(q))
        assert M_pkg.shape == M_ref.shape
        err = rel(M_pkg, M_ref)
        assert err <= RTOL, (
            f"{name}: ||M_pkg - M_ref||/||M_ref|| = {err:.3e} at q={q.tolist()}; "
            f"largest |dM| at index {np.unravel_index(np.abs(M_pkg - M_ref).argmax(), M_ref.shape)}"
        )


def test_package_forward_dynamics_matches_oracle(models):
    name, pkg, ref = models
    n_links = len(CHAINS[name])
    for q, qdot in random_states(n_links, ref.n_dof, seed=4048):
        a_ref = ref.forward_dynamics(q, qdot)
        a_pkg = np.asarray(pkg.forward_dynamics(q, qdot))
        err = rel(a_pkg, a_ref)
        assert err <= RTOL, (
            f"{name}: ||qdd_pkg - qdd_ref||/||qdd_ref|| = {err:.3e} at q={q.tolist()}, "
            f"qdot={qdot.tolist()}; largest |dqdd| at coordinate {np.abs(a_pkg - a_ref).argmax()}"
        )


def test_package_forward_dynamics_without_velocity_matches_oracle(models):
    """qdot = 0 isolates gravity + strain from the velocity terms."""
    name, pkg, ref = models
    n_links = len(CHAINS[name])
    for q, _ in random_states(n_links, ref.n_dof, seed=99, n=3):
        z = np.zeros_like(q)
        err = rel(np.asarray(pkg.forward_dynamics(q, z)), ref.forward_dynamics(q, z))
        assert err <= RTOL, f"{name}: qdot=0, relative error {err:.3e}"
