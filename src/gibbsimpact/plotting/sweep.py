"""The figure of a sweep: one column of its table against a varied key, one line per value of another.

Plain data in (the table's rows, as gibbsimpact.study.sweep returns them); matplotlib is
imported only when the figure is drawn (plotting.style._figure).
"""

from __future__ import annotations

import json
from numbers import Real

import numpy as np

from ..simulation.results import STATUS_FINISHED
from .style import _figure, _given_axes, _legend, _style

__all__ = ["plot_column"]


def _label(value) -> str:
    """Text of a varied key's value in the legend: numbers as they read back, arrays as JSON."""
    if isinstance(value, str):
        return value
    if isinstance(value, float):
        return repr(value)
    return json.dumps(value)


def _series(rows, column: str, x: str, lines) -> list:
    """[(value of ``lines`` or None, xs (n,), ys (n,), finished (n,) bool)] in order of first appearance,
    points sorted by x; a row without a value of ``column`` gives y = nan (a gap in its line)."""
    groups = {}
    for k, r in enumerate(rows, start=1):
        xv, yv = r.get(x), r.get(column)
        if not isinstance(xv, Real) or isinstance(xv, bool):
            raise ValueError(f"x: run {r.get('run', k)} has {x} = {xv!r}, not a number; draw against a key with "
                             "numbers (a key of strings or arrays can be lines=)")
        key = None if lines is None else json.dumps(r.get(lines), sort_keys=True)
        g = groups.setdefault(key, (r.get(lines) if lines is not None else None, [], [], []))
        g[1].append(float(xv))
        g[2].append(np.nan if yv is None else float(yv))
        g[3].append(r.get("status", STATUS_FINISHED) == STATUS_FINISHED)
    out = []
    for value, xs, ys, fin in groups.values():
        order = np.argsort(xs, kind="stable")
        xs = np.asarray(xs)[order]
        if np.any(np.diff(xs) == 0.0):
            raise ValueError(f"x: two runs with the same {x} = {float(xs[np.flatnonzero(np.diff(xs) == 0.0)[0]])!r} "
                             f"on one line{'' if lines is None else f' ({lines} = {_label(value)})'}; "
                             "every run must differ in x or lines")
        out.append((value, xs, np.asarray(ys)[order], np.asarray(fin)[order]))
    return out


def plot_column(rows, column: str, x: str, lines=None, title=None, ax=None):
    """Draw ``column`` of a sweep table against the varied key ``x``, one line per value of ``lines``.

    Parameters
    ----------
    rows : sequence of dict {column: value}, one per run (SweepResult.rows): the values of
        ``x`` real numbers, of ``column`` numbers or None (no value: a gap in the line);
        ``status`` (if present) other than "finished" draws the run as an open marker
    column : str, the column drawn on the vertical axis (its name, with its unit, is the label)
    x : str, the varied key on the horizontal axis (its key path is the label)
    lines : str or None, a second varied key: one line per value, in order of first appearance,
        labelled ``<lines> = <value>``; None draws one line
    title : str or None
    ax : None (a new figure) or one matplotlib Axes to draw into

    Returns the Figure. Raises ValueError for an x value that is no number, or two runs
    at the same x on one line (a third key varied).
    """
    series = _series(rows, column, x, lines)
    if ax is None:
        fig = _figure((7.5, 4.6))
        ax = fig.subplots()
    else:
        (ax,) = _given_axes(ax, 1, "plot_column")
        fig = ax.figure
    for k, (value, xs, ys, finished) in enumerate(series):
        style = _style(k)
        label = None if lines is None else f"{lines} = {_label(value)}"
        ax.plot(xs, ys, marker="o", ms=5, label=label, **style)
        if not finished.all():  # open markers over the runs that stopped early
            ax.plot(xs[~finished], ys[~finished], ls="none", marker="o", ms=7, mfc="white",
                    mec=style["color"], label="_stopped early")
    if any(not s[3].all() for s in series):
        ax.plot([], [], ls="none", marker="o", mfc="white", mec="k", label="open: run did not finish")
    ax.set_xlabel(x)
    ax.set_ylabel(column)
    ax.grid(True, lw=0.4, alpha=0.5)
    if title:
        ax.set_title(title, fontsize=9)
    _legend(ax)
    return fig
