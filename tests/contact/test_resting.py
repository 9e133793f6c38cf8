"""The pieces of resting contact (gibbsimpact.resting) against independent computations, and its outputs."""

import json

import numpy as np
import pytest
from conftest import single_link_sphere_model, single_link_sphere_state, two_link_circle_model, two_link_circle_state

import gibbsimpact as gi
from conftest import ZENO
from gibbsimpact.cli import commands as cli
from gibbsimpact.io import result_files as gio
from gibbsimpact.dynamics.gibbs_appell import forward_dynamics
from gibbsimpact.dynamics.kinematics import joint_positions
from gibbsimpact.contact.resting import RestingContacts, constraint_data

G = 9.81


def second_derivative(f, h):
    """(f(h) - 2 f(0) + f(-h)) / h^2 with Richardson extrapolation (error O(h^4))."""
    d = lambda s: (f(s) - 2 * f(0.0) + f(-s)) / (s * s)  # noqa: E731
    return (4 * d(h / 2) - d(h)) / 3


#: Every wall kind, containers and obstacles (inside=False: g = |P (p - c)| - R, the sign of g, n, H flipped).
WALLS = [gi.Circle(1.3, (0.2, -0.1)), gi.Sphere(1.1, (0.1, 0.2, -0.3)), gi.Plane((0, -1, 0), (0.3, 1.0, 0.2)),
         gi.Circle(0.3, (0.2, -0.1), inside=False), gi.Sphere(0.2, (0.1, 0.2, -0.3), inside=False)]


def test_obstacle_gap_and_normal_are_distance_minus_radius_and_outward():
    # A point 0.5 m from the centre of an obstacle of radius 0.2: g = 0.3 m, n = (p - c) / |p - c|; the
    # container of the same radius has g = -0.3 m and the opposite normal.
    p = np.array([[0.1 + 0.3, 0.2 + 0.4, 7.0]])
    for cls, c in ((gi.Circle, (0.1, 0.2)), (gi.Sphere, (0.1, 0.2, 7.0))):
        g, n, _ = cls(0.2, c, inside=False).geometry(p)
        assert g[0] == pytest.approx(0.3, abs=1e-15)
        np.testing.assert_allclose(n[0], (0.6, 0.8, 0.0), rtol=0, atol=1e-15)
        g_in, n_in, _ = cls(0.2, c).geometry(p)
        assert g_in[0] == -g[0] and np.array_equal(n_in, -n)
    with pytest.raises(ValueError, match="inside='no'.*True.*False"):
        gi.Circle(0.2, inside="no")


def chain_on_wall(which):
    """(model, wall, q): case 1's chain on the unit circle, or case 2's link in the unit sphere."""
    if which == "circle":
        model = two_link_circle_model()
        return model, gi.Circle(1.0), two_link_circle_state(model)[0]
    model = single_link_sphere_model()
    return model, gi.Sphere(1.0), single_link_sphere_state(model)[0]


@pytest.mark.parametrize("wall", WALLS)
def test_wall_curvature_is_the_second_derivative_of_the_gap(wall):
    # g(p0 + v t) along a straight line: g''(0) = v^T H v exactly (no n . p'' term).
    rng = np.random.default_rng(1)
    for _ in range(5):
        p0, v = rng.normal(size=3) * 0.3, rng.normal(size=3)
        fd = second_derivative(lambda t: float(wall.gap((p0 + v * t)[None, :])[0]), 1e-3)
        # abs: round-off of the differences, ~ 20 eps |g| / h^2 = 4e-9.
        assert float(wall.curvature(p0[None, :], v[None, :])[0]) == pytest.approx(fd, rel=1e-7, abs=1e-7)


