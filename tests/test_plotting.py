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
