"""The frictional impulse solver (gibbsimpact.friction) against independent sources.

* Closed forms of a rigid rod hitting a floor with one end (derived below by
  hand from the law, 2 x 2 algebra; no LCP), with M, Wn, Wt built in numpy and
  once through the package's model.
* Invariants on random impacts: the kinetic energy never rises; the law's
  complementarity conditions and the energy identity (4) of the module
  docstring, recomputed from the returned velocities and impulses only.
* mu = 0 reproduces the frictionless solver impact.solve_impulses.
* Lemke's method against brute-force enumeration of complementary bases.
* Bad input is refused with a ValueError naming the argument.
"""

import itertools

import numpy as np
import pytest
from scipy.linalg import cho_factor

import gibbsimpact as gi
from gibbsimpact.contact import friction
from gibbsimpact.dynamics.gibbs_appell import mass_matrix
from gibbsimpact.contact.friction import lemke, solve_frictional_impulses
from gibbsimpact.contact.impact import solve_impulses
from gibbsimpact.dynamics.kinematics import joint_positions_and_jacobians

# ---------------------------------------------------------------------------
# 1. Rigid rod, closed forms
#
# Planar rod, mass m, length l, inertia about its centre I = m l^2 / 12,
# coordinates (x, y, theta) of the centre, so M = diag(m, m, I). One end at
# r = (r_x, r_y) from the centre touches the floor y = 0: n = (0, 1), t1 =
# (1, 0), t2 = (0, 0, 1) (out of the plane: no coordinate moves the point
# along it, so its column of Wt is zero). The end's velocity is
# (vx - omega r_y, vy + omega r_x), hence
#
#     Wn = (0, 1, r_x),   Wt1 = (1, 0, -r_y),   Wt2 = 0,
#     G = [Wn Wt1]^T M^-1 [Wn Wt1]:
#     G_nn = 1/m + r_x^2/I,  G_tt = 1/m + r_y^2/I,  G_nt = -r_x r_y / I,
#     v+ = v- + G_nn P_n + G_nt P_t,  s+ = s- + G_nt P_n + G_tt P_t
#
# for the normal (v) and tangential (s) velocities of the end and the normal
# and tangential impulses P_n, P_t. The law with U~ = (u+ + e u-)/(1 + e):
# an approaching end (v- < 0) takes P_n > 0, so U~_n = 0, i.e. v+ = -e v-.
#
# Sticking, U~_t = 0 (so s+ = -e s-, NOT s+ = 0 unless e = 0):
#     G (P_n, P_t) = -(1 + e) (v-, s-)  ->  (P_n, P_t) = -(1 + e) G^-1 (v-, s-),
# admissible while |P_t| <= mu P_n, i.e. mu >= mu_c = |P_t| / P_n of that solution.
#
# Sliding (mu < mu_c): P_t = -sigma mu P_n with sigma = sign(U~_t) the direction
# of the average slip. U~_n = 0 gives
#     P_n = -(1 + e) v- / (G_nn - sigma mu G_nt),
#     s+  = s- + (G_nt - sigma mu G_tt) P_n,
# and sigma is the sign for which the stick solution's P_t would exceed the
# cone: sigma = -sign(P_t of the stick solution) (at mu = mu_c the two regimes
# coincide with U~_t = 0). The closed form asserts its own consistency
# (sigma U~_t > 0) before it is used.
# ---------------------------------------------------------------------------


def rod_closed_form(m, l, r, vcom, omega, e, mu):
    """(P_n, P_t, v+, s+, vcom+ (2,), omega+) of the rod end at r (2,) from the centre."""
    I = m * l**2 / 12
    rx, ry = r
    Gnn, Gtt, Gnt = 1 / m + rx**2 / I, 1 / m + ry**2 / I, -rx * ry / I
    v = vcom[1] + omega * rx
    s = vcom[0] - omega * ry
    assert v < 0
    G = np.array([[Gnn, Gnt], [Gnt, Gtt]])
    Pn, Pt = -(1 + e) * np.linalg.solve(G, [v, s])
    mu_c = abs(Pt) / Pn
    if mu >= mu_c:
        v_after, s_after = -e * v, -e * s
    else:
        sigma = -np.sign(Pt)
        Pn = -(1 + e) * v / (Gnn - sigma * mu * Gnt)
        Pt = -sigma * mu * Pn
        v_after = v + Gnn * Pn + Gnt * Pt
        s_after = s + Gnt * Pn + Gtt * Pt
        assert Pn > 0 and sigma * (s_after + e * s) / (1 + e) > 0  # consistent sliding
    vcom_after = np.array([vcom[0] + Pt / m, vcom[1] + Pn / m])
    omega_after = omega + (rx * Pn - ry * Pt) / I
    return Pn, Pt, v_after, s_after, vcom_after, omega_after, mu_c


