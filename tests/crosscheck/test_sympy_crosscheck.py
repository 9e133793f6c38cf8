"""Two-route cross-check: gibbsimpact against an independent sympy derivation.

The oracle (``tests/reference/sympy_chain.py``) shares no code with the package:
it builds the chain with ``sympy.physics.mechanics`` frames, computes its own
mode shapes and exact modal integrals with mpmath, forms Kane's equations
(continuum -> dynamically equivalent particles, see ``derive``) and lambdifies
M(q) and forcing(q, qdot).  The first group of tests checks the oracle itself
against closed forms and a second symbolic route (Lagrange); the second group
compares the package with it at random states:

    ||M_pkg - M_ref|| / ||M_ref|| <= 1e-9,   ||qdd_pkg - qdd_ref|| / ||qdd_ref|| <= 1e-9

Chains d-f have Hermite finite-element links (docs/theory.md §4.4: behind a
revolute joint the global Hermite functions are assumed modes); the oracle
integrates its own Hermite basis exactly in rational arithmetic.
Measured relative-error maxima (M and qdd over 20 states, qdd at qdot = 0 over 3):
d 1.8e-16, 2.3e-12, 1.1e-12;  e 2.7e-16, 1.2e-13, 3.5e-14;  f 2.3e-15, 1.7e-12, 2.1e-13.
Swapping (EI_y, EI_z) in the package's FE links gives qdd errors 0.2-0.7, mu (1 + 1e-8)
gives 1e-8, j_x * 1.001 gives >= 1.5e-7 in M.
"""
from __future__ import annotations

from collections import namedtuple
from fractions import Fraction

import numpy as np
import pytest

try:
    from reference.sympy_chain import (
        RefLink, RefMode, beta_l, fe_integrals_exact, modal_integrals, reference_model,
    )
except ImportError:  # tests/ collected as a package
    from tests.reference.sympy_chain import (
        RefLink, RefMode, beta_l, fe_integrals_exact, modal_integrals, reference_model,
    )

RTOL = 1e-9
N_STATES = 6
N_STATES_FE = 20  # states per finite-element chain in the package comparisons
GRAVITY = (0.0, -9.81, 0.0)

# Hermite finite elements in place of the mode list: n_e elements per direction set
FE = namedtuple("FE", "elements directions")

# Each link: (length, mass_per_length, (EI_y, EI_z), [(bc, direction), ...] or FE(n_e, dirs),
#             (j_x, j_y, j_z))
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
    # (d) two FE links: 2 in-plane elements on link 1 (its tip node carries E_1 =
    # Trans(l, w_2) Rz(t_2)), 1 element and rotary inertia on link 2; EI_y != EI_z
    "d_fe_two_links": [
        (1.0, 1.2, (18.0, 22.0), FE(2, ("y",)), (0.0, 0.0, 0.0)),
        (0.7, 0.9, (14.0, 11.0), FE(1, ("y",)), (1e-3, 2e-3, 3e-3)),
    ],
    # (e) one spatial FE link, 2 elements in y and z (8 coordinates), j_x > 0
    "e_fe_one_link_y_and_z": [
        (0.8, 1.3, (15.0, 25.0), FE(2, ("y", "z")), (2e-3, 1e-3, 1.5e-3)),
    ],
    # (f) an assumed-mode link (clamped-free, = link 1 of chain c) followed by an FE link
    "f_mode_then_fe": [
        (1.0, 1.0, (20.0, 20.0), [("clamped-free", "y")], (1e-3, 2e-3, 3e-3)),
        (0.9, 1.1, (16.0, 13.0), FE(1, ("y",)), (5e-4, 1e-3, 1e-3)),
    ],
}
EXPECTED_N = {"a_two_links_planar": 9, "b_one_link_y_and_z": 8, "c_three_links_mixed": 11,
              "d_fe_two_links": 13, "e_fe_one_link_y_and_z": 14, "f_mode_then_fe": 10}


def is_fe_chain(spec):
    return any(isinstance(modes, FE) for _, _, _, modes, _ in spec)


def n_states(name):
    return N_STATES_FE if is_fe_chain(CHAINS[name]) else N_STATES


