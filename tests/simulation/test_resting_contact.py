"""Resting (sustained) contact: rods and a chain that come to rest on walls, against closed forms.

Contract under test (public API only): an accumulation of impacts (e < 1) or a plastic
impact (e = 0) continues in unilateral contact with a normal force lambda >= 0 and the run
finishes; ``Result.contact_forces`` (K, W, P) [N] holds the force of wall w on contact point
O_(j+1) at every stored sample (0 where the pair is not in sustained contact; an impact
sample carries the force of the contact phase after it).

Every expected number below is derived in the comments from Newton's laws of the rigid
rod or the chain, independently of the package's dynamics. A rigid free link has the
coordinates (X1, X2, X3, theta_-1, theta_0, theta_1): O1 = (X1, X2, X3) and, in the plane
(theta_-1 = theta_0 = 0), O2 = O1 + l (cos theta_1, sin theta_1, 0); its rotary inertia
j_x > 0 (spin about its own axis) only keeps M regular and plays no part in planar motion
(j_y = j_z = 0: the rod's inertia about its centre is m l^2 / 12).
"""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.interpolate import CubicHermiteSpline, CubicSpline
from scipy.optimize import brentq
from scipy.special import ellipk

import gibbsimpact as gi
from conftest import two_link_circle_model, two_link_circle_state

G = 9.81
CONTACT_TOL = 1e-9  # simulate's default contact_tol [m]


def rigid_rod(l, mu):
    return gi.Model(gi.Chain([gi.Link(l, mu, 1.0, rotary_inertia=(1e-4, 0.0, 0.0))]), gravity=(0.0, -G, 0.0))


def floor():
    return gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def gaps(res):
    """(K, W, P) gap of every (wall, contact point) pair at every sample [m]."""
    P = res.joint_positions()
    return np.stack([w.gap(P) for w in res.walls], axis=1)


def check_contact_forces(res, weight):
    """Shape (K, W, P); lambda >= 0; a force only where the pair touches (complementarity)."""
    F = np.asarray(res.contact_forces)
    assert F.shape == (res.t.size, len(res.walls), res.model.n_joints)
    assert np.all(np.isfinite(F))
    assert F.min() >= -1e-12 * weight
    assert np.all(gaps(res)[F > 1e-12 * weight] <= 10 * CONTACT_TOL)
    return F


def check_energy_never_rises(res, scale, rel):
    """Every impact and every stretch between samples: E never above its running minimum + rel * scale."""
    for rec in res.impacts:
        assert rec.energy_after.kinetic <= rec.energy_before.kinetic + 1e-12 * scale
        assert rec.energy_after.total <= rec.energy_before.total + 1e-12 * scale
    E = res.energy().total
    assert np.max(E - np.minimum.accumulate(E)) <= rel * scale


def unique_samples(t, *arrays):
    """Drop the first of two samples at one instant (impact or phase boundary): strictly increasing t."""
    keep = np.append(np.diff(t) > 0, True)
    return (t[keep],) + tuple(a[keep] for a in arrays)


