"""The collision episodes of a Result as file rows: what ``episodes.csv`` and the ``episodes`` of summary.json
hold (io.result_files writes them; docs/case-format.md, "Output files"; the rules: docs/theory.md §14.7,
gibbsimpact.simulation.episodes).

Walls, contact points and impacts are numbered from 1, as in impacts.csv. A Result without the
settings of its run (built by hand) has no episodes: an empty episodes.csv, ``"episodes": null``.
"""

from __future__ import annotations

import math

from ..simulation.episodes import has_episodes

__all__ = ["EPISODE_COLUMNS", "episode_cell", "episode_rows"]

#: Columns of episodes.csv, one row per episode (units in the names; restitution and non_contact_share NaN
#: when the episode started resting, not with an impact).
EPISODE_COLUMNS = [
    "episode", "start_s", "end_s", "duration_s", "ended", "walls", "contact_points", "first_contact_point",
    "n_impacts", "first_impact", "last_impact", "impulse_N_s", "max_impulse_N_s", "max_force_N", "resting_time_s",
    "energy_before_J", "energy_after_J", "energy_lost_J", "restitution", "non_contact_share", "max_penetration_m",
    "damping_work_J", "friction_work_J",
]


def _point_name(result, c: int) -> str:
    """'O2', 'link 1' or 'body 1' for the 1-based gap-matrix column c (Contacts.names)."""
    from ..simulation.contact_points import contact_points

    points = contact_points(result.model, bool(result.settings.get("link_contacts", True)), result.walls)
    return points[c - 1].name if 0 < c <= len(points) else f"point {c}"


def episode_rows(result) -> list[dict] | None:
    """The episodes as plain dicts with the keys of EPISODE_COLUMNS (numbers from 1, floats in SI units),
    or None for a Result without the settings of its run."""
    if not has_episodes(result):
        return None
    rows = []
    for k, ep in enumerate(result.episodes, start=1):
        rows.append({
            "episode": k, "start_s": ep.start, "end_s": ep.end, "duration_s": ep.duration, "ended": bool(ep.ended),
            "walls": [w + 1 for w in ep.walls], "contact_points": [_point_name(result, c) for c in ep.points],
            "first_contact_point": _point_name(result, ep.first_point), "n_impacts": ep.n_impacts,
            "first_impact": ep.impacts[0] + 1 if ep.impacts else None,
            "last_impact": ep.impacts[-1] + 1 if ep.impacts else None,
            "impulse_N_s": ep.impulse, "max_impulse_N_s": ep.max_impulse, "max_force_N": ep.max_force,
            "resting_time_s": ep.resting_time, "energy_before_J": ep.energy_before,
            "energy_after_J": ep.energy_after, "energy_lost_J": ep.energy_lost, "restitution": ep.restitution,
            "non_contact_share": ep.non_contact_share, "max_penetration_m": ep.max_penetration,
            "damping_work_J": ep.damping_work, "friction_work_J": ep.friction_work,
        })
    return rows


def episode_cell(v) -> str:
    """One episodes.csv cell: floats as the shortest text that reads back to the same double, lists joined by
    '+' (walls '1+2', points 'O1+O3'), None empty, booleans 'true'/'false'."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if v is None:
        return ""
    if isinstance(v, list):
        return "+".join(str(x) for x in v)
    if isinstance(v, float):
        return repr(v) if not math.isnan(v) else "nan"
    return str(v)
