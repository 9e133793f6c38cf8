"""contact/span_cells.py: several contact candidates along one link (issue 25 item 1), one per cell, each the
lowest point of its closed cell, against a second route sharing no code with the search: the public
material points on a dense grid; and a flexible beam lying across two posts resting on both at once."""

from __future__ import annotations

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.contact.candidates import material_jacobian, material_points
from gibbsimpact.contact.span_cells import cell_count, link_cells, link_minima
from gibbsimpact.contact.span_resting import span_point_terms


def _beam(elements=4, stiffened=False):
    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=elements, geometric_stiffening=stiffened)
    return gi.Model(gi.Chain([link], base="planar"), gravity=(0.0, -9.81, 0.0))


def test_cell_count_follows_the_mode_content():
    """m_i: one cell per element; floor(beta_max l / (2 pi)) + 1 for modes (clamped-clamped 1: beta l = 4.730,
    one cell; 3: beta l = 10.996, two); one for a rigid link."""
    assert cell_count(_beam(4), 0) == 4
    modal = lambda n: gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y", n)])]))  # noqa: E731
    assert cell_count(modal(1), 0) == 1 and cell_count(modal(3), 0) == 2
    assert cell_count(gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0)])), 0) == 1
    assert link_cells(_beam(2), [0]) == [(0, 0, 2), (0, 1, 2)]


@pytest.mark.parametrize("stiffened", [False, True])
def test_every_cell_minimum_against_a_dense_grid(stiffened):
    """A bent 4-element beam above a floor and inside a circle: each cell's (gap, x) equals the minimum of the
    public material points' gaps over that closed cell on a grid of spacing dx = 2.5e-5 m, within the grid's
    own error 1/2 max|g''| dx^2 (< 5e-10 m for |g''| < 1 /m) plus round-off; an interior minimum is
    stationary, a cell's end is not."""
    model = _beam(4, stiffened)
    rng = np.random.default_rng(1)
    q = np.zeros(model.n_dof)
    q[:3] = (-0.5, 0.02, 0.001)
    q[3:] = rng.normal(scale=0.003, size=model.n_dof - 3)
    walls = [gi.Plane((0, 0, 0), (0, 1, 0)), gi.Circle(2.0, (0.0, 1.9))]
    cm = link_minima(model, q, walls, link_cells(model, [0]))
    xs = np.linspace(0.0, 1.0, 40001)
    P = material_points(model, q, 0, xs)
    for w, wall in enumerate(walls):
        g = wall.gap(P)
        for c in range(4):
            sel = (xs >= c / 4 - 1e-12) & (xs <= (c + 1) / 4 + 1e-12)
            j = np.argmin(g[sel])
            assert cm.gap[w, c] <= g[sel][j] + 1e-14
            assert g[sel][j] - cm.gap[w, c] < 5e-10
            assert cm.x[w, c] == pytest.approx(xs[sel][j], abs=2e-4)
            at_end = min(abs(cm.x[w, c] - c / 4), abs(cm.x[w, c] - (c + 1) / 4)) < 1e-12
            assert cm.stationary[w, c] == (not at_end)
            assert cm.inside[w, c] == (0.0 < cm.x[w, c] < 1.0)
    assert cm.stationary.any() and not cm.stationary.all()


def test_a_cell_column_is_continuous_when_its_minimum_crosses_the_cell_end():
    """g_wic(q) = min over a closed cell is continuous: along a path on which the beam's interior minimum moves
    from cell 2 into cell 3 (a rotation of the bent beam), no column jumps by more than the 1-Lipschitz bound
    |dg| <= |dp| <= (1 + l) |dq| (a translation moves a point 1:1, a rotation by its lever arm <= l)."""
    model = _beam(4)
    q = np.zeros(model.n_dof)
    q[:3] = (-0.5, 0.02, 0.0)
    nodes = np.array([0.25, 0.5, 0.75, 1.0])
    q[3::2], q[4::2] = -0.02 * nodes * (1.0 - nodes), -0.02 * (1.0 - 2.0 * nodes)   # a sag v = -0.02 x (1 - x)
    cells = link_cells(model, [0])
    floor = [gi.Plane((0, 0, 0), (0, 1, 0))]
    thetas = np.linspace(-0.01, 0.01, 401)
    G, X = [], []
    for th in thetas:
        q[2] = th
        cm = link_minima(model, q, floor, cells)
        G.append(cm.gap[0])
        X.append(cm.x[0])
    G, X = np.array(G), np.array(X)
    assert np.abs(np.diff(G, axis=0)).max() <= 2.0 * (thetas[1] - thetas[0])
    # The interior minimum x = (1 - theta / 0.02) / 2 did cross: the lowest column moved from cell 3 to cell 2.
    low = np.argmin(G, axis=1)
    assert set(low) >= {1, 2}