def test_tilted_rod_comes_to_rest_on_a_plane():
    # Rod l = 1 m, mu = 2 kg/m (m = 2 kg), lower end O1 5 cm above the floor y = 0, tilted
    # by 15 degrees, released at rest, e = 0.5. It bounces, rocks and must end lying flat.
    # Closed forms:
    #  * the only forces besides gravity are floor forces and impulses along +y, so the
    #    mass centre keeps x_G(t) = x_G(0) = X1 + (l/2) cos a (horizontal momentum 0);
    #  * at rest both ends lie on the floor (y = 0), O1 and O2 at x_G -/+ l/2, and
    #    the two equal-armed supports carry lambda_1 = lambda_2 = m g / 2
    #    (sum of forces m g, moments about the centre (l/2)(lambda_2 - lambda_1) = 0);
    #  * E = T + m g y_G starts at E0 = m g (h + (l/2) sin a) and ends at 0; impacts
    #    (e < 1) only remove energy and the frictionless floor does no work.
    l, mu, h, a, t_end = 1.0, 2.0, 0.05, np.radians(15.0), 2.0
    m = mu * l
    model = rigid_rod(l, mu)
    q0 = model.state(X1=0.1, X2=h, theta_1=a)
    res = gi.simulate(model, q0, np.zeros(6), (0.0, t_end), walls=[floor()], restitution=0.5)
    assert res.status == "finished", res.message
    assert res.t[-1] == pytest.approx(t_end, abs=1e-12)
    assert len(res.impacts) >= 2
    E0 = m * G * (h + l / 2 * np.sin(a))
    assert res.energy().total[0] == pytest.approx(E0, rel=1e-14)
    check_energy_never_rises(res, E0, 1e-9)
    F = check_contact_forces(res, m * G)
    # Never beyond the floor by more than contact_tol, at any stored sample.
    assert res.joint_positions()[:, :, 1].min() >= -CONTACT_TOL
    # Horizontal momentum stays 0: the mass centre does not move sideways.
    xG0 = 0.1 + l / 2 * np.cos(a)
    xG = np.array([model.center_of_mass(q)[0] for q in res.q])
    assert np.max(np.abs(xG - xG0)) <= 1e-8
    # At rest, lying flat, at the end.
    P_end = res.joint_positions()[-1]
    np.testing.assert_allclose(P_end[:, 1], 0.0, atol=CONTACT_TOL)
    np.testing.assert_allclose(P_end[:, 0], [xG0 - l / 2, xG0 + l / 2], atol=1e-8)
    E_end = res.energy()
    assert E_end.kinetic[-1] <= 1e-12 * E0  # |v| < ~2e-6 m/s
    assert abs(E_end.total[-1]) <= 2 * m * G * CONTACT_TOL + 1e-12 * E0
    np.testing.assert_allclose(F[-1, 0], [m * G / 2, m * G / 2], rtol=1e-8)


