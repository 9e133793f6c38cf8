"""Figures of a simulation: time histories, energies, configurations at the impacts, animation.

matplotlib is imported here only, and only when a figure is drawn;
``import gibbsimpact`` never imports it. Figures are built as
``matplotlib.figure.Figure`` objects, not through pyplot: every function returns
one figure and nothing stays open in pyplot's figure registry, so calling them
in a loop or a notebook never accumulates figures (save one with
``fig.savefig``, or hand axes of your own figure to ``ax=``). In IPython or
Jupyter, pyplot is imported once (never used to make figures) so that a
returned Figure is displayed inline. Without a display (no DISPLAY or
WAYLAND_DISPLAY on Linux, no MPLBACKEND set) the non-interactive Agg backend
is selected before pyplot is first imported.

Every time plot marks the impact instants with dotted vertical lines numbered
above the axes (impacts too close to be numbered one by one share a label
"a-b", and numbers that would overlap are left out); the figure's footnote
lists the first ones (time, joints). A run that stopped early says so, with
its status and message, under every figure's title (in a red box inside the
axes when drawing into ``ax=``). Configurations are drawn in 2D (X1-X2 plane)
when the motion is planar and in 3D otherwise; in 3D, X2 (the usual "up"
against gravity) is the vertical axis and the camera looks along the
direction in which the joints moved least. Link drawings and joint paths
have separate colour sets; red is kept for impacts.

Prismatic joints: their variables d_i [m] get panels of their own in "angles"
(with their ranges as thin dashed lines); configuration drawings show a
FixedPrismatic (Pb) guide as a small sleeve at the host's tip with the link's
part behind it as a thin line along the host, a SlidingPrismatic (Pa)
carriage as a box on its host (and, on the base, its rail). An end-stop
impact (ImpactRecord wall -1) is named "stop i (d_min|d_max)" and drawn as a
red diamond at the guide or carriage. "deflection" is each link's tip
deflection in its own frame (model.link_deflection at x = l_i; at mid-span
for clamped-clamped modes), with the protruding length of Pb links below.
"""

from __future__ import annotations

import os
import re
import sys
import textwrap

import numpy as np

from ..dynamics.kinematics import joint_positions, transforms
from ..dynamics.link_points import link_points, points_on_link
from ..model.shapes import link_deflection
from ..contact.walls import Circle, Plane, Sphere, describe

__all__ = [
    "FIGURES", "OPTIONAL_FIGURES", "animate", "camera", "is_planar", "link_points", "plot_angles", "plot_configurations",
    "plot_contact_forces",
    "plot_deflection", "plot_energy", "plot_joint_positions", "plot_joint_velocities", "plot_modes", "plot_one",
    "plot_result", "plot_trajectory", "save_figures", "tip_deflections",
]

#: Figure keys of plot_result, in drawing order; each is saved as <key>.png.
FIGURES = ("angles", "modes", "deflection", "joint_positions", "joint_velocities", "energy", "configurations",
           "trajectory")
#: Figures drawn (and saved) besides FIGURES only when the run has what they show.
OPTIONAL_FIGURES = ("contact_forces",)  # a run with resting contact

_PLANAR_TOL = 1e-9  # m or rad: out-of-plane motion below this counts as planar

#: Colours of the link drawings (cycled) ...
LINK_COLOURS = ("#1f77b4", "#ff7f0e", "#8c564b", "#e377c2", "#bcbd22")
#: ... and of the joints' paths and time curves (O_1, O_2, ...): no colour of either set is in the
#: other, and neither holds red, which marks impacts.
JOINT_COLOURS = ("#6a3d9a", "#1b9e77", "#17becf", "#2ca02c", "#253494", "#a6761d", "#7f7f7f")


def _link_colour(i: int) -> str:
    return LINK_COLOURS[i % len(LINK_COLOURS)]


def _joint_colour(j: int) -> str:
    return JOINT_COLOURS[j % len(JOINT_COLOURS)]


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


def _figure(figsize, layout=None):
    """A new Figure outside pyplot's registry (nothing to close, nothing accumulates)."""
    from matplotlib.figure import Figure

    if "IPython" in sys.modules:
        # Importing pyplot under IPython installs the inline display of Figure objects;
        # no figure is made through it.
        _pyplot()
    return Figure(figsize=figsize, layout=layout)


def _given_axes(ax, n_max: int, what: str) -> list:
    """``ax`` (one Axes or a sequence of them) as a list of at most ``n_max`` Axes."""
    axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
    if not axes or not all(hasattr(a, "plot") and hasattr(a, "figure") for a in axes):
        raise ValueError(f"{what}: ax={ax!r} must be a matplotlib Axes or a sequence of them")
    if len(axes) > n_max:
        raise ValueError(f"{what}: ax holds {len(axes)} Axes but this figure has at most {n_max} panel(s); "
                         f"pass at most {n_max}")
    return axes


# --------------------------------------------------------------------------
# Geometry

def _link_parts(model, q, n_points: int = 41) -> list:
    """Per link (main (m, 3), rear (2, 3) or None) [m].

    A link sliding through a FixedPrismatic guide (Pb, protruding length d) is split at the
    guide: main is its protruding part x = l - d ... l, where it bends, sampled with
    ``n_points`` points; rear is the straight part behind the guide, x = 0 ... l - d (None when
    d = l). Every other link is main only, as link_points samples it.
    """
    q = np.asarray(q, dtype=float)
    T = transforms(model, q)
    out = []
    for i, lk in enumerate(model.chain.links):
        rear = None
        if model.chain.joints[i].kind == "Pb":
            s = min(max(lk.length - float(q[model.theta_index[i]]), 0.0), lk.length)
            main = points_on_link(model, q, T, i, np.linspace(s, lk.length, n_points))
            if s > 0.0:
                rear = points_on_link(model, q, T, i, np.array([0.0, s]))
        else:
            main = points_on_link(model, q, T, i, np.linspace(0.0, lk.length, n_points))
        out.append((main, rear))
    return out


def _chain_scale(model) -> float:
    """Length that sizes the joint symbols: the sum of the link lengths [m]."""
    return float(sum(lk.length for lk in model.chain.links)) or 1.0


def _box(p, a, b, half_length, half_width) -> np.ndarray:
    """Closed outline (5, 3) of the rectangle centred at p with unit axes a (length) and b (width)."""
    corners = [(1, 1), (-1, 1), (-1, -1), (1, -1), (1, 1)]
    return np.array([p + sa * half_length * a + sb * half_width * b for sa, sb in corners])


