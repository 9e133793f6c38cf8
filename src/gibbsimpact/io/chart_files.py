"""The free base's charts in the result files (docs/theory.md §2.1): result.npz's arrays of Result.base_chart
and Result.charts, and summary.json's orientation and re-charts."""

from __future__ import annotations

import numpy as np

from ..simulation.charts import ChartChange


def base_summary(result) -> dict:
    """A spatial free base's chart-free final orientation (a unit quaternion [w, x, y, z]) and its re-charts
    (time [s], the old chart's angles [rad]) for summary.json; {} for other bases."""
    if result.base_orientation is None:
        return {}
    return {"base_orientation_final_wxyz": [float(v) for v in result.base_orientation[-1]],
            "base_recharts": [{"time_s": float(c.time), "angles_before_rad": [float(a) for a in c.angles_before]}
                              for c in result.charts]}


def chart_arrays(result) -> dict:
    """The free base's charts of a Result that re-charted (Result.base_chart, Result.charts) as NPZ arrays
    ({} for one that did not)."""
    if result.base_chart is None:
        return {}
    ch = result.charts
    return {"base_chart": np.asarray(result.base_chart, dtype=float),
            "chart_time": np.array([c.time for c in ch], dtype=float),
            "chart_sample": np.array([c.sample for c in ch], dtype=np.int64),
            "chart_angles_before": np.array([c.angles_before for c in ch], dtype=float).reshape(-1, 3),
            "chart_after": np.array([c.chart_after for c in ch], dtype=float).reshape(-1, 3, 3)}


def charts_from(a: dict) -> dict:
    """Result's base_chart and charts from the arrays of chart_arrays ({} for a file without them)."""
    if "base_chart" not in a:
        return {}
    return {"base_chart": a["base_chart"],
            "charts": [ChartChange(float(t), int(k), b, R) for t, k, b, R in
                       zip(a["chart_time"], a["chart_sample"], a["chart_angles_before"], a["chart_after"])]}
