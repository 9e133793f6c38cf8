"""Figures of a simulation: time histories, energies, configurations at the impacts, animation.

matplotlib is imported in this package only, and only when a figure is drawn;
``import gibbsimpact`` never imports it. Figures are built as
``matplotlib.figure.Figure`` objects, not through pyplot: every function returns
one figure and nothing stays open in pyplot's figure registry, so calling them
in a loop or a notebook never accumulates figures (save one with
``fig.savefig``, or hand axes of your own figure to ``ax=``). In IPython or
Jupyter, pyplot is imported once (never used to make figures) so that a
returned Figure is displayed inline. Without a display (no DISPLAY or
WAYLAND_DISPLAY on Linux, no MPLBACKEND set) the non-interactive Agg backend
is selected before pyplot is first imported.

Every time plot marks the impact instants (impacts: up to 12 numbered dotted
lines, past that a rug of ticks and one label per collision episode; the
footnote lists the first impacts, or the episodes with their impulse,
effective restitution and energy lost) and draws its curves decimated
to the pixel columns of its axes, a curve too dense to read as its envelope
(decimate). A run that stopped early says so, with
its status and message, under every figure's title (in a red box inside the
axes when drawing into ``ax=``). Configurations are drawn in 2D (X1-X2 plane)
when the motion is planar and in 3D otherwise; in 3D, X2 (the usual "up"
against gravity) is the vertical axis and the camera looks along the
direction in which the joints moved least. Link drawings and joint paths
have separate colour sets; red is kept for impacts.

Prismatic joints: their variables d_i [m] get panels of their own in "angles"
(with their ranges as thin dashed lines); configuration drawings show a
FixedPrismatic (Pb) guide as a small sleeve at the host's tip with the link's
part behind it as a thin line along the host, a SlidingPrismatic (Pa)
carriage as a box on its host (and, on the base, its rail). An end-stop
impact (ImpactRecord wall -1) is named "stop i (d_min|d_max)" and drawn as a
red diamond at the guide or carriage. "deflection" is each link's tip
deflection in its own frame (model.link_deflection at x = l_i; at mid-span
for clamped-clamped modes), with the protruding length of Pb links below.

Modules: style (matplotlib access, colours, legends), labels (texts), impacts (impact marks on
time axes, contact episodes), decimate (what a curve draws, numpy only), geometry (points of the
drawings, numpy only), scene (drawing chains and walls), time_histories, configurations and
animation (the figures), figures (all of them, saving). docs/case-format.md ("Impacts and long
runs in the figures") states the rules.
"""

# The public names of gibbsimpact.plotting as it was one module (documented paths keep working).
from ..dynamics.link_points import link_points
from .animation import animate
from .configurations import plot_configurations, plot_trajectory
from .figures import FIGURES, OPTIONAL_FIGURES, plot_one, plot_result, save_figures
from .geometry import camera, is_planar
from .style import JOINT_COLOURS, LINK_COLOURS
from .time_histories import (plot_angles, plot_contact_forces, plot_deflection, plot_energy, plot_joint_positions,
                             plot_joint_velocities, plot_modes, tip_deflections)

__all__ = [
    "FIGURES", "OPTIONAL_FIGURES", "LINK_COLOURS", "JOINT_COLOURS", "link_points", "is_planar",
    "plot_angles", "plot_modes", "tip_deflections", "plot_deflection", "plot_contact_forces",
    "plot_joint_positions", "plot_joint_velocities", "plot_energy", "camera",
    "plot_configurations", "plot_trajectory", "plot_result", "plot_one", "save_figures", "animate",
]