def rod_matrices(m, l, r):
    """M (3, 3), Wn (3, 1), Wt (3, 1, 2) of the planar rod in centre coordinates (x, y, theta)."""
    M = np.diag([m, m, m * l**2 / 12])
    Wn = np.array([[0.0], [1.0], [r[0]]])
    Wt = np.zeros((3, 1, 2))
    Wt[:, 0, 0] = [1.0, 0.0, -r[1]]
    return M, Wn, Wt


ROD_CASES = [
    # m [kg], l [m], angle of the rod [rad], (vx, vy) [m/s], omega [rad/s], e
    (2.0, 1.5, 0.6, (1.0, -2.0), 0.5, 0.5),
    (1.0, 1.0, 1.1, (-0.7, -1.0), -2.0, 0.0),
    (3.0, 0.8, 0.3, (2.0, -0.5), 3.0, 1.0),
    (0.5, 2.0, 0.9, (0.1, -1.5), -0.4, 0.8),
]


@pytest.mark.parametrize("case", ROD_CASES)
@pytest.mark.parametrize("mu_factor", [0.0, 0.3, 0.9, 0.999, 1.0, 1.001, 1.5, 4.0])
def test_rod_closed_form(case, mu_factor):
    m, l, angle, vcom, omega, e = case
    r = -0.5 * l * np.array([np.cos(angle), np.sin(angle)])  # the lower end
    mu_c = rod_closed_form(m, l, r, vcom, omega, e, 0.0)[-1]
    mu = mu_factor * mu_c
    Pn, Pt, v_after, s_after, vcom_after, omega_after, _ = rod_closed_form(m, l, r, vcom, omega, e, mu)
    M, Wn, Wt = rod_matrices(m, l, r)
    qd = np.array([vcom[0], vcom[1], omega])
    sol = solve_frictional_impulses(M, Wn, Wt, qd, e, [mu])
    scale = np.abs(qd).max()
    assert sol.rounds == 1
    np.testing.assert_allclose(sol.impulses, [Pn], rtol=1e-10)
    np.testing.assert_allclose(sol.tangential_impulses[0, 0], Pt, rtol=1e-10, atol=1e-10 * Pn)
    np.testing.assert_allclose(sol.v_after, [v_after], rtol=1e-10, atol=1e-10 * scale)
    np.testing.assert_allclose(sol.slip_after[0, 0], s_after, rtol=1e-10, atol=1e-10 * scale)
    np.testing.assert_allclose(sol.qdot_after, [*vcom_after, omega_after], rtol=1e-10, atol=1e-10 * scale)
    # Sticking leaves with s+ = -e s-, sliding keeps the friction at the cone.
    if mu_factor >= 1.0:
        np.testing.assert_allclose(sol.slip_after[0, 0], -e * sol.slip_before[0, 0], rtol=1e-10, atol=1e-12)
    else:
        np.testing.assert_allclose(abs(sol.tangential_impulses[0, 0]), mu * sol.impulses[0], rtol=1e-10)


def test_rod_regimes_change_at_the_critical_mu():
    # One case, the closed form's mu_c: below it the impulse ratio is mu (sliding),
    # above it stays at mu_c (sticking), continuous at mu_c.
    m, l, angle, vcom, omega, e = ROD_CASES[0]
    r = -0.5 * l * np.array([np.cos(angle), np.sin(angle)])
    M, Wn, Wt = rod_matrices(m, l, r)
    qd = np.array([*vcom, omega])
    mu_c = rod_closed_form(m, l, r, vcom, omega, e, 0.0)[-1]
    assert 0.05 < mu_c < 5.0
    for f in np.linspace(0.05, 3.0, 25):
        sol = solve_frictional_impulses(M, Wn, Wt, qd, e, [f * mu_c])
        ratio = abs(sol.tangential_impulses[0, 0]) / sol.impulses[0]
        np.testing.assert_allclose(ratio, min(f, 1.0) * mu_c, rtol=1e-10)