def test_a_dip_growing_out_of_a_resting_end_is_seen_from_its_start():
    """Issue 25 item 5: a fixed-base 2-element stiffened arm tilted onto its tip; turning it (theta from
    -0.0571 to -0.0570 rad) a dip grows out of the tip on the foreshortened centreline while the linear
    centreline's samples (the search's) still slope out of the link at the tip. Cell 2's column must equal
    the public material points' minimum over the closed cell (grid dx = 2.5e-5 m, error < 5e-10 m) at
    every angle, from the dip's birth at the tip: on main it held the tip's gap until the dip was 7e-7 m
    deep, so the arm pressed onto the floor (tau = -2 N m, docs/benchmarks.md) went 1.1e-6 m below
    the floor with no event."""
    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=2)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.02), 0.0)), gravity=(0.0, -9.81, 0.0))
    assert model.chain.links[0].stiffened
    floor, cells = [gi.Plane((0, 0, 0), (0, 1, 0))], link_cells(model, [0])
    xs = np.linspace(0.5, 1.0, 20001)
    deepest = 0.0
    for th in np.linspace(-0.05712, -0.05700, 25):
        q = np.array([th, 0.0113, 0.0416, 0.0371, 0.0571])
        g = material_points(model, q, 0, xs)[:, 1]
        cm = link_minima(model, q, floor, cells)
        assert cm.gap[0, 1] <= g.min() + 1e-14
        assert g.min() - cm.gap[0, 1] < 5e-10
        assert cm.x[0, 1] == pytest.approx(xs[np.argmin(g)], abs=2e-4)
        if g[-1] - g.min() > 1e-9:  # a dip beside the tip: interior, stationary
            assert cm.stationary[0, 1] and cm.inside[0, 1]
        deepest = max(deepest, g[-1] - g.min())
    assert deepest > 1e-6   # the dip did grow (not vacuous)


def test_a_fixed_material_point_has_no_sliding_term():
    """span_point_terms(stationary=False) at a cell's end: W^T qddot + c is the second derivative of the gap of
    that material point along q(t) = q + t qd + t^2/2 qdd (central differences of the public material points,
    step 1e-4 s: truncation ~ tau^2 g'''' / 12 ~ 2e-8, round-off ~ 4 eps g / tau^2 ~ 1e-8; tolerance 1e-7 m/s^2)."""
    model = _beam(4)
    wall = gi.Circle(0.2, (0.0, 0.0), inside=False)
    rng = np.random.default_rng(3)
    q = np.zeros(model.n_dof)
    q[:3] = (-0.5, 0.25, 0.02)
    q[3:] = rng.normal(scale=0.003, size=model.n_dof - 3)
    qd, qdd = rng.normal(scale=0.3, size=model.n_dof), rng.normal(scale=0.5, size=model.n_dof)
    x = 0.5
    _, J, n, pd, _, g, c = span_point_terms(model, wall, q, qd, 0, x, stationary=False)
    tau = 1e-4
    G = [float(wall.gap(material_points(model, q + t * qd + 0.5 * t * t * qdd, 0, [x]))[0]) for t in (-tau, 0.0, tau)]
    assert G[1] == pytest.approx(g, abs=1e-15)
    assert (G[2] - 2 * G[1] + G[0]) / tau**2 == pytest.approx(n @ J @ qdd + c, abs=1e-7)


