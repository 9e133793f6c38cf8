"""Impact instants on the time axes, contact episodes, and the footnote that lists them.

Up to ``MAX_LABELLED`` impacts, each is a dotted vertical line numbered above the axes (impacts
too close to be numbered one by one share a label "a-b"; a number that would overlap is left
out). Past that count the lines would bury the curves: each impact is a thin tick of a rug
along the bottom of the axes, each contact episode gets one dotted line at its start (while
there are at most MAX_LABELLED episodes) and one label "a-b", and the footnote lists the
episodes instead of the first impacts.

The impacts are grouped by :func:`impact_groups`: for a Result of a run (its settings hold the
contact band) the groups are its collision episodes (Result.episodes, docs/theory.md §14.7: the
impacts and resting phases of one meeting with the walls), and the footnote gives each episode's
impulse, effective restitution and energy lost, not a count of micro-impacts. A Result built by hand
(no settings) falls back to contact episodes by time: a run of impacts each following the previous one
by at most ``EPISODE_GAP`` of the run's duration, 1/300, three pixel columns of a time axis about 900
pixels wide, so impacts that the time plots cannot tell apart form one group. The configuration figure
draws one panel per group, split where the chain moved between two of its impacts (panel_groups).
"""

from __future__ import annotations

import numpy as np

from ..simulation.episodes import has_episodes
from .labels import _contacts_text, _sample_index

#: Impacts drawn as numbered lines; past this count, a rug and one label per contact episode.
MAX_LABELLED = 12
#: Largest gap between two impacts of one contact episode, as a fraction of the run (3 px in 900).
EPISODE_GAP = 1.0 / 300.0
#: Two impacts of one group share a configuration panel while no contact point moved more than this
#: fraction of the run's extent between them (panel_groups): 5 %, a few millimetres on a panel 8 cm wide.
PANEL_MOVE = 0.05
#: Axis fraction per character is CHAR_EM * fontsize / axis width [pt]: DejaVu Sans digits are 0.636 em.
CHAR_EM = 0.64
_LABEL_Y = 1.015  # axes fraction of the row of numbers above an axis
_RUG = 0.035  # height of a rug tick, axes fraction


def contact_episodes(times, t0: float, t1: float, gap: float = EPISODE_GAP) -> list:
    """Contact episodes of the impact times (K,) [s] of a run over t0 ... t1 [s].

    Impact k starts a new episode when t_k - t_(k-1) > gap (t1 - t0). Returns
    [(first, last)], 0-based inclusive indices into ``times``, in time order.
    """
    times = np.asarray(times, dtype=float)
    if times.size == 0:
        return []
    starts = np.flatnonzero(np.r_[True, np.diff(times) > gap * max(t1 - t0, 0.0)])
    ends = np.r_[starts[1:], times.size] - 1
    return [(int(a), int(b)) for a, b in zip(starts, ends)]


def impact_groups(result) -> tuple[list, bool]:
    """([(first, last)] 0-based inclusive impact ranges in time order, physical): the collision episodes'
    impacts (physical True; an impact outside every episode, an end stop of a run without walls, alone),
    or for a Result without the run's settings (built by hand) contact_episodes by time (physical False)."""
    n = len(result.impacts)
    if not has_episodes(result):
        return contact_episodes(result.impact_times, float(result.t[0]), float(result.t[-1])), False
    groups = [(ep.impacts[0], ep.impacts[-1]) for ep in result.episodes if ep.impacts]
    covered = {i for a, b in groups for i in range(a, b + 1)}
    return sorted(groups + [(i, i) for i in range(n) if i not in covered]), True


def panel_groups(result) -> list:
    """The impact ranges [(first, last)] (0-based, inclusive, in time order) that the configuration figure
    draws one panel each: impact_groups, each split between two consecutive impacts where some contact point
    moved by more than PANEL_MOVE of the run's extent (the diagonal of the box around every point's path) from
    the sample before the one to the sample before the other. One panel draws one state: a walker's feet strike
    a step apart within one long collision episode (its stance foot rests in between), and each strike gets its
    own panel, while the micro-impacts of one strike stay together."""
    groups = impact_groups(result)[0]
    if not groups:
        return []
    P = result.joint_positions()  # (K, P, 3) [m]
    flat = P.reshape(-1, 3)
    move = PANEL_MOVE * float(np.linalg.norm(flat.max(axis=0) - flat.min(axis=0)))
    k = [_sample_index(result, rec.time) for rec in result.impacts]
    out = []
    for a, b in groups:
        cuts = [i for i in range(a + 1, b + 1) if np.linalg.norm(P[k[i]] - P[k[i - 1]], axis=1).max() > move]
        out += list(zip([a] + cuts, [i - 1 for i in cuts] + [b]))
    return out


