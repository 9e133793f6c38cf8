"""Every figure of a result at once, one by name, and saving them as PNG files.

The figure makers live in time_histories, configurations and animation (plotting/__init__
describes what they draw); this module holds the list of figure keys and the functions that
take a whole result: plot_result, plot_one, save_figures (and animate, re-exported).
"""

from __future__ import annotations

import sys

from .animation import animate
from .configurations import plot_configurations, plot_trajectory
from .time_histories import (plot_angles, plot_contact_forces, plot_deflection, plot_effort, plot_energy,
                             plot_joint_positions, plot_joint_velocities, plot_modes)

__all__ = ["FIGURES", "OPTIONAL_FIGURES", "animate", "plot_one", "plot_result", "save_figures"]

#: Figure keys of plot_result, in drawing order; each is saved as <key>.png.
FIGURES = ("angles", "modes", "deflection", "joint_positions", "joint_velocities", "energy", "configurations",
           "trajectory")
#: Figures drawn (and saved) besides FIGURES only when the run has what they show.
OPTIONAL_FIGURES = ("contact_forces", "effort")  # a run with resting contact; with prescribed coordinates


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
        "contact_forces": plot_contact_forces, "effort": plot_effort,
    }
    if which in makers:
        return makers[which](result, case_name, ax=ax)
    if which == "configurations":
        return plot_configurations(result, case_name, n_points, ax=ax)
    if which == "trajectory":
        return plot_trajectory(result, case_name, n_points, ax=ax)
    hint = ""
    if "/" in which or "\\" in which or which.endswith(".png"):  # a path given where a figure name goes
        hint = f"; to save every figure as <dir>/<name>.png, pass the folder as directory={which!r}"
    raise ValueError(f"unknown figure {which!r}; choose from {', '.join(FIGURES + OPTIONAL_FIGURES)}{hint}")


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
