"""What a time curve draws: every sample, the extremes of each pixel column, or its envelope.

A time axis W inches wide saved at 120 dpi (the default of ``[output] dpi``) has 120 W pixel
columns, about 900 for a full-width axis and 400 for one of two side by side; n such columns
are n equal time buckets here.

* min/max decimation keeps, in each bucket, the sample of the smallest and of the largest value
  (in time order), and the first and last samples: at most 2 n + 2 points; every extreme of
  every column survives, so the drawn line covers to within a pixel what the full one covers;
* a curve that turns more than n / 6 times (turns by more than 1/100 of its range: a period
  under twelve pixel columns, about eight once a figure's layout has made room for its labels
  and legend, which a line 2 pixels wide fills into a band) is drawn as a filled band between
  its per-bucket minimum and maximum (its envelope), with buckets of about four turns each so
  that the band's edges follow the envelope and not the oscillation itself.

numpy only; the figures (time_histories) choose between the two.
"""

from __future__ import annotations

import numpy as np

#: Default number of buckets: about the pixel columns of a full-width time axis (7.5 in at 120 dpi: 900).
BUCKETS = 1000
#: Pixels per inch the buckets are counted at: the default dpi of the saved figures.
COLUMNS_PER_INCH = 120.0
#: A curve with more visible turns than this fraction of its axis' columns is drawn as its envelope.
DENSE_TURNS = 1.0 / 6.0


def _buckets(t, t0: float, t1: float, n_buckets: int) -> np.ndarray:
    """Bucket index (K,) of each time t (K,) [s]: floor(n (t - t0) / (t1 - t0)), clipped to [0, n - 1]."""
    span = max(float(t1) - float(t0), 1e-300)
    b = np.floor((np.asarray(t, dtype=float) - t0) * (n_buckets / span)).astype(np.int64)
    return np.clip(b, 0, n_buckets - 1)


def count_turns(y, h: float) -> int:
    """Number of visible turns of the samples y (K,): a turn counts when y, after rising (falling),
    comes back down (up) by more than h from its highest (lowest) value since the last turn."""
    y = np.asarray(y, dtype=float).tolist()
    turns, direction, ext, lo, hi = 0, 0, y[0], y[0], y[0]
    for v in y:
        if direction == 0:  # no direction yet: wait for a move of more than h
            lo, hi = min(lo, v), max(hi, v)
            direction, ext = (-1, v) if hi - v > h else ((1, v) if v - lo > h else (0, ext))
        elif (v - ext) * direction > 0:
            ext = v
        elif abs(v - ext) > h:
            turns, direction, ext = turns + 1, -direction, v
    return turns


def visible_turns(t, y, n_buckets: int = BUCKETS) -> int:
    """Turns of (t, y) an axis of ``n_buckets`` pixel columns can show: count_turns of the min/max
    decimation with h = 1/100 of the range of y (a few pixels of an axis' height)."""
    _, yd = minmax_decimate(t, y, n_buckets)
    return count_turns(yd, 0.01 * (float(np.max(yd)) - float(np.min(yd)))) if len(yd) else 0


def _extreme_rows(b, y) -> tuple[np.ndarray, np.ndarray]:
    """Per non-empty bucket (b sorted, (K,)): the row of the smallest and of the largest y (first
    row in case of a tie)."""
    order = np.lexsort((np.arange(len(y)), y, b))  # by bucket, then value, then row
    sb = b[order]
    starts = np.flatnonzero(np.r_[True, sb[1:] != sb[:-1]])
    ends = np.r_[starts[1:], len(order)] - 1
    # The largest value's first row: step back over the equal values at the end of the bucket.
    ys = y[order]
    first_of_equal = np.r_[True, (ys[1:] != ys[:-1]) | (sb[1:] != sb[:-1])]
    run_start = np.maximum.accumulate(np.where(first_of_equal, np.arange(len(order)), 0))
    last = run_start[ends]
    return order[starts], order[last]


def minmax_decimate(t, y, n_buckets: int = BUCKETS, t0=None, t1=None) -> tuple[np.ndarray, np.ndarray]:
    """The samples of (t, y) that keep every bucket's extremes.

    Parameters
    ----------
    t : (K,) sample times [s], non-decreasing; y : (K,) values (any unit)
    n_buckets : number of equal time buckets over t0 ... t1 (default the first and last t)

    Returns
    -------
    (t_d, y_d), each (M,) with M <= 2 n_buckets + 2: in time order, the first and last samples and,
    in each non-empty bucket, the sample of its minimum and that of its maximum. max(y_d) = max(y)
    and min(y_d) = min(y) exactly (they are samples, not averages).
    """
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if len(t) <= 2 * n_buckets + 2:
        return t, y
    t0 = float(t[0]) if t0 is None else t0
    t1 = float(t[-1]) if t1 is None else t1
    lo, hi = _extreme_rows(_buckets(t, t0, t1, n_buckets), y)
    rows = np.unique(np.concatenate([[0, len(t) - 1], lo, hi]))
    return t[rows], y[rows]


def envelope(t, y, n_buckets: int, t0=None, t1=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The envelope of (t, y) over ``n_buckets`` equal time buckets.

    Returns (t_c, y_min, y_max), each (B,) for the B non-empty buckets in time order: the
    bucket's centre time [s] (the first and last at t0 and t1, so that the band spans the
    axis) and the smallest and largest sample in it.
    """
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    t0 = float(t[0]) if t0 is None else t0
    t1 = float(t[-1]) if t1 is None else t1
    b = _buckets(t, t0, t1, n_buckets)
    lo, hi = _extreme_rows(b, y)
    used = b[lo]
    tc = t0 + (used + 0.5) * (t1 - t0) / n_buckets
    tc[0], tc[-1] = t0, t1
    return tc, y[lo], y[hi]