@pytest.mark.parametrize("wall", WALLS)
def test_wall_geometry_is_gap_gradient_and_curvature(wall):
    # geometry(p, v) gives in one call what resting contact needs: g (the gap function itself,
    # bit for bit), n = grad g by central differences, and v^T H v (the test above).
    rng = np.random.default_rng(2)
    p, v = rng.normal(size=(4, 3)) * 0.3, rng.normal(size=(4, 3))
    g, n, curv = wall.geometry(p, v)
    assert np.array_equal(g, wall.gap(p))
    h = 1e-6
    grad = np.stack([(wall.gap(p + h * e) - wall.gap(p - h * e)) / (2 * h) for e in np.eye(3)], axis=1)
    assert np.allclose(n, grad, rtol=0, atol=1e-8)
    assert np.array_equal(curv, wall.curvature(p, v))
    assert wall.geometry(p)[2] is None
    if not isinstance(wall, gi.Plane):  # at the centre the direction is undefined: 0
        centre = np.zeros((1, 3))
        centre[0, :len(wall.center)] = wall.center
        assert np.array_equal(wall.geometry(np.vstack((centre, p)))[1][0], np.zeros(3))


@pytest.mark.parametrize("wall", WALLS)
def test_compiled_contact_terms_are_the_walls_geometry(wall):
    # constraint_data's compiled wall terms (kernel.contact_terms) against walls.py's numpy
    # gap, normal and curvature at the joint points, their velocities J qdot and Tddot0's a0.
    from gibbsimpact.dynamics.kinematics import frames, joint_positions_and_jacobians

    model = single_link_sphere_model() if isinstance(wall, gi.Sphere) else two_link_circle_model()
    rng = np.random.default_rng(4)
    q, _ = (single_link_sphere_state if isinstance(wall, gi.Sphere) else two_link_circle_state)(model)
    q = q + 0.05 * rng.normal(size=model.n_dof)
    qd = rng.normal(size=model.n_dof)
    pairs = np.array([[0, j] for j in range(model.n_links + 1)])
    d = constraint_data(model, [wall], q, qd, None, pairs)
    P, J = joint_positions_and_jacobians(model, q)
    p, pd = P[pairs[:, 1]], J[pairs[:, 1]] @ qd
    a0 = frames(model, q, qd).Tdd0[pairs[:, 1], :3, 3]
    np.testing.assert_allclose(d.g, wall.gap(p), rtol=0, atol=1e-15)
    np.testing.assert_allclose(d.n, wall.normal(p), rtol=0, atol=1e-15)
    np.testing.assert_allclose(d.pd, pd, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(d.c, np.sum(wall.normal(p) * a0, axis=1) + wall.curvature(p, pd), rtol=1e-13,
                               atol=1e-13)
    np.testing.assert_allclose(d.v, np.sum(wall.normal(p) * pd, axis=1), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(d.W, np.einsum("kcn,kc->nk", J[pairs[:, 1]], wall.normal(p)), rtol=1e-14, atol=1e-15)
    # The event layer's compiled joint gaps (kernel.event_gaps) at every contact point, and one by one.
    from gibbsimpact.simulation.contacts import Contacts

    ct = Contacts(model, [wall])
    np.testing.assert_allclose(ct.gaps(q)[0, :model.n_joints], wall.gap(P), rtol=0, atol=1e-15)
    for j in range(model.n_joints):
        assert ct.gap_single(q, 0, j) == ct.gaps(q)[0, j]


@pytest.mark.parametrize("which", ["circle", "sphere"])
def test_compiled_frictionless_solve_stops_the_contact_accelerations(which):
    # Equation (3) solved inside kernel.contact_terms (the right-hand side of a frictionless
    # contact phase): lam is lstsq's solution of G lam = -(W^T qdd_free + c) from numpy, and the
    # constrained qddot has zero normal accelerations W^T qddot + c = 0 (G regular here), with M
    # qddot = M qdd_free + W lam, from the public mass matrix.
    model, wall, q = chain_on_wall(which)
    rng = np.random.default_rng(8)
    q = q + 0.1 * rng.normal(size=model.n_dof)  # off the sphere's diameter, where G is singular
    qd = rng.normal(size=model.n_dof)
    pairs = np.array([[0, j] for j in range(model.n_links + 1)])
    d = constraint_data(model, [wall], q, qd, None, pairs)
    assert np.linalg.cond(d.G) < 1e6
    b = -(d.W.T @ d.qdd_free + d.c)
    lam = np.linalg.lstsq(d.G, b, rcond=1e-10)[0]
    np.testing.assert_allclose(d.lam, lam, rtol=1e-10, atol=1e-12 * np.abs(lam).max())
    scale = np.abs(d.W.T @ d.qdd_free).max() + np.abs(d.c).max()
    np.testing.assert_allclose(d.W.T @ d.qdd + d.c, 0.0, atol=1e-11 * scale)
    M = model.mass_matrix(q)
    np.testing.assert_allclose(M @ d.qdd, M @ d.qdd_free + d.W @ d.lam, rtol=1e-11,
                               atol=1e-11 * np.abs(M @ d.qdd_free).max())
    # A resting set without friction takes its right-hand side from these sections.
    r = RestingContacts(model, [wall], 1e-9)
    r.active[0, :] = True
    qdd, lam_n, F_t, power, lam_t, data = r.acceleration(q, qd)
    assert np.array_equal(qdd, d.qdd) and np.array_equal(lam_n, d.lam) and data is None
    assert not F_t.any() and not power.any() and not lam_t.any()


def test_compiled_friction_solve_meets_the_constraints_and_coulombs_law():
    # Equations (6)-(7) solved by kernel.friction_solve (the right-hand side of a frictional
    # contact phase), checked with numpy and walls.tangent_basis: the normal accelerations vanish,
    # a sticking point's tangential acceleration vanishes, a slipping point's friction is
    # -mu lambda_n s (s from (7)), and M qddot = M qdd_free + W lambda_n + sum J^T F_t.
    from gibbsimpact import kernel as _k
    from gibbsimpact.contact.walls import tangent_basis

    model = single_link_sphere_model()
    q, _ = single_link_sphere_state(model)
    rng = np.random.default_rng(11)
    q = q + 0.1 * rng.normal(size=model.n_dof)
    qd = rng.normal(size=model.n_dof)
    wall = gi.Sphere(1.0, friction=0.4)
    pairs = np.array([[0, 0], [0, 1]])
    d = constraint_data(model, [wall], q, qd, None, pairs)
    M = model.mass_matrix(q)
    # (Both ends of this link sticking at these random velocities would ask the rigid link for zero
    # acceleration at both ends while they move apart tangentially: no consistent solution.)
    for stick in ([1, 0], [0, 1], [0, 0]):
        stick = np.array(stick, dtype=np.int64)
        sdir = rng.normal(size=(2, 3))
        mu = np.array([0.4, 0.4])
        r = _k.lazy("friction_solve")(d.M, d.W, d.J, d.n, d.pd, d.a0, d.c, d.qdd_free, mu, stick, sdir, 1e-6)
        N, k = model.n_dof, 2
        qdd, lam, F_t, lam_t, power = (r[:N], r[N:N + k], r[N + k:N + 4 * k].reshape(k, 3),
                                       r[N + 4 * k:N + 6 * k].reshape(k, 2), r[N + 6 * k:])
        acc = np.einsum("kcn,n->kc", d.J, qdd) + d.a0  # point accelerations J qddot + Jdot qdot
        scale = np.abs(acc).max()
        np.testing.assert_allclose(d.W.T @ qdd + d.c, 0.0, atol=1e-10 * scale)
        for a in range(k):
            if stick[a]:
                np.testing.assert_allclose(tangent_basis(d.n[a])[0] @ acc[a], 0.0, atol=1e-10 * scale)
                np.testing.assert_allclose(F_t[a], lam_t[a] @ tangent_basis(d.n[a])[0], rtol=1e-12, atol=1e-12)
            else:
                vt = d.pd[a] - (d.pd[a] @ d.n[a]) * d.n[a]
                s = (vt + 1e-6 * sdir[a]) / np.linalg.norm(vt + 1e-6 * sdir[a])
                np.testing.assert_allclose(F_t[a], -mu[a] * lam[a] * s, rtol=1e-12, atol=1e-12)
                assert not lam_t[a].any()
        np.testing.assert_allclose(power, np.sum(F_t * d.pd, axis=1), rtol=1e-12, atol=1e-12)
        force = d.W @ lam + np.einsum("kcn,kc->n", d.J, F_t)
        np.testing.assert_allclose(M @ qdd, M @ d.qdd_free + force, rtol=1e-10, atol=1e-10 * np.abs(force).max())


def test_svd_solve_is_lstsq_with_its_cut():
    # kernel._svd_solve (one-sided Jacobi SVD: friction's nonsymmetric solve) against numpy's lstsq
    # with rcond 1e-10 on square matrices of full and deficient rank, up to m = 20.
    from gibbsimpact import kernel as _k

    rng = np.random.default_rng(5)
    for m, rank in [(1, 1), (2, 2), (3, 2), (5, 5), (6, 3), (8, 8), (12, 7), (20, 20), (20, 9)]:
        A = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, m))
        b = rng.normal(size=m)
        ref = np.linalg.lstsq(A, b, rcond=1e-10)[0]
        assert np.allclose(_k._svd_solve(A, b), ref, rtol=0, atol=1e-11 * (1 + np.abs(ref).max()))