@pytest.mark.parametrize("n_directions", [4, 8, 16])
def test_rod_closed_form_through_the_package_model(n_directions):
    # The same rod built by the package: one rigid link on a free (spatial) base, zero
    # gravity, a small rotary inertia about its own axis (else M is singular). O1 at
    # height 0.9 m, theta_1 = -0.6 rad: O2 is the lower end and touches y = 0. Its
    # Jacobian and M come from the package; t2 = e_z now moves the rod out of the plane.
    l, mu_l, phi = 1.5, 2.0, 0.6
    m = mu_l * l
    model = gi.Model(gi.Chain([gi.Link(l, mu_l, 1.0, modes=[], rotary_inertia=(1e-3, 0.0, 0.0))]),
                     gravity=(0.0, 0.0, 0.0))
    q = model.state(X2=l * np.sin(phi), theta_1=-phi)
    P, J = joint_positions_and_jacobians(model, q)
    assert abs(P[1, 1]) < 1e-12
    M = mass_matrix(model, q)
    Wn = (J[1].T @ [0.0, 1.0, 0.0])[:, None]
    Wt = np.stack([J[1].T @ [1.0, 0.0, 0.0], J[1].T @ [0.0, 0.0, 1.0]], axis=1)[:, None, :]
    Xdot, omega = np.array([0.8, -1.2]), 0.7
    qd = model.state(X1=Xdot[0], X2=Xdot[1], theta_1=omega)
    u = np.array([np.cos(-phi), np.sin(-phi)])  # rod axis, O1 -> O2
    perp = np.array([-u[1], u[0]])  # z x u
    vcom = Xdot + omega * 0.5 * l * perp
    r = 0.5 * l * u
    mu_c = rod_closed_form(m, l, r, vcom, omega, 0.6, 0.0)[-1]
    for mu in (0.5 * mu_c, 2.0 * mu_c):
        Pn, Pt, v_after, s_after, vcom_after, omega_after, _ = rod_closed_form(m, l, r, vcom, omega, 0.6, mu)
        sol = solve_frictional_impulses(M, Wn, Wt, qd, 0.6, [mu], n_directions=n_directions)
        np.testing.assert_allclose(sol.impulses, [Pn], rtol=1e-10)
        np.testing.assert_allclose(sol.tangential_impulses[0], [Pt, 0.0], rtol=1e-10, atol=1e-10 * Pn)
        np.testing.assert_allclose(sol.v_after, [v_after], rtol=1e-10)
        np.testing.assert_allclose(sol.slip_after[0], [s_after, 0.0], rtol=1e-10, atol=1e-10)
        Xdot_after = vcom_after - omega_after * 0.5 * l * perp
        expected = model.state(X1=Xdot_after[0], X2=Xdot_after[1], theta_1=omega_after)
        np.testing.assert_allclose(sol.qdot_after, expected, rtol=1e-10, atol=1e-10)


# ---------------------------------------------------------------------------
# 2. Random impacts: energy, complementarity, cone, termination
# ---------------------------------------------------------------------------


def _random_problem(rng):
    N = int(rng.integers(2, 13))
    k = int(rng.integers(1, 7))
    X = rng.normal(size=(N, N))
    M = X @ X.T + 0.1 * np.eye(N)
    Wn = rng.normal(size=(N, k))
    Wt = rng.normal(size=(N, k, 2))
    qd = rng.normal(size=N)
    if not np.any(Wn.T @ qd < 0):
        qd = -qd
    e = rng.uniform(0, 1, k) if rng.uniform() < 0.7 else np.full(k, rng.choice([0.0, 0.5, 1.0]))
    mu = rng.uniform(0, 1.5, k)
    mu[rng.uniform(size=k) < 0.1] = 0.0
    return M, Wn, Wt, qd, e, mu


