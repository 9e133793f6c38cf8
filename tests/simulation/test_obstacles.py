"""gibbsimpact.simulate with obstacles (Circle / Sphere with inside=False, g = |P (p - c)| - R), against
closed forms and invariants: a rod striking a post or a ball with its span (frictionless, and sliding
or sticking on a rough post; a free rod in space on a ball off its plane), a rod balanced on a rough
cylinder, a mixed run of containers, obstacles and a plane at e = 1. (A module of its own: the
behaviour runs through contact/walls.py, contact/closest_points.py, kernel/contact.py and
simulation/contacts.py at once.)"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gibbsimpact as gi
from conftest import two_link_circle_model

G = 9.81


def planar_rod(length=1.0, mu=1.0):
    """A free rigid rod in the X1-X2 plane (X1, X2 of O_1, theta_1), mass m = mu l, I_G = m l^2 / 12."""
    return gi.Model(gi.Chain([gi.Link(length, mu, 20.0)], base="planar"), gravity=(0.0, -G, 0.0))


@pytest.mark.parametrize("wall", [gi.Circle(0.1, (0.0, 0.0), inside=False),
                                  gi.Sphere(0.1, (0.0, 0.0, 0.0), inside=False)])
@pytest.mark.parametrize("e", [0.5, 1.0])
def test_rod_dropped_on_a_post_or_ball_bounces_by_newtons_law(wall, e):
    """A horizontal rod (l = 1 m, m = 1 kg) falls from rest with O_1 at (x0, y0) = (-0.3, 0.5) m onto an
    obstacle of radius R = 0.1 m centred at the origin, which it strikes with its span at x = 0, a = 0.2 m
    right of its centre of mass G. Closed form (a rigid body striking a fixed convex obstacle):

        impact time t* = sqrt(2 h / g), h = y0 - R;   approach speed v = g t*
        effective mass at the point: 1 / m_eff = 1 / m + a^2 / I_G,   I_G = m l^2 / 12
        Newton's law: Lambda = (1 + e) m_eff v;  v_G+ = -v + Lambda / m,  omega+ = a Lambda / I_G
        O_1's velocity after: (0, v_G+ - omega+ l / 2),  theta_1' = omega+.

    Free fall is a quadratic in t, which the integrator follows to round-off: 1e-12 relative."""
    model = planar_rod()
    x0, y0, R, l, m = -0.3, 0.5, 0.1, 1.0, 1.0
    res = gi.simulate(model, model.state(X1=x0, X2=y0), np.zeros(3), (0.0, 0.35), walls=[wall], restitution=e)
    assert res.status == "finished", res.message
    rec = res.impacts[0]
    t_star = np.sqrt(2 * (y0 - R) / G)
    v, a, I_G = G * t_star, 0.0 - (x0 + l / 2), m * l * l / 12
    lam = (1 + e) * v / (1 / m + a * a / I_G)
    vg, om = -v + lam / m, a * lam / I_G
    assert rec.time == pytest.approx(t_star, rel=1e-12)
    assert rec.joints == (3,)            # the column of link 1's closest point: its span, not a joint
    np.testing.assert_allclose(rec.points[0], (0.0, R, 0.0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.normals[0], (0.0, 1.0, 0.0), rtol=0, atol=1e-12)
    assert rec.impulses[0] == pytest.approx(lam, rel=1e-12)
    np.testing.assert_allclose(rec.qdot_after, (0.0, vg - om * l / 2, om), rtol=1e-12, atol=1e-12)
    # The rod then clears the obstacle: no point of it is ever inside (64 points per sample).
    x = np.linspace(0.0, l, 64)
    p = res.q[:, None, :2] + x[None, :, None] * np.stack((np.cos(res.q[:, 2]), np.sin(res.q[:, 2])), axis=1)[:, None]
    assert np.min(np.hypot(p[..., 0], p[..., 1]) - R) >= -res.settings["contact_tol"]


@pytest.mark.parametrize("mu", [0.1, 2.0])
def test_rod_sliding_onto_a_rough_post_obeys_coulomb_in_the_impact(mu):
    """The rod of the test above, moving sideways at u = 0.5 m/s as it falls, strikes a rough post (mu = 0.1:
    it slides through the impact; mu = 2: it sticks) with e = 0.5. At the contact the tangent t = X1 is
    along G -> contact (r = (a, 0)), so the normal and tangential problems decouple (r x t = 0):

        P_n = (1 + e) v / (1 / m + a^2 / I_G)   (as above, a = -(x0 + l/2 + u t*))
        Moreau-Glocker (friction.py): the average U_t = (u+ + e u-) / (1 + e) is 0 when sticking, which
        needs f = (1 + e) m u <= mu P_n; then u+ = -e u, else f = mu P_n and u+ = u - mu P_n / m.

    X1' after the impact is u+ (the tangential impulse turns nothing: r x t = 0); X2', theta_1' as above."""
    model = planar_rod()
    x0, y0, R, l, m, u, e = -0.3, 0.5, 0.1, 1.0, 1.0, 0.5, 0.5
    wall = gi.Circle(R, (0.0, 0.0), inside=False, friction=mu)
    res = gi.simulate(model, model.state(X1=x0, X2=y0), model.state(X1=u), (0.0, 0.3), walls=[wall], restitution=e)
    assert res.status == "finished", res.message
    rec = res.impacts[0]
    t_star = np.sqrt(2 * (y0 - R) / G)
    v, a, I_G = G * t_star, -(x0 + l / 2 + u * t_star), m * l * l / 12
    Pn = (1 + e) * v / (1 / m + a * a / I_G)
    stick = (1 + e) * m * u <= mu * Pn
    assert stick == (mu > 1.0)
    u_after = -e * u if stick else u - mu * Pn / m
    vg, om = -v + Pn / m, a * Pn / I_G
    assert rec.time == pytest.approx(t_star, rel=1e-12) and rec.joints == (3,)
    assert rec.impulses[0] == pytest.approx(Pn, rel=1e-9)
    np.testing.assert_allclose(rec.qdot_after, (u_after, vg - om * l / 2, om), rtol=1e-9, atol=1e-9)