def _momentum(model, q, qd):
    """Linear momentum (3,) [kg m/s] of the single uniform link (mu = 1 kg/m): the integral of the material
    points' velocities, 2-point Gauss per element (exact: the velocity is a cubic in x on an element)."""
    ne = model.chain.links[0].elements
    gx = 0.5 * (1.0 + np.array([-1.0, 1.0]) / np.sqrt(3.0))
    xs = ((np.arange(ne)[:, None] + gx[None, :]) / ne).ravel()
    return sum(material_jacobian(model, q, qd, 0, x)[1] @ qd for x in xs) / (2 * ne)


def _gauss(model, n=4):
    """Abscissae x [m] and weights [m] of n-point Gauss rules on every element of the single 1 m link (exact for
    polynomials of degree 2 n - 1 in x on an element)."""
    ne = model.chain.links[0].elements
    gx, gw = np.polynomial.legendre.leggauss(n)
    h = 1.0 / ne
    return ((np.arange(ne)[:, None] + 0.5 * (1.0 + gx[None, :])) * h).ravel(), np.tile(0.5 * h * gw, ne)


def _angular_momentum(model, q, qd):
    """z-component of the angular momentum [kg m^2/s] about the world origin of the single uniform link (mu = 1 kg/m,
    no rotary inertia): the integral of (p x pdot)_z over the centreline, 4-point Gauss per element (exact: the
    integrand is of degree 6 in x on an element)."""
    total = 0.0
    for x, wt in zip(*_gauss(model)):
        p, J, _ = material_jacobian(model, q, qd, 0, x)
        v = J @ qd
        total += wt * (p[0] * v[1] - p[1] * v[0])
    return total


def _centre_x(model, q):
    """x [m] of the mass centre of the single uniform 1 kg link (Gauss, exact for the cubic centreline)."""
    x, wt = _gauss(model)
    return float(wt @ material_points(model, q, 0, x)[:, 0])


def _simpson(f, dt):
    """Simpson's rule over samples f (K, ...) spaced dt (K odd)."""
    return dt / 3 * (f[0] + f[-1] + 4 * f[1:-1:2].sum(axis=0) + 2 * f[2:-1:2].sum(axis=0))