def test_random_impacts_never_raise_energy():
    rng = np.random.default_rng(2024)
    worst_gain = worst_compl = worst_cone = worst_identity = worst_newton = 0.0
    max_pivots = n_single = n_multi = n_stick = n_slide = 0
    n_problems = 1000
    for _ in range(n_problems):
        M, Wn, Wt, qd, e, mu = _random_problem(rng)
        k = Wn.shape[1]
        n_dir = int(rng.choice([4, 6, 8]))
        sol = solve_frictional_impulses(M, Wn, Wt, qd, e, mu, n_directions=n_dir)
        max_pivots = max(max_pivots, sol.lemke_pivots)
        T0 = 0.5 * qd @ M @ qd
        T1 = 0.5 * sol.qdot_after @ M @ sol.qdot_after
        worst_gain = max(worst_gain, (T1 - T0) / T0)
        assert T1 <= T0 * (1 + 1e-12), (T0, T1)
        Pn, f = sol.impulses, sol.tangential_impulses
        vscale = max(np.abs(Wn.T @ qd).max(), np.abs(np.einsum("nkc,n->kc", Wt, qd)).max())
        Pscale = max(np.abs(Pn).max(), np.abs(f).max(), 1e-300)
        # Impulse balance M (qdot+ - qdot-) = Wn P_n + Wt f, and the reported velocities.
        np.testing.assert_allclose(M @ (sol.qdot_after - qd), Wn @ Pn + np.einsum("nkc,kc->n", Wt, f),
                                   atol=1e-9 * Pscale * np.abs(Wn).max())
        np.testing.assert_allclose(sol.v_after, Wn.T @ sol.qdot_after, atol=1e-12 * vscale)
        np.testing.assert_allclose(sol.slip_after, np.einsum("nkc,n->kc", Wt, sol.qdot_after), atol=1e-12 * vscale)
        # Impulses push, friction inside the (linearised, so also the round) cone, impact over.
        assert np.all(Pn >= 0)
        cone = np.hypot(f[:, 0], f[:, 1]) - mu * Pn
        worst_cone = max(worst_cone, cone.max() / Pscale)
        assert np.all(cone <= 1e-10 * Pscale)
        assert np.all(sol.v_after >= -1e-9 * vscale)
        if sol.rounds == 1:
            # One round: the law holds for the impact as a whole with the round's e =
            # min e over the contacts that approach or rest (sol.v_before <= tol).
            n_single += 1
            v0 = sol.v_before
            S = v0 <= 1e-13 * np.abs(v0).max()
            er = e[S].min()
            assert np.all(Pn[~S] == 0) and np.all(f[~S] == 0)
            Un = (sol.v_after + er * v0) / (1 + er)
            Ut = (sol.slip_after + er * sol.slip_before) / (1 + er)
            worst_compl = max(worst_compl, np.abs(Pn * Un)[S].max() / (Pscale * vscale))
            assert np.all(Un[S] >= -1e-10 * vscale)
            assert np.all(np.abs(Pn * Un)[S] <= 1e-10 * Pscale * vscale)
            # Newton's law on the normal where the contact carries an impulse.
            act = S & (Pn > 1e-8 * Pscale)
            worst_newton = max(worst_newton, np.abs(Un[act]).max(initial=0.0) / vscale)
            # Coulomb, polyhedral: f.U~_t = -gamma mu P_n with gamma = max_j(-d_j.U~_t) >=
            # |U~_t| cos(pi/n); f strictly inside the cone's inscribed circle => U~_t = 0.
            ut = np.hypot(Ut[:, 0], Ut[:, 1])
            fn = np.hypot(f[:, 0], f[:, 1])
            work = np.sum(f * Ut, axis=1)
            c = np.cos(np.pi / n_dir)
            assert np.all(work <= -c * mu * Pn * ut + 1e-9 * Pscale * vscale)
            inside = S & (fn < (1 - 1e-6) * c * mu * Pn)
            assert np.all(ut[inside] <= 1e-8 * vscale)
            n_stick += int(np.sum(inside & (Pn > 1e-8 * Pscale)))
            n_slide += int(np.sum(S & (ut > 1e-6 * vscale) & (Pn > 1e-8 * Pscale)))
            # Energy identity (4): T+ - T- = P^T U~ - 1/2 (1 - e)/(1 + e) P^T A P, with A
            # the inverse effective mass of all contact directions in the caller's basis.
            W3 = np.hstack([Wn, Wt[:, :, 0], Wt[:, :, 1]])
            A = W3.T @ np.linalg.solve(M, W3)
            P3 = np.concatenate([Pn, f[:, 0], f[:, 1]])
            rhs = Pn @ Un + np.sum(f * Ut) - 0.5 * (1 - er) / (1 + er) * P3 @ A @ P3
            worst_identity = max(worst_identity, abs((T1 - T0) - rhs) / T0)
            assert abs((T1 - T0) - rhs) <= 1e-10 * T0
        else:
            n_multi += 1
        assert sol.rounds <= 10 * k + 11
    assert n_single > 300 and n_multi > 50 and n_stick > 50 and n_slide > 50, (n_single, n_multi, n_stick, n_slide)
    print(f"\n{n_problems} impacts ({n_single} one round, {n_multi} several; {n_stick} sticking, {n_slide} "
          f"sliding contacts): max relative energy change {worst_gain:.2e}, max Lemke pivots {max_pivots}, "
          f"max |P_n U~_n| {worst_compl:.2e}, max Newton residual {worst_newton:.2e}, "
          f"max cone excess {worst_cone:.2e}, max energy-identity error {worst_identity:.2e}")