def test_rod_balanced_on_a_rough_cylinder_pivots_about_its_end():
    """A rod (l = 1 m, m = 1 kg) stands on its end O_1 on top of a rough obstacle cylinder (Circle,
    inside=False, R = 0.2 m, mu = 1), tilted by theta_0 = 0.05 rad from the vertical, at rest.

    A rod lying *across* the cylinder and rocking on it would need resting contact along a link's
    span (issue 25 item 1: not yet modelled; an accumulation there stops the run "zeno"), so this is
    the configuration the package supports: the end O_1 rests and sticks, a pivot at (0, R). Closed
    form (rigid rod about a fixed end, theta from the vertical):

        I_O theta'' = m g (l / 2) sin theta,  I_O = m l^2 / 3   ->   theta'' = (3 g / 2 l) sin theta
        theta'^2 = (3 g / l) (cos theta_0 - cos theta)            (energy)
        normal force  N = m (g + a_G2),  friction  F = m a_G1,
        a_G = (l / 2) (theta'' cos theta - theta'^2 sin theta, -theta'' sin theta - theta'^2 cos theta)

    (small angles: theta = theta_0 cosh(sqrt(3 g / 2 l) t)). theta(t) is checked against scipy's
    solution of the ODE to 1e-8 rad (the run's rtol), N against its closed form to 1e-6 relative,
    O_1 stays at (0, R) (stick: no slip; contact: no drift beyond contact_tol), |F| <= mu N."""
    model = planar_rod()
    R, l, m, th0 = 0.2, 1.0, 1.0, 0.05
    wall = gi.Circle(R, (0.0, 0.0), inside=False, friction=1.0)
    res = gi.simulate(model, model.state(X1=0.0, X2=R, theta_1=np.pi / 2 - th0), np.zeros(3), (0.0, 0.8),
                      walls=[wall], restitution=0.0)
    assert res.status == "finished", res.message
    assert res.impacts == [] and res.resting_time == pytest.approx(0.8, rel=1e-12)
    th = np.pi / 2 - res.q[:, 2]
    ref = solve_ivp(lambda t, y: [y[1], 1.5 * G / l * np.sin(y[0])], (0.0, 0.8), [th0, 0.0], rtol=1e-12,
                    atol=1e-14, dense_output=True).sol(res.t)[0]
    assert np.max(np.abs(th - ref)) <= 1e-8
    assert th[-1] > 0.5                                     # it has fallen 10 times its initial tilt
    assert np.max(np.abs(res.q[:, :2] - (0.0, R))) <= res.settings["contact_tol"]
    w2 = 3 * G / l * (np.cos(th0) - np.cos(th))
    wd = 1.5 * G / l * np.sin(th)
    N = m * (G - l / 2 * (wd * np.sin(th) + w2 * np.cos(th)))
    F = m * l / 2 * (wd * np.cos(th) - w2 * np.sin(th))
    np.testing.assert_allclose(res.contact_forces[:, 0, 0], N, rtol=1e-6)
    Ft = np.linalg.norm(res.friction_forces[:, 0, 0], axis=-1)
    np.testing.assert_allclose(Ft, np.abs(F), rtol=1e-6, atol=1e-9)
    assert np.all(Ft <= 1.0 * N)