def _stop_point(model, q, joint: int) -> np.ndarray:
    """Where prismatic joint ``joint`` (1-based) is drawn (3,) [m]: the guide of a FixedPrismatic
    joint (link i's axis at x = l_i - d_i), the carriage centre O_i of a SlidingPrismatic one."""
    q = np.asarray(q, dtype=float)
    T = transforms(model, q)
    i = joint - 1
    if model.chain.joints[i].kind == "Pb":
        s = model.chain.links[i].length - float(q[model.theta_index[i]])
        return (T[i] @ np.array([s, 0.0, 0.0, 1.0]))[:3]
    return T[i][:3, 3].copy()


def _prismatic_marks(model, q) -> list:
    """Outlines of the prismatic joints at q: [(kind, joint i (1-based), (m, 3) polyline [m])].

    kind "guide": the FixedPrismatic guide, a sleeve around link i's axis at the host's tip;
    "carriage": the SlidingPrismatic carriage, a box along its chord on the host (length 2 c,
    at least a few per cent of the chain so that a point slider shows); "rail": the straight
    rail on the base of a SlidingPrismatic joint 1, its travel d_min - c ... d_max + c along the
    base x axis, with a tick at each end.
    """
    kinds = [j.kind for j in model.chain.joints]
    if all(k == "R" for k in kinds):
        return []
    q = np.asarray(q, dtype=float)
    T = transforms(model, q)
    L = _chain_scale(model)
    out = []
    for i, jt in enumerate(model.chain.joints):
        if jt.kind == "Pb":
            a, b = T[i][:3, 0], T[i][:3, 1]
            out.append(("guide", i + 1, _box(_stop_point(model, q, i + 1), a, b, 0.03 * L, 0.014 * L)))
        elif jt.kind == "Pa":
            g = jt.angle
            # The carriage frame is link i's frame turned back by gamma.
            a = np.cos(g) * T[i][:3, 0] - np.sin(g) * T[i][:3, 1]
            b = np.sin(g) * T[i][:3, 0] + np.cos(g) * T[i][:3, 1]
            out.append(("carriage", i + 1, _box(T[i][:3, 3], a, b, max(jt.half_length, 0.015 * L), 0.012 * L)))
            if i == 0 and model.base_transform is not None:
                T0 = np.asarray(model.base_transform, dtype=float)
                lo, hi = jt.range[0] - jt.half_length, jt.range[1] + jt.half_length
                ends = [(T0 @ np.array([x, 0.0, 0.0, 1.0]))[:3] for x in (lo, hi)]
                out.append(("rail", 1, np.array(ends)))
                for e in ends:
                    out.append(("rail", 1, np.array([e - 0.02 * L * T0[:3, 1], e + 0.02 * L * T0[:3, 1]])))
    return out


#: How the joint symbols are drawn: kind -> (legend label, line keywords).
_MARK_STYLE = {
    "guide": ("guide (prismatic, link slides through)", {"color": "k", "lw": 1.3}),
    "carriage": ("carriage (prismatic, slides on the host)", {"color": "k", "lw": 1.8}),
    "rail": ("rail of joint 1 (its travel)", {"color": "0.35", "lw": 1.0}),
}


def _scene_points(model, q, n_points: int = 41) -> np.ndarray:
    """Every point a configuration drawing shows (links and prismatic joint symbols), (m, 3) [m]."""
    pts = [link_points(model, q, n_points).reshape(-1, 3)] + [P for _, _, P in _prismatic_marks(model, q)]
    return np.concatenate(pts)


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
    # Only the spatial free base has X3, theta_-1, theta_0 (a planar one has X1, X2 only).
    idx = [2, 3, 4] if model.chain.base == "free" else []
    idx += [k for k, d in enumerate(model.bending_directions) if d == "z"]
    planar = np.all(np.abs(result.q[:, idx]) < _PLANAR_TOL) and np.all(np.abs(result.qdot[:, idx]) < _PLANAR_TOL)
    return bool(planar) and all(_wall_is_2d(w) for w in result.walls)