def test_pushed_contact_joins_the_next_round_with_friction():
    # Issue 12.2's reproducer (test_impact.py) with friction: a rigid rod lying on the
    # floor, O2 approaching, O1 moving away and sliding. Round 1 solves O2 alone and
    # pushes O1 into the floor; round 2 takes it. Energy does not rise.
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, (20.0, 20.0), rotary_inertia=(5e-5, 2.5e-5, 2.5e-5))]),
                     gravity=(0.0, 0.0, 0.0))
    q, qd = np.array([0, 1e-10, 0, 0, 0, 0.0]), np.array([0.3, 0.2, 0, 0, 0, -0.7])
    M = model.mass_matrix(q)
    J = model.joint_jacobians(q)
    Wn = np.stack([J[0].T @ [0, 1.0, 0], J[1].T @ [0, 1.0, 0]], axis=1)
    Wt = np.stack([np.stack([J[j].T @ [1.0, 0, 0], J[j].T @ [0, 0, 1.0]], axis=1) for j in (0, 1)], axis=1)
    for e in (0.0, 0.5, 1.0):
        sol = solve_frictional_impulses(M, Wn, Wt, qd, e, [0.4, 0.4])
        assert sol.rounds == 2
        assert sol.v_before[0] > 0 and sol.impulses[0] > 0  # O1 moved away, yet was pushed in
        assert np.all(sol.v_after >= -1e-12)
        assert sol.qdot_after @ M @ sol.qdot_after <= qd @ M @ qd * (1 + 1e-12)


def test_jammed_rod_ends_in_a_plastic_round_with_friction():
    # A vertical rigid rod (3-dof, centre coordinates) between a floor and a ceiling that
    # fit it exactly, e = 1, moving up and sideways: the rounds cannot end by themselves;
    # after max_rounds the plastic round leaves both ends at v_n = 0.
    m, l = 1.0, 1.0
    M = np.diag([m, m, m * l**2 / 12])
    # Bottom end r = (0, -l/2), n = (0, 1); top end r = (0, l/2), n = (0, -1); t1 = (1, 0).
    Wn = np.array([[0.0, 0.0], [1.0, -1.0], [0.0, 0.0]])
    Wt = np.zeros((3, 2, 2))
    Wt[:, 0, 0] = [1.0, 0.0, l / 2]
    Wt[:, 1, 0] = [1.0, 0.0, -l / 2]
    qd = np.array([0.5, 1.0, 0.2])
    sol = solve_frictional_impulses(M, Wn, Wt, qd, 1.0, [0.3, 0.3], max_rounds=7)
    assert sol.rounds == 8
    np.testing.assert_allclose(sol.v_after, [0.0, 0.0], atol=1e-12)
    assert sol.qdot_after @ M @ sol.qdot_after < qd @ M @ qd


# ---------------------------------------------------------------------------
# 3. mu = 0 is the frictionless solver
# ---------------------------------------------------------------------------


def _spd(rng, N):
    X = rng.normal(size=(N, N))
    return X @ X.T + 0.5 * np.eye(N)


