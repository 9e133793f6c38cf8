"""The column names of contact_forces.csv (io.result_files.write_contact_forces_csv writes it): the forces of
resting contacts, compliant walls and end stops, walls, contact points, links and bodies numbered from 1."""

from __future__ import annotations

import numpy as np

from ..simulation.results import Result

__all__ = ["contact_force_columns", "stop_force_columns", "compliant_force_columns", "has_contact_forces"]


def contact_force_columns(result: Result) -> list[str]:
    """Column names F_w<wall>_<point>_N of contact_forces.csv (walls and points from 1; a link's span
    point: F_w<wall>_link<i>_N)."""
    names = _force_point_names(result)
    return [f"F_w{w + 1}_{names[j]}_N" for w in range(len(result.walls)) for j in range(len(names))]


def stop_force_columns(result: Result) -> list[str]:
    """Column names Fstop_<coordinate>_<min|max|carriage>_N of the end-stop forces in contact_forces.csv,
    in the order of Result.stop_forces (simulation.joint_limits.joint_limits)."""
    from ..simulation.joint_limits import joint_limits

    names = result.model.coordinate_names
    kinds = ("min", "max", "carriage")
    out, seen = [], {}
    for lim in joint_limits(result.model):
        k = result.model.theta_index[lim.joint - 1]
        seen[k] = seen.get(k, -1) + 1
        out.append(f"Fstop_{names[k]}_{kinds[seen[k]]}_N")
    return out


def compliant_force_columns(result: Result) -> list[str]:
    """Column names Fc_w<wall>_<column>_N of the compliant forces (Result.compliant_forces (K, W, C)): the columns
    of the run's gap matrix (simulation.contact_points.contact_points): the joints, then link<i> for the closest
    point of link i (contacts.link_columns: every link when a wall is an obstacle), then body<k> for the centre of
    the k-th attached body with an offset (walls, points, links and bodies from 1)."""
    from ..simulation.contact_points import contact_points

    C = np.shape(result.compliant_forces)[2]
    names = list(result.model.contact_point_names)
    points = contact_points(result.model, bool(result.settings.get("link_contacts", True)), result.walls)
    names += [p.name.replace(" ", "") for p in points[len(names):]]
    return [f"Fc_w{w + 1}_{names[c]}_N" for w in range(len(result.walls)) for c in range(C)]


def has_contact_forces(result: Result) -> bool:
    """Whether contact_forces.csv is written: some pair rested, an end stop held its joint, or some pair
    pressed on a compliant wall (Result.has_resting_forces)."""
    return result.has_resting_forces
def _force_point_names(result: Result) -> list[str]:
    """Names of the columns of Result.contact_forces: O1 .. O_P, then link<i> for the span point of link i
    (link<i>.<c> for its cell c: simulation.contacts.link_column_cells), as many as the array has."""
    from ..simulation.contacts import link_column_cells, link_column_name

    names = list(result.model.contact_point_names)
    C = len(names) if result.contact_forces is None else np.shape(result.contact_forces)[2]
    return (names + [link_column_name(*cell, sep="") for cell in link_column_cells(result.model, result.walls)])[:C]
