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
from gibbsimpact.plotting.impacts import _impact_labels, _impact_note
from gibbsimpact.plotting.labels import _status_line

CASES = Path(__file__).resolve().parents[2] / "cases"


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
    code = ("import matplotlib, gibbsimpact.plotting.style as p; p._pyplot(); "
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
    with pytest.raises(ValueError, match=r"pass the folder as directory='out/figs'"):  # a path where a name goes
        planar.plot("out/figs")
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
    from gibbsimpact.simulation.results import Result

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
    labels = _impact_labels(times, 0.0, 2.8, width_pt)
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


# --------------------------------------------------------------------------
# Prismatic joints and the planar floating base: d in metres, tip deflections, end stops

def _two_links():
    return [gi.Link(length=1.0, mass_per_length=1.0, EI=25.0, elements=3, geometric_stiffening=False),
            gi.Link(length=0.6, mass_per_length=0.5, EI=8.0, elements=2, geometric_stiffening=False)]


def _prismatic_run(which):
    """Short runs (0.05 s) of an R-Pb and an R-Pa chain on a fixed base and of an R-Pb chain on a
    planar floating base falling onto a floor."""
    fixed = gi.FixedBase(position=(0.0, 0.0), angle=0.0)
    if which == "R-Pb":
        # Driven (work and power balance); d_2 runs into d_max = 0.6 at t ~ 0.025 s: an end-stop impact.
        chain = gi.Chain(_two_links(), joints=[gi.Revolute(), gi.FixedPrismatic(angle=0.0, range=(0.2, 0.6))],
                         base=fixed)
        model = gi.Model(chain, gravity=(0.0, -9.81, 0.0))
        return gi.simulate(model, model.state(theta_1=0.3, d_2=0.55, delta_1_5=0.01),
                           model.state(theta_1=1.0, d_2=2.0), (0.0, 0.05), rtol=1e-7, atol=1e-9, output_dt=1e-3,
                           inputs={"theta_1": lambda t, q, qd: 0.5 * np.sin(t)}, joint_limit="impact")
    if which == "R-Pa":
        chain = gi.Chain(_two_links(), base=fixed, joints=[
            gi.Revolute(), gi.SlidingPrismatic(angle=0.6, half_length=0.04, range=(0.1, 0.95))])
        model = gi.Model(chain, gravity=(0.0, -9.81, 0.0))
        return gi.simulate(model, model.state(theta_1=0.3, d_2=0.5, delta_1_5=0.01),
                           model.state(theta_1=1.0, d_2=0.5), (0.0, 0.05), rtol=1e-7, atol=1e-9, output_dt=1e-3)
    chain = gi.Chain(_two_links(), joints=[gi.Revolute(), gi.FixedPrismatic(angle=0.3, range=(0.2, 0.6))],
                     base="planar")
    model = gi.Model(chain, gravity=(0.0, -9.81, 0.0))
    return gi.simulate(model, model.state(X2=0.05, theta_1=0.3, d_2=0.4, delta_2_3=0.01),
                       model.state(X2=-1.0, d_2=0.5), (0.0, 0.05), rtol=1e-7, atol=1e-9, output_dt=1e-3,
                       walls=[gi.Plane((0, 0, 0), (0, 1, 0))])


PRISMATIC = ("R-Pb", "R-Pa", "planar R-Pb")


@pytest.fixture(scope="module")
def prismatic():
    """{name: (Result, {figure: Figure})}, every figure of FIGURES built once per run."""
    out = {}
    for name in PRISMATIC:
        res = _prismatic_run(name)
        assert res.success, res
        out[name] = (res, plotting.plot_result(res, n_points=11))
    return out


def _lines_labelled(ax, text):
    return [ln for ln in ax.get_lines() if ln.get_label() == text]


@pytest.mark.parametrize("name", PRISMATIC)
def test_every_figure_builds_for_prismatic_chains(prismatic, name):
    res, figs = prismatic[name]
    assert set(figs) == set(plotting.FIGURES)
    assert plotting.is_planar(res)  # a planar base has no X3, theta_-1, theta_0: drawn in 2D
    assert len(figs["joint_positions"].axes) == 2
    assert all(ax.name != "3d" for ax in figs["configurations"].axes + figs["trajectory"].axes)
    assert figs["configurations"].axes[0].get_aspect() == 1.0
    # The prismatic joint's symbol is drawn: the guide of a Pb link, the carriage of a Pa link.
    kind = "guide" if "Pb" in name else "carriage"
    labels = [ln.get_label() for ln in figs["configurations"].axes[0].get_lines()]
    assert any(s.startswith(kind) for s in labels), labels
    if "Pb" in name:
        assert "link 2 behind its guide" in labels
    # Angles: theta_1 only on the radian axis (a planar base adds no theta_-1, theta_0, and X1, X2 are
    # not angles); the energy figure shows the balance.
    ax = figs["angles"].axes[0]
    assert "[rad]" in ax.get_ylabel()
    assert [ln.get_label() for ln in ax.get_lines() if not ln.get_label().startswith("_")] == [r"$\theta_{1}$"]
    assert figs["energy"].axes[1].get_ylabel().startswith("$E - E(t_0)")
    import matplotlib.pyplot as plt

    for f in figs.values():
        plt.close(f)


def test_legends_say_what_each_contact_point_is(prismatic):
    # A Pb arm has O1 ... O4 with O2 behind the guide and O4 the host's tip: the legends name them,
    # and each name is checked against the geometry it claims.
    from gibbsimpact.dynamics.link_points import points_on_link
    from gibbsimpact.dynamics.kinematics import transforms

    want = {
        "R-Pb": ["joint 1", "rear end of link 2, behind its guide", "tip of link 2", "tip of link 1, guide of joint 2"],
        "R-Pa": ["joint 1", "carriage of joint 2", "tip of link 2", "tip of link 1, host of carriage 2"],
    }
    for name, words in want.items():
        res, figs = prismatic[name]
        labels = [t.get_text() for t in figs["joint_positions"].axes[0].get_legend().get_texts()]
        assert labels == [f"$O_{{{j}}}$ ({w})" for j, w in enumerate(words, start=1)]
        traj = [t.get_text() for t in figs["trajectory"].axes[0].get_legend().get_texts()]
        assert [f"path of {s}" for s in labels] == traj[:len(labels)]
        model, q = res.model, res.q[-1]
        O, T = model.joint_positions(q), transforms(model, q)
        tip1 = points_on_link(model, q, T, 0, [model.chain.links[0].length])[0]
        tip2 = points_on_link(model, q, T, 1, [model.chain.links[1].length])[0]
        np.testing.assert_allclose(O[3], tip1, atol=1e-12)  # "tip of link 1"
        np.testing.assert_allclose(O[2], tip2, atol=1e-12)  # "tip of link 2"
        if name == "R-Pb":  # "rear end of link 2": link 2 at x = 0, d_2 behind the guide at link 1's tip
            np.testing.assert_allclose(O[1], points_on_link(model, q, T, 1, [0.0])[0], atol=1e-12)
            d2 = q[model.coordinate_names.index("d_2")]
            assert np.linalg.norm(O[1] - O[3]) == pytest.approx(model.chain.links[1].length - d2, rel=1e-9)


def test_contact_force_legend_says_what_the_point_is():
    import dataclasses

    from conftest import burst_result

    res = burst_result(bursts=((0.5, 3),))
    F = np.zeros((len(res.t), 1, res.model.n_joints))
    F[res.t > 0.6, 0, 2] = 4.0  # O3 rests on the floor
    fig = plotting.plot_contact_forces(dataclasses.replace(res, contact_forces=F))
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == ["$O_{3}$ (tip of link 2) on wall 1"]


def test_prismatic_variable_is_in_metres_with_its_range(prismatic):
    from matplotlib.figure import Figure

    res, figs = prismatic["R-Pb"]
    model = res.model
    k = model.coordinate_names.index("d_2")
    axes = figs["angles"].axes
    assert [a.get_ylabel() for a in axes] == ["joint angle [rad]", "angular velocity [rad/s]",
                                              "prismatic joint d [m]", "prismatic velocity [m/s]"]
    ax = axes[2]
    (curve,) = _lines_labelled(ax, "$d_{2}$")
    np.testing.assert_array_equal(curve.get_ydata(), res.q[:, k])
    # The range: two horizontal dashed lines at d_min and d_max spanning the axis.
    flat = [ln for ln in ax.get_lines() if len(set(ln.get_ydata())) == 1 and ln.get_linestyle() == "--"]
    assert sorted(float(ln.get_ydata()[0]) for ln in flat) == [0.2, 0.6]
    assert ax.get_ylim()[0] <= 0.2 and ax.get_ylim()[1] >= 0.6
    np.testing.assert_array_equal(_lines_labelled(axes[3], r"$\dot{d}_{2}$")[0].get_ydata(), res.qdot[:, k])
    # No d on the angle axes.
    assert not any("d_{2}" in ln.get_label() for a in axes[:2] for ln in a.get_lines())
    # Given axes: with two, the angles and d (positions before rates).
    two = Figure().subplots(2, 1)
    res.plot("angles", ax=two)
    assert "[rad]" in two[0].get_ylabel() and two[1].get_ylabel() == "prismatic joint d [m]"


@pytest.mark.parametrize("name", PRISMATIC)
def test_deflection_figure_is_the_tip_deflection(prismatic, name):
    from gibbsimpact.model.shapes import link_deflection

    res, figs = prismatic[name]
    model = res.model
    ax = figs["deflection"].axes[0]
    assert ax.get_ylabel() == "tip deflection [m]"
    rows = np.linspace(0, len(res.t) - 1, 12).astype(int)
    for i, lk in enumerate(model.chain.links):
        (line,) = _lines_labelled(ax, f"link {i + 1}: $v(l_{{{i + 1}}})$")
        np.testing.assert_array_equal(line.get_xdata(), res.t)
        want = [link_deflection(model, res.q[r], i, np.array([lk.length]))[0][0] for r in rows]
        np.testing.assert_allclose(line.get_ydata()[rows], want, rtol=1e-12, atol=1e-15)
        assert np.ptp(line.get_ydata()) > 1e-6  # the links do bend in these runs
    if "Pb" in name:  # below: the protruding length with its range
        low = figs["deflection"].axes[1]
        np.testing.assert_array_equal(_lines_labelled(low, "link 2: $d_{2}$")[0].get_ydata(),
                                      res.q[:, model.coordinate_names.index("d_2")])
        assert "[m]" in low.get_ylabel()
    else:
        assert len(figs["deflection"].axes) == 1


def test_deflection_of_clamped_clamped_modes_is_at_mid_span(planar):
    # Clamped-clamped shapes vanish at the tip: the figure shows v(l/2) instead of a zero line.
    from gibbsimpact.model.shapes import link_deflection

    fig = plotting.plot_deflection(planar)
    ax = fig.axes[0]
    model = planar.model
    rows = np.linspace(0, len(planar.t) - 1, 7).astype(int)
    for i, lk in enumerate(model.chain.links):
        (line,) = _lines_labelled(ax, f"link {i + 1}: $v(l_{{{i + 1}}}/2)$")
        want = [link_deflection(model, planar.q[r], i, np.array([0.5 * lk.length]))[0][0] for r in rows]
        np.testing.assert_allclose(line.get_ydata()[rows], want, rtol=1e-12, atol=1e-15)
    assert ax.get_ylabel() == "deflection [m]" and "mid-span" in _texts(fig)
    rigid = gi.Model([gi.Link(1.0, 1.0, 1.0, rotary_inertia=(1e-4, 1e-4, 1e-4))])
    assert plotting.plot_deflection(_still(rigid, rigid.state(), [])) is None


def test_end_stop_impacts_are_labelled_as_stops(prismatic, tmp_path):
    res, figs = prismatic["R-Pb"]
    stops = [r for r in res.impacts if tuple(r.wall) == (-1,)]
    assert stops and stops[0].joints == (2,)
    k = res.impacts.index(stops[0]) + 1
    # Footnote of the time plots, title of the configuration panel, marker in the trajectory.
    note = _texts(figs["angles"])
    assert f"{k}: stop 2 (d_max) at" in note and "O2 at" not in note
    titles = [a.get_title() for a in figs["configurations"].axes]
    assert any(t.startswith(f"impact {k}:") and t.endswith("stop 2 (d_max)") for t in titles), titles
    traj = figs["trajectory"].axes[0]
    (marks,) = _lines_labelled(traj, "end-stop impacts")
    assert len(marks.get_xdata()) == len(stops)
    # The marker sits at the guide: the tip of link 1 (the host).
    q = res.q[np.searchsorted(res.t, stops[0].time)]
    tip1 = plotting.link_points(res.model, q, 5)[0, -1]
    np.testing.assert_allclose([marks.get_xdata()[0], marks.get_ydata()[0]], tip1[:2], atol=1e-12)
    # An end stop mixed with wall contacts in one record, and the animation, do not break either.
    import dataclasses

    from gibbsimpact.simulation.results import ImpactRecord

    rec = stops[0]
    mixed = ImpactRecord(rec.time, (3, 2), (0, -1), np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]),
                         np.ones(2), -np.ones(2), np.ones(2), np.ones(2), rec.qdot_before, rec.qdot_after,
                         rec.energy_before, rec.energy_after)
    both = dataclasses.replace(res, impacts=[mixed], walls=(gi.Plane((0, -2, 0), (0, 1, 0)),))
    fig = plotting.plot_configurations(both, n_points=5)
    assert fig.axes[1].get_title().endswith("O3+stop 2 (d_max)")
    assert "1: O3+stop 2 (d_max) at" in _impact_note(both)
    plotting.plot_trajectory(both, n_points=5)
    from PIL import Image

    path = plotting.animate(res, tmp_path / "stops.gif", fps=40, speed=0.5, n_points=5, max_frames=6)
    with Image.open(path) as im:
        assert im.n_frames >= 2
    import matplotlib.pyplot as plt

    plt.close("all")