def _clip_polygon(poly: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """The part of a convex polygon (m, d) where normal . p >= offset (Sutherland-Hodgman, one plane)."""
    if len(poly) == 0:
        return poly
    s = poly @ normal - offset
    out = []
    for k in range(len(poly)):
        a, b, sa, sb = poly[k - 1], poly[k], s[k - 1], s[k]
        if sb >= 0:
            if sa < 0:
                out.append(a + (b - a) * (sa / (sa - sb)))
            out.append(b)
        elif sa >= 0:
            out.append(a + (b - a) * (sa / (sa - sb)))
    return np.array(out).reshape(-1, poly.shape[1])


def _wall_curves_2d(walls, extent, n_samples: int = 721) -> list:
    """[(wall index, (m, 2) polyline)]: each wall's section with the X1-X2 plane, clipped to the
    view box and to the free side of every other wall (NaN rows break a polyline).

    A plane is a straight segment: the box and the other planes clip it exactly (so two
    planes meet in a V, not an X); circles and spheres are sampled and masked.
    """
    x0, x1, y0, y1 = extent
    tol = 1e-9 * max(x1 - x0, y1 - y0)
    box = [(np.array([1.0, 0.0]), x0), (np.array([-1.0, 0.0]), -x1),
           (np.array([0.0, 1.0]), y0), (np.array([0.0, -1.0]), -y1)]
    out = []
    for k, w in enumerate(walls):
        if isinstance(w, Plane):
            n3, p3 = np.asarray(w.normal_vector), np.asarray(w.point)
            n = n3[:2] / np.linalg.norm(n3[:2])
            # Points with n12 . p12 = n . point (the section at X3 = 0), along the tangent.
            c = (n3 @ p3) / np.linalg.norm(n3[:2]) * n
            t = np.array([-n[1], n[0]])
            big = 4.0 * max(x1 - x0, y1 - y0) + 4.0 * np.linalg.norm(c - [0.5 * (x0 + x1), 0.5 * (y0 + y1)])
            s_lo, s_hi = -big, big
            cuts = box + [(np.asarray(o.normal_vector)[:2], np.asarray(o.normal_vector) @ np.asarray(o.point))
                          for i, o in enumerate(walls) if i != k and isinstance(o, Plane)]
            for a, b in cuts:
                # a . (c + s t) >= b
                at, rhs = a @ t, b - a @ c
                if abs(at) < 1e-14:
                    if rhs > tol:
                        s_lo, s_hi = 1.0, 0.0
                    continue
                if at > 0:
                    s_lo = max(s_lo, rhs / at)
                else:
                    s_hi = min(s_hi, rhs / at)
            if s_hi <= s_lo:
                continue
            s = np.linspace(s_lo, s_hi, n_samples)
            seg = c + s[:, None] * t
        else:
            R = w.radius if isinstance(w, Circle) else np.sqrt(max(w.radius ** 2 - w.center[2] ** 2, 0.0))
            s = np.linspace(0.0, 2.0 * np.pi, n_samples)
            seg = np.asarray(w.center[:2]) + R * np.stack([np.cos(s), np.sin(s)], axis=-1)
        P = np.column_stack([seg, np.zeros(len(seg))])
        # Planes clipped a plane's segment exactly; the rest are sampled.
        ok = np.ones(len(seg), dtype=bool)
        for i, o in enumerate(walls):
            if i != k and not (isinstance(w, Plane) and isinstance(o, Plane)):
                ok &= o.gap(P) >= -tol
        seg = seg.copy()
        seg[~ok] = np.nan
        if np.any(ok):
            out.append((k, seg))
    return out


def _plane_polygon_3d(walls, k: int, lo, hi) -> np.ndarray:
    """Plane wall k inside the box [lo, hi] (3,) and on the free side of every other plane: (m, 3)."""
    w = walls[k]
    n, p = np.asarray(w.normal_vector), np.asarray(w.point)
    a = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    mid = 0.5 * (lo + hi)
    c = mid - ((mid - p) @ n) * n
    size = 2.0 * np.linalg.norm(hi - lo)
    poly = np.array([c + size * (sa * a + sb * b) for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    for d in range(3):
        e = np.eye(3)[d]
        poly = _clip_polygon(poly, e, lo[d])
        poly = _clip_polygon(poly, -e, -hi[d])
    for i, o in enumerate(walls):
        if i != k and isinstance(o, Plane):
            no = np.asarray(o.normal_vector)
            poly = _clip_polygon(poly, no, no @ np.asarray(o.point))
    return poly


# --------------------------------------------------------------------------
# Labels

def _tex(name: str, dot: bool = False) -> str:
    """Mathtext label of a coordinate name: theta_-1 -> theta_{-1}, delta_1_2 -> delta_{1,2}, d_2 -> d_{2}."""
    if name.startswith("theta_"):
        sym, sub = r"\theta", name[6:]
    elif name.startswith("delta_"):
        sym, sub = r"\delta", name[6:].replace("_", ",")
    elif name.startswith("d_"):
        sym, sub = "d", name[2:]
    else:
        sym, sub = "X", name[1:]
    if dot:
        sym = r"\dot{" + sym + "}"
    return f"${sym}_{{{sub}}}$"


def _joint_list(joints) -> str:
    return "+".join(f"O{j}" for j in joints)


def _is_stop(wall) -> bool:
    """True for an end-stop contact (a prismatic joint at an end of its range: wall index -1)."""
    return int(wall) < 0


def _sample_at(result, time: float) -> np.ndarray:
    """q at the first sample at or after ``time`` (an impact time: the state before the impact)."""
    return result.q[min(int(np.searchsorted(result.t, time, side="left")), len(result.t) - 1)]


def _stop_label(result, joint: int, q) -> str:
    """'stop i (d_min)' / 'stop i (d_max)' for an end-stop impact of prismatic joint i at q, or
    'stop i' when it is another limit (a carriage at the end of a Pb link's protruding part)."""
    model = result.model
    jt = model.chain.joints[joint - 1] if 1 <= joint <= model.n_links else None
    if jt is None or jt.kind == "R":
        return f"stop {joint}"
    d = float(q[model.theta_index[joint - 1]])
    lo, hi = jt.range
    tol = 1e-3 * (hi - lo)
    if abs(d - lo) <= tol:
        return f"stop {joint} (d_min)"
    if abs(d - hi) <= tol:
        return f"stop {joint} (d_max)"
    return f"stop {joint}"


def _point_name(model, j: int) -> str:
    """'O2' for contact point j (1-based) of model.contact_point_names; 'link 1' for the closest point
    of a flexible link (contacts.Contacts: the columns after the P points)."""
    from ..simulation.contacts import flexible_links

    P = model.n_joints
    if j <= P:
        return f"O{j}"
    flex = flexible_links(model)
    return f"link {flex[j - P - 1] + 1}" if j - P - 1 < len(flex) else f"point {j}"


def _contacts_text(result, rec) -> str:
    """The contacts of an impact: 'O2' for a joint point at a wall, 'link 1' for a link's span,
    'stop 2 (d_max)' for an end stop."""
    walls = tuple(rec.wall) if len(rec.wall) == len(rec.joints) else (0,) * len(rec.joints)
    if not any(_is_stop(w) for w in walls) and all(j <= result.model.n_joints for j in rec.joints):
        return _joint_list(rec.joints)
    q = _sample_at(result, rec.time)
    return "+".join(_stop_label(result, int(j), q) if _is_stop(w) else _point_name(result.model, int(j))
                    for j, w in zip(rec.joints, walls))


def _split_contacts(rec):
    """(wall contacts [(contact point j, normal (3,), where it touched (3,) or None)], end-stop joints [i])
    of an impact record. The point is ImpactRecord.points (None in older files: then O_j)."""
    walls = tuple(rec.wall) if len(rec.wall) == len(rec.joints) else (0,) * len(rec.joints)
    normals = np.asarray(rec.normals, dtype=float).reshape(-1, 3)
    points = getattr(rec, "points", None)
    hits, stops = [], []
    for c, (j, w) in enumerate(zip(rec.joints, walls)):
        if _is_stop(w):
            stops.append(int(j))
        else:
            hits.append((int(j), normals[c] if c < len(normals) else np.zeros(3),
                         None if points is None else np.asarray(points[c], dtype=float)))
    return hits, stops


def _impact_note(result, limit: int = 8) -> str:
    imps = result.impacts
    if not imps:
        return "no impacts"
    items = [f"{k}: {_contacts_text(result, r)} at {r.time:.6f} s" for k, r in enumerate(imps[:limit], start=1)]
    more = f"; ... ({len(imps)} in all, every one in impacts.csv)" if len(imps) > limit else ""
    return "impacts (dotted lines): " + "; ".join(items) + more


def _status_line(result, width: int = 150) -> str:
    """'' for a finished run; else the status, the time reached and the message, shortened to
    ``width`` characters (parenthetical remarks dropped first)."""
    if result.status == "finished":
        return ""
    head = f"STOPPED EARLY ({result.status}) at t = {float(result.t[-1]):.6g} s: "
    msg, prev = str(result.message), None
    while msg != prev:  # innermost first, so that nested remarks go whole
        msg, prev = re.sub(r"\s*\([^()]*\)", "", msg), msg
    return head + textwrap.shorten(msg, max(20, width - len(head)), placeholder=" ...")


def _title(result, what, case_name=None, width_in: float = 9.5):
    """Figure title; a run that stopped early gets its status below, wrapped to the figure width."""
    title = f"{case_name}: {what}" if case_name else what
    per_line = int(12.5 * width_in)  # characters of a 10 pt line
    status = _status_line(result, width=2 * per_line)
    lines = textwrap.wrap(status, per_line)
    if len(lines) > 2:
        lines = [lines[0], textwrap.shorten(" ".join(lines[1:]), per_line, placeholder=" ...")]
    return "\n".join(textwrap.wrap(title, int(1.1 * per_line)) + lines)


def _status_box(ax, result):
    """The early-stop status in a red box in the top left corner of ``ax`` (drawing into given axes)."""
    status = _status_line(result, width=90)
    if status:
        text = "\n".join(textwrap.wrap(status, 60))
        put = ax.text2D if ax.name == "3d" else ax.text
        put(0.01, 0.99, text, transform=ax.transAxes, fontsize=7, color="darkred", va="top", ha="left", zorder=20,
            bbox={"boxstyle": "round", "fc": "#fde0dc", "ec": "darkred", "alpha": 0.9})


def _impact_labels(times, t0: float, t1: float, width_pt: float, fontsize: float = 7.0) -> list:
    """Impact numbers in one row above an axis of ``width_pt`` points spanning t0 ... t1.

    Returns [(t, text)], each text left-aligned at t minus half its first number. Impacts
    within about two characters of a group's first one share a label "a-b"; a number that
    would overlap the previous label is left out (its dotted line stays).
    """
    span = max(t1 - t0, 1e-300)
    char = 0.6 * fontsize / max(width_pt, 1.0)  # axis fraction per digit (DejaVu Sans: 0.64 em)
    space = 1.0 * char
    cluster = 2.0 * char
    labels = []
    cur = None  # [first, last, x_first, x_last]

    def left(g):
        return g[2] - 0.5 * len(str(g[0])) * char

    def text(g):
        return str(g[0]) if g[0] == g[1] else f"{g[0]}\u2013{g[1]}"

    def right(g):
        return left(g) + len(text(g)) * char

    for k, t in enumerate(np.asarray(times, dtype=float), start=1):
        x = (t - t0) / span
        if cur is None:
            cur = [k, k, x, x]
        elif x - cur[2] <= cluster and cur[1] == k - 1:
            cur[1], cur[3] = k, x
        elif x - 0.5 * len(str(k)) * char >= right(cur) + space:
            labels.append(cur)
            cur = [k, k, x, x]
    if cur is not None:
        labels.append(cur)
    # The last label, if it would run past the right end of the axis, ends there instead, and the
    # labels it would then overlap are left out.
    out = [(left(g), text(g)) for g in labels]
    if out:
        x_last = min(out[-1][0], 1.0 + 0.5 * char - len(out[-1][1]) * char)
        out[-1] = (x_last, out[-1][1])
        while len(out) > 1 and out[-2][0] + len(out[-2][1]) * char + space > x_last:
            del out[-2]
    return [(t0 + x * span, label) for x, label in out]


def _mark_impacts(axes, result, number_axes=()):
    """Dotted vertical lines at the impact times on every axis; numbers above each of ``number_axes``."""
    times = result.impact_times
    if times.size == 0:
        return
    many = times.size > 40
    for ax in axes:
        if times.size <= 200:
            for t in times:
                ax.axvline(t, color="0.35", ls=":", lw=0.6 if many else 0.9, zorder=0)
        else:  # one artist for all of them
            ax.vlines(times, 0, 1, transform=ax.get_xaxis_transform(), colors="0.35", linestyles=":", lw=0.5,
                      zorder=0)
    for ax in number_axes:
        x0, x1 = ax.get_xlim()
        fig = ax.figure
        width_pt = ax.get_position().width * fig.get_figwidth() * 72.0
        tr = ax.get_xaxis_transform()
        for t, text in _impact_labels(times, x0, x1, width_pt):
            ax.text(t, 1.015, text, transform=tr, ha="left", va="bottom", fontsize=7, color="0.25", clip_on=False)


def _finish_time_figure(fig, axes, result, title, own: bool, number_axes=None, right: float = 1.0):
    """Limits, grid, impact markers; on a figure of our own the title, the footnote and the layout."""
    axes = list(axes)
    bottom = [ax for ax in axes if ax.get_subplotspec() is None or ax.get_subplotspec().is_last_row()]
    for ax in bottom or axes[-1:]:
        ax.set_xlabel("t [s]")
    t0, t1 = float(result.t[0]), float(result.t[-1])
    for ax in axes:
        ax.set_xlim(t0, t1)
        ax.grid(True, lw=0.3, alpha=0.6)
    if own:
        # Subplot positions before tight_layout only estimate the widths the numbers get.
        fig.subplots_adjust(left=0.08, right=min(0.84, right))
    _mark_impacts(axes, result, number_axes=axes[:1] if number_axes is None else number_axes)
    if own:
        fig.suptitle(title, fontsize=11 if "\n" not in title else 10)
        fig.text(0.01, 0.005, _impact_note(result), fontsize=7, color="0.3", ha="left", va="bottom", wrap=True)
        fig.tight_layout(rect=(0, 0.035, right, 1))
    else:
        _status_box(axes[0], result)


#: Line styles cycled with the colours, so that curves that coincide (symmetric motions) stay visible.
_STYLES = ("-", "--", "-.", (0, (5, 1, 1, 1, 1, 1)))


def _style(k: int, colour=None) -> dict:
    return {"color": colour or f"C{k % 10}", "ls": _STYLES[k % len(_STYLES)], "lw": 1.3}


def _legend(ax, ncol=None, outside=True):
    """Legend to the right of the axes (never on top of the data), or inside at the best place."""
    handles, _ = ax.get_legend_handles_labels()
    if not handles:
        return
    if outside:
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)
    else:
        ax.legend(fontsize=8, ncol=ncol or min(len(handles), 4), loc="best", framealpha=0.85)


# --------------------------------------------------------------------------
# Time histories

def _joint_variables(result):
    """[(colour index, coordinate index, joint number or None, 'R' | 'Pa' | 'Pb')] of the joint variables
    plot_angles draws: theta_-1, theta_0 of a spatial free base when the motion is not planar,
    then theta_i / d_i of every joint (a planar free base adds no angle: its theta_1 is joint 1's)."""
    model = result.model
    rows = [(k, i, kd) for i, (k, kd) in enumerate(zip(model.theta_index, model.joint_kinds), start=1)]
    if model.chain.base == "free" and not is_planar(result):
        rows = [(3, None, "R"), (4, None, "R")] + rows
    return [(c, k, i, kd) for c, (k, i, kd) in enumerate(rows)]


#: Line styles of the d curves: none of them dashed like the range lines (_RANGE_STYLE).
_P_STYLES = ("-", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 1)))
_RANGE_STYLE = {"ls": (0, (5, 3)), "lw": 0.8, "alpha": 0.8, "zorder": 1}


