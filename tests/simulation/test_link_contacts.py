"""Contact along links (issue 9 item 2): a flexible link that bulges into a wall between its joints.

Positions here come from the public kinematics (transforms, model.link_deflection), not from
gibbsimpact.linkpoints, which the event loop uses.
"""

import warnings

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.kinematics import transforms

G = 9.81


def points_along(model, q, n=64):
    """(n_links, n, 3) world points p(x) = T_i (x, v, w) at n abscissae per link [m]."""
    T = transforms(model, q)
    out = []
    for i, lk in enumerate(model.chain.links):
        x = np.linspace(0.0, lk.length, n)
        v, w = gi.model.link_deflection(model, q, i, x)
        r = np.stack((x, v, w, np.ones_like(x)), axis=1)
        out.append((r @ T[i].T)[:, :3])
    return np.array(out)


def flat_link():
    link = gi.Link(1.0, 1.0, 50.0, modes=[gi.Mode("clamped-clamped", "y")], rotary_inertia=(1e-4, 0, 0))
    return gi.Model(gi.Chain([link]), gravity=(0.0, -G, 0.0))


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_flexible_link_falling_flat_hits_at_mid_span_first(e):
    # A clamped-clamped link lying flat 1 mm above a floor, its first mode moving towards it
    # (delta_dot < 0: the middle goes down, the ends stay): the middle reaches the floor first.
    model = flat_link()
    q0 = model.state(X1=-0.5, X2=1e-3)
    qd0 = model.state(delta_1_1=-0.5)
    floor = gi.Plane((0, 0, 0), (0, 1, 0))
    res = gi.simulate(model, q0, qd0, (0.0, 0.05), walls=[floor], restitution=e)
    assert res.status == "finished", res.message
    first = res.impacts[0]
    P = model.n_joints
    assert first.joints == (P + 1,)  # the closest point of link 1, not a joint
    x_hit = first.points[0, 0] + 0.5  # abscissa along the link (O1 at X1 = -0.5, the link along X1)
    assert x_hit == pytest.approx(0.5, abs=1e-3)  # mid-span (symmetric shape; the rigid part is level)
    assert abs(first.points[0, 1]) <= 1e-9
    # Newton's law at that point, from the velocity of the material point by central differences
    # of p(q + s qdot) at the impact configuration (public kinematics only).
    k = int(np.nonzero(res.t == first.time)[0][0])
    q = res.q[k]
    T0 = transforms(model, q)[0]

    def height(qq, x):
        v, _ = gi.model.link_deflection(model, qq, 0, np.array([x]))
        return float((transforms(model, qq)[0] @ np.array([x, v[0], 0.0, 1.0]))[1])

    x_loc = float(np.linalg.solve(T0[:3, :3], first.points[0] - T0[:3, 3])[0])
    h = 1e-6
    vn = [(height(q + h * qd, x_loc) - height(q - h * qd, x_loc)) / (2 * h) for qd in (first.qdot_before, first.qdot_after)]
    assert vn[0] < -0.1
    assert vn[1] == pytest.approx(-e * vn[0], rel=1e-7)
    assert first.energy_after.total == pytest.approx(first.energy_before.total, rel=1e-12) if e == 1.0 else \
        first.energy_after.total < first.energy_before.total
    # No material point (64 per link) beyond the floor at any stored sample.
    heights = np.array([points_along(model, qk)[..., 1].min() for qk in res.q])
    assert heights.min() >= -1e-9


def test_link_contacts_can_be_switched_off():
    # joints only: the bulge goes through the floor unnoticed (the published model), which the
    # penetration check between events catches.
    model = flat_link()
    res = gi.simulate(model, model.state(X1=-0.5, X2=1e-3), model.state(delta_1_1=-0.5), (0.0, 0.05),
                      walls=[gi.Plane((0, 0, 0), (0, 1, 0))], link_contacts=False)
    assert all(j <= model.n_joints for r in res.impacts for j in r.joints)
    heights = np.array([points_along(model, qk)[..., 1].min() for qk in res.q])
    assert heights.min() < -1e-4


def test_a_link_starting_beyond_a_wall_is_refused():
    model = flat_link()
    with pytest.raises(ValueError, match="link 1 bends .* beyond wall 1"):
        gi.simulate(model, model.state(X1=-0.5, X2=1e-3, delta_1_1=-0.01), np.zeros(7), (0.0, 0.01),
                    walls=[gi.Plane((0, 0, 0), (0, 1, 0))])


