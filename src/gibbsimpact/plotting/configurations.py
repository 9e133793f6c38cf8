"""Configuration figures: the chain at t0 and at the impacts, and the joints' paths over the run."""

from __future__ import annotations

import numpy as np

from ..contact.walls import describe
from ..dynamics.kinematics import transforms
from .geometry import (_run_camera, _scene_extent_2d, _scene_extent_3d, _scene_points, _stop_point, _to3,
                       is_planar)
from .labels import _contacts_text, _sample_at, _split_contacts, _status_box, _title
from .scene import _draw_chain_2d, _draw_chain_3d, _draw_links, _draw_walls_2d, _draw_walls_3d, _setup_3d
from .style import _STOP_MARKER, _figure, _given_axes, _joint_colour, _legend


_MAX_PANELS = 12  # the initial state and at most 11 impacts


def _panels(result):
    """(time, q, title, hit joints, [(joint, normal)], end-stop joints) for the initial state, the
    impacts (the first ones and the last, _MAX_PANELS in all) and, without impacts or when the run
    stopped after its last impact, the final state."""
    panels = [(float(result.t[0]), result.q[0], f"t = {result.t[0]:.6g} s (initial)", (), None, ())]
    t_end = float(result.t[-1])
    last = result.impacts[-1].time if result.impacts else -np.inf
    final = not result.impacts or (result.status != "finished" and t_end > last + 1e-9 * max(1.0, abs(t_end)))
    room = _MAX_PANELS - 1 - int(final)
    imps = list(enumerate(result.impacts, start=1))
    if len(imps) > room:
        imps = imps[:room - 1] + imps[-1:]
    for k, rec in imps:
        i = int(np.searchsorted(result.t, rec.time, side="left"))
        i = min(i, len(result.t) - 1)
        q = result.q[i]
        normals, stops = _split_contacts(rec)
        panels.append((rec.time, q, f"impact {k}: t = {rec.time:.6f} s, {_contacts_text(result, rec)}",
                       tuple(j for j, _, _ in normals), normals, tuple(stops)))
    if final:
        end = "final" if result.status == "finished" else f"stopped: {result.status}"
        panels.append((t_end, result.q[-1], f"t = {t_end:.6g} s ({end})", (), None, ()))
    return panels