def _draw_ranges(ax, model, rows, colour=None):
    """Thin dashed lines at d_min and d_max of the prismatic joints of ``rows`` [(colour index, _, joint, _)],
    in the colour of their curves (or ``colour(joint)``)."""
    for c, _, i, _ in rows:
        for k, y in enumerate(model.chain.joints[i - 1].range):
            ax.axhline(y, color=colour(i) if colour else f"C{c % 10}", label=f"range of $d_{{{i}}}$" if k == 0 else None,
                       **_RANGE_STYLE)


def plot_angles(result, case_name=None, ax=None):
    """Joint variables against time: angles theta [rad] and their rates [rad/s]; the variables d [m]
    of prismatic joints (thin dashed lines: their ranges d_min, d_max) and their rates [m/s] on
    panels of their own; returns the Figure.

    Panels, top to bottom: angles, angular velocities, then (with prismatic joints) d and d rates.
    ax : None (a new figure with every panel) or one or more Axes that receive the panels in that
    order; with fewer Axes than panels the rates are left out first (one Axes: the angles, or d
    for a chain of prismatic joints only; two: angles and d).
    """
    model = result.model
    rows = _joint_variables(result)
    groups = {"R": [r for r in rows if r[3] == "R"], "P": [r for r in rows if r[3] != "R"]}
    panels = [(g, rate) for g in ("R", "P") for rate in (False, True) if groups[g]]
    own = ax is None
    if own:
        fig = _figure((9.5, 6.0 if len(panels) <= 2 else 1.2 + 2.1 * len(panels)))
        axes = list(fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0])
    else:
        axes = _given_axes(ax, len(panels), "plot_angles")
        fig = axes[0].figure
        keep = sorted(panels, key=lambda p: p[1])[:len(axes)]  # positions before rates
        panels = [p for p in panels if p in keep]
    ylabels = {("R", False): "joint angle [rad]", ("R", True): "angular velocity [rad/s]",
               ("P", False): "prismatic joint d [m]", ("P", True): "prismatic velocity [m/s]"}
    for a, (g, rate) in zip(axes, panels):
        for pos, (c, k, _, _) in enumerate(groups[g]):
            name = model.coordinate_names[k]
            # One colour per joint variable over all panels; line styles cycle within a panel (never
            # dashed for d, whose range lines are dashed).
            style = dict(_style(pos, f"C{c % 10}"), ls=(_STYLES if g == "R" else _P_STYLES)[pos % 4])
            a.plot(result.t, (result.qdot if rate else result.q)[:, k], label=_tex(name, dot=rate), **style)
        if g == "P" and not rate:
            _draw_ranges(a, model, groups[g])
        a.set_ylabel(ylabels[g, rate])
    for a in axes:
        _legend(a, outside=own)
    if not groups["P"]:
        what = "joint angles and angular velocities"
    elif not groups["R"]:
        what = "prismatic joint variables d (dashed: their ranges) and velocities"
    else:
        what = "joint variables: angles [rad], prismatic d [m] (dashed: ranges), and their rates"
    _finish_time_figure(fig, axes, result, _title(result, what, case_name), own)
    return fig