def test_stop_message_loses_nested_remarks_whole():
    import dataclasses

    from gibbsimpact.simulation.results import Result

    res = Result(model=None, walls=(), t=np.array([0.0, 0.25]), q=np.zeros((2, 1)), qdot=np.zeros((2, 1)),
                 phase=np.zeros(2, dtype=int), impacts=[], status="joint_limit",
                 message="joint 2 reached its limit d_2 <= d_max = 0.6 m at t = 0.25 s; results up to there are "
                         "kept (simulate(..., joint_limit='impact') bounces instead)")
    line = _status_line(res)
    assert line.endswith("results up to there are kept") and "bounces" not in line and "(" not in line[20:]
    assert _status_line(dataclasses.replace(res, status="finished")) == ""


def test_energy_title_gives_the_whole_run_and_the_per_phase_error(planar):
    # The drift of the run first, then the largest of one flight phase, each named (issue 23 item 4).
    title = " ".join(_texts(planar.plot("energy")).split())  # the title is wrapped to the figure width
    assert (f"relative drift over the whole run {planar.energy_error_whole_run:.1e}, "
            f"max per flight phase {planar.energy_error:.1e}") in title


def test_contact_force_figure_draws_the_end_stop_forces():
    # A slide held at its upper stop with mu = 2 N (tests/simulation/test_joint_limits.py): its curve
    # is in the contact-force panel, labelled with the bound.
    rod = gi.Link(0.6, 1.0, 1.0)
    model = gi.Model(gi.Chain([rod], joints=[gi.FixedPrismatic(range=(0.1, 0.5))], base=gi.FixedBase((0.0, 0.0), 0.0)),
                     gravity=(0.0, 0.0, 0.0))
    res = gi.simulate(model, model.state(d_1=0.45), np.zeros(1), (0.0, 0.4), joint_limit="impact",
                      joint_restitution=0.0, inputs={"d_1": 2.0})
    fig = plotting.plot_contact_forces(res)
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == ["end stop d_1 <= d_max = 0.5 m"]
    line = fig.axes[0].get_lines()[0]
    assert float(line.get_ydata()[-1]) == pytest.approx(2.0, rel=1e-8)


def test_energy_balance_axis_says_when_its_steps_are_impact_losses():
    # The lower panel's E - E(t0) steps down at every impact with e < 1 (a walker's heel strikes): the axis
    # says so, so that a reader does not take the steps for integration error; with e = 1 it does not.
    rod = gi.Link(1.0, 1.0, 1.0)
    model = gi.Model(gi.Chain([rod], base="planar"), gravity=(0.0, -9.81, 0.0))
    floor = gi.Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    labels = []
    for e in (0.5, 1.0):
        res = gi.simulate(model, model.state(X1=0.0, X2=0.3, theta_1=0.4), np.zeros(3), (0.0, 0.5),
                          walls=[floor], restitution=e)
        lost = res.impacts[0].energy_before.total - res.impacts[0].energy_after.total
        assert lost > 0.1 if e < 1 else abs(lost) < 1e-9  # Newton's law: (1 - e²) of the normal kinetic energy
        labels.append(plotting.plot_energy(res).axes[1].get_ylabel())
    assert "lost in impacts" in labels[0] and "lost in impacts" not in labels[1]