def test_link_impacts_are_stored_and_drawn(tmp_path):
    model = flat_link()
    res = gi.simulate(model, model.state(X1=-0.5, X2=1e-3), model.state(delta_1_1=-0.5), (0.0, 0.01),
                      walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=0.5)
    back = gi.load_result(res.save(tmp_path / "r.npz"))
    for a, b in zip(res.impacts, back.impacts):
        assert a.joints == b.joints
        np.testing.assert_array_equal(a.points, b.points)
    from gibbsimpact.plotting.labels import _contacts_text

    assert _contacts_text(res, res.impacts[0]) == "link 1"
    fig = res.plot("configurations")
    assert any("link 1" in ax.get_title() for ax in fig.axes)


# -- the skip rule of contacts.Contacts (a link is searched only where it can touch) ------------

from link_models import MODELS, _obstacles_near, _state, _walls_hugging, _walls_near  # noqa: E402

from gibbsimpact.contact import candidates as lp  # noqa: E402  (search_interval, end_joints only)
from gibbsimpact.simulation.contacts import Contacts  # noqa: E402
from gibbsimpact.dynamics.kinematics import joint_positions  # noqa: E402
from gibbsimpact.dynamics.link_points import material_points  # noqa: E402


def _interior_gaps(model, q, wall, i, n=2001):
    """s (n,) in (0, 1) and the gaps (n,) [m] of link i's material points at the abscissae
    x = a + s (b - a) of its search interval [a, b], farther than 1e-6 l from both ends; points
    from the public kinematics (transforms, model.link_deflection)."""
    a, b = lp.search_interval(model, q)
    l = model.chain.links[i].length
    x = np.linspace(a[i] + 1e-6 * l, b[i] - 1e-6 * l, n)
    v, w = gi.model.link_deflection(model, q, i, x)
    p = (np.stack((x, v, w, np.ones_like(x)), axis=1) @ transforms(model, q)[i].T)[:, :3]
    return (x - a[i]) / (b[i] - a[i]), wall.gap(p)


def _walls_at_joints(model, q, rng):
    """Walls through joint points: a plane and a circle or sphere through the outermost joint
    (gap 0 there, the other joints inside), and a circle or sphere through both ends of a
    flexible link (the chord of length L at depth ~L^2 / 8R: what the sagitta rule (4) uses)."""
    P = joint_positions(model, q)
    nv = rng.normal(size=3)
    if model.planar:
        nv[2] = 0.0
    nv /= np.linalg.norm(nv)
    out = [gi.Plane(P[np.argmin(P @ nv)], nv)]
    c = P.mean(axis=0) + rng.normal(scale=0.1, size=3)
    out += [gi.Circle(np.max(np.hypot(*(P[:, :2] - c[:2]).T)), c[:2]), gi.Sphere(np.max(np.linalg.norm(P - c, axis=1)), c)]
    ends = lp.end_joints(model)
    f = [i for i in range(model.n_links) if model.delta_index[i].size and min(ends[i]) >= 0]
    if f:
        i = f[rng.integers(len(f))]
        A, B = P[ends[i, 0]], P[ends[i, 1]]
        d = (B - A)[:2]
        perp = np.array([-d[1], d[0]]) / np.linalg.norm(d) * rng.choice([-1.0, 1.0])
        mid = 0.5 * (A + B)[:2] + perp * np.linalg.norm(d) * rng.uniform(0.3, 2.0)
        out.append(gi.Circle(float(np.hypot(*(A[:2] - mid))), mid))
        c3 = 0.5 * (A + B) + np.append(perp, 0.0) * np.linalg.norm(B - A) * rng.uniform(0.3, 2.0)
        out.append(gi.Sphere(float(np.linalg.norm(A - c3)), c3))
    return out


