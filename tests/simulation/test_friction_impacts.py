"""Frictional impacts through simulate (walls with ``friction``), against a closed form and invariants."""

import numpy as np
import pytest
from conftest import single_link_sphere_model, two_link_circle_model

import gibbsimpact as gi
from gibbsimpact.dynamics.gibbs_appell import mass_matrix
from gibbsimpact.contact.friction import solve_frictional_impulses
from gibbsimpact.dynamics.kinematics import joint_positions_and_jacobians
from gibbsimpact.contact.walls import tangent_basis

G = 9.81


def planar_rod(l=1.0, mu=2.0):
    # Line mass: I_G = m l^2 / 12 about z; j_x > 0 only so that M is regular (spin about the axis).
    link = gi.Link(l, mu, 20.0, modes=[], rotary_inertia=(1e-4, 0.0, 0.0))
    return gi.Model(gi.Chain([link]), gravity=(0.0, -G, 0.0))


def rod_impact_closed_form(m, l, theta, vG, omega, e, mu):
    """Post-impact (vG (2,), omega) of a rod of mass m, length l at angle theta hitting the floor y = 0
    with its lower end O1, under Moreau's law (U~ = (u+ + e u-)/(1 + e) for both directions) with
    Coulomb friction.

    r = O1 - G = -(l/2)(cos theta, sin theta), I = m l^2 / 12, contact velocity u = vG + omega e3 x r:
    u_t = vx - omega r_y, u_n = vy + omega r_x. An impulse (Pt, Pn) at O1 changes
        du_t = Pt (1/m + r_y^2/I) - Pn r_x r_y / I,   du_n = Pn (1/m + r_x^2/I) - Pt r_x r_y / I.
    Normal: U~_n = 0 -> du_n = -(1 + e) u_n-.
    Stick: U~_t = 0 -> du_t = -(1 + e) u_t-: a 2x2 linear system; valid if |Pt| <= mu Pn.
    Slip: Pt = -s mu Pn, s = sign(U~_t), with Pn from the normal equation; valid if
    U~_t = u_t- + du_t / (1 + e) has the sign s. s = sign(u_t-) is tried first; the normal impulse's
    coupling a_tn can reverse the average slip, and then s = -sign(u_t-) is the solution.
    """
    I = m * l * l / 12
    rx, ry = -0.5 * l * np.cos(theta), -0.5 * l * np.sin(theta)
    ut = vG[0] - omega * ry
    un = vG[1] + omega * rx
    a_tt, a_nn, a_tn = 1 / m + ry * ry / I, 1 / m + rx * rx / I, -rx * ry / I
    Pt, Pn = np.linalg.solve([[a_tt, a_tn], [a_tn, a_nn]], [-(1 + e) * ut, -(1 + e) * un])
    regime = "stick"
    if abs(Pt) > mu * Pn:
        for s in (np.sign(ut), -np.sign(ut)):
            Pn = -(1 + e) * un / (a_nn - s * mu * a_tn)
            Pt = -s * mu * Pn
            if Pn > 0 and np.sign(ut + (Pt * a_tt + Pn * a_tn) / (1 + e)) == s:
                regime = "slip" if s == np.sign(ut) else "reversed slip"
                break
        else:
            raise AssertionError("no consistent slip solution")
    vG_after = np.array(vG) + np.array([Pt, Pn]) / m
    omega_after = omega + (rx * Pn - ry * Pt) / I
    return vG_after, omega_after, Pt, Pn, regime


# With X1dot = 0.3 m/s the sticking impulse needs |Pt| / Pn = 0.1506: mu below slips (the average
# slip reversed by the normal impulse), above sticks. With 1.5 m/s sticking needs 72.5: it slips on.
@pytest.mark.parametrize("x1dot, mu, regime", [(1.5, 0.3, "slip"), (0.3, 0.05, "reversed slip"),
                                               (0.3, 0.14, "reversed slip"), (0.3, 0.16, "stick"), (0.3, 0.5, "stick")])