def ref_links(spec):
    return tuple(
        RefLink(length=l, mu=mu, EI_y=EI[0], EI_z=EI[1], rotary_inertia=tuple(j),
                elements=modes.elements, element_directions=tuple(modes.directions))
        if isinstance(modes, FE) else
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


def _fraction(r):
    return Fraction(int(r.p), int(r.q))


def _textbook_fe(l, mu, EI, n_e):
    """docs/theory.md §4.2, §4.3 by hand, in exact rational arithmetic: the element
    matrices eq. (13)/(27) and load vectors, assembled, node 0's rows/columns deleted."""
    h = Fraction(l) / n_e
    mu, EI = Fraction(mu), Fraction(EI)
    Me = [[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
          [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]]
    Ke = [[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
          [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]]
    se = [Fraction(1, 2), h / 12, Fraction(1, 2), -h / 12]  # int_0^1 (H1, h H2, H3, h H4) d eta
    te = [Fraction(3, 20), h / 30, Fraction(7, 20), -h / 20]  # int_0^1 eta (...) d eta
    n = 2 * n_e + 2
    M = [[Fraction(0)] * n for _ in range(n)]
    K = [[Fraction(0)] * n for _ in range(n)]
    s = [Fraction(0)] * n
    t = [Fraction(0)] * n
    for e in range(n_e):
        x0 = e * h
        for a in range(4):
            s[2 * e + a] += mu * h * se[a]
            t[2 * e + a] += mu * h * (x0 * se[a] + h * te[a])  # x = x0 + h eta
            for b in range(4):
                M[2 * e + a][2 * e + b] += mu * h / 420 * Me[a][b]
                K[2 * e + a][2 * e + b] += EI / h**3 * Ke[a][b]
    return ([r[2:] for r in M[2:]], [r[2:] for r in K[2:]], s[2:], t[2:])


@pytest.mark.parametrize("n_e", [1, 2, 3])
def test_oracle_fe_integrals_equal_textbook_element_matrices(n_e):
    """The oracle's exact Hermite integrals = assembled eq. (13), (27) (exact, rational)."""
    l, mu, EI = 0.8, 1.3, 25.0
    ex = fe_integrals_exact(l, mu, EI, n_e)
    M, K, s, t = _textbook_fe(l, mu, EI, n_e)
    m = 2 * n_e
    assert ex["S"].shape == ex["K"].shape == (m, m)
    assert [[_fraction(ex["S"][a, b]) for b in range(m)] for a in range(m)] == M
    assert [[_fraction(ex["K"][a, b]) for b in range(m)] for a in range(m)] == K
    assert [_fraction(v) for v in ex["s"]] == s
    assert [_fraction(v) for v in ex["t"]] == t
    # end transform data: v(l) = w_ne, v'(l) = t_ne
    assert list(ex["end_value"]) == [0] * (m - 2) + [1, 0]
    assert list(ex["end_slope"]) == [0] * (m - 1) + [1]
    # nodal interpolation (psi_(2j-1)(x_i) = psi_(2j)'(x_i) = delta_ij, the other two 0)
    # and C1 continuity across the interior nodes
    B = ex["basis"]
    for k in range(m):
        j = k // 2 + 1
        for i in range(n_e + 1):
            x = B.nodes[i]
            assert B.value(k, x) == (1 if (k % 2 == 0 and i == j) else 0)
            assert B.value(k, x, 1) == (1 if (k % 2 == 1 and i == j) else 0)
            if 0 < i < n_e:
                for d in (0, 1):
                    left = B.pieces[k][i - 1].diff("x", d).subs("x", x)
                    right = B.pieces[k][i].diff("x", d).subs("x", x)
                    assert left == right


def test_oracle_fe_link_integrals_and_frequencies():
    """y+z FE link: shared Hermite basis, EI_z for y, EI_y for z, no stiffness coupling;
    clamped-free frequencies from (K, S) approach beta_k l from above (docs/theory.md §4.4)."""
    from scipy.linalg import eigh

    l, mu, EI_y, EI_z, n_e = 0.8, 1.3, 15.0, 25.0, 4
    mi = modal_integrals(RefLink(l, mu, EI_y, EI_z, elements=n_e, element_directions=("y", "z")))
    m = 2 * n_e
    assert mi.S.shape == mi.K.shape == (2 * m, 2 * m)
    assert len(set(mi.shape_ids)) == m and mi.shape_ids[:m] == mi.shape_ids[m:]
    for blk in (mi.S[:m, :m], mi.S[:m, m:], mi.S[m:, :m], mi.S[m:, m:]):
        np.testing.assert_array_equal(blk, mi.S[:m, :m])
    assert not mi.K[:m, m:].any() and not mi.K[m:, :m].any()
    np.testing.assert_allclose(mi.K[m:, m:], mi.K[:m, :m] * EI_y / EI_z, rtol=1e-15)
    np.testing.assert_array_equal(mi.s[:m], mi.s[m:])
    # all w_j = 1, t_j = 0: v = H3 on element 1 (w_0 = 0), 1 beyond: int mu v = mu (l - h/2)
    assert mi.s[0:m:2].sum() == pytest.approx(mu * (l - l / n_e / 2), rel=1e-14)
    for EI, blk in ((EI_z, slice(0, m)), (EI_y, slice(m, 2 * m))):
        omega = np.sqrt(eigh(mi.K[blk, blk], mi.S[blk, blk], eigvals_only=True)[:2])
        exact = np.array([1.8751040687, 4.6940911330]) ** 2 * np.sqrt(EI / (mu * l**4))
        err = omega / exact - 1
        assert np.all(err > 0) and err[0] < 5e-5 and err[1] < 2e-3, err


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
    """Joint points O_1..O_(n+1) of the sympy frames = the 4x4 product of docs/theory.md §2."""
    name, spec, ref = chain
    links = ref_links(spec)
    ints = [modal_integrals(lk) for lk in links]
    n = len(links)
    for q, _ in random_states(n, ref.n_dof, seed=11, n=3):
        T = _trans(q[:3]) @ _rx(q[3]) @ _ry(q[4]) @ _rz(q[5])
        pts, k0 = [], 5 + n
        for i, (lk, mi) in enumerate(zip(links, ints)):
            d = q[k0:k0 + lk.n_coords]
            k0 += lk.n_coords
            y = [k for k, dk in enumerate(lk.directions) if dk == "y"]
            z = [k for k, dk in enumerate(lk.directions) if dk == "z"]
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
        gi.Link(length=l, mass_per_length=mu, EI=EI, rotary_inertia=j,
                elements=modes.elements, element_directions=tuple(modes.directions), geometric_stiffening=False)
        if isinstance(modes, FE) else
        gi.Link(length=l, mass_per_length=mu, EI=EI,
                modes=[gi.Mode(bc, direction=d) for bc, d in modes], rotary_inertia=j, geometric_stiffening=False)
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
    for q, _ in random_states(n_links, ref.n_dof, seed=2024, n=n_states(name)):
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
    for q, qdot in random_states(n_links, ref.n_dof, seed=4048, n=n_states(name)):
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