@pytest.mark.parametrize("name", [m for m in MODELS if m != "rigid"])
def test_skip_rule_is_a_valid_lower_bound(name, rng):
    """At random deflected states and walls through the joints or hugging a bulge, for every
    flexible link and wall (2001 interior points per link, public kinematics):

    * (2): G(s) >= g(c(s)) - Lam s (1 - s), c(s) the chord of the end joints, Lam from the tables;
    * a skipped pair has G(s) > t = min(g_A, g_B, refine_below) at every interior point, so its
      column is NOT_INTERIOR or above refine_below (the Contacts docstring's argument).

    And the rule is not idle: it skips pairs with a joint within refine_below of the wall
    (which the old bound (1) always searched) and searches pairs that do touch."""
    model = MODELS[name]()
    ends = lp.end_joints(model)
    n_skip_near = n_search = n_checked = 0
    for trial in range(10):
        q, _ = _state(model, rng, delta=(0.002, 0.02, 0.08)[trial % 3])
        P = joint_positions(model, q)
        walls = _walls_at_joints(model, q, rng) + _walls_near(model, q, rng)
        flex = [i for i in range(model.n_links) if model.delta_index[i].size]
        walls += _walls_hugging(model, q, flex[trial % len(flex)], rng)
        # One Contacts for the trial's walls (its tables cost 40 ms on fe-off-grid; one per wall took 4.4 of the
        # test's 5.4 s): the rule and Lam are per (wall, link) pair, the same as with each wall alone.
        ct = Contacts(model, walls)
        skips = ct.skipped(q)
        lam = ct._link_bounds(q[None], np.array([w.gap(P) for w in walls])[None], P[None])[0][0]
        for wall, skip in zip(walls, skips):
            gj = wall.gap(P)
            for f, i in enumerate(ct.flex):
                s, G = _interior_gaps(model, q, wall, i)
                if min(ends[i]) < 0:
                    assert not skip[f]   # a Pb link on the base: always searched
                    continue
                gA, gB = gj[ends[i]]
                A, B = P[ends[i]]
                chord = wall.gap((1.0 - s)[:, None] * A + s[:, None] * B)
                bound = chord - lam[f] * s * (1.0 - s)
                assert np.all(G >= bound - 1e-12), (name, trial, wall, i, np.min(G - bound))
                t = min(gA, gB, ct.refine_below)
                n_checked += 1
                if skip[f]:
                    assert G.min() > t - 1e-12, (name, trial, wall, i, G.min(), t)
                    n_skip_near += min(gA, gB) <= ct.refine_below
                else:
                    n_search += 1
    assert n_checked >= 50 and n_skip_near >= 3 and n_search >= 3, (n_checked, n_skip_near, n_search)


def test_skip_rule_bounds_a_stiffened_link(rng):
    """A stiffened link's points (the public material points: x + u_f, v, w) leave the chord along the axis
    by a(s) = u_f(s l) - s u_f(l) too; with Lam + Lam_f, Lam_f = l/2 (sum_k |delta_k| mu_k)^2 (Contacts
    docstring), (2) G(s) >= g(c(s)) - Lam s (1 - s) holds at 2001 points for planes through the tip at every
    angle to the link (along its axis, where phi has no part), and a skipped pair has G > t there. Without
    Lam_f the bound fails by 0.60 m at the last state (deflections ~1 m: a is quadratic, Lam linear in delta;
    found among 60 random states of scale 0.5), so the test is not vacuous."""
    link = gi.Link(1.0, 1.0, 20.0, elements=3)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.0), 0.0)))
    s = np.linspace(1e-6, 1.0 - 1e-6, 2001)
    worst_without = np.inf
    states = [np.append(0.0, rng.normal(scale=amp, size=model.n_dof - 1)) for amp in (0.002, 0.02, 0.2)
              for _ in range(6)]
    for q in states + [np.array([0.0, 1.38, 0.52, -0.39, -0.67, -0.49, -0.01])]:
        P = joint_positions(model, q)
        A, B = P[0], P[1]
        G_pts = material_points(model, q, 0, s * link.length)
        for angle in np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False):
            axis = (B - A) / np.linalg.norm(B - A)
            normal = np.cos(angle) * axis + np.sin(angle) * np.array([-axis[1], axis[0], 0.0])
            wall = gi.Plane(tuple(B), tuple(normal))
            ct = Contacts(model, [wall])
            G, chord, u = wall.gap(G_pts), wall.gap((1.0 - s)[:, None] * A + s[:, None] * B), s * (1.0 - s)
            lam = ct._link_bounds(q[None], wall.gap(P)[None, None], P[None])[0][0][0]
            assert np.all(G >= chord - lam * u - 1e-12), (q, angle, np.min(G - chord + lam * u))
            if ct.skipped(q)[0, 0]:
                assert G.min() > min(wall.gap(P).min(), ct.refine_below) - 1e-12
            ct._axial = None
            lam_old = ct._link_bounds(q[None], wall.gap(P)[None, None], P[None])[0][0][0]
            worst_without = min(worst_without, np.min(G - chord + lam_old * u))
    assert worst_without < -0.5