def _range_text(first: int, last: int) -> str:
    """'a' or 'a-b' (en dash) for the 1-based numbers first ... last."""
    return str(first) if first == last else f"{first}\u2013{last}"


def _fit_last(out: list, char: float, space: float) -> list:
    """[(x_left, text)] with the last label moved left to end at the axis' right end if it would run
    past it, and the labels it then overlaps left out."""
    if out:
        x_last = min(out[-1][0], 1.0 + 0.5 * char - len(out[-1][1]) * char)
        out[-1] = (x_last, out[-1][1])
        while len(out) > 1 and out[-2][0] + len(out[-2][1]) * char + space > x_last:
            del out[-2]
    return out


def _impact_labels(times, t0: float, t1: float, width_pt: float, fontsize: float = 7.0) -> list:
    """Impact numbers in one row above an axis of ``width_pt`` points spanning t0 ... t1.

    Returns [(t, text)], each text left-aligned at t minus half its first number. Impacts
    within about two characters of a group's first one share a label "a-b"; a number that
    would overlap the previous label is left out (its dotted line stays).
    """
    span = max(t1 - t0, 1e-300)
    char = CHAR_EM * fontsize / max(width_pt, 1.0)  # axis fraction per character
    space, cluster = char, 2.0 * char
    groups = []  # [first, last, x_first]

    def right(g):
        return g[2] - 0.5 * len(str(g[0])) * char + len(_range_text(g[0], g[1])) * char

    for k, t in enumerate(np.asarray(times, dtype=float), start=1):
        x = (t - t0) / span
        if not groups:
            groups.append([k, k, x])
        elif x - groups[-1][2] <= cluster and groups[-1][1] == k - 1:
            groups[-1][1] = k
        elif x - 0.5 * len(str(k)) * char >= right(groups[-1]) + space:
            groups.append([k, k, x])
    out = [(g[2] - 0.5 * len(str(g[0])) * char, _range_text(g[0], g[1])) for g in groups]
    return [(t0 + x * span, text) for x, text in _fit_last(out, char, space)]


def _episode_labels(times, episodes, t0: float, t1: float, width_pt: float, fontsize: float = 7.0) -> list:
    """One label "a-b" per contact episode [(first, last)] (0-based) in one row above the axis; an
    episode label that would overlap the previous one is left out. Returns [(t, text)] as
    _impact_labels."""
    span = max(t1 - t0, 1e-300)
    char = CHAR_EM * fontsize / max(width_pt, 1.0)
    out = []
    for a, b in episodes:
        text = _range_text(a + 1, b + 1)
        x = (float(times[a]) - t0) / span - 0.5 * len(str(a + 1)) * char
        if not out or x >= out[-1][0] + len(out[-1][1]) * char + char:
            out.append((x, text))
    return [(t0 + x * span, text) for x, text in _fit_last(out, char, char)]


def _impact_lines(axes, result):
    """Dotted lines at the impacts (at most MAX_LABELLED), else a rug of ticks along the bottom of each
    axis and a dotted line at the start of each episode (while there are at most MAX_LABELLED)."""
    times = result.impact_times
    if times.size <= MAX_LABELLED:
        for ax in axes:
            for t in times:
                ax.axvline(t, color="0.35", ls=":", lw=0.9, zorder=0)
        return
    episodes = impact_groups(result)[0]
    starts = [times[a] for a, _ in episodes] if len(episodes) <= MAX_LABELLED else []
    for ax in axes:
        tr = ax.get_xaxis_transform()
        ax.vlines(times, 0.0, _RUG, transform=tr, colors="0.15", lw=0.6, zorder=2.5, gid="impact rug")
        if starts:
            ax.vlines(starts, 0.0, 1.0, transform=tr, colors="0.35", linestyles=":", lw=0.8, zorder=0)


