"""Configuration figures of long runs: one panel per contact episode; in 3D the chain at t0 and the
floor shadow drawn unlike each other."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import FE_ARM_BURSTS, burst_result, single_link_sphere_model, single_link_sphere_state
from gibbsimpact.plotting import plot_configurations, plot_trajectory


def test_one_panel_per_contact_episode():
    res = burst_result()  # 101 impacts in 7 bursts, each within 0.85 ms
    fig = plot_configurations(res, n_points=5)
    titles = [a.get_title() for a in fig.axes if a.get_visible()]
    assert len(titles) == 1 + len(FE_ARM_BURSTS)  # t0, then one per episode (the run finished)
    first = np.cumsum([0] + [n for _, n in FE_ARM_BURSTS])
    for title, a, b, (start, _) in zip(titles[1:], first[:-1] + 1, first[1:], FE_ARM_BURSTS):
        assert title.startswith(f"impacts {a}\u2013{b}: t = {start:.6f} \u2026 ") and title.endswith(", O3")
    assert "101 impacts in 7 contact episodes, one panel each" in fig._suptitle.get_text()
    # The panel shows the state before the episode's first impact, with its contact point starred.
    panel = fig.axes[1]
    stars = [ln for ln in panel.get_lines() if ln.get_marker() == "*"]
    assert len(stars) == 1
    # Impacts further apart than 1/300 of the run keep a panel each, titled as before.
    apart = burst_result(bursts=((0.2, 1), (0.5, 1), (0.51, 1)))
    titles = [a.get_title() for a in plot_configurations(apart, n_points=5).axes if a.get_visible()]
    assert [t.split(":")[0] for t in titles[1:]] == ["impact 1", "impact 2", "impact 3"]


@pytest.fixture(scope="module")
def spatial():
    import gibbsimpact as gi

    model = single_link_sphere_model()
    q, qd = single_link_sphere_state(model)
    return gi.simulate(model, q, qd, (0.0, 0.2), walls=[gi.Sphere(1.0)], rtol=1e-8, atol=1e-10,
                       output_dt=1e-2)


def test_chain_at_t0_and_floor_shadow_look_different_in_3d(spatial):
    import matplotlib.colors as mc

    ax = plot_trajectory(spatial, n_points=11).axes[0]
    assert ax.name == "3d"
    legend = {t.get_text(): h for t, h in zip(ax.get_legend().get_texts(), ax.get_legend().legend_handles)}
    t0, shadow = legend["chain at $t_0$"], legend["shadow on the floor"]
    assert t0.get_linestyle() == "--" and shadow.get_linestyle() == "-"
    assert mc.to_hex(t0.get_color()) != mc.to_hex(shadow.get_color())
    assert shadow.get_linewidth() > t0.get_linewidth()
    # The drawing itself: the link at t0 in the dashed style, its shadow in the wide pale one.
    style = {(ln.get_linestyle(), mc.to_hex(ln.get_color()), ln.get_linewidth()) for ln in ax.get_lines()
             if len(ln.get_xdata()) > 2}
    assert ("--", mc.to_hex(t0.get_color()), t0.get_linewidth()) in style
    assert ("-", mc.to_hex(shadow.get_color()), shadow.get_linewidth()) in style


def test_attached_bodies_are_drawn_at_their_centres():
    # A hub (open disc on joint 1) and an offset payload (square at its centre) in both figures.
    import gibbsimpact as gi
    from gibbsimpact.dynamics.link_points import body_centers

    links = [gi.Link(1.0, 1.0, 25.0, elements=2, bodies=[gi.RigidBody(0.5, inertia=(0.01, 0.01, 0.02), at=0.0)]),
             gi.Link(0.6, 0.5, 8.0, bodies=[gi.RigidBody(0.3, center=(0.05, 0.02, 0.0))])]
    model = gi.Model(gi.Chain(links, base=gi.FixedBase((0.0, 0.6), 0.0)))
    res = gi.simulate(model, model.state(theta_2=0.4), np.zeros(model.n_dof), (0.0, 0.05), output_dt=1e-2)
    P, _ = body_centers(model, res.q[-1])
    for fig in (plot_configurations(res, n_points=5), plot_trajectory(res, n_points=5)):
        ax = fig.axes[-1] if len(fig.axes) == 1 else [a for a in fig.axes if a.get_visible()][-1]
        marks = {ln.get_marker(): np.array(ln.get_xydata())[0] for ln in ax.get_lines() if ln.get_marker() in "os"
                 and ln.get_markersize() >= 8}
        np.testing.assert_allclose(marks["o"], P[0, :2], atol=1e-12)
        np.testing.assert_allclose(marks["s"], P[1, :2], atol=1e-12)
        labels = ax.get_legend_handles_labels()[1]
        assert "hub (body at a joint)" in labels and "payload (attached body)" in labels
    # The animation's frame puts the same markers at the same places.
    from gibbsimpact.plotting.animation import _actors, _pose, _stage

    fig, ax, floor = _stage(res, np.arange(len(res.t)), 5, True)
    actors = _actors(ax, model, res.q[0], True)
    _pose(actors, res, res.q[-1], float(res.t[-1]), 0.0, 5, floor, True)
    np.testing.assert_allclose([np.ravel(a.get_xydata()) for a in actors["bodies"]], P[:, :2], atol=1e-12)
    assert [a.get_marker() for a in actors["bodies"]] == ["o", "s"]


def test_obstacles_are_drawn_as_filled_bodies():
    """An obstacle (inside=False) is a filled Polygon patch (its section) in 2D, a surface (Poly3DCollection)
    in 3D; its outline is drawn like every wall; a container gets neither fill nor surface."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    import gibbsimpact as gi
    from gibbsimpact.plotting.scene import _draw_walls_3d

    model = gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0)], base="planar"), gravity=(0.0, -9.81, 0.0))
    walls = [gi.Circle(2.0), gi.Circle(0.1, (0.0, 0.0), inside=False), gi.Sphere(0.15, (0.5, 0.0, 0.0), inside=False),
             gi.Plane((0.0, -0.5, 0.0), (0.0, 1.0, 0.0))]
    res = gi.simulate(model, model.state(X1=-0.3, X2=0.5), np.zeros(3), (0.0, 0.4), walls=walls, restitution=0.5)
    assert res.impacts
    fig = plot_configurations(res, n_points=11)
    ax = fig.axes[0]
    bodies = {p.get_gid(): p for p in ax.patches if isinstance(p, Polygon)}
    assert set(bodies) == {"obstacle 2", "obstacle 3"} and all(p.get_fill() for p in bodies.values())
    # The post's body is its section: radius 0.1 about the origin.
    xy = bodies["obstacle 2"].get_xy()
    np.testing.assert_allclose(np.hypot(xy[:, 0], xy[:, 1]), 0.1, rtol=1e-12)
    assert {"wall 1", "wall 2", "wall 3", "wall 4"} <= {ln.get_gid() for ln in ax.get_lines()}
    plt.close(fig)
    fig = plt.figure()
    ax3 = fig.add_subplot(projection="3d")
    _draw_walls_3d(ax3, walls, np.full(3, -2.0), np.full(3, 2.0))
    surfaces = {c.get_gid() for c in ax3.collections if isinstance(c, Poly3DCollection)}
    assert {"obstacle 2", "obstacle 3"} <= surfaces and not any(g and "obstacle 1" in g for g in surfaces)
    plt.close(fig)


