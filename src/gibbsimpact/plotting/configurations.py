"""Configuration figures: the chain at t0 and at each collision episode, and the joints' paths over the run."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..contact.walls import describe
from ..dynamics.kinematics import transforms
from .geometry import (_run_camera, _scene_extent_2d, _scene_extent_3d, _scene_points, _stop_point, _to3,
                       is_planar)
from .impacts import _episode_contacts, _range_text, impact_groups, panel_groups
from .labels import (_point_label, _sample_index, _split_contacts, _status_box, _title, _wrap_note,
                     coincident_groups)
from .scene import _draw_chain_2d, _draw_chain_3d, _draw_links, _draw_walls_2d, _draw_walls_3d, _setup_3d
from .style import _STOP_MARKER, _T0_STYLE, _figure, _given_axes, _joint_colour, _legend

_MAX_PANELS = 12  # the initial state and at most 11 contact episodes


class _Panel(NamedTuple):
    """One configuration drawing: time [s], q (N,), title, impacting contact points, [(point, normal (3,),
    where it touched (3,) or None)] or None, end-stop joints; episode: 1-based impact numbers or None;
    model: the model of q's chart of the free base (Result.model_at)."""
    t: float
    q: np.ndarray
    text: str
    hit: tuple
    normals: list | None
    stops: tuple
    episode: tuple | None = None
    model: object = None


def _episode_panel(result, first: int, last: int) -> _Panel:
    """The panel of the contact episode of impacts first ... last (0-based): the state before its first
    impact, with every contact point, normal and end stop of the episode (each point once)."""
    imps = result.impacts
    normals, stops, seen = [], [], set()
    for rec in imps[first:last + 1]:
        hits, ends = _split_contacts(rec)
        normals += [h for h in hits if h[0] not in seen]
        seen |= {h[0] for h in hits}
        stops += [i for i in ends if i not in stops]
    t_a, t_b = imps[first].time, imps[last].time
    when = f"t = {t_a:.6f} s" if first == last else f"t = {t_a:.6f} \u2026 {t_b:.6f} s"
    head = f"impact {first + 1}" if first == last else f"impacts {_range_text(first + 1, last + 1)}"
    k = _sample_index(result, t_a)
    return _Panel(t_a, result.q[k], f"{head}: {when}, {_episode_contacts(result, first, last)}",
                  tuple(j for j, _, _ in normals), normals, tuple(stops), (first + 1, last + 1), result.model_at(k))


def _panels(result) -> list:
    """The panels of plot_configurations: the initial state, the impact groups (impacts.impact_groups: the
    collision episodes of a run; the first ones and the last, _MAX_PANELS in all) and, without impacts or
    when the run stopped after its last impact, the final state."""
    panels = [_Panel(float(result.t[0]), result.q[0], f"t = {result.t[0]:.6g} s (initial)", (), None, (),
                     model=result.model_at(0))]
    t_end = float(result.t[-1])
    last = result.impacts[-1].time if result.impacts else -np.inf
    final = not result.impacts or (result.status != "finished" and t_end > last + 1e-9 * max(1.0, abs(t_end)))
    room = _MAX_PANELS - 1 - int(final)
    episodes = panel_groups(result)
    if len(episodes) > room:
        episodes = episodes[:room - 1] + episodes[-1:]
    panels += [_episode_panel(result, a, b) for a, b in episodes]
    if final:
        end = "final" if result.status == "finished" else f"stopped: {result.status}"
        panels.append(_Panel(t_end, result.q[-1], f"t = {t_end:.6g} s ({end})", (), None, (),
                             model=result.model_at(len(result.t) - 1)))
    return panels