def test_skip_rule_bounds_a_pb_link_of_several_cells(rng):
    """(2) G(s) >= g(c(s)) - Lam s (1 - s) on a 2-element link behind a Pb guide (two cells), drawn in to
    d = 0.15 .. 0.3 of l = 0.6 m, bent by its slopes (e_k = delta_k d / l for a slope), against planes along its
    chord (2001 points, public kinematics). The tables used to scale the slopes by d / l once per cell, here
    (d / l)^2: Lam fell short of the bound by up to 0.016 m on these 20 states."""
    model = MODELS["R-Pb"]()
    ends, di = lp.end_joints(model), model.delta_index[1]
    s = np.linspace(1e-6, 1.0 - 1e-6, 2001)
    for _ in range(20):
        q = np.zeros(model.n_dof)
        q[model.theta_index[0]], q[model.theta_index[1]] = rng.uniform(-1.0, 1.0), rng.uniform(0.15, 0.3)
        q[di] = rng.normal(scale=0.05, size=di.size)
        q[di[0::2]] = rng.normal(scale=0.001, size=di[0::2].size)  # small deflections, large slopes
        P = joint_positions(model, q)
        A, B = P[ends[1]]
        a, b = lp.search_interval(model, q)
        x = a[1] + s * (b[1] - a[1])
        v, w = gi.model.link_deflection(model, q, 1, x)
        p = (np.stack((x, v, w, np.ones_like(x)), axis=1) @ transforms(model, q)[1].T)[:, :3]
        normal = np.array([A[1] - B[1], B[0] - A[0], 0.0]) / np.linalg.norm(B - A)
        for wall in (gi.Plane(tuple(A), tuple(normal)), gi.Plane(tuple(A), tuple(-normal))):
            ct = Contacts(model, [wall])
            chord = wall.gap((1.0 - s)[:, None] * A + s[:, None] * B)
            lam = np.array(ct._link_bounds(q[None], wall.gap(P)[None, None], P[None])[0][0])
            for f in [f for f, i in enumerate(ct.flex) if i == 1]:
                assert np.all(wall.gap(p) >= chord - lam[f] * s * (1.0 - s) - 1e-12), (q, f)


@pytest.mark.parametrize("name", list(MODELS))
def test_obstacle_skip_rule_is_a_valid_lower_bound(name, rng):
    """Rule (5) of contacts.Contacts on obstacles (inside=False): at random states with obstacles beside a
    link (clearance 1 mm to 0.3 m; 2001 interior points per link, public kinematics), a skipped pair has
    G(s) > t = min(g_A, g_B, refine_below) at every interior point; every link, rigid ones included,
    has a column; the rule skips far obstacles and searches near ones."""
    model = MODELS[name]()
    ends = lp.end_joints(model)
    n_skip = n_search = 0
    for trial in range(6):
        q, _ = _state(model, rng, delta=(0.002, 0.02, 0.08)[trial % 3])
        P = joint_positions(model, q)
        walls = _obstacles_near(model, q, trial % model.n_links, rng, clearance=(0.001, 0.02, 0.3)[trial % 3])
        for wall in walls:
            ct = Contacts(model, [wall])
            assert sorted(set(ct.flex)) == list(range(model.n_links))  # one column per cell of every link
            skip = ct.skipped(q)[0]
            gj = wall.gap(P)
            for f, i in enumerate(ct.flex):
                if min(ends[i]) < 0:
                    assert not skip[f]
                    continue
                G = _interior_gaps(model, q, wall, i)[1]
                t = min(gj[ends[i, 0]], gj[ends[i, 1]], ct.refine_below)
                if skip[f]:
                    assert G.min() > t - 1e-12, (name, trial, wall, i, G.min(), t)
                    n_skip += 1
                else:
                    n_search += 1
    assert n_skip >= 1 and n_search >= 1, (n_skip, n_search)


