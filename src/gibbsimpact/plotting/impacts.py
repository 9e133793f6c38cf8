"""Impact instants on the time axes: dotted lines and their numbers above the axes."""

from __future__ import annotations

import numpy as np


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