def test_oblique_rod_impact_matches_the_closed_form(x1dot, mu, regime):
    # A rod falling tilted (O1 lowest) and moving sideways hits a frictional floor.
    l, mu_l, e = 1.0, 2.0, 0.6
    model = planar_rod(l, mu_l)
    m = model.total_mass
    q0 = model.state(X2=0.05, theta_1=0.4)
    qd0 = model.state(X1=x1dot, X2=-0.5, theta_1=0.8)
    res = gi.simulate(model, q0, qd0, (0.0, 0.2), walls=[gi.Plane((0, 0, 0), (0, 1, 0), friction=mu)], restitution=e)
    rec = res.impacts[0]
    assert rec.joints == (1,) and rec.friction_impulses is not None
    k = int(np.nonzero(res.t == rec.time)[0][0])  # the sample before the impact
    theta = res.q[k, model.coordinate_names.index("theta_1")]
    X1d, X2d, w = (rec.qdot_before[model.coordinate_names.index(c)] for c in ("X1", "X2", "theta_1"))
    # G = O1 + (l/2)(cos, sin): vG = Xdot + w e3 x (l/2)(cos, sin)
    vG = np.array([X1d - w * 0.5 * l * np.sin(theta), X2d + w * 0.5 * l * np.cos(theta)])
    vG_a, w_a, Pt, Pn, got = rod_impact_closed_form(m, l, theta, vG, w, e, mu)
    assert got == regime
    X1a, X2a, wa = (rec.qdot_after[model.coordinate_names.index(c)] for c in ("X1", "X2", "theta_1"))
    np.testing.assert_allclose([X1a - wa * 0.5 * l * np.sin(theta), X2a + wa * 0.5 * l * np.cos(theta), wa],
                               [*vG_a, w_a], rtol=1e-10, atol=1e-12)
    assert rec.impulses[0] == pytest.approx(Pn, rel=1e-10)
    np.testing.assert_allclose(rec.friction_impulses[0], [Pt, 0.0, 0.0], rtol=1e-10, atol=1e-12)
    assert rec.energy_after.total <= rec.energy_before.total
    if regime == "stick":
        assert rec.slip_after[0, 0] == pytest.approx(-e * rec.slip_before[0, 0], rel=1e-10)
    # Frictionless (the mu = 0 path, Newton's law): the closed form with mu = 0, no tangential impulse.
    res0 = gi.simulate(model, q0, qd0, (0.0, 0.2), walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=e)
    r0 = res0.impacts[0]
    assert r0.friction_impulses is None and r0.time == pytest.approx(rec.time, rel=1e-12)  # the same flight before
    vG_a, w_a, Pt, Pn, _ = rod_impact_closed_form(m, l, theta, vG, w, e, 0.0)
    assert Pt == 0.0 and r0.impulses[0] == pytest.approx(Pn, rel=1e-10)
    X1a, X2a, wa = (r0.qdot_after[model.coordinate_names.index(c)] for c in ("X1", "X2", "theta_1"))
    np.testing.assert_allclose([X1a - wa * 0.5 * l * np.sin(theta), X2a + wa * 0.5 * l * np.cos(theta), wa],
                               [*vG_a, w_a], rtol=1e-10, atol=1e-12)


