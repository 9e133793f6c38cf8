"""Drawing the chain and its walls into 2D (X1-X2) or 3D axes."""

from __future__ import annotations

import numpy as np

from ..dynamics.kinematics import joint_positions, transforms
from ..dynamics.link_points import body_centers, link_points
from .geometry import _link_parts, _plane_polygon_3d, _prismatic_marks, _stop_point, _to3, _wall_curves_2d
from .labels import _shared_label, coincident_groups
from .style import _BODY_STYLE, _MARK_STYLE, _SHADOW_STYLE, _STOP_MARKER, _link_colour


def _draw_walls_2d(ax, walls, extent):
    """Shade the region outside the walls and draw the boundary of the free region in the X1-X2 plane.

    Each wall is drawn only where it bounds the free region (inside the view and on the
    free side of the other walls): two planes make a V, not an X. An obstacle (inside=False) is
    also filled as a solid body (a Polygon patch of its section, gid "obstacle k").
    """
    if not walls:
        return
    x0, x1, y0, y1 = extent
    X, Y = np.meshgrid(np.linspace(x0, x1, 300), np.linspace(y0, y1, 300))
    P = np.stack([X, Y, np.zeros_like(X)], axis=-1)
    G = np.min([w.gap(P) for w in walls], axis=0)
    ax.contourf(X, Y, G, levels=[-np.inf, 0.0], colors=["0.85"], zorder=0)
    for k, w in enumerate(walls):
        if w.obstacle and len(w.section()):
            patch, = ax.fill(*w.section().T, facecolor=_OBSTACLE_FACE, edgecolor="none", zorder=0.5)
            patch.set_gid(f"obstacle {k + 1}")
    for k, seg in _wall_curves_2d(walls, extent):
        ln, = ax.plot(seg[:, 0], seg[:, 1], color="0.15", lw=1.6, zorder=1)
        ln.set_gid(f"wall {k + 1}")


def _draw_links(plot, model, q, n_points, lw=2.4, colour=None, label=True, **kw):
    """Draw every link through ``plot(points (m, 3), **style)``: the part of a Pb link behind its guide
    thinner and on top (it runs along the host), then the prismatic joint symbols."""
    for i, (main, rear) in enumerate(_link_parts(model, q, n_points)):
        c = colour or _link_colour(i)
        plot(main, lw=lw, color=c, label=f"link {i + 1}" if label else None, **kw)
        if rear is not None:
            rear_kw = dict(kw, zorder=kw["zorder"] + 0.5) if "zorder" in kw else kw
            plot(rear, lw=0.45 * lw, color=c, label=f"link {i + 1} behind its guide" if label else None, **rear_kw)
    seen = set()
    for kind, _, P in _prismatic_marks(model, q):
        text, style = _MARK_STYLE[kind]
        style = dict(style, color=colour) if colour is not None else style
        plot(P, label=text if label and kind not in seen else None, **{**style, **kw})
        seen.add(kind)


def _draw_bodies(plot, model, q, label=True, colour=None, **kw):
    """Draw the attached rigid bodies through ``plot(points (1, 3), **style)``: a hub as an open disc
    on its joint, a payload as a square at its centre (style._BODY_STYLE), in its link's colour."""
    P, owner = body_centers(model, q)
    seen = set()
    for p, (i, b) in zip(P, owner):
        text, style = _body_style(i, b, colour)
        plot(p[None, :], label=text if label and text not in seen else None, **{**style, **kw})
        seen.add(text)


def _body_style(i: int, body, colour=None) -> tuple[str, dict]:
    """(legend text, marker style) of a body on link i (0-based): a hub (at = 0, no offset) an open disc,
    any other body a filled square, in the link's colour (style._BODY_STYLE)."""
    kind = "hub" if body.at == 0.0 and not any(body.center) else "payload"
    text, style = _BODY_STYLE[kind]
    c = colour or _link_colour(i)
    return text, dict(style, color=c, mfc="none" if kind == "hub" else c)