def _configurations_title(result, panels, case_name, width_in: float) -> str:
    """Title of the configurations figure: the walls, and which impacts and episodes are drawn."""
    walls = "; ".join(describe(w) for w in result.walls) or "no walls"
    drawn = [p.episode for p in panels if p.episode is not None]
    n_imp = len(result.impacts)
    groups, physical = impact_groups(result)
    n_ep, n_panels = len(groups), len(panel_groups(result))
    shown = ""
    if n_ep < n_imp:
        kind = "collision" if physical else "contact"
        shown = f"; {n_imp} impacts in {n_ep} {kind} episode{'s' if n_ep > 1 else ''}, " + (
            "one panel each" if n_panels == n_ep else "one panel per impact" if n_panels == n_imp else
            f"{n_panels} panels, a new one where the chain has moved")
        if len(drawn) < n_panels:
            shown += f" (the first {len(drawn) - 1} and the last drawn)"
    elif len(drawn) < n_imp:
        shown = f"; impacts 1-{drawn[-2][1]} and {drawn[-1][0]} of {n_imp} drawn"
    what = "configurations at the impacts" if n_imp else "configurations at the start and the end, no impacts"
    return _title(result, f"{what} ({walls}{shown})", case_name, width_in=width_in)


def _panel_title(ax, text: str) -> str:
    """A panel's title broken into lines as wide as its column of the figure (9 pt; labels._wrap_note's
    measure), or as its Axes when they were given, so that a long list of contacts does not run over the
    next panel."""
    spec = ax.get_subplotspec()
    width = ax.figure.get_figwidth() / spec.get_gridspec().ncols if spec is not None else \
        ax.get_position().width * ax.figure.get_figwidth()
    return _wrap_note(text, width, fontsize=9.0)


def _draw_panels_2d(result, axes, panels, n_points, all_pts):
    """The 2D panels (X1-X2 plane), one per Axes; the unused Axes hidden."""
    extent = _scene_extent_2d(result, all_pts)
    for a, p in zip(axes, panels):
        _draw_walls_2d(a, result.walls, extent)
        _draw_chain_2d(a, p.model, p.q, n_points, p.hit, p.normals, arrow=0.12 * (extent[1] - extent[0]),
                       stops=p.stops)
        a.set_xlim(extent[0], extent[1])
        a.set_ylim(extent[2], extent[3])
        a.set_aspect("equal")
        a.set_title(_panel_title(a, p.text), fontsize=9)
        a.set_xlabel("$X_1$ [m]", fontsize=8)
        a.set_ylabel("$X_2$ [m]", fontsize=8)
        a.tick_params(labelsize=7)
    for a in axes[len(panels):]:
        a.set_visible(False)
    axes[0].legend(fontsize=7, loc="lower left")


def _draw_panels_3d(result, axes, panels, n_points, all_pts, own: bool):
    """The 3D panels (X2 vertical, the camera along the least joint motion), one per Axes."""
    lo, hi = _scene_extent_3d(result, all_pts)
    view = _run_camera(result, all_pts)
    for a, p in zip(axes, panels):
        _draw_walls_3d(a, result.walls, lo, hi)
        _draw_chain_3d(a, p.model, p.q, n_points, p.hit, p.normals, floor=lo[1], arrow=0.12 * (hi[0] - lo[0]),
                       stops=p.stops)
        _setup_3d(a, lo, hi, view, zoom=0.92 if own else 1.0)
        if own:  # inside the panel's box: the panels touch
            a.text2D(0.5, 0.99, _panel_title(a, p.text), transform=a.transAxes, ha="center", va="top", fontsize=9)
        else:
            a.set_title(_panel_title(a, p.text), fontsize=9)


def _configurations_note(model, panels, planar: bool) -> str:
    """The footnote of the configuration figure: what its marks mean, only those it draws."""
    parts = [
        "red star: impacting point; red arrow: wall normal into the free region" if any(p.hit for p in panels) else "",
        "red diamond: a prismatic joint at an end stop" if any(p.stops for p in panels) else "",
        "thin line on the host: the part of a link behind its guide" if any(k.guide for k in model.joint_specs) else "",
        "" if planar else "pale wide band: the chain's shadow on the floor; X2 vertical, camera along the least "
                          "joint motion",
    ]
    return "; ".join(p for p in parts if p)


