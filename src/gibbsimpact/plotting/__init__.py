"""Figures of a Result (matplotlib is imported here only, and only when a figure is drawn)."""

# The public names of gibbsimpact.plotting as it was one module (documented paths keep working).
from .figures import (
    FIGURES, OPTIONAL_FIGURES, LINK_COLOURS, JOINT_COLOURS, link_points, is_planar, plot_angles,
    plot_modes, tip_deflections, plot_deflection, plot_contact_forces, plot_joint_positions,
    plot_joint_velocities, plot_energy, camera, plot_configurations, plot_trajectory, plot_result,
    plot_one, save_figures, animate,
)

__all__ = [
    "FIGURES", "OPTIONAL_FIGURES", "LINK_COLOURS", "JOINT_COLOURS", "link_points", "is_planar",
    "plot_angles", "plot_modes", "tip_deflections", "plot_deflection", "plot_contact_forces",
    "plot_joint_positions", "plot_joint_velocities", "plot_energy", "camera",
    "plot_configurations", "plot_trajectory", "plot_result", "plot_one", "save_figures", "animate",
]
