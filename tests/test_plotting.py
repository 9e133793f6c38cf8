"""Figures: matplotlib stays out of `import gibbsimpact`; link sampling follows the mode shapes;
every figure is drawn, saved and non-blank; the animation has frames."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact import plotting

CASES = Path(__file__).resolve().parents[1] / "cases"


@pytest.fixture(scope="module")
def planar():
    case = gi.load_case(CASES / "circle_two_link.toml")
    return case.simulate(t_end=0.5, rtol=1e-8, atol=1e-10, output_dt=5e-3)


@pytest.fixture(scope="module")
def spatial():
    case = gi.load_case(CASES / "sphere_single_link.toml")
    return case.simulate(t_end=0.6, rtol=1e-8, atol=1e-10, output_dt=5e-3)


def nonblank(path):
    import matplotlib.image as mpimg

    img = mpimg.imread(path)
    return img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100 and float(img[..., :3].std()) > 0.01


def test_import_does_not_load_matplotlib():
    code = "import sys, gibbsimpact; gibbsimpact.load_case; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_agg_backend_without_display():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MPLBACKEND")}
    code = ("import matplotlib, gibbsimpact.plotting as p; p._pyplot(); "
            "print(matplotlib.get_backend().lower())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    assert out.stdout.strip() == "agg"


def test_link_points_follow_joints_and_mode_shape():
    links = [gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")]),
             gi.Link(0.8, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "z")])]
    model = gi.Model(links)
    q = model.state(X1=0.1, X2=-0.2, theta_1=0.4, theta_2=-0.7, delta_1_1=0.05, delta_2_1=-0.03)
    pts = plotting.link_points(model, q, 21)
    assert pts.shape == (2, 21, 3)
    O = model.joint_positions(q)
    # Clamped-clamped shapes vanish at both ends: the links end at the joints.
    np.testing.assert_allclose(pts[:, 0], O[:2], atol=1e-12)
    np.testing.assert_allclose(pts[:, -1], O[1:], atol=1e-12)
    # At mid-span psi = 1, so the point sits delta off the chord, along the link's y (link 1) or z (link 2).
    chord1 = 0.5 * (O[0] + O[1])
    d = pts[0, 10] - chord1
    assert np.linalg.norm(d) == pytest.approx(0.05, rel=1e-9)
    assert abs(d @ (O[1] - O[0])) < 1e-12 and abs(d[2]) < 1e-12
    d2 = pts[1, 10] - 0.5 * (O[1] + O[2])
    # Planar joint rotations are about z, so link 2's z axis is the inertial X3: w = delta_2_1 e_3.
    np.testing.assert_allclose(d2, [0.0, 0.0, -0.03], atol=1e-12)


def test_is_planar(planar, spatial):
    assert plotting.is_planar(planar)
    assert not plotting.is_planar(spatial)


@pytest.mark.parametrize("which", ["planar", "spatial"])
def test_every_figure_is_saved_and_nonblank(which, request, tmp_path):
    res = request.getfixturevalue(which)
    figs = res.plot(directory=tmp_path, case_name=which)
    assert set(figs) == set(plotting.FIGURES)
    for name in plotting.FIGURES:
        assert nonblank(tmp_path / f"{name}.png"), name
    import matplotlib.pyplot as plt

    # Labels with units, impact markers on the time plots, equal axes for configurations.
    ax = figs["angles"].axes[0]
    assert "[rad]" in ax.get_ylabel() and figs["angles"].axes[-1].get_xlabel() == "t [s]"
    n_vlines = sum(1 for ln in ax.get_lines() if len(set(ln.get_xdata())) == 1 and len(ln.get_xdata()) == 2)
    assert n_vlines == len(res.impacts)
    conf = figs["configurations"].axes[0]
    if which == "planar":
        assert conf.get_aspect() == 1.0
        assert len(figs["joint_positions"].axes) == 2
    else:
        assert conf.name == "3d"
        assert len(figs["joint_positions"].axes) == 3
    for f in figs.values():
        plt.close(f)


def test_rigid_chain_has_no_modes_figure_and_kinds_are_checked(tmp_path):
    model = gi.Model([gi.Link(1.0, 1.0, 1.0, rotary_inertia=(1e-4, 1e-4, 1e-4))])
    res = gi.simulate(model, model.state(), model.state(X1=0.1), (0.0, 0.01), rtol=1e-8, atol=1e-10)
    figs = plotting.plot_result(res)
    assert "modes" not in figs and "angles" in figs
    with pytest.raises(ValueError, match="unknown figure"):
        plotting.plot_result(res, kinds=["angles", "spectrum"])
    import matplotlib.pyplot as plt

    plt.close("all")


def test_animation_gif_has_frames(spatial, tmp_path):
    from PIL import Image

    path = plotting.animate(spatial, tmp_path / "a.gif", fps=10, speed=1.0, n_points=11)
    with Image.open(path) as im:
        assert im.n_frames >= 5
        frames = []
        for k in (0, im.n_frames - 1):
            im.seek(k)
            frames.append(np.asarray(im.convert("RGB"), dtype=float))
    assert frames[0].std() > 1.0
    assert np.abs(frames[0] - frames[1]).max() > 0  # the chain moved


def test_fixed_base_fe_driven_run_figures(tmp_path):
    # Fixed base, FE links (drawn deformed, tip deflections in modes.png), inputs and
    # damping (work and the power balance in energy.png).
    arm = gi.Link(1.0, 1.0, 4.0, elements=2, damping=0.01)
    tip = gi.Link(0.6, 0.5, 2.0, elements=1, element_directions=("y", "z"))
    model = gi.Model(gi.Chain([arm, tip], base=gi.FixedBase((0.0, 0.5), 0.0)))
    q = model.state(theta_1=-0.2, delta_1_3=0.05, delta_1_4=0.1)
    pts = plotting.link_points(model, q, 9)
    np.testing.assert_allclose(pts[0, -1], model.joint_positions(q)[1], atol=1e-14)  # deformed tip = O2
    assert np.ptp(pts[0, :, 1] - np.linspace(0.5, pts[0, -1, 1], 9)) > 1e-3  # link 1 is drawn bent
    res = gi.simulate(model, q, np.zeros(model.n_dof), (0.0, 0.05), inputs={"theta_1": -1.0},
                      rtol=1e-8, atol=1e-10, output_dt=1e-3)
    assert plotting.is_planar(res)  # z elements at rest
    figs = res.plot(directory=tmp_path)
    for name in figs:
        assert nonblank(tmp_path / f"{name}.png"), name
    labels = [t.get_text() for t in figs["modes"].axes[0].get_legend().get_texts()]
    assert any("link 1, tip deflection in y" in s for s in labels) and any("link 2, tip deflection in z" in s for s in labels)
    assert "power-balance" in figs["energy"]._suptitle.get_text() or any(
        "power-balance" in ax.get_title() for ax in figs["energy"].axes)
    import matplotlib.pyplot as plt
    plt.close("all")


# --------------------------------------------------------------------------
# Figures that do not accumulate, ax=, repr, early-stop status, walls, labels, colours, camera

def _texts(fig):
    """Every text a figure shows: suptitle, figure texts, axes titles and texts."""
    out = [t.get_text() for t in fig.texts]
    if fig._suptitle is not None:
        out.append(fig._suptitle.get_text())
    for ax in fig.axes:
        out += [ax.get_title()] + [t.get_text() for t in ax.texts]
    return "\n".join(out)


def test_figures_do_not_accumulate_in_pyplot(planar):
    import warnings

    import matplotlib.pyplot as plt

    plt.close("all")
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # matplotlib's "More than 20 figures" warning
        for _ in range(21):
            fig = planar.plot("energy")
    assert plt.get_fignums() == []
    from matplotlib.figure import Figure

    assert isinstance(fig, Figure) and len(fig.axes) == 2
    figs = plotting.plot_result(planar, kinds=["angles", "modes", "joint_positions"])
    assert plt.get_fignums() == [] and set(figs) == {"angles", "modes", "joint_positions"}


def test_plot_into_given_axes(planar, spatial):
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.add_subplot()
    assert planar.plot("angles", ax=ax) is fig
    assert len(fig.axes) == 1 and len(ax.get_lines()) == 2 + len(planar.impacts)  # theta_1, theta_2, markers
    fig2 = Figure()
    axes = fig2.subplots(2, 1)
    assert planar.plot(which="energy", ax=axes) is fig2
    assert axes[1].get_ylabel().startswith("$E - E(t_0)")
    assert planar.plot("modes", ax=Figure().add_subplot()) is not None
    fig3 = Figure()
    ax3 = fig3.add_subplot(projection="3d")
    assert spatial.plot("trajectory", ax=ax3) is fig3 and len(ax3.get_lines()) > 2
    with pytest.raises(ValueError, match="projection='3d'"):
        spatial.plot("trajectory", ax=Figure().add_subplot())
    with pytest.raises(ValueError, match="at most 2 panel"):
        planar.plot("angles", ax=Figure().subplots(3, 1))
    with pytest.raises(ValueError, match="ax= draws one figure"):
        planar.plot(ax=ax)
    with pytest.raises(ValueError, match="unknown figure 'spectrum'"):
        planar.plot("spectrum")
    assert set(planar.plot(["angles", "energy"])) == {"angles", "energy"}  # a list: {name: Figure}


def test_repr_is_short(planar, spatial):
    for res in (planar, spatial):
        text = repr(res)
        assert len(text) < 400 and "\n" not in text
        assert text.startswith("Result(finished; t = 0 ... ") and f"{len(res.impacts)} impacts" in text
        assert "energy_error" in text and "nfev" in text
    import dataclasses

    stopped = dataclasses.replace(planar, status="zeno", message="accumulation of impacts: " + "x" * 500)
    assert len(repr(stopped)) < 400 and "zeno (accumulation of impacts" in repr(stopped)
    assert [f.name for f in dataclasses.fields(planar)][:9] == [
        "model", "walls", "t", "q", "qdot", "phase", "impacts", "status", "message"]


def test_early_stop_status_is_on_every_figure(planar):
    import dataclasses

    from matplotlib.figure import Figure

    msg = ("accumulation of impacts: joint O2 stayed within 3e-09 m of wall 1 through 10 consecutive impacts "
           "(its rebounds no longer leave the contact band); estimated accumulation time 0.5 s")
    stopped = dataclasses.replace(planar, status="zeno", message=msg)
    figs = plotting.plot_result(stopped, n_points=11)
    for name, fig in figs.items():
        text = _texts(fig)
        assert "STOPPED EARLY (zeno) at t = 0.5 s: accumulation of impacts" in text, name
        assert "(its rebounds" not in text  # parenthetical remarks dropped to keep it short
    ax = Figure().add_subplot()
    stopped.plot("energy", ax=ax)
    assert any("STOPPED EARLY (zeno)" in t.get_text() for t in ax.texts)
    assert "STOPPED EARLY" not in _texts(planar.plot("energy"))


def _still(model, q, walls, status="finished"):
    from gibbsimpact.results import Result

    Q = np.array([q, q])
    return Result(model=model, walls=tuple(walls), t=np.array([0.0, 0.1]), q=Q, qdot=np.zeros_like(Q),
                  phase=np.zeros(2, dtype=int), impacts=[], status=status, message="")


def test_two_planes_are_drawn_as_a_v():
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")])
    model = gi.Model(gi.Chain([link, link]))
    walls = [gi.Plane((0, 0, 0), (1, 1, 0)), gi.Plane((0, 0, 0), (-1, 1, 0))]
    res = _still(model, model.state(X1=-0.7, X2=0.9, theta_1=-0.3, theta_2=0.9), walls)  # vertex in view
    fig = plotting.plot_configurations(res, n_points=11)
    ax = fig.axes[0]
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    segs = {ln.get_gid(): np.column_stack(ln.get_data()) for ln in ax.get_lines() if (ln.get_gid() or "").startswith("wall")}
    assert set(segs) == {"wall 1", "wall 2"}
    for k, (gid, s) in enumerate(sorted(segs.items())):
        s = s[np.all(np.isfinite(s), axis=1)]
        # Inside the view box and on the free side of the other plane ...
        assert np.all((s[:, 0] >= x0 - 1e-9) & (s[:, 0] <= x1 + 1e-9) & (s[:, 1] >= y0 - 1e-9) & (s[:, 1] <= y1 + 1e-9))
        other = walls[1 - k]
        assert other.gap(np.column_stack([s, np.zeros(len(s))])).min() >= -1e-9
        # ... from the vertex (0, 0) up to the edge of the view: one arm of the V each.
        ends = s[[0, -1]]
        assert np.min(np.linalg.norm(ends, axis=1)) < 1e-9
        far = ends[np.argmax(np.linalg.norm(ends, axis=1))]
        assert min(abs(far[0] - x0), abs(far[0] - x1), abs(far[1] - y0), abs(far[1] - y1)) < 1e-9
    # The left arm goes up-left, the right arm up-right: a V, not an X.
    xs = sorted(np.nanmean(s[:, 0]) for s in segs.values())
    assert xs[0] < 0 < xs[1] and all(np.nanmin(s[:, 1]) > -1e-9 for s in segs.values())


def test_impact_numbers_never_overlap():
    # 28 impacts with clusters (as in a long run at e = 0.9): labels in one row, none overlapping.
    import itertools

    rng = np.random.default_rng(3)
    times = np.sort(np.concatenate([rng.uniform(0.5, 2.5, 14), 2.76 + 0.004 * np.arange(8),
                                    1.7 + 0.01 * np.arange(6)]))
    width_pt = 500.0
    labels = plotting._impact_labels(times, 0.0, 2.8, width_pt)
    char = 0.6 * 7.0 / width_pt * 2.8  # seconds per character, as _impact_labels assumes
    spans = [(t, t + len(text) * char) for t, text in labels]
    assert all(b[0] >= a[1] for a, b in itertools.pairwise(spans))
    assert labels[0][1] in ("1", "1\u20132") and len(labels) < len(times)
    # Every number shown is an impact number, ranges in order, none twice.
    shown = [int(n) for _, text in labels for n in text.split("\u2013")]
    assert shown == sorted(shown) and len(set(shown)) == len(shown) and shown[-1] <= 28


def test_link_and_path_colours_differ_and_avoid_red():
    import matplotlib.colors as mc

    links = {mc.to_hex(c) for c in plotting.LINK_COLOURS}
    joints = {mc.to_hex(c) for c in plotting.JOINT_COLOURS}
    assert not links & joints
    for c in links | joints:
        r, g, b = mc.to_rgb(c)
        assert not (r > 0.7 and g < 0.3 and b < 0.3), c


def test_camera_looks_along_the_least_motion():
    rng = np.random.default_rng(0)
    flat = np.column_stack([rng.normal(size=200), rng.normal(size=200), 0.01 * rng.normal(size=200)])
    elev, azim = plotting.camera(flat)  # motion in X1-X2: look along X3 (the plot's x axis), from low
    assert elev == pytest.approx(10.0) and min(abs(azim), abs(abs(azim) - 180.0)) < 5.0
    floor = np.column_stack([rng.normal(size=200), 0.01 * rng.normal(size=200), rng.normal(size=200)])
    assert plotting.camera(floor)[0] == pytest.approx(75.0)  # motion in X1-X3: from above (capped)
    assert plotting.camera(rng.normal(size=(300, 3))) == (18.0, -60.0)  # no clear direction: default