def _mode_rows(model):
    """Per link: [(coordinate index, description)] of the curves modes.png draws (FE: tip deflections)."""
    rows = []
    for i, lk in enumerate(model.chain.links):
        idx = model.delta_index[i]
        if lk.elements:
            per = 2 * lk.elements
            rows.append([(int(idx[(j + 1) * per - 2]), f"tip deflection in {d} (FE)")
                         for j, d in enumerate(lk.element_directions)])
        else:
            rows.append([(int(k), f"{md.direction}, {md.kind} #{md.number}") for k, md in zip(idx, lk.modes)])
    return rows


def plot_modes(result, case_name=None, ax=None):
    """Modal coordinates delta [m] and their rates [m/s], one row of two axes per flexible link;
    None for a chain of rigid links.

    A finite-element link is shown by its tip deflection (the node-n_e deflection
    coordinate of each bending direction), not by all its nodal coordinates.
    ax : None (a new figure: per link, coordinates left and rates right), one Axes (every
    modal coordinate of every link in it) or two (coordinates, rates).
    """
    model = result.model
    rows = [(i, r) for i, r in enumerate(_mode_rows(model)) if r]
    if not rows:
        return None
    own = ax is None
    if own:
        fig = _figure((9.5, 1.0 + 2.1 * len(rows)))
        grid = fig.subplots(len(rows), 2, sharex=True, squeeze=False)
        pairs = [(grid[r, 0], grid[r, 1]) for r in range(len(rows))]
        axes = list(grid.ravel())
    else:
        axes = _given_axes(ax, 2, "plot_modes")
        fig = axes[0].figure
        pairs = [(axes[0], axes[1] if len(axes) > 1 else None)] * len(rows)
    # One colour per modal coordinate over the whole chain, so that one legend serves every row.
    c = 0
    for (i, curves), (a_q, a_v) in zip(rows, pairs):
        for k, text in curves:
            name = model.coordinate_names[k]
            label = _tex(name) + f"  link {i + 1}, " + text
            a_q.plot(result.t, result.q[:, k], label=label, **_style(c))
            if a_v is not None:
                a_v.plot(result.t, result.qdot[:, k], label=_tex(name, dot=True), **_style(c))
            c += 1
        if own:
            a_q.set_ylabel(f"link {i + 1}\n" + r"$\delta$ [m]")
            a_v.set_ylabel(r"$\dot\delta$ [m/s]")
    right = 1.0
    if own:
        handles = [h for a, _ in pairs for h in a.get_legend_handles_labels()[0]]
        # Owned by the first axes, drawn right of the top row's rate axes, kept out of tight_layout.
        leg = axes[0].legend(handles, [h.get_label() for h in handles], fontsize=7.5, loc="upper left",
                             bbox_to_anchor=(1.03, 1.0), bbox_transform=pairs[0][1].transAxes,
                             borderaxespad=0.0, frameon=False)
        leg.set_in_layout(False)
        right = 1.0 - leg.get_window_extent().width / (fig.dpi * fig.get_figwidth()) - 0.02
    else:
        axes[0].set_ylabel("modal coordinate [m]")
        if len(axes) > 1:
            axes[1].set_ylabel("modal velocity [m/s]")
        _legend(axes[0], outside=False)
    for a in axes:
        a.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    title = _title(result, "modal coordinates (left) and velocities (right), one row per link", case_name)
    _finish_time_figure(fig, axes, result, title, own, number_axes=list(axes[:2]) if own else axes[:1], right=right)
    if own:
        leg.set_in_layout(True)  # tight_layout is done; a tight savefig must keep the legend
    return fig