def test_rod_in_a_circle_swings_as_a_compound_pendulum():
    # Rod (l = 1.2 m, mu = 1 kg/m, m = 1.2 kg) with both ends on a frictionless circle of
    # radius R = 1 about the origin, the chord below the centre, gravity -y, e = 0.
    # The wall forces are radial (through the centre O), so they have no moment about O
    # and the rod turns about O as a compound pendulum:
    #   d = sqrt(R^2 - l^2/4) = 0.8 (centre O to mass centre G), I_O = m (l^2/12 + d^2),
    #   I_O phi'' = -m g d sin(phi),   phi = angle of OG from the downward vertical,
    #   phi'^2 = 2 m g d (cos phi - cos phi0) / I_O                   (energy),
    #   period T = 4 sqrt(I_O / (m g d)) K(k),  k = sin(phi0 / 2),
    # K the complete elliptic integral of the first kind with modulus k; scipy's
    # ellipk takes the parameter m = k^2 (checked against a direct integration of the
    # 1-dof ODE: equal to 3e-15; small amplitude: 2 pi sqrt(I_O / (m g d))).
    # Starting at rest at phi0, phi crosses 0 at T/4, 3T/4, 5T/4.
    #
    # Geometry: u = (cos phi, sin phi) along the rod, G = d (sin phi, -cos phi);
    # with theta_1 = phi, O1 = G - (l/2) u and O2 = G + (l/2) u (|O1| = |O2| = R; for
    # phi > 0, O1 is the lower end). Wall force on end i: lambda_i n_i, n_i = -O_i / R.
    # With e = -G/d (unit vector from G towards O), m a_G = m g_vec + sum_i lambda_i n_i:
    #   along e: (lambda_1 + lambda_2) d / R = m (d phi'^2 + g cos phi)
    #   along u: (lambda_1 - lambda_2) (l/2) / R = m (d phi'' + g sin phi)
    #                                  = m g sin(phi) (l^2/12) / (l^2/12 + d^2)
    # (checked against the constrained equations M qdd = f + W lambda, W^T qdd + Wdot^T qd = 0
    # of the model at 7 states: equal to 1e-11). Both stay > 0 for |phi| <= phi0 = 1 rad
    # (min 2.67 N against m g = 11.8 N), so the rod never leaves the wall.
    l, mu, R, phi0 = 1.2, 1.0, 1.0, 1.0
    m = mu * l
    d = np.sqrt(R**2 - l**2 / 4)
    I_O = m * (l**2 / 12 + d**2)
    kappa = (l**2 / 12) / (l**2 / 12 + d**2)
    T = 4 * np.sqrt(I_O / (m * G * d)) * ellipk(np.sin(phi0 / 2) ** 2)

    def lambdas(phi, phid):
        s = R / d * m * (d * phid**2 + G * np.cos(phi))
        dlt = 2 * R / l * m * G * kappa * np.sin(phi)
        return np.stack([(s + dlt) / 2, (s - dlt) / 2], axis=-1)

    model = rigid_rod(l, mu)
    u0 = np.array([np.cos(phi0), np.sin(phi0)])
    O1 = d * np.array([np.sin(phi0), -np.cos(phi0)]) - l / 2 * u0
    q0 = model.state(X1=O1[0], X2=O1[1], theta_1=phi0)
    wall = gi.Circle(R)
    # The initial state is exactly on the wall (both ends at radius R, at rest).
    assert np.max(np.abs(wall.gap(model.joint_positions(q0)))) <= 1e-15
    t_end = 1.3 * T  # crossings at T/4, 3T/4, 5T/4
    res = gi.simulate(model, q0, np.zeros(6), (0.0, t_end), walls=[wall], restitution=0.0, output_dt=2e-3)
    assert res.status == "finished", res.message
    assert res.t[-1] == pytest.approx(t_end, abs=1e-12)
    F = check_contact_forces(res, m * G)
    g = gaps(res)
    assert g.min() >= -CONTACT_TOL and g.max() <= 10 * CONTACT_TOL  # both ends stay on the circle
    # Energy conserved: E = T + m g y_G = -m g d cos(phi0) (no impact, workless wall forces).
    E0 = -m * G * d * np.cos(phi0)
    E = res.energy().total
    assert np.max(np.abs(E - E0)) <= 1e-8 * abs(E0)

    P, V = res.joint_positions(), res.joint_velocities()
    Gp, Gv = P.mean(axis=1), V.mean(axis=1)  # uniform rigid rod: G is the midpoint of O1 O2
    assert np.max(np.abs(np.hypot(Gp[:, 0], Gp[:, 1]) - d)) <= 1e-8
    phi = np.arctan2(Gp[:, 0], -Gp[:, 1])
    phid = (Gp[:, 0] * Gv[:, 1] - Gp[:, 1] * Gv[:, 0]) / d**2

    # Forces along the swing against the closed form, at every sample.
    ref = lambdas(phi, phid)
    assert ref.min() > 2.0
    np.testing.assert_allclose(F[:, 0, :], ref, rtol=1e-6, atol=0)

    # Zero crossings of phi from a cubic Hermite interpolant of (phi, phi') between samples
    # (interpolation error ~ (omega dt)^4: far below 1e-9 s at dt = 2 ms).
    ts, ph, phd = unique_samples(res.t, phi, phid)
    roots = CubicHermiteSpline(ts, ph, phd).roots(extrapolate=False)
    roots = roots[np.abs(np.interp(roots, ts, phd)) > 0.1]  # crossings, not touches of 0
    assert roots.size == 3
    np.testing.assert_allclose(roots, np.array([0.25, 0.75, 1.25]) * T, rtol=0, atol=1e-6 * T)
    assert roots[2] - roots[0] == pytest.approx(T, rel=1e-6)