def _configurations_figure(planar: bool, n: int, title: str):
    """A new figure of n configuration panels and its Axes (2D, or 3D touching panels)."""
    ncols = n if n <= 3 else (2 if n == 4 else (3 if n <= 9 else 4))
    nrows = int(np.ceil(n / ncols))
    if planar:
        fig = _figure((3.7 * ncols, 3.7 * nrows + 0.7 + 0.25 * title.count("\n")), layout="constrained")
        return fig, list(fig.subplots(nrows, ncols, squeeze=False).ravel())
    size = 5.0 if ncols > 1 else 6.0
    fig = _figure((size * ncols, size * nrows + 0.8))
    top = 1.0 - (0.5 + 0.2 * title.count("\n")) / (size * nrows + 0.8)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.3 / (size * nrows + 0.8), top=top, wspace=0.0, hspace=0.0)
    return fig, [fig.add_subplot(nrows, ncols, k + 1, projection="3d") for k in range(n)]


def plot_configurations(result, case_name=None, n_points: int = 41, ax=None):
    """The chain at t0 and at each collision episode with impacts (impacts.impact_groups: Result.episodes;
    for a Result built by hand, impacts closer than 1/300 of the run; at most 11 episode panels, the first
    10 and the last; a run that stopped early also at its last state), walls drawn, equal axes; returns
    the Figure.

    Deformed links are drawn with their mode shapes, at the state before the episode's first impact;
    the episode's impacting points are red stars with their wall normal as a red arrow. ax : None (a
    new figure), or one or more Axes (3D axes, ``projection="3d"``, for a spatial run) that receive
    the panels in turn.
    """
    model = result.model
    panels = _panels(result)
    planar = is_planar(result)
    own = ax is None
    if not own:
        axes = _given_axes(ax, len(panels), "plot_configurations")
        if not planar and any(a.name != "3d" for a in axes):
            raise ValueError("plot_configurations: this run moves in 3D; pass axes made with projection='3d'")
        panels, fig = panels[:len(axes)], axes[0].figure
    n = len(panels)
    ncols = n if n <= 3 else (2 if n == 4 else (3 if n <= 9 else 4))
    all_pts = np.concatenate([_scene_points(p.model, p.q, n_points) for p in panels])
    title = _configurations_title(result, panels, case_name,
                                  (3.7 if planar else (5.0 if ncols > 1 else 6.0)) * ncols)
    note = _configurations_note(model, panels, planar)
    if own:
        fig, axes = _configurations_figure(planar, n, title)
    if planar:
        _draw_panels_2d(result, axes, panels, n_points, all_pts)
    else:
        _draw_panels_3d(result, axes, panels, n_points, all_pts, own)
    if own:
        fig.suptitle(title, fontsize=11 if "\n" not in title else 10)
        if planar:
            fig.supxlabel(note, fontsize=7, color="0.3", x=0.01, ha="left")
        else:
            fig.text(0.01, 0.005, note, fontsize=7, color="0.3", ha="left", va="bottom")
    else:
        _status_box(axes[0], result)
    return fig


def _impact_points(result) -> tuple[np.ndarray, np.ndarray]:
    """Where the impacts touched (M, 3) [m] (ImpactRecord.points, else the joint O_j) and where the
    end-stop impacts were (S, 3) [m] (the guide or carriage)."""
    impact_points, stop_points = [], []
    for rec in result.impacts:
        k = _sample_index(result, rec.time)
        q, model = result.q[k], result.model_at(k)
        hits, stops = _split_contacts(rec)
        if hits:
            O = transforms(model, q)[:, :3, 3]
            impact_points += [pt if pt is not None else O[j - 1] for j, _, pt in hits]
        stop_points += [_stop_point(model, q, i) for i in stops]
    return np.array(impact_points).reshape(-1, 3), np.array(stop_points).reshape(-1, 3)


