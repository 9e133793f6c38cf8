"""The chain moving in its walls, as a GIF."""

from __future__ import annotations

import textwrap

import numpy as np

from ..dynamics.kinematics import transforms
from ..dynamics.link_points import link_points
from .geometry import (_link_parts, _prismatic_marks, _run_camera, _scene_extent_2d, _scene_extent_3d,
                       _scene_points, _stop_point, _to3, is_planar)
from .labels import _split_contacts, _status_line
from .scene import _draw_walls_2d, _draw_walls_3d, _setup_3d
from .style import _MARK_STYLE, _STOP_MARKER, _figure, _link_colour


def animate(result, path, fps: int = 20, speed: float = 0.25, n_points: int = 41, max_frames: int = 400,
            case_name=None, dpi: int = 100):
    """Write a GIF of the chain moving in its walls (matplotlib's PillowWriter).

    Parameters
    ----------
    path : output file (.gif)
    fps : frames per second of the animation
    speed : simulated seconds per second of animation (0.25 = four times slower than real time)
    max_frames : cap on the number of frames (the frame rate is kept; frames are spread over the run)

    Returns the Path written.
    """
    from pathlib import Path

    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    model = result.model
    t0, t1 = float(result.t[0]), float(result.t[-1])
    n_frames = int(min(max_frames, max(2, np.ceil((t1 - t0) / speed * fps) + 1)))
    times = np.linspace(t0, t1, n_frames)
    rows = np.clip(np.searchsorted(result.t, times, side="right") - 1, 0, len(result.t) - 1)
    imp_t = result.impact_times
    flash = max(3.0 * (t1 - t0) / n_frames, 1e-12)  # an impacting joint stays red for ~3 frames
    planar = is_planar(result)
    all_pts = np.concatenate([_scene_points(model, result.q[i], n_points) for i in rows[:: max(1, n_frames // 40)]])
    marks0 = _prismatic_marks(model, result.q[0])
    title = (case_name + ": " if case_name else "")
    status = _status_line(result, width=70)
    if planar:
        fig = _figure((5.2, 5.4))
        FigureCanvasAgg(fig)
        ax = fig.subplots()
        extent = _scene_extent_2d(result, all_pts)
        _draw_walls_2d(ax, result.walls, extent)
        lines = [ax.plot([], [], lw=2.4, color=_link_colour(i), solid_capstyle="round", label=f"link {i + 1}")[0]
                 for i in range(model.n_links)]
        rears = [ax.plot([], [], lw=1.1, color=_link_colour(i), zorder=3)[0] for i in range(model.n_links)]
        symbols = [ax.plot([], [], **_MARK_STYLE[kind][1])[0] for kind, _, _ in marks0]
        joints, = ax.plot([], [], "o", ms=4, color="k")
        stars, = ax.plot([], [], "*", ms=14, color="red", mec="darkred", ls="none")
        diamonds, = ax.plot([], [], **_STOP_MARKER)
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.set_xlabel("$X_1$ [m]")
        ax.set_ylabel("$X_2$ [m]")
        ax.legend(fontsize=7, loc="lower left")
    else:
        fig = _figure((5.8, 6.0))
        FigureCanvasAgg(fig)
        ax = fig.add_subplot(projection="3d")
        lo, hi = _scene_extent_3d(result, all_pts)
        _draw_walls_3d(ax, result.walls, lo, hi)
        _setup_3d(ax, lo, hi, _run_camera(result, all_pts), zoom=0.95)
        lines = [ax.plot([], [], [], lw=2.4, color=_link_colour(i), label=f"link {i + 1}")[0]
                 for i in range(model.n_links)]
        rears = [ax.plot([], [], [], lw=1.1, color=_link_colour(i))[0] for i in range(model.n_links)]
        symbols = [ax.plot([], [], [], **_MARK_STYLE[kind][1])[0] for kind, _, _ in marks0]
        shadows = [ax.plot([], [], [], lw=1.6, color="0.5", alpha=0.6)[0] for _ in range(model.n_links)]
        floor = lo[1]
        joints, = ax.plot([], [], [], "o", ms=4, color="k", ls="none")
        stars, = ax.plot([], [], [], "*", ms=14, color="red", mec="darkred", ls="none")
        diamonds, = ax.plot([], [], [], **_STOP_MARKER)
    label = ax.set_title("", fontsize=9)
    if planar:
        fig.tight_layout()
    else:
        fig.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=0.9)

    def put(artist, P):
        P = np.asarray(P, dtype=float).reshape(-1, 3)
        if planar:
            artist.set_data(P[:, 0], P[:, 1])
        else:
            artist.set_data_3d(*_to3(P))

    def draw(f):
        q = result.q[rows[f]]
        parts = _link_parts(model, q, n_points)
        O = transforms(model, q)[:, :3, 3]
        recent = [rec for rec in result.impacts if 0.0 <= times[f] - rec.time < flash]
        hit = sorted({j for rec in recent for j, _, _ in _split_contacts(rec)[0] if j <= len(O)})
        stopped = sorted({i for rec in recent for i in _split_contacts(rec)[1]})
        for ln, rear, (main, back) in zip(lines, rears, parts):
            put(ln, main)
            put(rear, back if back is not None else np.zeros((0, 3)))
        for sym, (_, _, P) in zip(symbols, _prismatic_marks(model, q)):
            put(sym, P)
        put(joints, O)
        put(stars, O[[j - 1 for j in hit]] if hit else np.zeros((0, 3)))
        put(diamonds, [_stop_point(model, q, i) for i in stopped])
        if not planar:
            for sh, p in zip(shadows, link_points(model, q, n_points)):
                p = p.copy()
                p[:, 1] = floor
                sh.set_data_3d(*_to3(p))
        n_imp = int(np.count_nonzero(imp_t <= times[f]))
        text = f"{title}t = {times[f]:.3f} s   impacts so far: {n_imp}"
        if status and f == n_frames - 1:
            text += "\n" + "\n".join(textwrap.wrap(status, 70))
        label.set_text(text)
        label.set_color("darkred" if status and f == n_frames - 1 else "black")
        return [*lines, *rears, *symbols, joints, stars, diamonds, label]

    anim = FuncAnimation(fig, draw, frames=n_frames, blit=False)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    anim.save(path, writer=PillowWriter(fps=fps), dpi=dpi)
    return path
