"""Figures of a simulation: time histories, energies, configurations at the impacts, animation.

matplotlib is imported here only, and only when a figure is drawn;
``import gibbsimpact`` never imports it. Without a display (no DISPLAY or
WAYLAND_DISPLAY on Linux, no MPLBACKEND set) the non-interactive Agg backend
is selected before pyplot is first imported.

Every time plot marks the impact instants with dotted vertical lines numbered
1, 2, ... above the axes; the figure's footnote lists them (time, joints).
Configurations are drawn in 2D (X1-X2 plane) when the motion is planar and in
3D otherwise; in 3D, X2 (the usual "up" against gravity) is the vertical axis.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from .kinematics import transforms
from .model import shape_functions
from .walls import Circle, Sphere, describe

__all__ = [
    "FIGURES", "animate", "is_planar", "link_points", "plot_angles", "plot_configurations", "plot_energy",
    "plot_joint_positions", "plot_joint_velocities", "plot_modes", "plot_result", "plot_trajectory",
    "save_figures",
]

#: Figure keys of plot_result, in drawing order; each is saved as <key>.png.
FIGURES = ("angles", "modes", "joint_positions", "joint_velocities", "energy", "configurations", "trajectory")

_PLANAR_TOL = 1e-9  # m or rad: out-of-plane motion below this counts as planar


def _pyplot():
    import matplotlib

    if (
        "matplotlib.pyplot" not in sys.modules
        and "MPLBACKEND" not in os.environ
        and sys.platform.startswith("linux")
        and not os.environ.get("DISPLAY")
        and not os.environ.get("WAYLAND_DISPLAY")
    ):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


# --------------------------------------------------------------------------
# Geometry

def link_points(model, q, n_points: int = 41) -> np.ndarray:
    """Points along every deformed link, shape (n_links, n_points, 3) [m].

    p(x) = T_i r_i(x),  r_i(x) = (x, v(x), w(x), 1),  v = sum_k psi_k(x) delta_k over
    the link's y-modes, w over its z-modes, x = 0 ... l_i (formulation.md section 2).
    """
    q = np.asarray(q, dtype=float)
    T = transforms(model, q)
    out = np.empty((model.n_links, n_points, 3))
    for i, lk in enumerate(model.chain.links):
        x = np.linspace(0.0, lk.length, n_points)
        r = np.zeros((4, n_points))
        r[0], r[3] = x, 1.0
        directions, psi = shape_functions(lk, x)
        for k, d, p_k in zip(model.delta_index[i], directions, psi):
            r[1 if d == "y" else 2] += p_k * q[k]
        out[i] = (T[i] @ r)[:3].T
    return out


def _wall_is_2d(w) -> bool:
    if isinstance(w, Circle):
        return True
    if isinstance(w, Sphere):
        return abs(w.center[2]) < _PLANAR_TOL
    return abs(w.normal_vector[2]) < _PLANAR_TOL


def is_planar(result) -> bool:
    """True when the chain stays in the X1-X2 plane (X3, theta_-1, theta_0, z-modes ~ 0) and every
    wall has a curve as its section with that plane."""
    model = result.model
    idx = [2, 3, 4] if model.free_base else []
    idx += [k for k, d in enumerate(model.bending_directions) if d == "z"]
    planar = np.all(np.abs(result.q[:, idx]) < _PLANAR_TOL) and np.all(np.abs(result.qdot[:, idx]) < _PLANAR_TOL)
    return bool(planar) and all(_wall_is_2d(w) for w in result.walls)


# --------------------------------------------------------------------------
# Labels

def _tex(name: str, dot: bool = False) -> str:
    """Mathtext label of a coordinate name: theta_-1 -> theta_{-1}, delta_1_2 -> delta_{1,2}."""
    if name.startswith("theta_"):
        sym, sub = r"\theta", name[6:]
    elif name.startswith("delta_"):
        sym, sub = r"\delta", name[6:].replace("_", ",")
    else:
        sym, sub = "X", name[1:]
    if dot:
        sym = r"\dot{" + sym + "}"
    return f"${sym}_{{{sub}}}$"


def _joint_list(joints) -> str:
    return "+".join(f"O{j}" for j in joints)


def _impact_note(result, limit: int = 8) -> str:
    imps = result.impacts
    if not imps:
        return "no impacts"
    items = [f"{k}: {_joint_list(r.joints)} at {r.time:.6f} s" for k, r in enumerate(imps[:limit], start=1)]
    more = f"; ... ({len(imps)} in all)" if len(imps) > limit else ""
    return "impacts (dotted lines): " + "; ".join(items) + more


def _mark_impacts(axes, result, number_axis=None):
    """Dotted vertical lines at the impact times on every axis; numbers above ``number_axis``."""
    times = result.impact_times
    if times.size == 0:
        return
    many = times.size > 40
    for ax in axes:
        for t in times:
            ax.axvline(t, color="0.35", ls=":", lw=0.6 if many else 0.9, zorder=0)
    if number_axis is None or many:
        return
    tr = number_axis.get_xaxis_transform()
    x0, x1 = number_axis.get_xlim()
    last = -np.inf
    level = 0
    for k, t in enumerate(times, start=1):
        # Stagger numbers that would overlap (closer than 2.5 % of the axis).
        level = level + 1 if (t - last) < 0.025 * (x1 - x0) else 0
        last = t
        number_axis.text(t, 1.02 + 0.07 * (level % 3), str(k), transform=tr, ha="center", va="bottom",
                         fontsize=7, color="0.25")


def _finish_time_figure(fig, axes, result, title):
    axes[-1].set_xlabel("t [s]")
    t0, t1 = float(result.t[0]), float(result.t[-1])
    for ax in axes:
        ax.set_xlim(t0, t1)
        ax.grid(True, lw=0.3, alpha=0.6)
    _mark_impacts(axes, result, number_axis=axes[0])
    fig.suptitle(title, fontsize=11)
    fig.text(0.01, 0.005, _impact_note(result), fontsize=7, color="0.3", ha="left", va="bottom", wrap=True)
    fig.tight_layout(rect=(0, 0.035, 1, 1))


#: Line styles cycled with the colours, so that curves that coincide (symmetric motions) stay visible.
_STYLES = ("-", "--", "-.", (0, (5, 1, 1, 1, 1, 1)))


def _style(k: int) -> dict:
    return {"color": f"C{k}", "ls": _STYLES[k % len(_STYLES)], "lw": 1.3}


def _legend(ax, ncol=None, outside=True):
    """Legend to the right of the axes (never on top of the data), or inside at the best place."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return
    if outside:
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)
    else:
        ax.legend(fontsize=8, ncol=ncol or min(len(handles), 4), loc="best", framealpha=0.85)