def test_zero_friction_equals_solve_impulses():
    rng = np.random.default_rng(7)
    for trial in range(60):
        N = int(rng.integers(3, 10))
        k = 1 if trial < 20 else int(rng.integers(2, min(N, 5) + 1))
        M = _spd(rng, N)
        Wn, Wt = rng.normal(size=(N, k)), rng.normal(size=(N, k, 2))
        qd = rng.normal(size=N)
        # Every contact approaches (simultaneous impact), one common e.
        v = Wn.T @ qd
        qd += Wn @ np.linalg.solve(Wn.T @ Wn, -np.abs(v) - 0.1 - v)  # now Wn^T qd = -|v| - 0.1
        assert np.all(Wn.T @ qd < 0)
        e = float(rng.choice([0.0, 0.3, 1.0]))
        ref = solve_impulses(M, Wn, qd, e)
        # The public function calls solve_impulses: identical bits.
        sol = solve_frictional_impulses(M, Wn, Wt, qd, e, np.zeros(k))
        assert np.array_equal(sol.qdot_after, ref.qdot_after)
        assert np.array_equal(sol.impulses, ref.impulses)
        assert np.all(sol.tangential_impulses == 0) and sol.rounds == len(ref.rounds)
        # The frictional LCP route with mu = 0 (not taken by the public function) agrees.
        Pn, f, qd_after, rounds, _ = friction._frictional_rounds(cho_factor(M), Wn, Wt, qd, np.full(k, e),
                                                                  np.zeros(k), 8, None)
        np.testing.assert_allclose(qd_after, ref.qdot_after, rtol=1e-12, atol=1e-12 * np.abs(qd).max())
        np.testing.assert_allclose(Pn, ref.impulses, rtol=1e-10, atol=1e-12 * np.abs(ref.impulses).max())
        assert np.all(f == 0) and rounds == len(ref.rounds)


def test_zero_friction_multi_round_equals_solve_impulses():
    # The separating-contact reproducer: two rounds in both solvers.
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, (20.0, 20.0), rotary_inertia=(5e-5, 2.5e-5, 2.5e-5))]),
                     gravity=(0.0, 0.0, 0.0))
    q, qd = np.array([0, 1e-10, 0, 0, 0, 0.0]), np.array([0, 0.2, 0, 0, 0, -0.7])
    M = model.mass_matrix(q)
    J = model.joint_jacobians(q)
    Wn = np.stack([J[0].T @ [0, 1.0, 0], J[1].T @ [0, 1.0, 0]], axis=1)
    Wt = np.stack([np.stack([J[j].T @ [1.0, 0, 0], J[j].T @ [0, 0, 1.0]], axis=1) for j in (0, 1)], axis=1)
    ref = solve_impulses(M, Wn, qd, 1.0)
    assert len(ref.rounds) == 2
    Pn, f, qd_after, rounds, _ = friction._frictional_rounds(cho_factor(M), Wn, Wt, qd, np.ones(2), np.zeros(2),
                                                              8, None)
    assert rounds == 2 and np.all(f == 0)
    np.testing.assert_allclose(qd_after, ref.qdot_after, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(Pn, ref.impulses, rtol=1e-12)


# ---------------------------------------------------------------------------
# 4. Lemke's method
# ---------------------------------------------------------------------------


def brute_force_lcp(M, q, tol=1e-9):
    """All distinct solutions z of w = M z + q >= 0, z >= 0, z.w = 0 over the 2^n complementary bases.

    Basis alpha: z_alpha = -M_aa^-1 q_alpha, z = 0 elsewhere, accepted when z >= 0 and
    w >= 0 up to tol relative to |z|, |q|.
    """
    n = q.size
    found = []
    for mask in itertools.product([False, True], repeat=n):
        a = np.array(mask)
        z = np.zeros(n)
        if a.any():
            try:
                z[a] = np.linalg.solve(M[np.ix_(a, a)], -q[a])
            except np.linalg.LinAlgError:
                continue
        w = M @ z + q
        zs = max(1e-300, np.abs(z).max())
        ws = max(1e-300, np.abs(q).max(), np.abs(M @ z).max())
        if z.min() >= -tol * zs and w.min() >= -tol * ws and not any(np.allclose(z, y, rtol=1e-8, atol=tol * zs)
                                                                      for y in found):
            found.append(z)
    return found


def _p_matrix(rng, n):
    kind = rng.integers(3)
    if kind == 0:  # positive definite, not symmetric: SPD plus skew-symmetric
        X, Y = rng.normal(size=(n, n)), rng.normal(size=(n, n))
        return X @ X.T + 0.1 * np.eye(n) + 2 * (Y - Y.T)
    if kind == 1:  # triangular with positive diagonal (principal minors = products of the diagonal)
        L = np.tril(rng.normal(scale=3.0, size=(n, n)), -1) + np.diag(rng.uniform(0.2, 2.0, n))
        p = rng.permutation(n)
        return L[np.ix_(p, p)]
    X = rng.normal(size=(n, n))  # symmetric positive definite, ill-scaled
    d = 10.0 ** rng.uniform(-3, 3, n)
    return d[:, None] * (X @ X.T + 0.1 * np.eye(n)) * d[None, :]


def test_lemke_p_matrices_match_brute_force():
    rng = np.random.default_rng(11)
    max_piv = 0
    for _ in range(300):
        n = int(rng.integers(1, 7))
        M = _p_matrix(rng, n)
        q = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 3)
        if rng.uniform() < 0.3:
            q[rng.uniform(size=n) < 0.4] = 0.0  # degenerate: zeros in q
        (z_ref,) = brute_force_lcp(M, q)  # a P-matrix LCP has exactly one solution
        sol = lemke(M, q)
        max_piv = max(max_piv, sol.pivots)
        np.testing.assert_allclose(sol.z, z_ref, rtol=1e-8, atol=1e-10 * max(1.0, np.abs(z_ref).max()))
        np.testing.assert_allclose(sol.w, M @ sol.z + q, rtol=1e-12, atol=1e-12 * np.abs(q).max())
    assert max_piv <= 2 * 6 + 2