def test_symmetric_solve_is_lstsq_with_its_cut():
    # _solve_sym (compiled Jacobi eigenpairs, kernel.sym_solve) against numpy's lstsq with rcond
    # 1e-10 on symmetric matrices: regular, rank-deficient (a redundant contact) and indefinite,
    # up to k = 30; and G of size 0.
    from gibbsimpact.contact.resting import _solve_sym

    rng = np.random.default_rng(3)
    for k, rank in [(1, 1), (3, 3), (3, 2), (5, 3), (4, 4), (12, 12), (12, 7), (30, 9)]:
        X = rng.normal(size=(k, rank))
        G = X @ np.diag(rng.uniform(0.5, 2.0, rank) * rng.choice([-1, 1], rank)) @ X.T
        G = 0.5 * (G + G.T)
        b = rng.normal(size=k)
        ref = np.linalg.lstsq(G, b, rcond=1e-10)[0]
        assert np.allclose(_solve_sym(G, b), ref, rtol=0, atol=1e-11 * (1 + np.abs(ref).max()))
    assert _solve_sym(np.zeros((0, 0)), np.zeros(0)).shape == (0,)


@pytest.mark.parametrize("which", ["circle", "sphere"])
def test_gap_acceleration_terms_match_differences_along_a_motion(which):
    # gddot = W^T qddot + c along q(t) = q0 + qdot t + qddot t^2 / 2: the gap of each joint
    # differenced twice in time, from joint positions and the wall's gap only.
    model, wall, q0 = chain_on_wall(which)
    rng = np.random.default_rng(7)
    qd, qdd = rng.normal(size=model.n_dof), rng.normal(size=model.n_dof)
    pairs = np.array([[0, j] for j in range(model.n_links + 1)])
    d = constraint_data(model, [wall], q0, qd, None, pairs)
    for a, (_, j) in enumerate(pairs):
        gap = lambda t: float(wall.gap(joint_positions(model, q0 + qd * t + 0.5 * qdd * t * t)[j][None, :])[0])  # noqa: E731
        assert d.W[:, a] @ qdd + d.c[a] == pytest.approx(second_derivative(gap, 2e-3), rel=1e-6, abs=1e-8)
        dg = (gap(1e-6) - gap(-1e-6)) / 2e-6
        assert d.v[a] == pytest.approx(dg, rel=1e-6, abs=1e-9)
    # G = W^T M^-1 W and M^-1 f from the public dynamics.
    M = model.mass_matrix(q0)
    np.testing.assert_allclose(d.G, d.W.T @ np.linalg.solve(M, d.W), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(d.qdd_free, forward_dynamics(model, q0, qd), rtol=1e-12, atol=1e-12)


def rod(l=1.0, mu=2.0):
    link = gi.Link(l, mu, 20.0, modes=[], rotary_inertia=(1e-4, 5e-5, 5e-5))
    return gi.Model(gi.Chain([link]), gravity=(0.0, -G, 0.0))


def test_projection_never_raises_kinetic_energy_and_closes_the_gaps():
    model = rod()
    r = RestingContacts(model, [gi.Plane((0, 0, 0), (0, 1, 0))], 1e-9)
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = model.state(X2=rng.uniform(-1e-7, 1e-7), theta_1=rng.uniform(-1e-7, 1e-7))
        qd = rng.normal(size=6)
        q2, qd2 = r.project(q, qd, np.array([[0, 0], [0, 1]]))
        assert np.max(np.abs(joint_positions(model, q2)[:, 1])) <= 1e-12
        T = lambda a, b: 0.5 * b @ model.mass_matrix(a) @ b  # noqa: E731
        assert T(q2, qd2) <= T(q, qd) * (1 + 1e-12)
        J = model.joint_jacobians(q2)
        assert np.max(np.abs(J[:, 1] @ qd2)) <= 1e-12 * (1 + np.abs(qd).max())


def test_rod_lying_on_a_plane_rests_from_the_start():
    # A rod of mass m at rest on a floor: lambda = m g / 2 at each end (statics), nothing moves.
    model = rod(1.0, 2.0)
    m = model.total_mass
    res = gi.simulate(model, model.state(), np.zeros(6), (0.0, 0.5), walls=[gi.Plane((0, 0, 0), (0, 1, 0))])
    assert res.status == "finished" and res.impacts == []
    np.testing.assert_allclose(res.contact_forces[:, 0, :], m * G / 2, rtol=1e-12)
    assert res.resting_time == pytest.approx(0.5, rel=1e-12)
    assert np.max(np.abs(res.q)) <= 1e-12
    # A rod tilted off the floor by an upward push leaves it: the force drops to 0 at once.
    res = gi.simulate(model, model.state(), model.state(X2=0.5), (0.0, 0.05), walls=[gi.Plane((0, 0, 0), (0, 1, 0))])
    assert res.status == "finished" and not np.any(res.contact_forces) and res.resting_time == 0.0


def test_accumulation_argument_is_checked():
    model = rod()
    with pytest.raises(ValueError, match="accumulation='soon'.*'rest'.*'stop'"):
        gi.simulate(model, model.state(X2=0.1), np.zeros(6), (0.0, 0.1), accumulation="soon")


# The rigid link of test_cli's ZENO case, dropped flat from 1 cm, with e = 0 and figures on.
DROP = (ZENO.replace('name = "zeno_drop"', 'name = "plastic_drop"').replace("restitution = 0.5", "restitution = 0.0")
        .replace("t_end_s = 1.0", "t_end_s = 0.2").split("[solver]")[0] + "[output]\nplots = true\n")


def test_case_run_writes_contact_forces(tmp_path, capsys):
    # A rigid link dropped flat with e = 0: one plastic impact, then resting contact with
    # m g / 2 on each end (m = 1 kg) in contact_forces.csv, the summary and the figure.
    case = tmp_path / "drop.toml"
    case.write_text(DROP)
    out = tmp_path / "o"
    code = cli.main(["run", str(case), "--out", str(out), "-q"])
    capsys.readouterr()
    assert code == 0
    cols = gio.read_csv(out / "contact_forces.csv")
    assert list(cols)[:2] == ["t_s", "phase"] and set(list(cols)[2:]) == {"F_w1_O1_N", "F_w1_O2_N"}
    t_hit = np.sqrt(2 * 0.01 / G)
    after = cols["t_s"] > t_hit + 1e-9
    np.testing.assert_allclose(cols["F_w1_O1_N"][after], G / 2, rtol=1e-10)
    np.testing.assert_allclose(cols["F_w1_O2_N"][after], G / 2, rtol=1e-10)
    assert np.all(cols["F_w1_O1_N"][cols["t_s"] < t_hit - 1e-9] == 0.0)
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "finished" and s["n_impacts"] == 1
    assert s["resting_time_s"] == pytest.approx(0.2 - t_hit, abs=1e-9)
    assert s["final_contact_forces_N"] == pytest.approx({"O1 on wall 1": G / 2, "O2 on wall 1": G / 2}, rel=1e-10)
    assert (out / "contact_forces.png").stat().st_size > 5000
    res = gi.load_result(out / "result.npz")
    np.testing.assert_array_equal(res.contact_forces[:, 0, 0], cols["F_w1_O1_N"])
    assert res.resting_time == pytest.approx(0.2 - t_hit, abs=1e-9)


def test_case2_with_restitution_08_runs_3_s_and_ends_resting_in_the_sphere():
    # Issue 9: the published case 2 with e = 0.8 stopped with status "zeno" after 113 impacts.
    # Now it goes on; the energy never rises (impacts dissipate, flight and contact phases
    # conserve it), and at the end the link lies in the sphere with both ends loaded.
    model = single_link_sphere_model()
    q, qd = single_link_sphere_state(model)
    res = gi.simulate(model, q, qd, (0.0, 3.0), walls=[gi.Sphere(1.0)], restitution=0.8)
    assert res.status == "finished", res.message
    E = res.energy().total
    assert np.max(np.diff(E)) <= 1e-8 * abs(E[0])
    assert all(r.energy_after.total <= r.energy_before.total + 1e-12 * abs(E[0]) for r in res.impacts)
    assert res.resting_time > 0.1
    assert np.all(res.contact_forces[-1, 0, :2] > 0.0)
    # Both ends on the sphere at the end (resting pairs are held within contact_tol).
    p = model.joint_positions(res.q[-1])
    np.testing.assert_allclose(np.linalg.norm(p[:2], axis=1), 1.0, atol=1e-9)


def test_carriage_on_a_fixed_base_rail_comes_to_rest_at_its_o1():
    """Issue 25 item 8 (the random tester's reproducer): a rigid link on a Pa carriage that runs down a
    vertical rail of a fixed base drops 1 cm onto a floor with e = 0.5. O_1 (the carriage) moves with
    d_1, so it must rest after the accumulation of bounces (at 3 sqrt(2 h / g) = 0.1355 s: each
    bounce lasts e times the one before), not stop "zeno" blaming a link's span. At rest the floor
    carries the weight: lambda n^T J = -m g . dr_G/dd with n^T J = -1 and dr_G/dd = (0, -1), so
    lambda = m g (m = 0.5 kg)."""
    link = gi.Link(0.5, 1.0, (20.0, 20.0), rotary_inertia=(1e-4, 5e-5, 5e-5))
    joint = gi.SlidingPrismatic(angle=1.8707963267948966, half_length=0.0, range=(-0.5, 0.6))
    chain = gi.Chain([link], base=gi.FixedBase((0.0, 0.5, 0.0), -1.5707963267948966), joints=[joint])
    model = gi.Model(chain, gravity=(0.0, -9.81, 0.0))
    res = gi.simulate(model, np.array([0.49]), np.array([0.0]), (0.0, 0.3),
                      walls=[gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))], restitution=0.5)
    assert res.status == "finished", res.message
    assert res.t[-1] == pytest.approx(0.3, rel=1e-12)
    assert res.impacts[0].time == pytest.approx(np.sqrt(2 * 0.01 / 9.81), rel=1e-6)
    assert res.resting_time == pytest.approx(0.3 - 3 * np.sqrt(2 * 0.01 / 9.81), abs=1e-3)
    assert res.contact_forces[-1, 0, 0] == pytest.approx(0.5 * 9.81, rel=1e-9)
    assert abs(res.q[-1, 0] - 0.5) <= 1e-9