def _title(result, what, case_name=None):
    return f"{case_name}: {what}" if case_name else what


# --------------------------------------------------------------------------
# Time histories

def plot_angles(result, case_name=None):
    """Joint angles theta [rad] and their rates [rad/s] against time."""
    plt = _pyplot()
    model = result.model
    idx = list(model.theta_index)
    if model.free_base and not is_planar(result):
        idx = [3, 4] + idx
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9.5, 6))
    for c, k in enumerate(idx):
        name = model.coordinate_names[k]
        axes[0].plot(result.t, result.q[:, k], label=_tex(name), **_style(c))
        axes[1].plot(result.t, result.qdot[:, k], label=_tex(name, dot=True), **_style(c))
    axes[0].set_ylabel("joint angle [rad]")
    axes[1].set_ylabel("angular velocity [rad/s]")
    _legend(axes[0])
    _legend(axes[1])
    _finish_time_figure(fig, axes, result, _title(result, "joint angles and angular velocities", case_name))
    return fig


def plot_modes(result, case_name=None):
    """Modal coordinates delta [m] and their rates [m/s]; None for a chain of rigid links.

    A finite-element link is shown by its tip deflection (the node-n_e deflection
    coordinate of each bending direction), not by all its nodal coordinates.
    """
    model = result.model
    rows = []
    for i, lk in enumerate(model.chain.links):
        idx = model.delta_index[i]
        if lk.elements:
            per = 2 * lk.elements
            rows += [(int(idx[(j + 1) * per - 2]), f"link {i + 1}, tip deflection in {d} (FE)")
                     for j, d in enumerate(lk.element_directions)]
        else:
            rows += [(int(k), f"link {i + 1}, {md.direction}, {md.kind} #{md.number}") for k, md in zip(idx, lk.modes)]
    if not rows:
        return None
    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9.5, 6))
    for c, (k, text) in enumerate(rows):
        name = model.coordinate_names[k]
        desc = "\n" + text
        axes[0].plot(result.t, result.q[:, k], label=_tex(name) + desc, **_style(c))
        axes[1].plot(result.t, result.qdot[:, k], label=_tex(name, dot=True), **_style(c))
    axes[0].set_ylabel("modal coordinate [m]")
    axes[1].set_ylabel("modal velocity [m/s]")
    for ax in axes:
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    _legend(axes[0])
    _legend(axes[1])
    _finish_time_figure(fig, axes, result, _title(result, "modal coordinates and velocities", case_name))
    return fig