def test_lemke_degenerate_problems():
    rng = np.random.default_rng(5)
    for _ in range(200):
        # Positive semidefinite M = B^T B with repeated columns of B (repeated rows and
        # columns of M); q = w* - M z* from a complementary pair (z*, w*) with shared zeros.
        r, n = int(rng.integers(1, 4)), int(rng.integers(2, 7))
        B = rng.normal(size=(r, n))
        B[:, rng.integers(n)] = B[:, rng.integers(n)]
        M = B.T @ B
        z_star = np.where(rng.uniform(size=n) < 0.4, rng.uniform(0, 2, n), 0.0)
        w_star = np.where(z_star == 0, np.where(rng.uniform(size=n) < 0.5, rng.uniform(0, 2, n), 0.0), 0.0)
        q = w_star - M @ z_star
        sol = lemke(M, q)
        # Monotone symmetric LCP: M z (hence w) is the same for every solution.
        np.testing.assert_allclose(M @ sol.z, M @ z_star, atol=1e-10)
        np.testing.assert_allclose(sol.w, w_star, atol=1e-10)
        assert sol.z.min() >= 0 and sol.w.min() >= -1e-10 and abs(sol.z @ sol.w) <= 1e-10
    # Ties in the first ratio test (equal q) and a repeated column.
    M = np.array([[2.0, 1.0, 1.0], [1.0, 2.0, 1.0], [1.0, 1.0, 2.0]])
    for q in ([-1.0, -1.0, -1.0], [-1.0, -1.0, 0.0], [0.0, 0.0, -1.0]):
        (z_ref,) = brute_force_lcp(M, np.array(q))
        np.testing.assert_allclose(lemke(M, np.array(q)).z, z_ref, atol=1e-12)
    M = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    sol = lemke(M, np.array([-1.0, -1.0, 0.0]))
    np.testing.assert_allclose(sol.z[:2].sum(), 1.0)
    np.testing.assert_allclose(sol.w, [0.0, 0.0, 0.0], atol=1e-12)


