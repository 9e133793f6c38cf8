"""The chain moving in its walls, as a GIF."""

from __future__ import annotations

import textwrap

import numpy as np

from ..dynamics.kinematics import transforms
from ..dynamics.link_points import body_centers
from .geometry import (_link_parts, _prismatic_marks, _run_camera, _scene_extent_2d, _scene_extent_3d,
                       _scene_points, _stop_point, _to3, is_planar)
from .labels import _split_contacts, _status_line
from .scene import _body_style, _draw_walls_2d, _draw_walls_3d, _setup_3d, _shadow_points
from .style import _MARK_STYLE, _SHADOW_STYLE, _STOP_MARKER, _figure, _link_colour


def _frames(result, fps: int, speed: float, max_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Frame times (F,) [s], evenly over the run, F = min(max_frames, span / speed * fps + 1), and the
    sample row (F,) drawn at each (the last sample at or before it)."""
    t0, t1 = float(result.t[0]), float(result.t[-1])
    n_frames = int(min(max_frames, max(2, np.ceil((t1 - t0) / speed * fps) + 1)))
    times = np.linspace(t0, t1, n_frames)
    return times, np.clip(np.searchsorted(result.t, times, side="right") - 1, 0, len(result.t) - 1)


def _stage(result, rows, n_points: int, planar: bool):
    """The animation's figure with its walls and fixed axes: (fig, ax, floor X2 [m] of 3D shadows or None)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    all_pts = np.concatenate([_scene_points(result.model_at(i), result.q[i], n_points)
                              for i in rows[:: max(1, len(rows) // 40)]])
    fig = _figure((5.2, 5.4) if planar else (5.8, 6.0))
    FigureCanvasAgg(fig)
    if planar:
        ax = fig.subplots()
        extent = _scene_extent_2d(result, all_pts)
        _draw_walls_2d(ax, result.walls, extent)
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.set_xlabel("$X_1$ [m]")
        ax.set_ylabel("$X_2$ [m]")
        return fig, ax, None
    ax = fig.add_subplot(projection="3d")
    lo, hi = _scene_extent_3d(result, all_pts)
    _draw_walls_3d(ax, result.walls, lo, hi)
    _setup_3d(ax, lo, hi, _run_camera(result, all_pts), zoom=0.95)
    return fig, ax, lo[1]


def _actors(ax, model, q0, planar: bool) -> dict:
    """The artists a frame updates, empty: links, their parts behind a guide, the prismatic joint symbols,
    the attached bodies, the 3D shadows, the joints, the impact stars and end-stop diamonds."""
    empty = ([], []) if planar else ([], [], [])
    n = model.n_links
    out = {
        "links": [ax.plot(*empty, lw=2.4, color=_link_colour(i), solid_capstyle="round", label=f"link {i + 1}")[0]
                  for i in range(n)],
        "rears": [ax.plot(*empty, lw=1.1, color=_link_colour(i), zorder=3)[0] for i in range(n)],
        "symbols": [ax.plot(*empty, **_MARK_STYLE[kind][1])[0] for kind, _, _ in _prismatic_marks(model, q0)],
        "bodies": [ax.plot(*empty, **_body_style(i, b)[1])[0] for i, lk in enumerate(model.chain.links)
                   for b in lk.bodies],
        "shadows": [] if planar else [ax.plot(*empty, **_SHADOW_STYLE)[0] for _ in range(n)],
        "joints": ax.plot(*empty, "o", ms=4, color="k", ls="none")[0],
        "stars": ax.plot(*empty, "*", ms=14, color="red", mec="darkred", ls="none")[0],
        "diamonds": ax.plot(*empty, **_STOP_MARKER)[0],
    }
    if planar:
        ax.legend(fontsize=7, loc="lower left")
    return out


def _put(artist, P, planar: bool):
    """Set a line's points P (m, 3) [m] (X1, X2 in 2D; the 3D axes' order in 3D)."""
    P = np.asarray(P, dtype=float).reshape(-1, 3)
    if planar:
        artist.set_data(P[:, 0], P[:, 1])
    else:
        artist.set_data_3d(*_to3(P))


def _pose(actors, result, q, time: float, flash: float, n_points: int, floor, planar: bool, model=None):
    """Put the chain at q into the artists; the points of impacts less than ``flash`` [s] before ``time`` [s]
    get stars (wall) or diamonds (end stop). model: q's chart of the free base (Result.model_at of its
    sample), default result.model."""
    model = result.model if model is None else model
    O = transforms(model, q)[:, :3, 3]
    recent = [rec for rec in result.impacts if 0.0 <= time - rec.time < flash]
    hit = sorted({j for rec in recent for j, _, _ in _split_contacts(rec)[0] if j <= len(O)})
    stopped = sorted({i for rec in recent for i in _split_contacts(rec)[1]})
    for ln, rear, (main, back) in zip(actors["links"], actors["rears"], _link_parts(model, q, n_points)):
        _put(ln, main, planar)
        _put(rear, back if back is not None else np.zeros((0, 3)), planar)
    for sym, (_, _, P) in zip(actors["symbols"], _prismatic_marks(model, q)):
        _put(sym, P, planar)
    for art, p in zip(actors["bodies"], body_centers(model, q)[0]):
        _put(art, p, planar)
    _put(actors["joints"], O, planar)
    _put(actors["stars"], O[[j - 1 for j in hit]] if hit else np.zeros((0, 3)), planar)
    _put(actors["diamonds"], [_stop_point(model, q, i) for i in stopped], planar)
    if floor is not None:
        for sh, p in zip(actors["shadows"], _shadow_points(model, q, n_points, floor)):
            _put(sh, p, planar)


def _pose_sample(actors, result, k: int, time: float, flash: float, n_points: int, floor, planar: bool):
    """_pose at sample k, in its chart of the free base (Result.model_at)."""
    _pose(actors, result, result.q[k], time, flash, n_points, floor, planar, result.model_at(k))


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

    times, rows = _frames(result, fps, speed, max_frames)
    flash = max(3.0 * (times[-1] - times[0]) / len(times), 1e-12)  # an impacting point stays red for ~3 frames
    planar = is_planar(result)
    fig, ax, floor = _stage(result, rows, n_points, planar)
    actors = _actors(ax, result.model, result.q[0], planar)
    label = ax.set_title("", fontsize=9)
    if planar:
        fig.tight_layout()
    else:
        fig.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=0.9)
    title = (case_name + ": " if case_name else "")
    status = _status_line(result, width=70)
    imp_t = result.impact_times

    def draw(f):
        _pose_sample(actors, result, rows[f], times[f], flash, n_points, floor, planar)
        text = f"{title}t = {times[f]:.3f} s   impacts so far: {int(np.count_nonzero(imp_t <= times[f]))}"
        last = bool(status) and f == len(times) - 1
        label.set_text(text + ("\n" + "\n".join(textwrap.wrap(status, 70)) if last else ""))
        label.set_color("darkred" if last else "black")

    anim = FuncAnimation(fig, draw, frames=len(times), blit=False)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    anim.save(path, writer=PillowWriter(fps=fps), dpi=dpi)
    return path
