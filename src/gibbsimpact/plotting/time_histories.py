"""Figures of quantities against time: joint variables, modal coordinates, tip deflections,
contact forces, joint positions and velocities, energies."""

from __future__ import annotations

import numpy as np

from ..model.joints import JOINT_KINDS
from ..model.shapes import link_deflection
from ..simulation.charts import recharts_text
from .geometry import is_planar
from .decimate import COLUMNS_PER_INCH, DENSE_TURNS, envelope, minmax_decimate, visible_turns
from .impacts import _impact_lines, _impact_note, _number_impacts
from .labels import _point_label, _point_name, _status_box, _tex, _title, _wrap_note, coincident_groups
from .style import _P_STYLES, _RANGE_STYLE, _STYLES, _figure, _given_axes, _joint_colour, _legend, _link_colour, _style


def _finish_time_figure(fig, axes, result, title, own: bool, number_axes=None, right: float = 1.0, note: str = ""):
    """Limits, grid, impact marks; on a figure of our own the title, the footnote (the impacts, then
    ``note``) and the layout.

    The impact numbers are placed after the layout, for the axes' final widths (a row laid out for
    the widths before it overlapped once tight_layout had narrowed the axes).
    """
    axes = list(axes)
    number_axes = axes[:1] if number_axes is None else list(number_axes)
    bottom = [ax for ax in axes if ax.get_subplotspec() is None or ax.get_subplotspec().is_last_row()]
    for ax in bottom or axes[-1:]:
        ax.set_xlabel("t [s]")
    t0, t1 = float(result.t[0]), float(result.t[-1])
    for ax in axes:
        ax.set_xlim(t0, t1)
        ax.grid(True, lw=0.3, alpha=0.6)
    _impact_lines(axes, result)
    if own:
        fig.subplots_adjust(left=0.08, right=min(0.84, right))
        for ax in number_axes:
            _number_impacts(ax, result, placeholder=True)  # reserves the row's height in the layout
        fig.suptitle(title, fontsize=11 if "\n" not in title else 10)
        note = _wrap_note(_impact_note(result) + note, fig.get_figwidth())
        fig.text(0.01, 0.005, note, fontsize=7, color="0.3", ha="left", va="bottom")
        fig.tight_layout(rect=(0, (10.0 * (note.count("\n") + 1) + 3.0) / (72.0 * fig.get_figheight()), right, 1))
    else:
        _status_box(axes[0], result)
    for ax in number_axes:
        _number_impacts(ax, result)
        # The y axis' multiplier ("1e-3") goes left of the corner, clear of the row of impact numbers.
        ax.yaxis.get_offset_text().set_x(-0.01)
        ax.yaxis.get_offset_text().set_horizontalalignment("right")