def tip_deflections(model, qs) -> list:
    """Tip deflection of every flexible link in its own frame at the states qs (K, N):
    [(link i (0-based), "v" | "w", x [m], values (K,) [m])], v along the link frame's y axis, w
    along z (w only for a link that bends in z), at x = l_i.

    The value is link_deflection(model, q, i, x) at every state, linear in the link's own
    coordinates at the tip (one evaluation per coordinate). For a link in a FixedPrismatic guide
    the stretching elements' tip value sum_k d^(a_k) N_k(1) delta_k does not depend on d (it is
    the last node's deflection), so the basis is evaluated at d = l_i. A direction whose shapes
    all vanish at the tip (clamped-clamped modes) is taken at mid-span, x = l_i / 2.
    """
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    out = []
    for i, lk in enumerate(model.chain.links):
        idx = np.asarray(model.delta_index[i], dtype=int)
        if idx.size == 0:
            continue
        x = np.array([lk.length, 0.5 * lk.length])
        basis = np.zeros((2, idx.size, 2))  # [tip | mid-span, coordinate, v | w]
        for c, k in enumerate(idx):
            e = np.zeros(model.n_dof)
            e[k] = 1.0
            if model.chain.joints[i].kind == "Pb":
                e[model.theta_index[i]] = lk.length  # any protruding length: the tip value is d-free
            basis[:, c] = np.column_stack(link_deflection(model, e, i, x))
        dirs = {model.bending_directions[k] for k in idx}
        for comp, name in ((0, "v"), (1, "w")):
            if ("y" if name == "v" else "z") in dirs:
                at = 0 if np.abs(basis[0, :, comp]).max() > 1e-12 * np.abs(basis[1, :, comp]).max() else 1
                out.append((i, name, float(x[at]), qs[:, idx] @ basis[at, :, comp]))
    return out


def plot_deflection(result, case_name=None, ax=None):
    """Tip deflection of each flexible link in its own frame, v(l_i) (and w(l_i) for a link bending in
    z) [m], in the link's colour of the configuration drawings (at mid-span, l_i / 2, for a link
    whose shapes all vanish at the tip: clamped-clamped modes); below, for links sliding through a
    FixedPrismatic guide, their protruding length d [m] (dashed: its range). None for a chain of
    rigid links.

    ax : None (a new figure), one Axes (the deflections) or two (deflections, protruding lengths).
    """
    model = result.model
    curves = tip_deflections(model, result.q)
    if not curves:
        return None
    pb = [i for i, kd in enumerate(model.joint_kinds) if kd == "Pb"]  # 0-based links in a guide
    n_panels = 2 if pb else 1
    own = ax is None
    if own:
        fig = _figure((9.5, 6.0 if pb else 4.2))
        axes = list(fig.subplots(n_panels, 1, sharex=True, squeeze=False,
                                 gridspec_kw={"height_ratios": [2.0, 1.0]} if pb else None)[:, 0])
    else:
        axes = _given_axes(ax, n_panels, "plot_deflection")
        fig = axes[0].figure
    mid = any(x != model.chain.links[i].length for i, _, x, _ in curves)
    for c, (i, comp, x, values) in enumerate(curves):
        at = f"l_{{{i + 1}}}" if x == model.chain.links[i].length else f"l_{{{i + 1}}}/2"
        # Link colours as in the configuration drawings; styles cycle so that curves that coincide
        # (a symmetric motion) stay visible.
        axes[0].plot(result.t, values, label=f"link {i + 1}: ${comp}({at})$", **_style(c, _link_colour(i)))
    axes[0].set_ylabel("deflection [m]" if mid else "tip deflection [m]")
    axes[0].ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    if len(axes) > 1:
        for pos, i in enumerate(pb):
            axes[1].plot(result.t, result.q[:, model.theta_index[i]], color=_link_colour(i), lw=1.3,
                         ls=_P_STYLES[pos % len(_P_STYLES)], label=f"link {i + 1}: $d_{{{i + 1}}}$")
        _draw_ranges(axes[1], model, [(0, None, i + 1, "Pb") for i in pb], colour=lambda j: _link_colour(j - 1))
        axes[1].set_ylabel("protruding\nlength d [m]")
    for a in axes:
        _legend(a, outside=own)
    what = ("tip deflection of each link in its own frame, v(l) along its y axis, w(l) along z"
            if any(c[1] == "w" for c in curves) else "tip deflection v(l) of each link in its own frame")
    if mid:
        what += "; at mid-span, l/2, where the shapes vanish at the tip"
    if pb:
        what += "; below: protruding length of the links in a prismatic guide"
    _finish_time_figure(fig, axes, result, _title(result, what, case_name), own)
    return fig


def plot_contact_forces(result, case_name=None, ax=None):
    """Normal force [N] of every (wall, contact point) pair that was ever in resting contact
    (Result.contact_forces), against time; None when no pair rested.

    ax : None (a new figure), one Axes (the normal forces) or two (and the friction forces |F_t|, with friction).
    """
    F = result.contact_forces
    if F is None or not np.any(F):
        return None
    Ft = result.friction_forces
    n_panels = 2 if Ft is not None and np.any(Ft) else 1
    own = ax is None
    if own:
        fig = _figure((9.5, 4.2 if n_panels == 1 else 6.4))
        axes = list(fig.subplots(n_panels, 1, sharex=True, squeeze=False)[:, 0])
    else:
        axes = _given_axes(ax, n_panels, "plot_contact_forces")
        fig = axes[0].figure
    names = result.model.contact_point_names
    c = 0
    for w, j in np.argwhere(np.any(F != 0.0, axis=0)):
        axes[0].plot(result.t, F[:, w, j], label=f"{names[j]} on wall {w + 1}", **_style(c, _joint_colour(int(j))))
        c += 1
    axes[0].set_ylabel("contact force [N]")
    if n_panels == 2:
        c = 0
        for w, j in np.argwhere(np.any(F != 0.0, axis=0)):
            axes[1].plot(result.t, np.linalg.norm(Ft[:, w, j], axis=1), label=f"{names[j]} on wall {w + 1}",
                         **_style(c, _joint_colour(int(j))))
            c += 1
        axes[1].set_ylabel("friction force\n|F_t| [N]")
    _legend(axes[0], outside=own)
    what = "normal force of each wall on each contact point in resting contact (0 in flight; impacts are impulses)"
    if n_panels == 2:
        what += "; below: the friction force |F_t|"
    _finish_time_figure(fig, axes, result, _title(result, what, case_name), own)
    return fig