@pytest.mark.filterwarnings("ignore::gibbsimpact.ValidityWarning")   # span impacts of a modal link (expected)
def test_mixed_containers_obstacles_and_plane_conserve_energy_at_e1():
    """Case 1's flexible two-link chain (2 clamped-clamped modes) inside a circle of radius 1.2 m, around
    an obstacle post (R = 0.15 m) and a ball (R = 0.1 m), above a floor: with e = 1 every impact keeps
    the energy, so the total energy stays at its start value to 1e-9 of the largest kinetic energy through
    the run (measured 3.3e-12 at rtol = 1e-12)."""
    model = two_link_circle_model()
    q = model.state(X1=-0.9, X2=0.3, theta_1=-0.2, theta_2=0.5)
    qd = model.state(X1=1.0, X2=-0.5, theta_1=1.5)
    walls = [gi.Circle(1.2), gi.Circle(0.15, (0.1, -0.3), inside=False),
             gi.Sphere(0.1, (-0.95, -0.45, 0.0), inside=False), gi.Plane((0.0, -0.8, 0.0), (0.0, 1.0, 0.0))]
    res = gi.simulate(model, q, qd, (0.0, 1.5), walls=walls, restitution=1.0, rtol=1e-12, atol=1e-13)
    assert res.status == "finished", res.message
    hit = {w for rec in res.impacts for w in rec.wall}
    assert {1, 2} <= hit and len(hit) >= 3, hit          # both obstacles and one other wall are struck
    E = res.energy().total
    assert np.max(np.abs(E - E[0])) <= 1e-9 * np.max(np.abs(res.energy().kinetic))


def test_spatial_rod_strikes_a_ball_off_its_plane():
    """A free rod in space (l = 1 m, m = 1 kg, rotary inertia j = (5e-5, 2.5e-5, 2.5e-5) kg m, so
    I_perp = m l^2 / 12 + j_z l about both axes normal to it) falls along -X2 with its axis along X1 onto
    an obstacle ball of R = 0.1 m centred z_c = 0.06 m off its vertical plane, below x = 0 (a = 0.2 m
    right of G). Closed form: it touches when the axis is R from the centre, at height y* = sqrt(R^2 -
    z_c^2) = 0.08 m, so t* = sqrt(2 (y0 - y*) / g); n = (0, y*, -z_c) / R; v_n = -g t* y* / R; r = (a, 0, 0)
    from G, |r x n| = a with r x n normal to the rod, so 1 / m_eff = 1 / m + a^2 / I_perp and
    Lambda = (1 + e) |v_n| m_eff; G's velocity after is (0, -g t*, 0) + Lambda n / m."""
    j = (5e-5, 2.5e-5, 2.5e-5)
    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, rotary_inertia=j)]), gravity=(0.0, -G, 0.0))
    x0, y0, R, zc, e, m, l = -0.3, 0.5, 0.1, 0.06, 0.5, 1.0, 1.0
    ball = gi.Sphere(R, (0.0, 0.0, zc), inside=False)
    res = gi.simulate(model, model.state(X1=x0, X2=y0), np.zeros(model.n_dof), (0.0, 0.3), walls=[ball],
                      restitution=e)
    assert res.status == "finished", res.message
    rec = res.impacts[0]
    ys = np.sqrt(R * R - zc * zc)
    t_star = np.sqrt(2 * (y0 - ys) / G)
    n = np.array([0.0, ys, -zc]) / R
    vn = -G * t_star * ys / R
    a, I_perp = 0.0 - (x0 + l / 2), m * l * l / 12 + j[2] * l
    lam = (1 + e) * abs(vn) / (1 / m + a * a / I_perp)
    assert rec.time == pytest.approx(t_star, rel=1e-12) and rec.joints == (3,)
    np.testing.assert_allclose(rec.normals[0], n, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.points[0], (0.0, ys, 0.0), rtol=0, atol=1e-12)
    assert rec.v_before[0] == pytest.approx(vn, rel=1e-12) and rec.impulses[0] == pytest.approx(lam, rel=1e-12)
    # Until the impact the rod only translates: q* = (x0, y*, 0, 0, 0, 0).
    p_after = model.linear_momentum(model.state(X1=x0, X2=ys), rec.qdot_after)
    np.testing.assert_allclose(p_after, m * np.array([0.0, -G * t_star, 0.0]) + lam * n, rtol=0, atol=1e-12)