def test_frictional_impacts_of_random_chains_never_create_energy():
    # >= 1000 impacts: random states of the published chains and an FE arm, 1-3 joints hitting
    # walls of random normal (moving into them), random e and mu.
    rng = np.random.default_rng(11)
    fe = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 30.0, elements=3), gi.Link(0.8, 1.0, 30.0, elements=2)]))
    models = [two_link_circle_model(), single_link_sphere_model(), fe]
    worst, n = -np.inf, 0
    for model in models:
        for _ in range(350):
            q = rng.normal(size=model.n_dof) * 0.3
            qd = rng.normal(size=model.n_dof)
            M = mass_matrix(model, q)
            _, Jac = joint_positions_and_jacobians(model, q)
            moving = [j for j in range(model.n_links + 1) if np.linalg.norm(Jac[j] @ qd) > 1e-6]
            k = int(rng.integers(1, min(3, len(moving)) + 1))
            js = rng.choice(moving, size=k, replace=False)
            # normals against each joint's velocity (plus noise): every contact approaches
            nrm = np.array([-(Jac[j] @ qd) / np.linalg.norm(Jac[j] @ qd) + 0.5 * rng.normal(size=3) for j in js])
            nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
            Wn = np.einsum("kc,kcn->nk", nrm, Jac[js])
            T = tangent_basis(nrm)
            Wt = np.einsum("kac,kcn->nka", T, Jac[js])
            sol = solve_frictional_impulses(M, Wn, Wt, qd, rng.uniform(0, 1, k), rng.uniform(0, 1.5, k))
            T0, T1 = 0.5 * qd @ M @ qd, 0.5 * sol.qdot_after @ M @ sol.qdot_after
            worst = max(worst, (T1 - T0) / T0)
            assert np.all(sol.impulses >= 0) and np.all(sol.v_after >= -1e-9 * np.abs(sol.v_before).max())
            n += 1
    assert n >= 1000
    assert worst <= 1e-12


def test_friction_is_checked_and_stored(tmp_path):
    with pytest.raises(ValueError, match="Plane friction=-0.1 must be a finite number >= 0"):
        gi.Plane((0, 0, 0), (0, 1, 0), friction=-0.1)
    with pytest.raises(ValueError, match="Circle friction"):
        gi.Circle(1.0, friction=float("nan"))
    # The same bound as the case files' walls.friction (it used to be accepted from Python).
    with pytest.raises(ValueError, match=r"Sphere friction=101 must be a finite number >= 0 and <= 100"):
        gi.Sphere(1.0, friction=101)
    assert gi.Sphere(1.0, friction=100).friction == 100.0
    model = planar_rod()
    walls = [gi.Plane((0, 0, 0), (0, 1, 0), friction=0.3), gi.Circle(5.0, friction=0.2), gi.Sphere(9.0, friction=1.0)]
    res = gi.simulate(model, model.state(X2=0.05, theta_1=0.4), model.state(X1=1.0), (0.0, 0.15), walls=walls,
                      restitution=0.5)
    assert res.impacts and res.impacts[0].friction_impulses is not None
    back = gi.load_result(res.save(tmp_path / "r.npz"))
    assert [w.friction for w in back.walls] == [0.3, 0.2, 1.0]
    np.testing.assert_array_equal(back.impacts[0].friction_impulses, res.impacts[0].friction_impulses)
    np.testing.assert_array_equal(back.impacts[0].slip_after, res.impacts[0].slip_after)
    cols = gi.io.read_csv(res.to_csv(tmp_path)["impacts"])
    assert cols["friction_impulse_X1_N_s"][0] == res.impacts[0].friction_impulses[0, 0]


def test_case_file_friction_key(tmp_path):
    from pathlib import Path

    from gibbsimpact.case import CaseError

    text = (Path(__file__).resolve().parents[2] / "cases" / "circle_two_link.toml").read_text()
    assert text.count('type = "circle"') == 1
    good = tmp_path / "f.toml"
    good.write_text(text.replace('type = "circle"', 'type = "circle"\nfriction = 0.4'))
    case = gi.load_case(good)
    assert case.walls[0].friction == 0.4 and "friction 0.4" in gi.walls.describe(case.walls[0])
    bad = tmp_path / "b.toml"
    bad.write_text(text.replace('type = "circle"', 'type = "circle"\nfriction = -0.2'))
    with pytest.raises(CaseError) as info:
        gi.load_case(bad)
    d = dict(info.value.problems)
    assert d["walls[1].friction"].startswith("must be in [0, 100]") and "got -0.2" in d["walls[1].friction"]