def plot_configurations(result, case_name=None, n_points: int = 41, ax=None):
    """The chain at t0 and at every impact (at most 11 impact panels: the first 10 and the last;
    a run that stopped early also at its last state), walls drawn, equal axes; returns the Figure.

    Deformed links are drawn with their mode shapes; impacting joints are red stars with
    their wall normal as a red arrow. ax : None (a new figure), or one or more Axes (3D
    axes, ``projection="3d"``, for a spatial run) that receive the panels in turn.
    """
    model = result.model
    panels = _panels(result)
    planar = is_planar(result)
    own = ax is None
    if not own:
        given = _given_axes(ax, len(panels), "plot_configurations")
        if not planar and any(a.name != "3d" for a in given):
            raise ValueError("plot_configurations: this run moves in 3D; pass axes made with projection='3d'")
        panels = panels[:len(given)]
    n = len(panels)
    ncols = n if n <= 3 else (2 if n == 4 else (3 if n <= 9 else 4))
    nrows = int(np.ceil(n / ncols))
    all_pts = np.concatenate([_scene_points(model, p[1], n_points) for p in panels])
    walls = "; ".join(describe(w) for w in result.walls) or "no walls"
    drawn = [p[2].split(":")[0].split()[1] for p in panels if p[2].startswith("impact")]
    n_imp = len(result.impacts)
    shown = "" if len(drawn) == n_imp else f"; impacts 1-{drawn[-2]} and {drawn[-1]} of {n_imp} drawn"
    title = _title(result, f"configurations at the impacts ({walls}{shown})", case_name,
                   width_in=(3.7 if planar else (5.0 if ncols > 1 else 6.0)) * ncols)
    note = ("red star: impacting joint; red arrow: wall normal into the free region"
            + ("; red diamond: a prismatic joint at an end stop" if any(p[5] for p in panels) else "")
            + ("; thin line on the host: the part of a link behind its guide"
               if "Pb" in model.joint_kinds else "")
            + ("" if planar else "; grey: shadow on the floor; X2 vertical, camera along the least joint motion"))
    if planar:
        if own:
            fig = _figure((3.7 * ncols, 3.7 * nrows + 0.7 + 0.25 * title.count("\n")), layout="constrained")
            axes = list(fig.subplots(nrows, ncols, squeeze=False).ravel())
        else:
            axes, fig = given, given[0].figure
        extent = _scene_extent_2d(result, all_pts)
        for a, (t, q, text, hit, normals, stops) in zip(axes, panels):
            _draw_walls_2d(a, result.walls, extent)
            _draw_chain_2d(a, model, q, n_points, hit, normals, arrow=0.12 * (extent[1] - extent[0]), stops=stops)
            a.set_xlim(extent[0], extent[1])
            a.set_ylim(extent[2], extent[3])
            a.set_aspect("equal")
            a.set_title(text, fontsize=9)
            a.set_xlabel("$X_1$ [m]", fontsize=8)
            a.set_ylabel("$X_2$ [m]", fontsize=8)
            a.tick_params(labelsize=7)
        for a in axes[n:]:
            a.set_visible(False)
        axes[0].legend(fontsize=7, loc="lower left")
        if own:
            fig.suptitle(title, fontsize=11 if "\n" not in title else 10)
            fig.supxlabel(note, fontsize=7, color="0.3", x=0.01, ha="left")
    else:
        lo, hi = _scene_extent_3d(result, all_pts)
        view = _run_camera(result, all_pts)
        if own:
            size = 5.0 if ncols > 1 else 6.0
            fig = _figure((size * ncols, size * nrows + 0.8))
            top = 1.0 - (0.5 + 0.2 * title.count("\n")) / (size * nrows + 0.8)
            fig.subplots_adjust(left=0.0, right=1.0, bottom=0.3 / (size * nrows + 0.8), top=top,
                                wspace=0.0, hspace=0.0)
            axes = [fig.add_subplot(nrows, ncols, k + 1, projection="3d") for k in range(n)]
        else:
            axes, fig = given, given[0].figure
        for a, (t, q, text, hit, normals, stops) in zip(axes, panels):
            _draw_walls_3d(a, result.walls, lo, hi)
            _draw_chain_3d(a, model, q, n_points, hit, normals, floor=lo[1], arrow=0.12 * (hi[0] - lo[0]),
                           stops=stops)
            _setup_3d(a, lo, hi, view, zoom=0.92 if own else 1.0)
            if own:  # inside the panel's box: the panels touch
                a.text2D(0.5, 0.99, text, transform=a.transAxes, ha="center", va="top", fontsize=9)
            else:
                a.set_title(text, fontsize=9)
        if own:
            fig.suptitle(title, fontsize=11 if "\n" not in title else 10)
            fig.text(0.01, 0.005, note, fontsize=7, color="0.3", ha="left", va="bottom")
    if not own:
        _status_box(axes[0], result)
    return fig


