"""Decimation of drawn curves: bucket extremes kept exactly, turns counted, dense curves drawn as
their envelope."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import burst_result
from gibbsimpact.plotting import plot_angles, plot_modes
from gibbsimpact.plotting.decimate import count_turns, envelope, minmax_decimate, visible_turns


def _bucket_extremes(t, y, n, t0, t1):
    """Per non-empty bucket (min, max) by a plain loop over the buckets (the second route)."""
    edges = np.linspace(t0, t1, n + 1)
    out = []
    for k in range(n):
        inside = (t >= edges[k]) & ((t < edges[k + 1]) if k < n - 1 else (t <= edges[k + 1]))
        if inside.any():
            out.append((y[inside].min(), y[inside].max()))
    return np.array(out)


@pytest.fixture(scope="module")
def signal():
    """200 001 uneven samples over 2 s: a slow swing, a 300 Hz oscillation and a random walk."""
    rng = np.random.default_rng(7)
    t = np.sort(np.concatenate([np.linspace(0.0, 2.0, 150001), rng.uniform(0.0, 2.0, 50000)]))
    y = np.sin(np.pi * t) + 0.2 * np.sin(2 * np.pi * 300.0 * t) + 1e-3 * np.cumsum(rng.normal(size=t.size))
    return t, y


def test_minmax_decimation_keeps_every_bucket_extreme_exactly(signal):
    t, y = signal
    n = 900
    td, yd = minmax_decimate(t, y, n)
    assert len(td) <= 2 * n + 2 and td[0] == t[0] and td[-1] == t[-1]
    assert np.all(np.diff(td) >= 0.0)
    rows = np.searchsorted(t, td)  # the points are samples, not averages
    np.testing.assert_array_equal(y[rows], yd)
    assert yd.max() == y.max() and yd.min() == y.min()
    got = _bucket_extremes(td, yd, n, t[0], t[-1])
    np.testing.assert_array_equal(got, _bucket_extremes(t, y, n, t[0], t[-1]))
    # Up to 2 n + 2 samples are drawn as they are.
    np.testing.assert_array_equal(minmax_decimate(t[:1802], y[:1802], n)[1], y[:1802])


def test_envelope_is_the_bucket_extremes(signal):
    t, y = signal
    tc, lo, hi = envelope(t, y, 150)
    np.testing.assert_array_equal(np.column_stack([lo, hi]), _bucket_extremes(t, y, 150, t[0], t[-1]))
    assert tc[0] == t[0] and tc[-1] == t[-1] and np.all(np.diff(tc) > 0)
    assert hi.max() == y.max() and lo.min() == y.min()


def test_turns():
    t = np.linspace(0.0, 1.0, 100001)
    # sin(2 pi f t) over f whole periods turns at each of its f peaks and f troughs.
    assert count_turns(np.sin(2 * np.pi * 37.0 * t), 0.01) == 2 * 37
    # Wiggles below h are not turns (round-off on a staircase, like an energy balance).
    stairs = np.repeat([0.0, -1.0, -2.0], 1000) + 1e-15 * np.random.default_rng(1).normal(size=3000)
    assert count_turns(stairs, 0.01) == 0
    assert visible_turns(np.arange(3000.0), stairs) == 0
    # An oscillation of 300 Hz over 2 s sampled at 10 kHz: its turns survive the bucket extremes.
    t = np.linspace(0.0, 2.0, 20001)
    assert visible_turns(t, np.sin(2 * np.pi * 300.0 * t), 900) >= 0.9 * 1200


def _dense_result():
    """A 2 s run, 2 modes per link, samples every 0.1 ms: the second mode coordinates oscillate at 300 Hz."""
    import dataclasses

    res = burst_result(bursts=(), t_end=2.0, dt=1e-4, modes=2)
    q, qdot = res.q.copy(), res.qdot.copy()
    w = 2 * np.pi * 300.0  # rad/s
    for idx in res.model.delta_index:
        q[:, idx[1]] = 0.01 * np.exp(-res.t) * np.sin(w * res.t)
        qdot[:, idx[1]] = 0.01 * np.exp(-res.t) * (w * np.cos(w * res.t) - np.sin(w * res.t))
    return dataclasses.replace(res, q=q, qdot=qdot)


def test_dense_modes_are_drawn_as_their_envelope_and_slow_ones_decimated():
    res = _dense_result()
    fig = plot_modes(res)
    ax = fig.axes[0]  # link 1, delta_1_1 (slow) and delta_1_2 (300 Hz)
    fast = res.model.delta_index[0][1]
    bands = [c for c in ax.collections if c.get_label().endswith("(envelope)")]
    assert len(bands) == 1 and "delta_{1,2}" in bands[0].get_label()
    verts = bands[0].get_paths()[0].vertices
    assert verts[:, 1].max() == res.q[:, fast].max() and verts[:, 1].min() == res.q[:, fast].min()
    # The slow coordinate stays a line, decimated to the extremes of the axis' pixel columns.
    slow = res.model.delta_index[0][0]
    (line,) = [ln for ln in ax.get_lines() if ln.get_label().startswith(r"$\delta_{1,1}$")]
    y = line.get_ydata()
    assert len(y) <= 2 * 1200 + 2 < len(res.t)
    assert y.max() == res.q[:, slow].max() and y.min() == res.q[:, slow].min()


def test_short_runs_draw_every_sample():
    res = burst_result(bursts=(), t_end=0.5)
    ax = plot_angles(res).axes[0]
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == r"$\theta_{1}$"]
    np.testing.assert_array_equal(line.get_ydata(), res.q[:, res.model.theta_index[0]])
