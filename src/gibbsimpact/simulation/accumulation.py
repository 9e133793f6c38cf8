"""Detection of an accumulation of impacts (rules (a) and (b) of gibbsimpact.simulate's docstring)."""

from __future__ import annotations

import numpy as np


def accumulation_time(times, intervals):
    """Estimate of the accumulation time of a run of impacts, and the ratio used.

    times : (k,) impact times [s]; intervals : (k,) the interval ending at each.
    Geometric extrapolation t_inf = t_j + d_j r / (1 - r) from the most geometric
    pair (smallest r = d_j / d_(j-1)): the latest intervals can be limited by the
    contact band and tend to a constant.
    """
    d = np.asarray(intervals, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = d[1:] / d[:-1]
    ok = np.isfinite(ratios) & (ratios > 0) & (ratios < 1)
    if not np.any(ok):
        return float(times[-1]), float("nan")
    j = int(np.argmin(np.where(ok, ratios, np.inf)))
    r = float(ratios[j])
    return float(times[j + 1] + d[j + 1] * r / (1 - r)), r


class Accumulation:
    """Detects an accumulation of impacts (rules (a) and (b) of the module docstring)."""

    def __init__(self, shape, zeno_count, zeno_interval, band, names=None):
        self.count, self.interval, self.band = zeno_count, zeno_interval, band
        # names of the columns (contacts.Contacts.names): "O2", "link 1", ...
        self.names = list(names) if names is not None else [f"O{j + 1}" for j in range(shape[1])]
        self.streak = np.zeros(shape, dtype=int)  # consecutive in-band impacts per (wall, joint)
        self.times: list[float] = []
        self.pairs: list[tuple] = []  # (walls, joints) that took an impulse, per impact

    def left_band(self, w_i, j):
        self.streak[w_i, j] = 0

    def reset(self):
        """Forget the impacts so far (the accumulation was resolved into resting contact)."""
        self.streak[:] = 0
        self.times, self.pairs = [], []

    def recent_pairs(self) -> np.ndarray:
        """(W, J) bool: the pairs that took an impulse in the last zeno_count impacts."""
        mask = np.zeros(self.streak.shape, dtype=bool)
        for walls, joints in self.pairs[-self.count:]:
            mask[list(walls), [j - 1 for j in joints]] = True
        return mask

    def add(self, rec, in_band_before) -> str | None:
        """Register an impact; in_band_before (W, J): pairs that stayed in the band since the last impact.

        Returns the stop message, or None.
        """
        self.times.append(rec.time)
        took = [(w, j) for w, j, lam in zip(rec.wall, rec.joints, rec.impulses) if lam > 0]
        self.pairs.append((tuple(w for w, _ in took), tuple(j for _, j in took)))
        for w_i, j, lam in zip(rec.wall, rec.joints, rec.impulses):
            if lam > 0:
                self.streak[w_i, j - 1] = self.streak[w_i, j - 1] + 1 if in_band_before[w_i, j - 1] else 0
        k = self.count
        times = np.array(self.times[-(k + 1):])
        d = np.diff(times)
        if np.max(self.streak) >= k:
            w_i, j = np.unravel_index(int(np.argmax(self.streak)), self.streak.shape)
            name = self.names[j]
            what = f"joint {name}" if name.startswith("O") else (f"the span of {name}" if name.startswith("link")
                                                                  else f"the centre of {name}")
            why = (f"{what} stayed within {1.5 * self.band:.3g} m of wall {w_i + 1} through {k} consecutive "
                   "impacts (its rebounds no longer leave the contact band)")
        elif d.size >= k and np.all(d[-k:] < self.interval):
            why = f"{k} consecutive impacts less than {self.interval:g} s apart"
        else:
            return None
        d = d[-k:]
        t_acc, ratio = accumulation_time(times[-d.size:], d)
        if not ratio < 0.9:
            # Intervals that do not shrink: the contact is closed (resting or sliding) since then.
            t_acc, ratio = float(times[-d.size - 1] if times.size > d.size else times[0]), ratio
        return (f"accumulation of impacts: {why}; last interval {d[-1]:.3g} s, interval ratio {ratio:.3g}; "
                f"estimated accumulation time {t_acc:.9g} s: resting contact from t = {t_acc:.9g} s")