def test_two_link_chain_comes_to_rest_in_a_circle():
    # The published case 1 chain (two links l = 1 m, mu = 1 kg/m, EI = 20 N m^2, one
    # clamped-clamped y-mode each; the symmetric V with O1, O3 at (-/+ 0.866, 0), O2 at
    # (0, -0.5), at rest) in a circle R = 1 with e = 0.8 for 3 s. The start is mirror
    # symmetric and stays so (test_simulate.test_case1_mirror_symmetry).
    #
    # Closed forms of the rest state:
    #  * Rigid statics: the lowest symmetric configuration has all three joints on the
    #    circle, each link a chord of length 1 = R subtending 60 degrees: O2 = (0, -1),
    #    O1, O3 = (-/+ sin 60, -cos 60) = (-/+ 0.866, -0.5), each link inclined 30 degrees,
    #    its centre at y = -0.75: V_rigid = -2 m_l g 0.75 = -14.715 J. (O1 at distance l
    #    from O2 = (0, -1) inside the disc lies on an arc whose lowest points are the
    #    60-degree ones; O2 itself is lowest on the wall.)
    #    Forces: radial at O1, O3 (n = (+/-0.866, 0.5)), vertical at O2. Moments about O2
    #    of link 1 (the revolute joint carries no moment): lambda_1 * 0.866 = m_l g 0.433,
    #    so lambda_1 = lambda_3 = m_l g / 2; vertical balance lambda_2 + 0.5 (lambda_1 +
    #    lambda_3) = 2 m_l g, so lambda_2 = 3 m_l g / 2.
    #  * Static sag: the clamped-clamped mode does not move the link's ends, so with the
    #    joints held by the wall each link sags independently by delta_s = F / K, with
    #    F = mu g cos(30 deg) int psi dx, K = EI int psi''^2 dx (psi the textbook
    #    eigenfunction, max |psi| = 1), lowering the energy by F^2 / (2 K) per link:
    #    E_static = -14.715 J - 2 F^2 / (2 K) = -14.71998 J, the global minimum of the
    #    potential over admissible states, so E(t) >= E_static for all t.
    #  * The vibration of the modes (~100 rad/s) is undamped and persists at rest: the
    #    instantaneous forces oscillate about the statics, so the balance of forces is
    #    checked exactly through the linear momentum p = model.linear_momentum:
    #    integral of (sum_j lambda_j n_j + m g_vec) dt = p(t_b) - p(t_a).
    #
    # Measured (an independent scratch prototype of resting contact: fixed active sets,
    # lambda from the acceleration-level equalities, plastic capture below 1e-4 m/s; and the
    # implementation when this test was written, 24 s): last impact at 2.436 s / 2.529 s (all
    # three joints), then all three in contact with lambda_1,3 in [3.6, 6.2] / [1.41, 8.40] N,
    # the joints at the rest points to 3e-10 / 8e-12 m, moving < 2e-11 m/s, vibration energy
    # E - E_static = 7.2e-4 / 5.3e-3 J, time means of the forces within 1 % / 0.8 % of the
    # statics. Limits used here: rest from t = 2.7 s; E - E_static <= 0.01 J (the end forces
    # oscillate by ~1.3 N at 7.2e-4 J and ~3.5 N at 5.3e-3 J, like sqrt(E): at 0.01 J they
    # reach m_l g / 2 = 4.9 N, so a chain holding more would lift O1 and O3 off and bounce
    # on); time means within 5 % (the vibration does not average out over a 0.3 s window).
    model = two_link_circle_model()
    q0, qd0 = two_link_circle_state(model)
    ml, mu, EI, l = 1.0, 1.0, 20.0, 1.0
    m = 2 * ml
    t_end, t_rest = 3.0, 2.7
    res = gi.simulate(model, q0, qd0, (0.0, t_end), walls=[gi.Circle(1.0)], restitution=0.8, output_dt=1e-3)
    assert res.status == "finished", res.message
    assert res.t[-1] == pytest.approx(t_end, abs=1e-12)
    E0 = res.energy().total[0]
    assert E0 == pytest.approx(-4.905, rel=1e-12)
    check_energy_never_rises(res, abs(E0), 1e-8)
    F = check_contact_forces(res, m * G)
    assert gaps(res).min() >= -CONTACT_TOL

    # E_static from the clamped-clamped eigenfunction (cos z cosh z = 1).
    bl = brentq(lambda z: np.cos(z) * np.cosh(z) - 1.0, 4.5, 5.0)
    b = bl / l
    sig = (np.cosh(bl) - np.cos(bl)) / (np.sinh(bl) - np.sin(bl))

    def psi(x):
        return np.cosh(b * x) - np.cos(b * x) - sig * (np.sinh(b * x) - np.sin(b * x))

    def psi2(x):  # psi''
        return b**2 * (np.cosh(b * x) + np.cos(b * x) - sig * (np.sinh(b * x) + np.sin(b * x)))

    peak = abs(psi(l / 2))
    F_mode = mu * G * np.cos(np.pi / 6) * quad(psi, 0, l, epsabs=1e-14)[0] / peak
    K_mode = EI * quad(lambda x: psi2(x) ** 2, 0, l, epsabs=1e-12)[0] / peak**2
    E_static = -2 * ml * G * 0.75 - 2 * F_mode**2 / (2 * K_mode)
    E = res.energy()
    assert E_static - 1e-8 <= E.total[-1] <= E_static + 0.01

    # At rest from t_rest: no impact, all three joints held at the rest points.
    assert all(rec.time < t_rest for rec in res.impacts)
    s = res.t >= t_rest
    assert np.count_nonzero(s) >= 250
    rest_points = np.array([[-np.sqrt(3) / 2, -0.5, 0.0], [0.0, -1.0, 0.0], [np.sqrt(3) / 2, -0.5, 0.0]])
    assert np.max(np.abs(res.joint_positions()[s] - rest_points)) <= 1e-6
    assert np.max(np.abs(res.joint_velocities()[s])) <= 1e-6
    assert np.max(E.kinetic[s]) <= 0.01
    lam = F[s, 0, :]
    assert lam.min() > 0.0
    assert np.max(np.abs(lam[:, 0] - lam[:, 2])) <= 1e-5 * m * G  # mirror symmetry

    # Newton's second law of the whole chain over the rest window: the wall forces
    # (along n_j = -O_j / R) and gravity change the linear momentum. Spline quadrature
    # error ~ (omega dt)^4 relative: ~1e-9 N s here (3e-9 N s in the prototype).
    ts, qs, qds, lam_s, P = unique_samples(res.t[s], res.q[s], res.qdot[s], lam, res.joint_positions()[s])
    n = -P / np.linalg.norm(P, axis=2, keepdims=True)
    force = np.einsum("kj,kjc->kc", lam_s, n) + m * np.array([0.0, -G, 0.0])
    impulse = np.array([CubicSpline(ts, force[:, c]).integrate(ts[0], ts[-1]) for c in range(3)])
    dp = model.linear_momentum(qs[-1], qds[-1]) - model.linear_momentum(qs[0], qds[0])
    np.testing.assert_allclose(impulse, dp, rtol=0, atol=1e-6 * m * G * (ts[-1] - ts[0]))
    # Time means against the rigid statics (the vibration averages out to within 5 %).
    mean = np.array([CubicSpline(ts, lam_s[:, j]).integrate(ts[0], ts[-1]) for j in range(3)]) / (ts[-1] - ts[0])
    np.testing.assert_allclose(mean, [ml * G / 2, 3 * ml * G / 2, ml * G / 2], rtol=0.05)