# -- a walker: one long collision episode, a strike per step; a hub where six spokes meet -----------------

CASES = __import__("pathlib").Path(__file__).resolve().parents[2] / "cases"


@pytest.fixture(scope="module")
def wheel():
    """The rimless wheel of cases/ (six rigid spokes of l = 1 m welded to a hub, plastic strikes on a 12 deg
    slope) to t = 1.7 s: two strikes, O8+O9 then O9+O10, in one collision episode (a foot always rests)."""
    import gibbsimpact as gi

    return gi.load_case(CASES / "rimless_wheel.toml").simulate(t_end=1.7)


def test_a_walker_gets_a_panel_per_strike_within_its_one_episode(wheel):
    from gibbsimpact.plotting.impacts import impact_groups, panel_groups

    assert impact_groups(wheel) == ([(0, 1)], True) and panel_groups(wheel) == [(0, 0), (1, 1)]
    fig = plot_configurations(wheel, n_points=5)
    panels = [a for a in fig.axes if a.get_visible()]
    assert [a.get_title().split(":")[0] for a in panels] == ["t = 0 s (initial)", "impact 1", "impact 2"]
    assert panels[1].get_title().endswith("O8+O9") and panels[2].get_title().endswith("O9+O10")
    assert "2 impacts in 1 collision episode, one panel per impact" in fig._suptitle.get_text().replace("\n", " ")
    # Each strike panel stars the two feet on the ground, one chord of the wheel apart: 2 l sin(pi / 6) = l.
    for a in panels[1:]:
        stars = np.array([(x, y) for ln in a.get_lines() if ln.get_marker() == "*"
                          for x, y in zip(ln.get_xdata(), ln.get_ydata())])
        assert len(stars) == 2
        assert np.linalg.norm(stars[1] - stars[0]) == pytest.approx(2.0 * np.sin(np.pi / 6.0), abs=1e-9)


def test_points_that_coincide_share_one_label_path_and_curve(wheel):
    # The six spokes' frame origins O1 ... O6 are the hub (welds at x = 0): one label, one path, one curve.
    from gibbsimpact.plotting import plot_joint_positions

    P = wheel.joint_positions()
    assert np.abs(P[:, :6] - P[:, :1]).max() <= 1e-12 and np.abs(P[:, 6:] - P[:, :1]).max() > 0.9
    panel = plot_configurations(wheel, n_points=5).axes[0]
    labels = [t.get_text() for t in panel.texts]
    assert labels.count("$O_{1}$\u2013$O_{6}$") == 1 and not {f"$O_{{{j}}}$" for j in range(1, 7)} & set(labels)
    assert sorted(labels) == sorted(["$O_{1}$\u2013$O_{6}$"] + [f"$O_{{{j}}}$" for j in range(7, 13)])
    ax = plot_trajectory(wheel, n_points=5).axes[0]
    paths = [t.get_text() for t in ax.get_legend().get_texts() if t.get_text().startswith("path of")]
    assert paths[0] == "path of $O_{1}$\u2013$O_{6}$ (joint 1 on the base)" and len(paths) == 7
    legend = [t.get_text() for t in plot_joint_positions(wheel).axes[0].get_legend().get_texts()]
    assert legend[0] == "$O_{1}$\u2013$O_{6}$ (joint 1 on the base)" and len(legend) == 7


def test_a_run_without_impacts_says_so_and_explains_no_marks():
    res = burst_result(bursts=())  # the arm on its floor, never touching it
    assert not res.impacts
    fig = plot_configurations(res, n_points=5)
    assert "configurations at the start and the end, no impacts" in fig._suptitle.get_text()
    assert [a.get_title().split(" (")[1] for a in fig.axes if a.get_visible()] == ["initial)", "final)"]
    assert "red star" not in fig._supxlabel.get_text()
    assert "red star: impacting point" in plot_configurations(burst_result(), n_points=5)._supxlabel.get_text()