def _draw_chain_2d(ax, model, q, n_points, hit=(), normals=None, labels=True, arrow=0.25, stops=()):
    _draw_links(lambda P, **st: ax.plot(P[:, 0], P[:, 1], solid_capstyle="round", **st), model, q, n_points,
                zorder=3)
    _draw_bodies(lambda P, **st: ax.plot(P[:, 0], P[:, 1], **st), model, q, label=labels, zorder=4.5)
    T = transforms(model, np.asarray(q, dtype=float))
    # Contact points: the frame origins, then the tips of hosts of prismatic joints (Model.n_joints).
    O = np.vstack((T[:, :3, 3], joint_positions(model, np.asarray(q, dtype=float))[T.shape[0]:]))
    ax.plot(O[:, 0], O[:, 1], "o", ms=4, color="k", zorder=4)
    for j, p in enumerate(O, start=1):
        if j in hit:
            ax.plot(p[0], p[1], "*", ms=13, color="red", mec="darkred", zorder=5)
    # One label per point: the points that coincide (a tree's links leaving one joint) share it.
    for group in coincident_groups(O) if labels else ():
        j, p, text = group[0] + 1, O[group[0]], _shared_label([k + 1 for k in group])
        a = T[j - 1][:2, 0] if j <= model.n_links else np.zeros(2)
        if j <= model.n_links and model.joint_specs[j - 1].guide and np.linalg.norm(a) > 0:
            # The rear end of a link in a guide lies on the host, with the guide just ahead:
            # its label goes beside the link (right-hand side), not onto the guide.
            a = a / np.linalg.norm(a)
            ax.annotate(text, p[:2], xytext=(9 * a[1], -9 * a[0]), textcoords="offset points",
                        fontsize=8, zorder=6, ha="center", va="center")
        else:
            ax.annotate(text, p[:2], xytext=(4, 4), textcoords="offset points", fontsize=8, zorder=6)
    for i in stops:
        p = _stop_point(model, q, i)
        ax.plot(p[0], p[1], zorder=5, **_STOP_MARKER)
    if normals is not None:
        for j, n, pt in normals:
            p = pt if pt is not None else O[j - 1]
            if j > len(O):  # a link's span (contacts.Contacts): its star here, joints' above
                ax.plot(p[0], p[1], "*", ms=13, color="red", mec="darkred", zorder=5)
            ax.annotate("", xy=p[:2] + arrow * n[:2], xytext=p[:2],
                        arrowprops={"arrowstyle": "->", "color": "red", "lw": 1.2}, zorder=5)


#: Fill colour of an obstacle's body (2D patch, 3D surface).
_OBSTACLE_FACE = "0.55"


def _draw_sphere_3d(ax, walls, k, lo, hi):
    """A container sphere as a light wireframe with two darker great circles; an obstacle as a solid surface."""
    w = walls[k]
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 37), np.linspace(0, np.pi, 19))
    c, R = np.asarray(w.center), w.radius
    P = np.stack([c[0] + R * np.cos(u) * np.sin(v), c[1] + R * np.sin(u) * np.sin(v), c[2] + R * np.cos(v)], axis=-1)
    if w.obstacle:
        ax.plot_surface(*_to3(P), color=_OBSTACLE_FACE, alpha=0.9, linewidth=0, shade=True).set_gid(f"obstacle {k + 1}")
        return
    ax.plot_wireframe(*_to3(P), color="0.6", lw=0.3, alpha=0.45, rstride=3, cstride=3)
    # Equator and the X1-X2 great circle, a little darker, for orientation.
    s = np.linspace(0, 2 * np.pi, 121)
    for ring in (np.stack([np.cos(s), np.zeros_like(s), np.sin(s)], -1),
                 np.stack([np.cos(s), np.sin(s), np.zeros_like(s)], -1)):
        ax.plot(*_to3(c + R * ring), color="0.45", lw=0.6, alpha=0.7)


def _draw_circle_3d(ax, walls, k, lo, hi):
    """A container cylinder (along X3, over the view's X3 range) as three rings; an obstacle as a solid surface."""
    w = walls[k]
    s = np.linspace(0, 2 * np.pi, 121)
    if w.obstacle:
        S, Z = np.meshgrid(s, np.linspace(lo[2], hi[2], 2))
        P = np.stack([w.center[0] + w.radius * np.cos(S), w.center[1] + w.radius * np.sin(S), Z], axis=-1)
        ax.plot_surface(*_to3(P), color=_OBSTACLE_FACE, alpha=0.9, linewidth=0, shade=True).set_gid(f"obstacle {k + 1}")
        return
    for z in np.linspace(lo[2], hi[2], 3):
        P = np.stack([w.center[0] + w.radius * np.cos(s), w.center[1] + w.radius * np.sin(s), np.full_like(s, z)],
                     axis=-1)
        ax.plot(*_to3(P), color="0.45", lw=0.8)