def test_lemke_frictional_lcp_is_degenerate_and_solved():
    # The LCP (3) of one contact of a 3-dof system, 4 directions (t1, t2, -t1, -t2), with
    # no pre-impact slip: its q is zero on every friction and gamma row (all ties).
    # Lemke's result must solve it and give the closed-form sticking impulse when mu is
    # large: U~ = 0 in all three directions, (P_n, f) = -G^-1 u-, G = W3^T M^-1 W3.
    rng = np.random.default_rng(3)
    n_stick = 0
    for trial in range(50):
        M3 = _spd(rng, 3)
        W3 = rng.normal(size=(3, 3))  # columns Wn, Wt1, Wt2
        qv = np.cross(W3[:, 1], W3[:, 2])  # no slip: Wt1.qv = Wt2.qv = 0
        qv *= -np.sign(W3[:, 0] @ qv)  # approaching
        B = np.column_stack([W3[:, 0], W3[:, 1], W3[:, 2], -W3[:, 1], -W3[:, 2]])
        A = B.T @ np.linalg.solve(M3, B)
        mu = 10.0 if trial < 25 else rng.uniform(0.0, 1.5)
        Ml = np.zeros((6, 6))
        Ml[:5, :5] = A
        Ml[1:5, 5] = 1.0
        Ml[5, 0], Ml[5, 1:5] = mu, -1.0
        q = np.concatenate([B.T @ qv, [0.0]])
        assert np.all(np.abs(q[1:]) <= 1e-12 * np.abs(q[0]))
        q[1:] = 0.0
        sol = lemke(Ml, q)
        assert sol.z.min() >= 0 and sol.w.min() >= -1e-10 * np.abs(q).max()
        assert abs(sol.z @ sol.w) <= 1e-10 * np.abs(q).max() * max(1.0, np.abs(sol.z).max())
        G = W3.T @ np.linalg.solve(M3, W3)
        P_ref = -np.linalg.solve(G, W3.T @ qv)
        if P_ref[0] > 0 and abs(P_ref[1]) + abs(P_ref[2]) < mu * P_ref[0]:
            # Sticking is admissible (strictly inside this 4-direction cone, |f|_1 < mu P_n).
            n_stick += 1
            P = np.array([sol.z[0], sol.z[1] - sol.z[3], sol.z[2] - sol.z[4]])
            np.testing.assert_allclose(P, P_ref, rtol=1e-9, atol=1e-12 * np.abs(P_ref).max())
    assert n_stick >= 10, n_stick


def test_lemke_reports_failure():
    with pytest.raises(RuntimeError, match="secondary ray"):
        lemke(np.array([[-1.0]]), np.array([-1.0]))  # -z - 1 >= 0 has no solution z >= 0
    with pytest.raises(RuntimeError, match="max_pivots"):
        lemke(np.eye(4), -np.ones(4), max_pivots=2)


# ---------------------------------------------------------------------------
# 5. Bad input
# ---------------------------------------------------------------------------


def _good():
    M, Wn, Wt = rod_matrices(1.0, 1.0, (-0.4, -0.3))
    return {"M": M, "Wn": Wn, "Wt": Wt, "qdot_before": np.array([0.0, -1.0, 0.0]), "restitution": 0.5,
            "friction": [0.3]}


@pytest.mark.parametrize("change, match", [
    ({"M": np.eye(2)}, r"Wn has shape \(3, 1\); it must be \(2, k\)"),
    ({"M": np.ones((3, 2))}, "M has shape"),
    ({"M": -np.eye(3)}, "M is not positive definite"),
    ({"M": np.triu(np.ones((3, 3)))}, "M is not symmetric"),
    ({"Wn": np.zeros((2, 1))}, "Wn has shape"),
    ({"Wt": np.zeros((3, 1))}, r"Wt has shape .* must be \(3, 1, 2\)"),
    ({"qdot_before": np.zeros(4)}, r"qdot_before has shape \(4,\)"),
    ({"qdot_before": np.array([0.0, np.nan, 0.0])}, "qdot_before has non-finite"),
    ({"restitution": 1.5}, r"restitution=1.5 must lie in \[0, 1\]"),
    ({"restitution": -0.1}, r"restitution=-0.1 must lie in \[0, 1\]"),
    ({"restitution": [0.5, 0.5]}, "restitution has shape"),
    ({"friction": [-0.2]}, r"friction=\[-0.2\] must be finite and >= 0"),
    ({"friction": [0.2, 0.3]}, "friction has shape"),
    ({"friction": [np.inf]}, "friction=.* must be finite"),
    ({"n_directions": 5}, "n_directions=5 must be an even integer >= 4"),
    ({"n_directions": 2}, "n_directions=2 must be an even integer >= 4"),
    ({"max_rounds": -1}, "max_rounds=-1 must be a non-negative integer"),
])
def test_bad_input_is_refused(change, match):
    args = _good() | change
    with pytest.raises(ValueError, match=match):
        solve_frictional_impulses(**args)


def test_nothing_approaches_is_no_impact():
    args = _good() | {"qdot_before": np.array([0.3, 1.0, 0.0])}
    sol = solve_frictional_impulses(**args)
    assert sol.rounds == 0 and np.all(sol.impulses == 0) and np.all(sol.tangential_impulses == 0)
    np.testing.assert_array_equal(sol.qdot_after, args["qdot_before"])