@pytest.mark.parametrize("name", ["circle_two_link", "sphere_single_link"])
def test_published_cases_with_link_contacts_are_the_joint_only_runs(name, monkeypatch):
    """Cases 1 and 2 never touch a wall between joints: with link contacts every sample, impact
    and nfev equal the joints-only run bitwise, and the skip rule never needs a link search
    (measured: 0 searches in 568 (case 1) and 1035 (case 2) link-column evaluations; the old
    bound (1) searched 461 times in case 1)."""
    from pathlib import Path

    case = gi.load_case(Path(__file__).resolve().parents[2] / "cases" / f"{name}.toml")
    off = case.simulate(link_contacts=False)
    searches = []
    real = lp.closest_points
    monkeypatch.setattr(lp, "closest_points", lambda *a, **k: searches.append(1) or real(*a, **k))
    on = case.simulate()
    assert on.status == off.status == "finished"
    assert on.nfev == off.nfev and on.n_steps == off.n_steps
    np.testing.assert_array_equal(on.t, off.t)
    np.testing.assert_array_equal(on.q, off.q)
    np.testing.assert_array_equal(on.qdot, off.qdot)
    assert [(r.time, r.joints) for r in on.impacts] == [(r.time, r.joints) for r in off.impacts]
    for a, b in zip(on.impacts, off.impacts):
        np.testing.assert_array_equal(a.qdot_after, b.qdot_after)
    assert len(searches) == 0


def test_issue25_item5_dip_out_of_a_resting_end_is_caught_on_the_wall():
    """Issue 25 item 5 (the random tester's reproducer): link 1 rests on the floor through O1 and O2
    (e = 0); link 2 turns about O2 and a dip grows out of that end. Before, the search saw the dip
    only when it was already 1.68e-5 m deep (the link column jumped from "not interior" to
    -1.68e-5 m at x = 0.0423 m): status "penetration" at t = 0.26588 s. Now the dip is found as
    soon as it is lower than the end (contact.closest_points._hidden_brackets), so the hit event
    of link 2's column fires at g = 0 +- contact_tol (t = 0.265843 s): every material point of
    every link (64 per link, at every stored sample) stays within contact_tol of the floor.
    After that impact (e = 0) the span point rests (contact.span_resting) and the whole run
    reaches t_end with no point beyond the floor by more than 1e-13 m, but its contact phase
    of a bending link costs ~2 minutes of CPU (2 ms a right-hand side in Python), so the test
    stops after the span's impact (max_impacts = 3)."""
    from conftest import (ISSUE25_ITEM5_FLOOR, ISSUE25_ITEM5_Q0, ISSUE25_ITEM5_QDOT0, ISSUE25_ITEM5_T_SPAN,
                          issue25_item5_model)

    model = issue25_item5_model()
    contact_tol = 1e-9
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, np.array(ISSUE25_ITEM5_Q0), np.array(ISSUE25_ITEM5_QDOT0), ISSUE25_ITEM5_T_SPAN,
                          walls=[ISSUE25_ITEM5_FLOOR], restitution=0.0, contact_tol=contact_tol, max_impacts=3)
    assert res.status == "max_impacts", res.message
    span = res.impacts[2]
    assert span.joints == (1, 2, 6)  # O1, O2 and the span of link 2 (column 6)
    assert span.time == pytest.approx(0.265843, abs=1e-6)
    assert ISSUE25_ITEM5_FLOOR.gap(span.points[2:3])[0] >= -contact_tol
    lowest = min(float(ISSUE25_ITEM5_FLOOR.gap(points_along(model, q).reshape(-1, 3)).min()) for q in res.q)
    assert lowest >= -contact_tol, lowest


def _o1_and_first_cell(contacts, q, thetas, held):
    """The gaps (O1, the first link column) (T, 2) [m] along the tilts thetas (T,) [rad] of q[2], without a
    resting pair (free) and with the pairs held (W, C) resting (rest)."""
    free, rest = [], []
    for th in thetas:
        q[2] = th
        contacts.resting = None
        free.append(contacts.gaps(q)[0, [0, contacts.n_joints]])
        contacts.resting = lambda: held
        rest.append(contacts.gaps(q)[0, [0, contacts.n_joints]])
    return np.array(free), np.array(rest)


