"""The sweep figure (gibbsimpact.plotting.sweep.plot_column) from plain table rows: one line per
value of the second key, points sorted by x, a gap where a run has no value, open markers over
the runs that did not finish, axes labelled with the key path and the column name."""

from __future__ import annotations

import numpy as np
import pytest

from gibbsimpact.plotting.sweep import plot_column

ROWS = [  # grid order of restitution x walls[1].radius_m, x given out of order
    {"run": 1, "restitution": 1.0, "walls[1].radius_m": 1.5, "status": "finished", "nfev": 300},
    {"run": 2, "restitution": 1.0, "walls[1].radius_m": 2.0, "status": "finished", "nfev": 200},
    {"run": 3, "restitution": 0.5, "walls[1].radius_m": 1.5, "status": "zeno", "nfev": 500},
    {"run": 4, "restitution": 0.5, "walls[1].radius_m": 2.0, "status": "invalid", "nfev": None},
    {"run": 5, "restitution": 0.75, "walls[1].radius_m": 1.5, "status": "finished", "nfev": 400},
    {"run": 6, "restitution": 0.75, "walls[1].radius_m": 2.0, "status": "finished", "nfev": 250},
]


def test_one_line_per_value_of_the_second_key():
    fig = plot_column(ROWS, "nfev", "restitution", "walls[1].radius_m", title="t")
    (ax,) = fig.axes
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_title()) == ("restitution", "nfev", "t")
    data = [ln for ln in ax.get_lines() if ln.get_linestyle() != "None"]
    assert [ln.get_label() for ln in data] == ["walls[1].radius_m = 1.5", "walls[1].radius_m = 2.0"]
    assert [list(ln.get_xdata()) for ln in data] == [[0.5, 0.75, 1.0]] * 2
    assert list(data[0].get_ydata()) == [500, 400, 300]
    y = np.asarray(data[1].get_ydata(), dtype=float)
    assert np.isnan(y[0]) and list(y[1:]) == [250, 200]  # the invalid run: a gap
    # Open markers over the runs that did not finish (zeno at 0.5 / 1.5, invalid at 0.5 / 2.0) and one legend entry.
    opened = [ln for ln in ax.get_lines() if ln.get_linestyle() == "None" and ln.get_label().startswith("_")]
    assert [(list(ln.get_xdata()), ln.get_markerfacecolor()) for ln in opened] == [([0.5], "white"), ([0.5], "white")]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["walls[1].radius_m = 1.5", "walls[1].radius_m = 2.0", "open: run did not finish"]


def test_one_line_without_a_second_key_and_into_given_axes():
    from matplotlib.figure import Figure

    rows = [r for r in ROWS if r["walls[1].radius_m"] == 1.5 and r["status"] == "finished"]
    ax = Figure().subplots()
    assert plot_column(rows, "nfev", "restitution", ax=ax) is ax.figure
    (line,) = ax.get_lines()
    assert list(line.get_xdata()) == [0.75, 1.0] and list(line.get_ydata()) == [400, 300]
    assert ax.get_legend() is None


def test_bad_x_values_and_a_third_key_are_errors():
    with pytest.raises(ValueError, match=r"x: run 1 has solver.method = 'RK45', not a number"):
        plot_column([{"run": 1, "solver.method": "RK45", "nfev": 3}], "nfev", "solver.method")
    with pytest.raises(ValueError, match=r"x: two runs with the same restitution = 0.5 on one line"):
        plot_column(ROWS, "nfev", "restitution")  # the radius varies too, but is not lines