def _joint_components(result, values, what, unit, case_name):
    plt = _pyplot()
    dims = 2 if is_planar(result) else 3
    fig, axes = plt.subplots(dims, 1, sharex=True, figsize=(9.5, 2.3 * dims + 1.2))
    for a in range(dims):
        for j in range(values.shape[1]):
            axes[a].plot(result.t, values[:, j, a], label=f"$O_{{{j + 1}}}$", **_style(j))
        axes[a].set_ylabel(f"along $X_{a + 1}$ [{unit}]")
    _legend(axes[0])
    _finish_time_figure(fig, list(axes), result, _title(result, what, case_name))
    return fig


def plot_joint_positions(result, case_name=None):
    """Positions of the joints O_1 ... O_(n+1) along X1, X2 (and X3) [m]."""
    return _joint_components(result, result.joint_positions(), "joint positions", "m", case_name)


def plot_joint_velocities(result, case_name=None):
    """Absolute velocities of the joints along X1, X2 (and X3) [m/s]."""
    return _joint_components(result, result.joint_velocities(), "joint absolute velocities", "m/s", case_name)


def plot_energy(result, case_name=None):
    """Kinetic, gravitational, strain and total energy [J]; below, total minus its initial value.

    With inputs or damping (result.work not None) the work W of each is drawn too,
    and the lower panel shows the energy balance E - E(t0) - W.
    """
    plt = _pyplot()
    E = result.energy()
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9.5, 6), gridspec_kw={"height_ratios": [2.2, 1]})
    axes[0].plot(result.t, E.kinetic, label="kinetic", **_style(0))
    axes[0].plot(result.t, E.gravity, label="gravitational", **_style(1))
    axes[0].plot(result.t, E.strain, label="strain", **_style(2))
    axes[0].plot(result.t, E.total, lw=1.8, color="k", label="total")
    balance = E.total - E.total[0]
    if result.work is not None:
        axes[0].plot(result.t, result.work[:, 0], label="work of inputs", **_style(3))
        axes[0].plot(result.t, result.work[:, 1], label="work of damping", **_style(4))
        balance = balance - result.work.sum(axis=1)
        axes[1].set_ylabel(r"$E - E(t_0) - W$ [J]")
        what = "max relative power-balance error in flight"
    else:
        axes[1].set_ylabel(r"$E - E(t_0)$ [J]")
        what = "max relative drift in flight"
    axes[0].set_ylabel("energy [J]")
    _legend(axes[0])
    axes[1].plot(result.t, balance, lw=1.0, color="k")
    axes[1].ticklabel_format(axis="y", style="sci", scilimits=(-2, 3), useOffset=False)
    title = _title(result, f"energy (E(t0) = {E.total[0]:.7g} J, {what} {result.energy_error:.1e})", case_name)
    _finish_time_figure(fig, axes, result, title)
    return fig