def _curve(ax, t, y, label=None, **style):
    """Draw the samples y (K,) against t (K,) [s] as decimate describes, with n buckets for the n pixel
    columns of ``ax``: every sample, or past 2 n + 2 samples the extremes of each bucket; a curve with
    more than DENSE_TURNS n visible turns as its envelope, a band in its colour (under the lines)
    with its edges in its line style. Returns the artists drawn."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    n = max(50, int(round(ax.get_position().width * ax.figure.get_figwidth() * COLUMNS_PER_INCH)))
    limit = int(DENSE_TURNS * n)
    turns = visible_turns(t, y, n) if len(y) > limit and np.all(np.isfinite(y)) else 0
    if turns <= limit:
        return ax.plot(*minmax_decimate(t, y, n), label=label, **style)
    tc, lo, hi = envelope(t, y, max(1, turns // 4))
    colour = style.get("color", "k")
    band = ax.fill_between(tc, lo, hi, color=colour, alpha=0.3, lw=0.0, zorder=1.5,
                           label=None if label is None else f"{label} (envelope)")
    edges = [ax.plot(tc, e, color=colour, ls=style.get("ls", "-"), lw=0.7)[0] for e in (lo, hi)]
    return [band, *edges]


# --------------------------------------------------------------------------
# Time histories

def _joint_variables(result):
    """[(colour index, coordinate index, joint number or None, its JointKind)] of the joint variables
    plot_angles draws: theta_-1, theta_0 of a spatial free base when the motion is not planar,
    then theta_i / d_i of every joint (a planar free base adds no angle: its theta_1 is joint 1's)."""
    model = result.model
    rows = [(k, i, kd) for i, (k, kd) in enumerate(zip(model.theta_index, model.joint_specs), start=1)
            if kd.has_coordinate]
    if model.chain.base == "free" and not is_planar(result):
        rows = [(3, None, JOINT_KINDS["R"]), (4, None, JOINT_KINDS["R"])] + rows
    return [(c, k, i, kd) for c, (k, i, kd) in enumerate(rows)]


def _draw_ranges(ax, model, rows, colour=None):
    """Thin dashed lines at d_min and d_max of the prismatic joints of ``rows`` [(colour index, _, joint, _)],
    in the colour of their curves (or ``colour(joint)``)."""
    for c, _, i, _ in rows:
        for k, y in enumerate(model.chain.joints[i - 1].range):
            ax.axhline(y, color=colour(i) if colour else f"C{c % 10}", label=f"range of $d_{{{i}}}$" if k == 0 else None,
                       **_RANGE_STYLE)


def _chart_marks(axes, result) -> str:
    """Dash-dotted lines at the re-charts of the free base (Result.charts, docs/theory.md §2.1) on
    ``axes``, where theta_-1, theta_0, theta_1 jump; returns the footnote's sentence on them ('' when
    the run never re-charted)."""
    times = [c.time for c in (getattr(result, "charts", None) or ())]
    if not times:
        return ""
    for ax in axes:
        for t in times:
            ax.axvline(t, color="C4", ls="-.", lw=0.8, zorder=0, gid="rechart")
    return ("; " + recharts_text(result.charts) + " (dash-dotted): "
            "theta_-1, theta_0, theta_1 jump there to another chart of the same orientation (theory §2.1; "
            "Result.base_orientation, timeseries.csv base_qw ... base_qz, is continuous)")


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
    groups = {"R": [r for r in rows if r[3].turns], "P": [r for r in rows if r[3].prismatic]}
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
            _curve(a, result.t, (result.qdot if rate else result.q)[:, k], label=_tex(name, dot=rate), **style)
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
    note = _chart_marks(axes[:2] if groups["R"] else [], result)
    _finish_time_figure(fig, axes, result, _title(result, what, case_name), own, note=note)
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
            _curve(a_q, result.t, result.q[:, k], label=label, **_style(c))
            if a_v is not None:
                _curve(a_v, result.t, result.qdot[:, k], label=_tex(name, dot=True), **_style(c))
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
            if model.chain.joints[i].spec.guide:
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
    pb = [i for i, kd in enumerate(model.joint_specs) if kd.guide]  # 0-based links in a guide
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
        _curve(axes[0], result.t, values, label=f"link {i + 1}: ${comp}({at})$", **_style(c, _link_colour(i)))
    axes[0].set_ylabel("deflection [m]" if mid else "tip deflection [m]")
    axes[0].ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    if len(axes) > 1:
        for pos, i in enumerate(pb):
            _curve(axes[1], result.t, result.q[:, model.theta_index[i]], color=_link_colour(i), lw=1.3,
                         ls=_P_STYLES[pos % len(_P_STYLES)], label=f"link {i + 1}: $d_{{{i + 1}}}$")
        _draw_ranges(axes[1], model, [(0, None, i + 1, JOINT_KINDS["Pb"]) for i in pb], colour=lambda j: _link_colour(j - 1))
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


def _stop_force_curves(ax, result, c: int) -> int:
    """The curves of the end stops that held their joints (Result.stop_forces (K, L) [N]) on ax, styles
    from number c on; returns the next style number."""
    S = result.stop_forces
    if S is None:
        return c
    from ..simulation.joint_limits import joint_limits

    limits = joint_limits(result.model)
    for k in np.nonzero(np.any(S != 0.0, axis=0))[0]:
        _curve(ax, result.t, S[:, k], label=f"end stop {limits[k].name}", **_style(c, _joint_colour(c)))
        c += 1
    return c


def plot_contact_forces(result, case_name=None, ax=None):
    """Normal force [N] of every (wall, contact point) pair that was ever in resting contact
    (Result.contact_forces) or pressed on a compliant wall (Result.compliant_forces: joints and closest
    points of flexible links), and the force [N] of every end stop that ever held its joint
    (Result.stop_forces), against time; None when there was none of these.

    ax : None (a new figure), one Axes (the normal forces) or two (and the friction forces |F_t|, with friction).
    """
    if not result.has_resting_forces:
        return None
    F, Fc = result.contact_forces, getattr(result, "compliant_forces", None)
    rested = F is not None and np.any(F)
    Ft = result.friction_forces
    n_panels = 2 if rested and Ft is not None and np.any(Ft) else 1
    own = ax is None
    if own:
        fig = _figure((9.5, 4.2 if n_panels == 1 else 6.4))
        axes = list(fig.subplots(n_panels, 1, sharex=True, squeeze=False)[:, 0])
    else:
        axes = _given_axes(ax, n_panels, "plot_contact_forces")
        fig = axes[0].figure
    P = result.model.n_joints
    names = [_point_label(result.model, j + 1) if j < P else f"span of {_point_name(result.model, j + 1, result.walls)}"
             for j in range(F.shape[2])]
    c = 0
    for w, j in (np.argwhere(np.any(F != 0.0, axis=0)) if rested else ()):
        _curve(axes[0], result.t, F[:, w, j], label=f"{names[j]} on wall {w + 1}", **_style(c, _joint_colour(int(j))))
        c += 1
    for w, j in (np.argwhere(np.any(Fc != 0.0, axis=0)) if Fc is not None else ()):
        point = names[j] if j < len(names) else _point_name(result.model, int(j) + 1)
        label = f"{point} on wall {w + 1} (compliant)"
        _curve(axes[0], result.t, Fc[:, w, j], label=label, **_style(c, _joint_colour(int(j))))
        c += 1
    c = _stop_force_curves(axes[0], result, c)
    axes[0].set_ylabel("contact force [N]")
    if n_panels == 2:
        c = 0
        for w, j in np.argwhere(np.any(F != 0.0, axis=0)):
            _curve(axes[1], result.t, np.linalg.norm(Ft[:, w, j], axis=1), label=f"{names[j]} on wall {w + 1}",
                   **_style(c, _joint_colour(int(j))))
            c += 1
        axes[1].set_ylabel("friction force\n|F_t| [N]")
    _legend(axes[0], outside=own)
    what = "normal force of each wall on each contact point in resting contact (0 in flight; impacts are impulses)"
    if Fc is not None and np.any(Fc):
        what = what.replace("in resting contact", "in resting contact or on a compliant wall")
    if result.stop_forces is not None and np.any(result.stop_forces):
        what = what.replace(" (0 in flight", ", and of each end stop holding its joint (0 in flight")
    if n_panels == 2:
        what += "; below: the friction force |F_t|"
    if result.settings.get("stepped_phases") and rested:
        # In a stepped contact phase a contact's force is a step's impulse over the step (docs/theory.md §15.5): an
        # impact there is a spike of impulse / step, 1e3 times the resting level, which a linear axis flattens.
        positive = F[F > 0.0]
        axes[0].set_yscale("symlog", linthresh=float(np.median(positive)))
        what += "; time-stepped contact phases: a step's impulse / the step (symlog axis)"
    _finish_time_figure(fig, axes, result, _title(result, what, case_name), own)
    return fig


def _joint_components(result, values, what, unit, case_name, ax, positions=None):
    """values (K, P, 3) of the contact points, one axis per component; ``positions`` (K, P, 3) [m]
    (default Result.joint_positions()) tell which points coincide all run long: they share one curve."""
    dims = 2 if is_planar(result) else 3
    own = ax is None
    if own:
        fig = _figure((9.5, 2.3 * dims + 1.2))
        axes = list(fig.subplots(dims, 1, sharex=True))
    else:
        axes = _given_axes(ax, dims, f"plot_{what.replace(' ', '_')}")
        fig = axes[0].figure
    # Points together all run long (a tree's joint, coincident_groups of the positions): one curve each.
    groups = coincident_groups(result.joint_positions() if positions is None else positions)
    for a, axis in enumerate(axes):
        for c, group in enumerate(groups):  # coloured by its place among the curves, as the paths
            j = group[0]
            _curve(axis, result.t, values[:, j, a], label=_point_label(result.model, j + 1, [k + 1 for k in group]),
                   **_style(c, _joint_colour(c)))
        axis.set_ylabel(f"along $X_{a + 1}$ [{unit}]")
    _legend(axes[0], outside=own)
    _finish_time_figure(fig, axes, result, _title(result, what, case_name), own)
    return fig


def plot_joint_positions(result, case_name=None, ax=None):
    """Positions of the joints O_1 ... O_(n+1) along X1, X2 (and X3) [m]; returns the Figure.

    ax : None (a new figure) or up to 2 (planar) / 3 Axes for the components X1, X2, X3 in turn.
    """
    P = result.joint_positions()
    return _joint_components(result, P, "joint positions", "m", case_name, ax, positions=P)


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
    _curve(axes[0], result.t, E.kinetic, label="kinetic", **_style(0))
    _curve(axes[0], result.t, E.gravity, label="gravitational", **_style(1))
    _curve(axes[0], result.t, E.strain, label="strain", **_style(2))
    _curve(axes[0], result.t, E.total, lw=1.8, color="k", label="total")
    balance = E.total - E.total[0]
    if result.work is not None:
        # A work that stays zero (no inputs, or no damped link) is left out of the legend and the plot.
        dissipation = ("work of damping and friction" if any(getattr(w, "friction", 0.0) > 0 for w in result.walls)
                       else "work of damping")
        for c, text in enumerate(("work of inputs", dissipation, "work of actuators")[:result.work.shape[1]]):
            if np.any(result.work[:, c] != 0.0) or not np.any(result.work != 0.0) and c == 0:
                _curve(axes[0], result.t, result.work[:, c], label=text, **_style(3 + c))
        balance = balance - result.work.sum(axis=1)
        ylabel = r"$E - E(t_0) - W$ [J]"
        what = "relative power-balance error"
    else:
        ylabel = r"$E - E(t_0)$ [J]"
        what = "relative drift"
    if _impact_losses(result):
        # The balance steps down at impacts with e < 1: it is not an integration error, say so on the axis.
        ylabel += "\n(steps: lost in impacts)"
    axes[0].set_ylabel("energy [J]")
    _legend(axes[0], outside=own)
    if len(axes) > 1:
        axes[1].set_ylabel(ylabel)
        _curve(axes[1], result.t, balance, lw=1.0, color="k")
        axes[1].ticklabel_format(axis="y", style="sci", scilimits=(-2, 3), useOffset=False)
    title = _title(result, f"energy (E(t0) = {E.total[0]:.7g} J; {what} over the whole run "
                           f"{result.energy_error_whole_run:.1e}, max per flight phase {result.energy_error:.1e})",
                   case_name)
    _finish_time_figure(fig, axes, result, title, own)
    return fig


def _impact_losses(result) -> bool:
    """Whether some impact of the run changed the total energy by more than round-off (1e-12 of its scale)."""
    scale = max((abs(r.energy_before.total) + abs(r.energy_before.kinetic) for r in result.impacts), default=0.0)
    return any(abs(r.energy_before.total - r.energy_after.total) > 1e-12 * scale for r in result.impacts)


def plot_effort(result, case_name=None, ax=None):
    """The effort Q_p of each prescribed coordinate's actuator [N m on an angle, N on a length] (Result.effort),
    one panel each, against time; None for a run without prescribed coordinates.

    ax : None (a new figure), or one Axes per prescribed coordinate.
    """
    if not result.prescribed or result.effort is None:
        return None
    n = len(result.prescribed)
    own = ax is None
    if own:
        fig = _figure((9.5, 2.3 * n + 1.2))
        axes = list(fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0])
    else:
        axes = _given_axes(ax, n, "plot_effort")
        fig = axes[0].figure
    units = dict(zip(result.model.coordinate_names, result.model.coordinate_units))
    for c, (a, name) in enumerate(zip(axes, result.prescribed)):
        _curve(a, result.t, result.effort[:, c], label=name, **_style(c))
        a.set_ylabel(f"effort on {name}\n[{'N m' if units[name] == 'rad' else 'N'}]")
    what = "generalised force each actuator applies to follow its prescribed motion (impulses at impacts not shown)"
    _finish_time_figure(fig, axes, result, _title(result, what, case_name), own)
    return fig