@pytest.mark.slow
def test_a_beam_across_two_posts_rests_on_both_at_once(tmp_path):
    """Issue 25 item 1: a 2-element beam (1 m, 1 kg, EI = 20 N m^2) laid at rest across two posts (R = 0.05 m at
    x = +-0.3 m) rests on one span point per post at once, cells 1 and 2 of the same link (one column per
    (wall, link) rested only one of them: the other sank into micro-impacts). Over 20 ms it vibrates on them
    without an impact, no material point (64, public kinematics) sinks into a post by more than contact_tol,
    both forces stay positive, and the recorded forces carry the beam's momentum: p(T) - p(0) equals
    int (F_1 n_1 + F_2 n_2 - m g) dt (Simpson's rule on the 1e-4 s samples; its error h^4/180 T max|F''''|
    for the beam's vibration below ~2000 rad/s is < 1e-4 N s against an impulse of 0.2 N s). Where the forces act
    (Result.contact_abscissae) is checked the same way: each recorded point lies on its post (|g| <= contact_tol) in
    its own cell, and the forces' moments carry the angular momentum about the origin, H(T) - H(0) =
    int sum_k (p_k x F_k n_k)_z - (p_G x m g)_z dt (same error bound, times the lever arm <= 0.5 m)."""
    model = _beam(2)
    R = 0.05
    posts = [gi.Circle(R, (-0.3, -R), inside=False), gi.Circle(R, (0.3, -R), inside=False)]
    q0 = model.state(X1=-0.5, X2=0.0)
    dt, T = 1e-4, 0.02
    res = gi.simulate(model, q0, np.zeros(model.n_dof), (0.0, T), walls=posts, restitution=0.0, output_dt=dt)
    assert res.status == "finished" and len(res.impacts) == 0
    F = res.contact_forces        # (K, W, C): columns O1, O2, link 1.1, link 1.2
    assert F.shape[2] == 4
    assert np.all(F[:, 0, 2] > 0.5) and np.all(F[:, 1, 3] > 0.5)
    xs = np.linspace(0.0, 1.0, 64)
    cells = link_cells(model, [0])
    X = res.contact_abscissae      # (K, W, C) [m]: where the span forces act, NaN elsewhere
    assert X.shape == F.shape and np.isnan(X[:, :, :2]).all() and np.isnan(X[:, 0, 3]).all()
    assert np.all((X[:, 0, 2] > 0.0) & (X[:, 0, 2] < 0.5)) and np.all((X[:, 1, 3] > 0.5) & (X[:, 1, 3] < 1.0))
    force, torque = np.zeros((len(res.t), 3)), np.zeros(len(res.t))
    for k, q in enumerate(res.q):
        P = material_points(model, q, 0, xs)
        assert min(float(w.gap(P).min()) for w in posts) > -1e-9
        cm = link_minima(model, q, posts, cells)
        force[k] = F[k, 0, 2] * cm.normal[0, 0] + F[k, 1, 3] * cm.normal[1, 1]
        for w, c in ((0, 2), (1, 3)):
            p = material_points(model, q, 0, [X[k, w, c]])
            assert abs(float(posts[w].gap(p)[0])) <= 1e-9
            f = F[k, w, c] * posts[w].normal(p)[0]
            torque[k] += p[0, 0] * f[1] - p[0, 1] * f[0]
        torque[k] -= 9.81 * _centre_x(model, q)     # (p_G x (0, -m g, 0))_z, m = 1 kg
    force[:, 1] -= 9.81
    assert len(res.t) % 2 == 1 and np.allclose(np.diff(res.t), dt)
    dp = _momentum(model, res.q[-1], res.qdot[-1]) - _momentum(model, res.q[0], res.qdot[0])
    np.testing.assert_allclose(dp, _simpson(force, dt), atol=1e-4)
    dH = _angular_momentum(model, res.q[-1], res.qdot[-1]) - _angular_momentum(model, res.q[0], res.qdot[0])
    assert dH == pytest.approx(_simpson(torque, dt), abs=5e-5)
    # The abscissae in contact_forces.csv and result.npz.
    rows = np.genfromtxt(res.to_csv(tmp_path)["contact_forces"], delimiter=",", names=True)
    np.testing.assert_array_equal(rows["x_w1_link11_m"], X[:, 0, 2])   # genfromtxt drops the '.' of link1.1
    assert np.isnan(rows["x_w1_link12_m"]).all() and np.isnan(rows["x_w2_link11_m"]).all()
    res.save(tmp_path / "r.npz")
    back = gi.load_result(tmp_path / "r.npz")
    np.testing.assert_array_equal(back.contact_abscissae, X)


def test_a_refined_cell_minimum_is_not_refined_again(monkeypatch):
    """The search's Newton refinement runs on the foreshortened centreline, so the foreshortening pass of the cells
    (span_cells._foreshorten_cells) evaluates that curve once per call, at the cells' points; a second Newton pass
    from the converged minimum moved x by an ulp and evaluated it again (docs/benchmarks.md, 1.49 -> 1.16 ms a call).
    The arm of tests/contact/test_closest_points.py, its dip refined in cell 3 (stationary)."""
    from gibbsimpact.contact import closest_points as cp

    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=3)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.0668636))), gravity=(0.0, -9.81, 0.0))
    q = np.array([-0.1, -0.008082050196454086, -0.02424615058936226, 0.0, 0.09698460235744903,
                  0.03307266072537224, 0.10033467208545054])
    calls = []
    curve = cp._foreshortened_curve
    monkeypatch.setattr(cp, "_foreshortened_curve", lambda *a: calls.append(a[3].copy()) or curve(*a))
    cm = link_minima(model, q, [gi.Plane((0, 0, 0), (0, 1, 0))], link_cells(model, [0]))
    assert cm.stationary[0].tolist() == [False, False, True] and cm.gap[0, 2] == pytest.approx(1e-4, abs=1e-6)
    assert len(calls) == 1