# --------------------------------------------------------------------------
# Configurations

def _scene_extent_2d(result, points):
    """(xmin, xmax, ymin, ymax) covering the curved walls, or the chain when only planes bound it."""
    lo, hi = points[..., :2].reshape(-1, 2).min(0), points[..., :2].reshape(-1, 2).max(0)
    curved = [w for w in result.walls if isinstance(w, (Circle, Sphere))]
    for w in curved:
        c = np.asarray(w.center[:2])
        lo, hi = np.minimum(lo, c - w.radius), np.maximum(hi, c + w.radius)
    span = max(hi - lo)
    pad = 0.08 * span if curved else 0.25 * max(span, 1e-3)
    mid = 0.5 * (lo + hi)
    half = 0.5 * span + pad
    return mid[0] - half, mid[0] + half, mid[1] - half, mid[1] + half


def _draw_walls_2d(ax, walls, extent):
    """Shade the region outside the walls and draw each wall's curve in the X1-X2 plane."""
    if not walls:
        return
    x0, x1, y0, y1 = extent
    X, Y = np.meshgrid(np.linspace(x0, x1, 300), np.linspace(y0, y1, 300))
    P = np.stack([X, Y, np.zeros_like(X)], axis=-1)
    G = np.min([w.gap(P) for w in walls], axis=0)
    ax.contourf(X, Y, G, levels=[-np.inf, 0.0], colors=["0.85"], zorder=0)
    for w in walls:
        ax.contour(X, Y, w.gap(P), levels=[0.0], colors=["0.15"], linewidths=1.6, zorder=1)


def _draw_chain_2d(ax, model, q, n_points, hit=(), normals=None, labels=True, arrow=0.25):
    pts = link_points(model, q, n_points)
    for i in range(pts.shape[0]):
        ax.plot(pts[i, :, 0], pts[i, :, 1], lw=2.4, color=f"C{i}", solid_capstyle="round", zorder=3,
                label=f"link {i + 1}")
    O = transforms(model, np.asarray(q, dtype=float))[:, :3, 3]
    ax.plot(O[:, 0], O[:, 1], "o", ms=4, color="k", zorder=4)
    for j, p in enumerate(O, start=1):
        if j in hit:
            ax.plot(p[0], p[1], "*", ms=13, color="red", mec="darkred", zorder=5)
        if labels:
            ax.annotate(f"$O_{{{j}}}$", p[:2], xytext=(4, 4), textcoords="offset points", fontsize=8, zorder=6)
    if normals is not None:
        for j, n in normals:
            p = O[j - 1]
            ax.annotate("", xy=p[:2] + arrow * n[:2], xytext=p[:2],
                        arrowprops=dict(arrowstyle="->", color="red", lw=1.2), zorder=5)


def _panels(result):
    """(time, q, title, hit joints, [(joint, normal)]) for the initial state and each impact (at most 11)."""
    panels = [(float(result.t[0]), result.q[0], f"t = {result.t[0]:.6g} s (initial)", (), None)]
    imps = list(enumerate(result.impacts, start=1))
    if len(imps) > 11:
        imps = imps[:10] + imps[-1:]
    for k, rec in imps:
        i = int(np.searchsorted(result.t, rec.time, side="left"))
        i = min(i, len(result.t) - 1)
        q = result.q[i]
        normals = [(int(j), np.asarray(rec.normals)[c]) for c, j in enumerate(rec.joints)]
        panels.append((rec.time, q, f"impact {k}: t = {rec.time:.6f} s, {_joint_list(rec.joints)}",
                       tuple(int(j) for j in rec.joints), normals))
    if not result.impacts:
        panels.append((float(result.t[-1]), result.q[-1], f"t = {result.t[-1]:.6g} s (final)", (), None))
    return panels


def _to3(p):
    """Inertial (X1, X2, X3) -> plot axes (X3, X1, X2): right-handed with X2 vertical."""
    p = np.asarray(p)
    return p[..., 2], p[..., 0], p[..., 1]