def _number_impacts(ax, result, placeholder: bool = False):
    """The row of impact (or episode) numbers above ``ax``, placed for its current width; with
    ``placeholder`` one invisible character that only reserves the row's height for a layout."""
    for text in [t for t in ax.texts if t.get_gid() == "impact label"]:
        text.remove()
    times = result.impact_times
    if times.size == 0:
        return
    tr = ax.get_xaxis_transform()
    style = {"transform": tr, "ha": "left", "va": "bottom", "fontsize": 7, "color": "0.25", "clip_on": False,
             "gid": "impact label"}
    if placeholder:
        ax.text(float(times[0]), _LABEL_Y, "0", alpha=0.0, **style)
        return
    x0, x1 = ax.get_xlim()
    width_pt = ax.get_position().width * ax.figure.get_figwidth() * 72.0
    if times.size <= MAX_LABELLED:
        labels = _impact_labels(times, x0, x1, width_pt)
    else:
        labels = _episode_labels(times, impact_groups(result)[0], x0, x1, width_pt)
    for t, text in labels:
        ax.text(t, _LABEL_Y, text, **style)


def _impact_note(result, limit: int = 8) -> str:
    """The footnote of the time plots: the first ``limit`` impacts (time, contacts), or past
    MAX_LABELLED impacts the first impact groups (impact numbers, times, contacts; for collision
    episodes their impulse, effective restitution and energy lost)."""
    imps = result.impacts
    if not imps:
        return "no impacts"
    if len(imps) <= MAX_LABELLED:
        items = [f"{k}: {_contacts_text(result, r)} at {r.time:.6f} s" for k, r in enumerate(imps[:limit], start=1)]
        more = f"; ... ({len(imps)} in all, every one in impacts.csv)" if len(imps) > limit else ""
        return "impacts (dotted lines): " + "; ".join(items) + more + _grouped_note(result)
    groups, physical = impact_groups(result)
    physics = _episode_physics(result) if physical else {}
    items = [f"{_range_text(a + 1, b + 1)}: {_episode_contacts(result, a, b)} at "
             + (f"{imps[a].time:.6f} s" if a == b else f"{imps[a].time:.6f}\u2013{imps[b].time:.6f} s")
             + physics.get(a, "") for a, b in groups[:limit // 2]]
    if physical:
        more = f"; ... ({len(groups)} in all)" if len(groups) > limit // 2 else ""
        return (f"{len(imps)} impacts (ticks at the bottom) in {len(groups)} collision episode"
                f"{'s' if len(groups) > 1 else ''}, numbered per episode (every episode in episodes.csv, every "
                "impact in impacts.csv): " + "; ".join(items) + more)
    more = f"; ... ({len(groups)} episodes in all)" if len(groups) > limit // 2 else ""
    return (f"{len(imps)} impacts (ticks at the bottom), numbered per contact episode (impacts at most "
            f"{EPISODE_GAP * (float(result.t[-1]) - float(result.t[0])):.3g} s apart; every impact in impacts.csv): "
            + "; ".join(items) + more)


def _grouped_note(result) -> str:
    """'; collision episodes: 2-6 (impulse ..., e_eff ..., ... J lost)' for the episodes of several impacts of a
    run numbered impact by impact, '' when each impact is its own episode (or the Result has no episodes)."""
    groups, physical = impact_groups(result)
    if not physical:
        return ""
    physics = _episode_physics(result)
    items = [f"{_range_text(a + 1, b + 1)}{physics.get(a, '')}" for a, b in groups if b > a]
    return "; collision episodes: " + "; ".join(items) if items else ""


def _episode_physics(result) -> dict:
    """{first impact (0-based): ', impulse 2.6 N s, e_eff 0.76, 0.54 J lost'} of the collision episodes."""
    out = {}
    for ep in result.episodes:
        if ep.impacts:
            e = "" if ep.restitution != ep.restitution else f", e_eff {ep.restitution:.3g}"
            if ep.non_contact_share > 0.1:  # not an impulsive collision: say why e_eff is no restitution
                e += f" with other forces {ep.non_contact_share:.2g} of the approach"
            out[ep.impacts[0]] = f" (impulse {ep.impulse:.3g} N s{e}, {ep.energy_lost:.3g} J lost)"
    return out


def _episode_contacts(result, first: int, last: int) -> str:
    """The contacts of impacts first ... last (0-based), each named once, in order of appearance."""
    names = []
    for rec in result.impacts[first:last + 1]:
        text = _contacts_text(result, rec)
        if text not in names:
            names.append(text)
    return ", ".join(names)