def test_a_resting_link_column_stays_continuous_at_the_link_end():
    """A resting span point rolls to its link's end (the FE arm of test_fe_arm_strikes_a_wall: its rolling
    contact reached O1 and the column jumped from 0 to NOT_INTERIOR, so its drift event fired at every phase
    start, 100 times, status "stalled"). Along a rotation that carries the minimum of a 2-element beam's first
    cell into O1, the column of a resting pair is the cell's minimum over the closed cell: continuous (1-Lipschitz
    in the motion of the points, |dg| <= (1 + l) |dtheta|) and equal to O1's gap once the minimum is there; the
    same column of a pair that does not rest is NOT_INTERIOR there (O1 stands for it)."""
    from gibbsimpact.simulation.contacts import NOT_INTERIOR, Contacts

    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=2, geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], base="planar"))
    contacts = Contacts(model, (gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),))
    P = model.n_joints
    q = np.zeros(model.n_dof)
    q[:3] = (-0.5, 0.01, 0.0)
    q[3:7] = (0.02 * 0.25, 0.02, 0.02, 0.04)   # v = 0.02 x^2: the minimum sits at x = -tan(theta) / 0.04
    held = np.zeros((1, contacts.n_cols), dtype=bool)
    held[0, P] = True
    thetas = np.linspace(-0.004, 0.001, 51)          # x* from 0.1 m to the end x = 0
    free, rest = _o1_and_first_cell(contacts, q, thetas, held)
    at_end = thetas > -1e-12                         # theta >= 0: the lowest point is O1 itself
    assert np.all(free[at_end, 1] == NOT_INTERIOR) and np.all(free[~at_end, 1] < free[~at_end, 0])
    np.testing.assert_allclose(rest[at_end, 1], rest[at_end, 0], atol=1e-15)
    assert np.abs(np.diff(rest[:, 1])).max() <= 2.0 * (thetas[1] - thetas[0])


def test_the_cell_next_to_a_resting_end_is_continuous_with_that_end():
    """Issue 25, the flat-dropped beam (docs/theory.md §15.3, a dip out of a resting end): while O1 rests, the
    column of the link's first cell is the cell's minimum over the closed cell, continuous as a dip grows out of
    O1 (|dg| <= (1 + l) |dtheta|) and equal to O1's gap while the minimum is O1 itself; before, it was
    NOT_INTERIOR there and jumped to ~g(O1) when the dip went below O1, a value its hit at g = 0 could miss.
    Without a resting pair the column is NOT_INTERIOR at the end, as before (O1 stands for it)."""
    from gibbsimpact.simulation.contacts import NOT_INTERIOR, Contacts

    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=2, geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], base="planar"))
    contacts = Contacts(model, (gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),))
    q = np.zeros(model.n_dof)
    q[:3] = (-0.5, 0.0, 0.0)                       # O1 on the floor
    q[3:7] = (0.02 * 0.25, 0.02, 0.02, 0.04)       # v = 0.02 x^2: the minimum sits at x = -tan(theta) / 0.04
    o1 = np.zeros((1, contacts.n_cols), dtype=bool)
    o1[0, 0] = True
    thetas = np.linspace(0.001, -0.004, 51)        # the dip grows out of O1 (x* from the end to 0.1 m)
    free, rest = _o1_and_first_cell(contacts, q, thetas, o1)
    at_end = thetas > -1e-12
    assert np.all(free[at_end, 1] == NOT_INTERIOR)
    np.testing.assert_allclose(rest[at_end, 1], rest[at_end, 0], atol=1e-15)
    # the dip's depth below O1: v(x*) - v(0) + x* tan(theta) = -tan(theta)^2 / 0.08 (closed form, small theta)
    dip = np.tan(thetas[~at_end]) ** 2 / 0.08
    np.testing.assert_allclose(rest[~at_end, 1] - rest[~at_end, 0], -dip * np.cos(thetas[~at_end]), rtol=1e-6,
                               atol=1e-12)
    assert np.abs(np.diff(rest[:, 1])).max() <= 2.0 * abs(thetas[1] - thetas[0])