def _scene_extent_3d(result, points):
    lo, hi = points.reshape(-1, 3).min(0), points.reshape(-1, 3).max(0)
    curved = False
    for w in result.walls:
        if isinstance(w, Sphere):
            c = np.asarray(w.center)
            lo, hi, curved = np.minimum(lo, c - w.radius), np.maximum(hi, c + w.radius), True
        elif isinstance(w, Circle):
            c = np.append(w.center, 0.5 * (lo[2] + hi[2]))
            r = np.array([w.radius, w.radius, 0.0])
            lo, hi, curved = np.minimum(lo, c - r), np.maximum(hi, c + r), True
    span = max(hi - lo)
    half = 0.5 * span * (1.05 if curved else 1.4) + 1e-3
    mid = 0.5 * (lo + hi)
    return mid - half, mid + half


def _draw_walls_3d(ax, walls, lo, hi):
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 37), np.linspace(0, np.pi, 19))
    for w in walls:
        if isinstance(w, Sphere):
            c, R = np.asarray(w.center), w.radius
            P = np.stack([c[0] + R * np.cos(u) * np.sin(v), c[1] + R * np.sin(u) * np.sin(v),
                          c[2] + R * np.cos(v)], axis=-1)
            ax.plot_wireframe(*_to3(P), color="0.6", lw=0.3, alpha=0.45, rstride=3, cstride=3)
            # Equator and the X1-X2 great circle, a little darker, for orientation.
            s = np.linspace(0, 2 * np.pi, 121)
            for ring in (np.stack([np.cos(s), np.zeros_like(s), np.sin(s)], -1),
                         np.stack([np.cos(s), np.sin(s), np.zeros_like(s)], -1)):
                ax.plot(*_to3(c + R * ring), color="0.45", lw=0.6, alpha=0.7)
        elif isinstance(w, Circle):
            s = np.linspace(0, 2 * np.pi, 121)
            for z in np.linspace(lo[2], hi[2], 3):
                P = np.stack([w.center[0] + w.radius * np.cos(s), w.center[1] + w.radius * np.sin(s),
                              np.full_like(s, z)], axis=-1)
                ax.plot(*_to3(P), color="0.45", lw=0.8)
        else:
            n = np.asarray(w.normal_vector)
            a = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
            a /= np.linalg.norm(a)
            b = np.cross(n, a)
            size = 0.5 * max(hi - lo)
            s = np.linspace(-size, size, 2)
            S, T = np.meshgrid(s, s)
            center = np.asarray(w.point) + ((0.5 * (lo + hi) - np.asarray(w.point)) @ (a)) * a + \
                ((0.5 * (lo + hi) - np.asarray(w.point)) @ b) * b
            P = center + S[..., None] * a + T[..., None] * b
            ax.plot_surface(*_to3(P), color="0.7", alpha=0.35, lw=0)


def _draw_chain_3d(ax, model, q, n_points, hit=(), normals=None, labels=True, floor=None, arrow=0.25):
    pts = link_points(model, q, n_points)
    for i in range(pts.shape[0]):
        ax.plot(*_to3(pts[i]), lw=2.4, color=f"C{i}", label=f"link {i + 1}")
        if floor is not None:
            # Shadow on the floor X2 = floor: shows where the chain is in depth.
            sh = pts[i].copy()
            sh[:, 1] = floor
            ax.plot(*_to3(sh), lw=1.6, color="0.5", alpha=0.6)
    O = transforms(model, np.asarray(q, dtype=float))[:, :3, 3]
    ax.plot(*_to3(O), "o", ms=4, color="k", ls="none")
    for j, p in enumerate(O, start=1):
        if j in hit:
            ax.plot(*_to3(p[None, :]), "*", ms=13, color="red", mec="darkred", ls="none")
        if labels:
            ax.text(*_to3(p), f"  $O_{{{j}}}$", fontsize=8)
    if normals is not None:
        for j, n in normals:
            p = O[j - 1]
            ax.quiver(*_to3(p), *_to3(arrow * n), color="red", lw=1.2, arrow_length_ratio=0.3)