def plot_trajectory(result, case_name=None, n_points: int = 41, ax=None):
    """Paths of the joints over the whole run, with the chain at t0 (grey) and at the end; returns the Figure.

    ax : None (a new figure) or one Axes (3D, ``projection="3d"``, for a spatial run).
    """
    model = result.model
    P = result.joint_positions()
    ends = [result.q[0], result.q[-1]]
    all_pts = np.concatenate([P.reshape(-1, 3)] + [_scene_points(model, q, n_points) for q in ends])
    planar = is_planar(result)
    own = ax is None
    if not own:
        ax = _given_axes(ax, 1, "plot_trajectory")[0]
        if not planar and ax.name != "3d":
            raise ValueError("plot_trajectory: this run moves in 3D; pass axes made with projection='3d'")
    end = "final state" if result.status == "finished" else f"state when it stopped ({result.status})"
    impact_points, stop_points = [], []
    for rec in result.impacts:
        q = _sample_at(result, rec.time)
        hits, stops = _split_contacts(rec)
        if hits:
            O = transforms(model, q)[:, :3, 3]
            impact_points += [pt if pt is not None else O[j - 1] for j, _, pt in hits]
        stop_points += [_stop_point(model, q, i) for i in stops]
    impact_points = np.array(impact_points).reshape(-1, 3)
    stop_points = np.array(stop_points).reshape(-1, 3)
    marks = "".join(["; red stars: impacts" if len(impact_points) else "",
                     "; red diamonds: end stops" if len(stop_points) else ""])
    what = (f"joint paths, t = {result.t[0]:.6g} ... {result.t[-1]:.6g} s "
            f"(coloured chain: {end}; grey: at t0{marks})")
    title = _title(result, what, case_name, width_in=7.4)
    if planar:
        if own:
            fig = _figure((7.4, 6.4 + 0.2 * title.count("\n")))
            ax = fig.subplots()
        fig = ax.figure
        extent = _scene_extent_2d(result, all_pts)
        _draw_walls_2d(ax, result.walls, extent)
        for j in range(P.shape[1]):
            ax.plot(P[:, j, 0], P[:, j, 1], lw=0.9, color=_joint_colour(j), label=f"path of $O_{{{j + 1}}}$",
                    zorder=2)
        _draw_links(lambda Q, **st: ax.plot(Q[:, 0], Q[:, 1], solid_capstyle="round", **st), model, ends[0],
                    n_points, lw=2.0, colour="0.6", label=False, zorder=2.5)
        ax.plot([], [], lw=2.0, color="0.6", label="chain at $t_0$")
        _draw_chain_2d(ax, model, ends[1], n_points, labels=True)
        if len(impact_points):
            ax.plot(impact_points[:, 0], impact_points[:, 1], "*", ms=10, color="red", mec="darkred", zorder=5,
                    ls="none", label="impacts")
        if len(stop_points):
            ax.plot(stop_points[:, 0], stop_points[:, 1], zorder=5, label="end-stop impacts", **_STOP_MARKER)
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.set_xlabel("$X_1$ [m]")
        ax.set_ylabel("$X_2$ [m]")
        _legend(ax, ncol=2, outside=own)
    else:
        if own:
            fig = _figure((7.6, 7.2 + 0.2 * title.count("\n")))
            ax = fig.add_subplot(projection="3d")
        fig = ax.figure
        lo, hi = _scene_extent_3d(result, all_pts)
        _draw_walls_3d(ax, result.walls, lo, hi)
        for j in range(P.shape[1]):
            ax.plot(*_to3(P[:, j]), lw=0.9, color=_joint_colour(j), label=f"path of $O_{{{j + 1}}}$")
        _draw_links(lambda Q, **st: ax.plot(*_to3(Q), **st), model, ends[0], n_points, lw=2.0, colour="0.6",
                    label=False)
        ax.plot([], [], [], lw=2.0, color="0.6", label="chain at $t_0$")
        _draw_chain_3d(ax, model, ends[1], n_points, floor=lo[1])
        if len(impact_points):
            ax.plot(*_to3(impact_points), "*", ms=10, color="red", mec="darkred", ls="none", label="impacts")
        if len(stop_points):
            ax.plot(*_to3(stop_points), label="end-stop impacts", **_STOP_MARKER)
        _setup_3d(ax, lo, hi, _run_camera(result, all_pts), zoom=1.1 if own else 1.0)
        ax.legend(fontsize=7, loc="upper left")
    if own:
        fig.suptitle(title, fontsize=10)
        if planar:
            fig.tight_layout()
        else:
            fig.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=0.93 - 0.02 * title.count("\n"))
    else:
        _status_box(ax, result)
    return fig