def test_a_dip_out_of_a_resting_tip_of_a_stiffened_arm_fires_its_hit_at_the_floor():
    """The pressed arm of docs/benchmarks.md (fixed base 2 cm above the floor, 2 stiffened elements, EI = 20 N m^2,
    tau = -2 N m, damping 0.05, e = 0, contact_tol = 1e-6 m), started at rest on its tip: at t = 0.0274 s a dip
    grows out of the resting tip. The cell search samples the linear centreline, whose slope at the tip still
    pointed out of the link, so cell 2's column stayed "not interior" and its hit fired at -1.095e-6 m (a stored
    sample 1.01e-6 m below the floor, the run stopped with "penetration" at 0.02762 s). Now the column follows
    the dip from the tip (contact.span_cells._foreshorten_cells): every material point (64 per link, at every
    stored sample) stays within contact_tol of the floor up to t_end = 0.0275 s (before the seated dip's
    drift decisions, docs/benchmarks.md, which still fail later)."""
    from gibbsimpact.dynamics.link_points import link_points

    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=2, damping=0.05)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.02), 0.0)), gravity=(0.0, -9.81, 0.0))
    contact_tol = 1e-6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, model.state(theta_1=-np.arcsin(0.02)), np.zeros(model.n_dof), (0.0, 0.0275),
                          walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=0.0, contact_tol=contact_tol,
                          inputs={"theta_1": -2.0})
    assert res.status == "finished", res.message
    lowest = min(float(link_points(model, q, 64)[0, :, 1].min()) for q in res.q)
    assert lowest >= -contact_tol, lowest


@pytest.mark.slow
def test_a_pressed_arm_comes_to_rest_along_its_span():
    """Issue 25, first bullet (the arm): a fixed-base arm of 3 linear finite elements (EI = 20 N m^2, 1 kg/m, 1 m,
    damping 0.5; base 2 cm above the floor; e = 0; contact_tol = 1e-6 m) driven onto the floor by tau = -2 N m
    on theta_1 comes to rest on its third element's span. On main it stopped at t = 0.0554 s: 'penetration'
    (the seated span point's drifted minimum was no candidate of the mode decision, its normal velocity ~1e-3 m/s
    being above grazing_velocity, so nothing rested and the next phase started 1e-6 m under the floor:
    stages._sunk; the 2-element arm with DOP853 then failed on a non-finite trial stage of the first step,
    tests/simulation/test_equations.py). Now it reaches t_end = 1 s (Radau at rtol 1e-6; |qdot| <= 5e-8 at the
    end): every material point (64, public kinematics) at every stored sample within contact_tol of the floor;
    the energy less the work of the torque and the damping never rising beyond the solver's error along phases,
    falling at impacts (e = 0), and moved by the projections of the mode decisions only within the work of the
    loads over contact_tol (below); and at the end the static
    balance about the base joint, computed independently of the dynamics: the moment of gravity on the material
    points (Gauss-Legendre, 8 points per element: exact for the cubic centreline) plus the recorded contact
    forces at their recorded points (Result.contact_abscissae) equals -tau to 1e-6 relative."""
    from gibbsimpact.dynamics.link_points import link_points
    from conftest import pressed_arm_moment

    link = gi.Link(1.0, 1.0, (20.0, 20.0), elements=3, damping=0.5, geometric_stiffening=False)
    model = gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.02), 0.0)), gravity=(0.0, -G, 0.0))
    contact_tol, tau = 1e-6, -2.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, model.state(), np.zeros(model.n_dof), (0.0, 1.0),
                          walls=[gi.Plane((0, 0, 0), (0, 1, 0))], restitution=0.0, contact_tol=contact_tol,
                          inputs={"theta_1": tau}, method="Radau", rtol=1e-6, atol=1e-9)
    assert res.status == "finished", res.message
    lowest = min(float(link_points(model, q, 64)[0, :, 1].min()) for q in res.q)
    assert lowest >= -contact_tol, lowest
    balance = res.energy().total - res.work.sum(axis=1)
    # Impacts (e = 0) dissipate. Along a flight or contact phase E - W holds to the solver's error
    # (energy_error_per_phase). A mode decision's projection onto g = 0 moves the resting point by at most
    # contact_tol (and the arm's other points less, towards the base): E - W then changes by at most the work of
    # the loads over that distance, (sum(lambda) + m g + |tau| / l) contact_tol.
    assert all(r.energy_after <= r.energy_before for r in res.impacts)
    total = res.contact_forces.sum(axis=(1, 2))
    loads = np.maximum(total[:-1], total[1:]) + G * model.total_mass + abs(tau) / link.length
    bound = loads * contact_tol + res.energy_error_per_phase * res.energy_scale
    rise = np.diff(balance)
    assert np.all(rise <= bound), (rise - bound).max()
    moment, F = pressed_arm_moment(model, res, G)
    assert F[model.n_joints + 2] > 0.9 * np.abs(F).sum(), F          # element 3's span carries the floor's force
    assert abs(moment + tau) <= 1e-6 * abs(tau), (moment + tau) / abs(tau)