def _draw_plane_3d(ax, walls, k, lo, hi):
    """A plane as a translucent polygon, clipped to the box [lo, hi] and to the free side of the other planes."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    poly = _plane_polygon_3d(walls, k, lo, hi)
    if len(poly) >= 3:
        X3, X1, X2 = _to3(poly)
        ax.add_collection3d(Poly3DCollection([np.column_stack([X3, X1, X2])], facecolor="0.7", alpha=0.35,
                                             edgecolor="0.3", lw=0.8))


#: How each wall kind (Wall.kind, walls.WALL_KINDS) is drawn in 3D axes: the one place figures dispatch on kinds.
_DRAW_3D = {"sphere": _draw_sphere_3d, "circle": _draw_circle_3d, "plane": _draw_plane_3d}


def _draw_walls_3d(ax, walls, lo, hi):
    """Draw every wall into 3D axes over the box [lo, hi] (3,) [m] (_DRAW_3D by kind)."""
    for k, w in enumerate(walls):
        _DRAW_3D[w.kind](ax, walls, k, lo, hi)


def _shadow_points(model, q, n_points, floor: float) -> np.ndarray:
    """The links' points (n_links, n_points, 3) [m] projected onto the floor X2 = floor [m]."""
    p = link_points(model, q, n_points)
    p[..., 1] = floor
    return p


def _draw_shadow(ax, model, q, n_points, floor: float, label: bool = False):
    """The chain's shadow on the floor X2 = floor (3D axes): shows where the chain is in depth."""
    for i, p in enumerate(_shadow_points(model, q, n_points, floor)):
        ax.plot(*_to3(p), label="shadow on the floor" if label and i == 0 else None, **_SHADOW_STYLE)


def _draw_chain_3d(ax, model, q, n_points, hit=(), normals=None, labels=True, floor=None, arrow=0.25, stops=()):
    _draw_links(lambda P, **st: ax.plot(*_to3(P), **st), model, q, n_points)
    _draw_bodies(lambda P, **st: ax.plot(*_to3(P), **st), model, q, label=labels)
    if floor is not None:
        _draw_shadow(ax, model, q, n_points, floor, label=labels)
    T = transforms(model, np.asarray(q, dtype=float))
    O = np.vstack((T[:, :3, 3], joint_positions(model, np.asarray(q, dtype=float))[T.shape[0]:]))
    ax.plot(*_to3(O), "o", ms=4, color="k", ls="none")
    for j, p in enumerate(O, start=1):
        if j in hit:
            ax.plot(*_to3(p[None, :]), "*", ms=13, color="red", mec="darkred", ls="none")
    for group in coincident_groups(O) if labels else ():  # one label per point, as in 2D
        ax.text(*_to3(O[group[0]]), "  " + _shared_label([k + 1 for k in group]), fontsize=8)
    for i in stops:
        ax.plot(*_to3(_stop_point(model, q, i)[None, :]), **_STOP_MARKER)
    if normals is not None:
        for j, n, pt in normals:
            p = pt if pt is not None else O[j - 1]
            if j > len(O):  # a link's span (contacts.Contacts)
                ax.plot(*_to3(p[None, :]), "*", ms=13, color="red", mec="darkred", ls="none")
            ax.quiver(*_to3(p), *_to3(arrow * n), color="red", lw=1.2, arrow_length_ratio=0.3)


def _setup_3d(ax, lo, hi, view=(18.0, -60.0), zoom=1.0):
    ax.set_xlim(lo[2], hi[2])
    ax.set_ylim(lo[0], hi[0])
    ax.set_zlim(lo[1], hi[1])
    ax.set_box_aspect((1, 1, 1), zoom=zoom)
    ax.set_xlabel("$X_3$ [m]", fontsize=8, labelpad=-2)
    ax.set_ylabel("$X_1$ [m]", fontsize=8, labelpad=-2)
    ax.set_zlabel("$X_2$ [m]", fontsize=8, labelpad=-2)
    ax.tick_params(labelsize=7, pad=0)
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))
    ax.view_init(elev=view[0], azim=view[1])