def test_flat_rod_with_plastic_impact_stays_on_the_plane():
    # Rod (l = 1 m, mu = 2 kg/m, m = 2 kg) horizontal at h = 5 cm, released at rest, e = 0.
    # Free fall: y(t) = h - g t^2 / 2 until t1 = sqrt(2 h / g), both ends at once at
    # v1 = sqrt(2 g h). The plastic impact stops it: impulses m v1 / 2 on each end
    # (symmetric, total m v1), velocity 0 after. From then on it lies still and each end
    # carries m g / 2; before t1 no force at all.
    l, mu, h, t_end = 1.0, 2.0, 0.05, 0.5
    m = mu * l
    model = rigid_rod(l, mu)
    res = gi.simulate(model, model.state(X2=h), np.zeros(6), (0.0, t_end), walls=[floor()], restitution=0.0)
    assert res.status == "finished", res.message
    assert res.t[-1] == pytest.approx(t_end, abs=1e-12)
    t1, v1 = np.sqrt(2 * h / G), np.sqrt(2 * G * h)
    first = res.impacts[0]
    assert first.time == pytest.approx(t1, rel=1e-9)  # the gap is located to ~1e-10 m
    assert tuple(sorted(first.joints)) == (1, 2)
    np.testing.assert_allclose(first.impulses, [m * v1 / 2, m * v1 / 2], rtol=1e-9)
    np.testing.assert_allclose(first.qdot_after, 0.0, atol=1e-9)
    # Stays on the plane from the first impact: nothing after it carries an impulse.
    for rec in res.impacts[1:]:
        assert np.max(rec.impulses) <= 1e-9 * m * v1
    check_energy_never_rises(res, m * G * h, 1e-9)
    F = check_contact_forces(res, m * G)
    before, after = res.t < first.time, res.t > first.time
    assert np.count_nonzero(before) and np.count_nonzero(after)
    np.testing.assert_allclose(res.q[before, 1], h - G * res.t[before] ** 2 / 2, rtol=0, atol=1e-10)
    assert np.all(F[before] == 0.0)
    k_after = np.nonzero(res.t == first.time)[0][-1]  # the sample after the impact
    on = np.nonzero(after)[0].tolist() + [k_after]
    np.testing.assert_allclose(F[on, 0, :], m * G / 2, rtol=1e-8)
    np.testing.assert_allclose(res.joint_positions()[on][:, :, 1], 0.0, atol=CONTACT_TOL)
    np.testing.assert_allclose(res.qdot[on], 0.0, atol=1e-9)