def _draw_trajectory(ax, result, n_points, P, planar: bool, floor=None):
    """Joint paths P (K, P, 3) [m], the chain at t0 (dashed grey) and at the end (link colours), the
    impact points (red stars) and end stops (red diamonds), into 2D or 3D axes."""
    model, first, last = result.model, result.model_at(0), result.model_at(len(result.t) - 1)
    put = (lambda Q: (Q[..., 0], Q[..., 1])) if planar else _to3
    # Points together all run long (a tree's joint): one path, coloured by its place among the paths.
    for c, group in enumerate(coincident_groups(P)):
        j = group[0]
        ax.plot(*put(P[:, j]), lw=0.9, color=_joint_colour(c), zorder=2,
                label=f"path of {_point_label(model, j + 1, [k + 1 for k in group])}")
    _draw_links(lambda Q, **st: ax.plot(*put(Q), solid_capstyle="round", **st), first, result.q[0], n_points,
                lw=_T0_STYLE["lw"], colour=_T0_STYLE["color"], label=False, ls=_T0_STYLE["ls"], zorder=2.5)
    ax.plot(*put(np.zeros((0, 3))), label="chain at $t_0$", **_T0_STYLE)
    if planar:
        _draw_chain_2d(ax, last, result.q[-1], n_points, labels=True)
    else:
        _draw_chain_3d(ax, last, result.q[-1], n_points, floor=floor)
    impact_points, stop_points = _impact_points(result)
    if len(impact_points):
        ax.plot(*put(impact_points), "*", ms=10, color="red", mec="darkred", zorder=5, ls="none", label="impacts")
    if len(stop_points):
        ax.plot(*put(stop_points), zorder=5, label="end-stop impacts", **_STOP_MARKER)
    return len(impact_points), len(stop_points)


def plot_trajectory(result, case_name=None, n_points: int = 41, ax=None):
    """Paths of the joints over the whole run, with the chain at t0 (dashed grey) and at the end (in the
    link colours); returns the Figure.

    ax : None (a new figure) or one Axes (3D, ``projection="3d"``, for a spatial run).
    """
    P = result.joint_positions()
    all_pts = np.concatenate([P.reshape(-1, 3)] + [_scene_points(result.model_at(k), result.q[k], n_points)
                                                   for k in (0, len(result.t) - 1)])
    planar = is_planar(result)
    own = ax is None
    if not own:
        ax = _given_axes(ax, 1, "plot_trajectory")[0]
        if not planar and ax.name != "3d":
            raise ValueError("plot_trajectory: this run moves in 3D; pass axes made with projection='3d'")
    else:
        fig = _figure((7.4, 6.4) if planar else (7.6, 7.2))
        ax = fig.add_subplot() if planar else fig.add_subplot(projection="3d")
    fig = ax.figure
    if planar:
        extent = _scene_extent_2d(result, all_pts)
        _draw_walls_2d(ax, result.walls, extent)
        n_imp, n_stop = _draw_trajectory(ax, result, n_points, P, planar)
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.set_xlabel("$X_1$ [m]")
        ax.set_ylabel("$X_2$ [m]")
        _legend(ax, ncol=2, outside=own)
    else:
        lo, hi = _scene_extent_3d(result, all_pts)
        _draw_walls_3d(ax, result.walls, lo, hi)
        n_imp, n_stop = _draw_trajectory(ax, result, n_points, P, planar, floor=lo[1])
        _setup_3d(ax, lo, hi, _run_camera(result, all_pts), zoom=1.1 if own else 1.0)
        ax.legend(fontsize=7, loc="upper left")
    if not own:
        _status_box(ax, result)
        return fig
    end = "final state" if result.status == "finished" else f"state when it stopped ({result.status})"
    marks = "".join(["; red stars: impacts" if n_imp else "", "; red diamonds: end stops" if n_stop else ""])
    title = _title(result, f"joint paths, t = {result.t[0]:.6g} ... {result.t[-1]:.6g} s "
                   f"(coloured chain: {end}; dashed: at t0{marks})", case_name, width_in=7.4)
    fig.set_figheight(fig.get_figheight() + 0.2 * title.count("\n"))
    fig.suptitle(title, fontsize=10)
    if planar:
        fig.tight_layout()
    else:
        fig.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=0.93 - 0.02 * title.count("\n"))
    return fig