def _setup_3d(ax, lo, hi):
    ax.set_xlim(lo[2], hi[2])
    ax.set_ylim(lo[0], hi[0])
    ax.set_zlim(lo[1], hi[1])
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("$X_3$ [m]", fontsize=8, labelpad=-2)
    ax.set_ylabel("$X_1$ [m]", fontsize=8, labelpad=-2)
    ax.set_zlabel("$X_2$ [m]", fontsize=8, labelpad=-2)
    ax.tick_params(labelsize=7, pad=0)
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))
    ax.view_init(elev=18, azim=-60)


def plot_configurations(result, case_name=None, n_points: int = 41):
    """The chain at t0 and at every impact (at most 11 impact panels), walls drawn, equal axes.

    Deformed links are drawn with their mode shapes; impacting joints are red stars with
    their wall normal as a red arrow.
    """
    plt = _pyplot()
    model = result.model
    panels = _panels(result)
    n = len(panels)
    ncols = n if n <= 3 else (2 if n == 4 else (3 if n <= 9 else 4))
    nrows = int(np.ceil(n / ncols))
    planar = is_planar(result)
    all_pts = np.concatenate([link_points(model, p[1], n_points).reshape(-1, 3) for p in panels])
    if planar:
        fig, axes = plt.subplots(nrows, ncols, figsize=(3.7 * ncols, 3.7 * nrows + 0.7), squeeze=False,
                                 layout="constrained")
        extent = _scene_extent_2d(result, all_pts)
        for ax, (t, q, title, hit, normals) in zip(axes.ravel(), panels):
            _draw_walls_2d(ax, result.walls, extent)
            _draw_chain_2d(ax, model, q, n_points, hit, normals, arrow=0.12 * (extent[1] - extent[0]))
            ax.set_xlim(extent[0], extent[1])
            ax.set_ylim(extent[2], extent[3])
            ax.set_aspect("equal")
            ax.set_title(title, fontsize=9)
            ax.set_xlabel("$X_1$ [m]", fontsize=8)
            ax.set_ylabel("$X_2$ [m]", fontsize=8)
            ax.tick_params(labelsize=7)
        for ax in axes.ravel()[n:]:
            ax.set_visible(False)
        axes[0, 0].legend(fontsize=7, loc="lower left")
    else:
        fig = plt.figure(figsize=(4.0 * ncols, 4.0 * nrows + 0.7), layout="constrained")
        lo, hi = _scene_extent_3d(result, all_pts)
        for k, (t, q, title, hit, normals) in enumerate(panels):
            ax = fig.add_subplot(nrows, ncols, k + 1, projection="3d")
            _draw_walls_3d(ax, result.walls, lo, hi)
            _draw_chain_3d(ax, model, q, n_points, hit, normals, floor=lo[1], arrow=0.12 * (hi[0] - lo[0]))
            _setup_3d(ax, lo, hi)
            ax.set_title(title, fontsize=9)
    walls = "; ".join(describe(w) for w in result.walls) or "no walls"
    fig.suptitle(_title(result, f"configurations at the impacts ({walls})", case_name), fontsize=11)
    fig.supxlabel("red star: impacting joint; red arrow: wall normal into the free region"
                  + ("" if planar else "; grey: shadow on the floor; axes drawn with X2 vertical"), fontsize=7, color="0.3", x=0.01, ha="left")
    return fig