def _joint_components(result, values, what, unit, case_name, ax):
    dims = 2 if is_planar(result) else 3
    own = ax is None
    if own:
        fig = _figure((9.5, 2.3 * dims + 1.2))
        axes = list(fig.subplots(dims, 1, sharex=True))
    else:
        axes = _given_axes(ax, dims, f"plot_{what.replace(' ', '_')}")
        fig = axes[0].figure
    for a, axis in enumerate(axes):
        for j in range(values.shape[1]):
            axis.plot(result.t, values[:, j, a], label=f"$O_{{{j + 1}}}$", **_style(j, _joint_colour(j)))
        axis.set_ylabel(f"along $X_{a + 1}$ [{unit}]")
    _legend(axes[0], outside=own)
    _finish_time_figure(fig, axes, result, _title(result, what, case_name), own)
    return fig


def plot_joint_positions(result, case_name=None, ax=None):
    """Positions of the joints O_1 ... O_(n+1) along X1, X2 (and X3) [m]; returns the Figure.

    ax : None (a new figure) or up to 2 (planar) / 3 Axes for the components X1, X2, X3 in turn.
    """
    return _joint_components(result, result.joint_positions(), "joint positions", "m", case_name, ax)


def plot_joint_velocities(result, case_name=None, ax=None):
    """Absolute velocities of the joints along X1, X2 (and X3) [m/s]; returns the Figure.

    ax : as for plot_joint_positions.
    """
    return _joint_components(result, result.joint_velocities(), "joint absolute velocities", "m/s", case_name, ax)


def plot_energy(result, case_name=None, ax=None):
    """Kinetic, gravitational, strain and total energy [J]; below, total minus its initial value.

    With inputs or damping (result.work not None) the work W of each is drawn too,
    and the lower panel shows the energy balance E - E(t0) - W.
    ax : None (a new figure), one Axes (the energies) or two (energies, balance).
    """
    E = result.energy()
    own = ax is None
    if own:
        fig = _figure((9.5, 6))
        axes = list(fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2.2, 1]}))
    else:
        axes = _given_axes(ax, 2, "plot_energy")
        fig = axes[0].figure
    axes[0].plot(result.t, E.kinetic, label="kinetic", **_style(0))
    axes[0].plot(result.t, E.gravity, label="gravitational", **_style(1))
    axes[0].plot(result.t, E.strain, label="strain", **_style(2))
    axes[0].plot(result.t, E.total, lw=1.8, color="k", label="total")
    balance = E.total - E.total[0]
    if result.work is not None:
        # A work that stays zero (no inputs, or no damped link) is left out of the legend and the plot.
        dissipation = ("work of damping and friction" if any(getattr(w, "friction", 0.0) > 0 for w in result.walls)
                       else "work of damping")
        for c, text in enumerate(("work of inputs", dissipation)):
            if np.any(result.work[:, c] != 0.0) or not np.any(result.work != 0.0) and c == 0:
                axes[0].plot(result.t, result.work[:, c], label=text, **_style(3 + c))
        balance = balance - result.work.sum(axis=1)
        ylabel = r"$E - E(t_0) - W$ [J]"
        what = "relative power-balance error"
    else:
        ylabel = r"$E - E(t_0)$ [J]"
        what = "relative drift"
    axes[0].set_ylabel("energy [J]")
    _legend(axes[0], outside=own)
    if len(axes) > 1:
        axes[1].set_ylabel(ylabel)
        axes[1].plot(result.t, balance, lw=1.0, color="k")
        axes[1].ticklabel_format(axis="y", style="sci", scilimits=(-2, 3), useOffset=False)
    title = _title(result, f"energy (E(t0) = {E.total[0]:.7g} J; {what} over the whole run "
                           f"{result.energy_error_whole_run:.1e}, max per flight phase {result.energy_error:.1e})",
                   case_name)
    _finish_time_figure(fig, axes, result, title, own)
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
    """Shade the region outside the walls and draw the boundary of the free region in the X1-X2 plane.

    Each wall is drawn only where it bounds the free region (inside the view and on the
    free side of the other walls): two planes make a V, not an X.
    """
    if not walls:
        return
    x0, x1, y0, y1 = extent
    X, Y = np.meshgrid(np.linspace(x0, x1, 300), np.linspace(y0, y1, 300))
    P = np.stack([X, Y, np.zeros_like(X)], axis=-1)
    G = np.min([w.gap(P) for w in walls], axis=0)
    ax.contourf(X, Y, G, levels=[-np.inf, 0.0], colors=["0.85"], zorder=0)
    for k, seg in _wall_curves_2d(walls, extent):
        ln, = ax.plot(seg[:, 0], seg[:, 1], color="0.15", lw=1.6, zorder=1)
        ln.set_gid(f"wall {k + 1}")


#: Marker of an end-stop impact (a prismatic joint at an end of its range); stars are wall impacts.
_STOP_MARKER = {"marker": "D", "ms": 8, "color": "red", "mec": "darkred", "ls": "none"}


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


