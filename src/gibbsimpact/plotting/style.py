"""The look of the figures: matplotlib access, colours, line styles, legends.

matplotlib is imported only inside these functions, when a figure is drawn. Figures are
``matplotlib.figure.Figure`` objects made outside pyplot's registry (nothing to close); in
IPython or Jupyter pyplot is imported once, never used to make figures, so that a returned
Figure is displayed inline. Without a display (no DISPLAY or WAYLAND_DISPLAY on Linux, no
MPLBACKEND set) the non-interactive Agg backend is selected before pyplot is first imported.
Link drawings and joint paths have separate colour sets; red is kept for impacts.
"""

from __future__ import annotations

import os
import sys

import numpy as np


#: Colours of the link drawings (cycled; seven, so that the six spokes of a rimless wheel differ) ...
LINK_COLOURS = ("#1f77b4", "#ff7f0e", "#8c564b", "#e377c2", "#bcbd22", "#5254a3", "#e7ba52")
#: ... and of the joints' paths and time curves (O_1, O_2, ...): no colour of either set is in the
#: other, and neither holds red, which marks impacts.
JOINT_COLOURS = ("#6a3d9a", "#1b9e77", "#17becf", "#2ca02c", "#253494", "#a6761d", "#7f7f7f")


def _link_colour(i: int) -> str:
    return LINK_COLOURS[i % len(LINK_COLOURS)]


def _joint_colour(j: int) -> str:
    return JOINT_COLOURS[j % len(JOINT_COLOURS)]


def _pyplot():
    import matplotlib

    if (
        "matplotlib.pyplot" not in sys.modules
        and "MPLBACKEND" not in os.environ
        and sys.platform.startswith("linux")
        and not os.environ.get("DISPLAY")
        and not os.environ.get("WAYLAND_DISPLAY")
    ):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _figure(figsize, layout=None):
    """A new Figure outside pyplot's registry (nothing to close, nothing accumulates)."""
    from matplotlib.figure import Figure

    if "IPython" in sys.modules:
        # Importing pyplot under IPython installs the inline display of Figure objects;
        # no figure is made through it.
        _pyplot()
    return Figure(figsize=figsize, layout=layout)


def _given_axes(ax, n_max: int, what: str) -> list:
    """``ax`` (one Axes or a sequence of them) as a list of at most ``n_max`` Axes."""
    axes = list(np.ravel(np.asarray(ax, dtype=object))) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
    if not axes or not all(hasattr(a, "plot") and hasattr(a, "figure") for a in axes):
        raise ValueError(f"{what}: ax={ax!r} must be a matplotlib Axes or a sequence of them")
    if len(axes) > n_max:
        raise ValueError(f"{what}: ax holds {len(axes)} Axes but this figure has at most {n_max} panel(s); "
                         f"pass at most {n_max}")
    return axes


#: Line styles cycled with the colours, so that curves that coincide (symmetric motions) stay visible.
_STYLES = ("-", "--", "-.", (0, (5, 1, 1, 1, 1, 1)))


def _style(k: int, colour=None) -> dict:
    return {"color": colour or f"C{k % 10}", "ls": _STYLES[k % len(_STYLES)], "lw": 1.3}


def _legend(ax, ncol=None, outside=True):
    """Legend to the right of the axes (never on top of the data), or inside at the best place."""
    handles, _ = ax.get_legend_handles_labels()
    if not handles:
        return
    if outside:
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)
    else:
        ax.legend(fontsize=8, ncol=ncol or min(len(handles), 4), loc="best", framealpha=0.85)


#: Line styles of the d curves: none of them dashed like the range lines (_RANGE_STYLE).
_P_STYLES = ("-", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 1)))
_RANGE_STYLE = {"ls": (0, (5, 3)), "lw": 0.8, "alpha": 0.8, "zorder": 1}


#: How the joint symbols are drawn: kind -> (legend label, line keywords).
_MARK_STYLE = {
    "guide": ("guide (prismatic, link slides through)", {"color": "k", "lw": 1.3}),
    "carriage": ("carriage (prismatic, slides on the host)", {"color": "k", "lw": 1.8}),
    "rail": ("rail of joint 1 (its travel)", {"color": "0.35", "lw": 1.0}),
}


#: Markers of the rigid bodies attached to links (docs/theory.md §6.8), by kind: a hub (at = 0) is an
#: open disc on its joint, any other body (a payload) a square at its centre, both in the link's colour.
_BODY_STYLE = {
    "hub": ("hub (body at a joint)", {"marker": "o", "ms": 11, "mfc": "none", "mew": 1.6, "ls": "none"}),
    "payload": ("payload (attached body)", {"marker": "s", "ms": 8, "mec": "k", "mew": 0.8, "ls": "none"}),
}


#: Marker of an end-stop impact (a prismatic joint at an end of its range); stars are wall impacts.
_STOP_MARKER = {"marker": "D", "ms": 8, "color": "red", "mec": "darkred", "ls": "none"}


#: The chain at t0 in the trajectory figure: dashed dark grey (the chain at the end has the link colours).
_T0_STYLE = {"color": "0.3", "ls": (0, (4, 2)), "lw": 1.5}
#: The chain's shadow on the floor in 3D: a wide, pale, solid band, unlike the dashed chain at t0.
_SHADOW_STYLE = {"color": "0.78", "lw": 3.2, "alpha": 0.7, "solid_capstyle": "round"}