def plot_trajectory(result, case_name=None, n_points: int = 41):
    """Paths of the joints over the whole run, with the chain at t0 (faint) and at the end."""
    plt = _pyplot()
    model = result.model
    P = result.joint_positions()
    ends = [result.q[0], result.q[-1]]
    all_pts = np.concatenate([P.reshape(-1, 3)] + [link_points(model, q, n_points).reshape(-1, 3) for q in ends])
    if is_planar(result):
        fig, ax = plt.subplots(figsize=(6.4, 6.4))
        extent = _scene_extent_2d(result, all_pts)
        _draw_walls_2d(ax, result.walls, extent)
        for j in range(P.shape[1]):
            ax.plot(P[:, j, 0], P[:, j, 1], lw=0.9, color=f"C{j + 2}", label=f"path of $O_{{{j + 1}}}$")
        pts0 = link_points(model, ends[0], n_points)
        for i in range(pts0.shape[0]):
            ax.plot(pts0[i, :, 0], pts0[i, :, 1], lw=2.0, color="0.6", zorder=3,
                    label="chain at $t_0$" if i == 0 else None)
        _draw_chain_2d(ax, model, ends[1], n_points, labels=True)
        for rec in result.impacts:
            O = transforms(model, result.q[min(np.searchsorted(result.t, rec.time), len(result.t) - 1)])[:, :3, 3]
            for j in rec.joints:
                ax.plot(O[j - 1, 0], O[j - 1, 1], "*", ms=10, color="red", mec="darkred", zorder=5)
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.set_xlabel("$X_1$ [m]")
        ax.set_ylabel("$X_2$ [m]")
        _legend(ax, ncol=2)
    else:
        fig = plt.figure(figsize=(6.8, 6.8))
        ax = fig.add_subplot(projection="3d")
        lo, hi = _scene_extent_3d(result, all_pts)
        _draw_walls_3d(ax, result.walls, lo, hi)
        for j in range(P.shape[1]):
            ax.plot(*_to3(P[:, j]), lw=0.9, color=f"C{j + 2}", label=f"path of $O_{{{j + 1}}}$")
        for i, seg in enumerate(link_points(model, ends[0], n_points)):
            ax.plot(*_to3(seg), lw=2.0, color="0.6", label="chain at $t_0$" if i == 0 else None)
        _draw_chain_3d(ax, model, ends[1], n_points, floor=lo[1])
        for rec in result.impacts:
            O = transforms(model, result.q[min(np.searchsorted(result.t, rec.time), len(result.t) - 1)])[:, :3, 3]
            for j in rec.joints:
                ax.plot(*_to3(O[j - 1][None, :]), "*", ms=10, color="red", mec="darkred", ls="none")
        _setup_3d(ax, lo, hi)
        ax.legend(fontsize=7, loc="upper left")
    fig.suptitle(_title(result, f"joint paths, t = {result.t[0]:.6g} ... {result.t[-1]:.6g} s "
                                "(coloured chain: final state; red stars: impacts)", case_name), fontsize=10)
    fig.tight_layout()
    return fig


# --------------------------------------------------------------------------
# All figures, saving, animation

def plot_result(result, kinds=None, case_name=None, n_points: int = 41) -> dict:
    """Draw the figures of a result.

    Parameters
    ----------
    result : Result
    kinds : iterable of keys from FIGURES, default all
    case_name : str, prefixed to the titles
    n_points : sample points per link in configuration drawings

    Returns
    -------
    dict {key: matplotlib Figure}; "modes" is absent for a chain of rigid links.
    """
    kinds = FIGURES if kinds is None else tuple(kinds)
    unknown = [k for k in kinds if k not in FIGURES]
    if unknown:
        raise ValueError(f"unknown figure(s) {', '.join(unknown)}; choose from {', '.join(FIGURES)}")
    makers = {
        "angles": lambda: plot_angles(result, case_name),
        "modes": lambda: plot_modes(result, case_name),
        "joint_positions": lambda: plot_joint_positions(result, case_name),
        "joint_velocities": lambda: plot_joint_velocities(result, case_name),
        "energy": lambda: plot_energy(result, case_name),
        "configurations": lambda: plot_configurations(result, case_name, n_points),
        "trajectory": lambda: plot_trajectory(result, case_name, n_points),
    }
    figs = {}
    for k in kinds:
        fig = makers[k]()
        if fig is not None:
            figs[k] = fig
    return figs