def _draw_chain_2d(ax, model, q, n_points, hit=(), normals=None, labels=True, arrow=0.25, stops=()):
    _draw_links(lambda P, **st: ax.plot(P[:, 0], P[:, 1], solid_capstyle="round", **st), model, q, n_points,
                zorder=3)
    T = transforms(model, np.asarray(q, dtype=float))
    # Contact points: the frame origins, then the tips of hosts of prismatic joints (Model.n_joints).
    O = np.vstack((T[:, :3, 3], joint_positions(model, np.asarray(q, dtype=float))[T.shape[0]:]))
    ax.plot(O[:, 0], O[:, 1], "o", ms=4, color="k", zorder=4)
    for j, p in enumerate(O, start=1):
        if j in hit:
            ax.plot(p[0], p[1], "*", ms=13, color="red", mec="darkred", zorder=5)
        if labels:
            a = T[j - 1][:2, 0] if j <= model.n_links else np.zeros(2)
            if j <= model.n_links and model.joint_kinds[j - 1] == "Pb" and np.linalg.norm(a) > 0:
                # The rear end of a link in a guide lies on the host, with the guide just ahead:
                # its label goes beside the link (right-hand side), not onto the guide.
                a = a / np.linalg.norm(a)
                ax.annotate(f"$O_{{{j}}}$", p[:2], xytext=(9 * a[1], -9 * a[0]), textcoords="offset points",
                            fontsize=8, zorder=6, ha="center", va="center")
            else:
                ax.annotate(f"$O_{{{j}}}$", p[:2], xytext=(4, 4), textcoords="offset points", fontsize=8, zorder=6)
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


def camera(points) -> tuple[float, float]:
    """(elev, azim) [deg] of the 3D view along the direction of least spread of ``points`` (..., 3) [m].

    The eigenvector of the smallest eigenvalue of the points' covariance, taken from
    above (elevation >= 0) and kept between 10 and 75 degrees of elevation so that the
    vertical X2 stays readable; (18, -60) when no direction spreads clearly less
    (smallest eigenvalue above 0.6 of the middle one).
    """
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) < 3:
        return 18.0, -60.0
    lam, vec = np.linalg.eigh(np.cov(P.T))
    if not lam[1] > 0 or lam[0] > 0.6 * lam[1]:
        return 18.0, -60.0
    x, y, z = _to3(vec[:, 0])
    if z < 0:
        x, y, z = -x, -y, -z
    elev = np.degrees(np.arcsin(np.clip(z, -1.0, 1.0)))
    azim = np.degrees(np.arctan2(y, x)) if np.hypot(x, y) > 1e-9 else -60.0
    return float(np.clip(elev, 10.0, 75.0)), float(azim)


def _draw_walls_3d(ax, walls, lo, hi):
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 37), np.linspace(0, np.pi, 19))
    for k, w in enumerate(walls):
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
            from mpl_toolkits.mplot3d.art3d import Poly3DCollection

            poly = _plane_polygon_3d(walls, k, lo, hi)
            if len(poly) >= 3:
                X3, X1, X2 = _to3(poly)
                ax.add_collection3d(Poly3DCollection([np.column_stack([X3, X1, X2])], facecolor="0.7",
                                                     alpha=0.35, edgecolor="0.3", lw=0.8))


def _draw_chain_3d(ax, model, q, n_points, hit=(), normals=None, labels=True, floor=None, arrow=0.25, stops=()):
    _draw_links(lambda P, **st: ax.plot(*_to3(P), **st), model, q, n_points)
    pts = link_points(model, q, n_points)
    for i in range(pts.shape[0]):
        if floor is not None:
            # Shadow on the floor X2 = floor: shows where the chain is in depth.
            sh = pts[i].copy()
            sh[:, 1] = floor
            ax.plot(*_to3(sh), lw=1.6, color="0.5", alpha=0.6)
    T = transforms(model, np.asarray(q, dtype=float))
    O = np.vstack((T[:, :3, 3], joint_positions(model, np.asarray(q, dtype=float))[T.shape[0]:]))
    ax.plot(*_to3(O), "o", ms=4, color="k", ls="none")
    for j, p in enumerate(O, start=1):
        if j in hit:
            ax.plot(*_to3(p[None, :]), "*", ms=13, color="red", mec="darkred", ls="none")
        if labels:
            ax.text(*_to3(p), f"  $O_{{{j}}}$", fontsize=8)
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


def _run_camera(result, extra=None):
    """The camera of a run's 3D figures: along the direction of least joint motion."""
    P = result.joint_positions().reshape(-1, 3)
    return camera(P if extra is None else np.concatenate([P, extra.reshape(-1, 3)]))


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


# --------------------------------------------------------------------------
# All figures, saving, animation

def plot_result(result, kinds=None, case_name=None, n_points: int = 41) -> dict:
    """Draw the figures of a result.

    Parameters
    ----------
    result : Result
    kinds : iterable of keys from FIGURES or OPTIONAL_FIGURES, default all
    case_name : str, prefixed to the titles
    n_points : sample points per link in configuration drawings

    Returns
    -------
    dict {key: matplotlib Figure}; "modes" and "deflection" are absent for a chain of rigid links,
    "contact_forces" for a run without resting contact. The
    figures are not registered with pyplot: nothing needs closing.
    """
    kinds = FIGURES + OPTIONAL_FIGURES if kinds is None else tuple(kinds)
    unknown = [k for k in kinds if k not in FIGURES + OPTIONAL_FIGURES]
    if unknown:
        raise ValueError(f"unknown figure(s) {', '.join(unknown)}; choose from {', '.join(FIGURES + OPTIONAL_FIGURES)}")
    figs = {}
    for k in kinds:
        fig = plot_one(result, k, case_name=case_name, n_points=n_points)
        if fig is not None:
            figs[k] = fig
    return figs


def plot_one(result, which: str, ax=None, case_name=None, n_points: int = 41):
    """One figure of FIGURES by name, or drawn into ``ax`` (see each plot_* function); returns the Figure
    (None for "modes" and "deflection" of a chain of rigid links, "contact_forces" without resting contact)."""
    makers = {
        "angles": plot_angles, "modes": plot_modes, "deflection": plot_deflection,
        "joint_positions": plot_joint_positions,
        "joint_velocities": plot_joint_velocities, "energy": plot_energy,
        "contact_forces": plot_contact_forces,
    }
    if which in makers:
        return makers[which](result, case_name, ax=ax)
    if which == "configurations":
        return plot_configurations(result, case_name, n_points, ax=ax)
    if which == "trajectory":
        return plot_trajectory(result, case_name, n_points, ax=ax)
    raise ValueError(f"unknown figure {which!r}; choose from {', '.join(FIGURES + OPTIONAL_FIGURES)}")


def save_figures(figures: dict, directory, dpi: int = 120, close: bool = True) -> dict:
    """Save each figure as <directory>/<key>.png; returns {key: Path}.

    close : also close figures that pyplot holds (those of plot_result are not held by it).
    """
    from pathlib import Path

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    paths = {}
    for k, fig in figures.items():
        paths[k] = d / f"{k}.png"
        fig.savefig(paths[k], dpi=dpi, bbox_inches="tight", pad_inches=0.12)
        if close and "matplotlib.pyplot" in sys.modules:
            sys.modules["matplotlib.pyplot"].close(fig)
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