def save_figures(figures: dict, directory, dpi: int = 120, close: bool = True) -> dict:
    """Save each figure as <directory>/<key>.png; returns {key: Path}."""
    from pathlib import Path

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    paths = {}
    for k, fig in figures.items():
        paths[k] = d / f"{k}.png"
        fig.savefig(paths[k], dpi=dpi, bbox_inches="tight", pad_inches=0.12)
        if close:
            _pyplot().close(fig)
    return paths


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

    plt = _pyplot()
    from matplotlib.animation import FuncAnimation, PillowWriter

    model = result.model
    t0, t1 = float(result.t[0]), float(result.t[-1])
    n_frames = int(min(max_frames, max(2, np.ceil((t1 - t0) / speed * fps) + 1)))
    times = np.linspace(t0, t1, n_frames)
    rows = np.clip(np.searchsorted(result.t, times, side="right") - 1, 0, len(result.t) - 1)
    imp_t = result.impact_times
    flash = max(3.0 * (t1 - t0) / n_frames, 1e-12)  # an impacting joint stays red for ~3 frames
    planar = is_planar(result)
    all_pts = np.concatenate([link_points(model, result.q[i], n_points).reshape(-1, 3) for i in rows[:: max(1, n_frames // 40)]])
    title = (case_name + ": " if case_name else "")
    if planar:
        fig, ax = plt.subplots(figsize=(5.2, 5.4))
        extent = _scene_extent_2d(result, all_pts)
        _draw_walls_2d(ax, result.walls, extent)
        lines = [ax.plot([], [], lw=2.4, color=f"C{i}", solid_capstyle="round", label=f"link {i + 1}")[0]
                 for i in range(model.n_links)]
        joints, = ax.plot([], [], "o", ms=4, color="k")
        stars, = ax.plot([], [], "*", ms=14, color="red", mec="darkred", ls="none")
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.set_xlabel("$X_1$ [m]")
        ax.set_ylabel("$X_2$ [m]")
        ax.legend(fontsize=7, loc="lower left")
    else:
        fig = plt.figure(figsize=(5.4, 5.6))
        ax = fig.add_subplot(projection="3d")
        lo, hi = _scene_extent_3d(result, all_pts)
        _draw_walls_3d(ax, result.walls, lo, hi)
        _setup_3d(ax, lo, hi)
        lines = [ax.plot([], [], [], lw=2.4, color=f"C{i}", label=f"link {i + 1}")[0] for i in range(model.n_links)]
        shadows = [ax.plot([], [], [], lw=1.6, color="0.5", alpha=0.6)[0] for _ in range(model.n_links)]
        floor = lo[1]
        joints, = ax.plot([], [], [], "o", ms=4, color="k", ls="none")
        stars, = ax.plot([], [], [], "*", ms=14, color="red", mec="darkred", ls="none")
    label = ax.set_title("", fontsize=9)
    fig.tight_layout()

    def draw(f):
        q = result.q[rows[f]]
        pts = link_points(model, q, n_points)
        O = transforms(model, q)[:, :3, 3]
        recent = [rec for rec in result.impacts if 0.0 <= times[f] - rec.time < flash]
        hit = sorted({j for rec in recent for j in rec.joints})
        H = O[[j - 1 for j in hit]] if hit else np.zeros((0, 3))
        if planar:
            for ln, p in zip(lines, pts):
                ln.set_data(p[:, 0], p[:, 1])
            joints.set_data(O[:, 0], O[:, 1])
            stars.set_data(H[:, 0], H[:, 1])
        else:
            for ln, sh, p in zip(lines, shadows, pts):
                ln.set_data_3d(*_to3(p))
                p = p.copy()
                p[:, 1] = floor
                sh.set_data_3d(*_to3(p))
            joints.set_data_3d(*_to3(O))
            stars.set_data_3d(*_to3(H))
        n_imp = int(np.count_nonzero(imp_t <= times[f]))
        label.set_text(f"{title}t = {times[f]:.3f} s   impacts so far: {n_imp}")
        return [*lines, joints, stars, label]

    anim = FuncAnimation(fig, draw, frames=n_frames, blit=False)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    anim.save(path, writer=PillowWriter(fps=fps), dpi=dpi)
    plt.close(fig)
    return path
