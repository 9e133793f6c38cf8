"""The ``[contact_filter]`` table of a case file: where a contact may begin (simulation.contact_filter).

    [contact_filter]
    rule = "lead"               # the only rule: simulation.contact_filter.LeadFilter
    points = ["O1", "O3"]       # joint points (>= 2) that must lead each other to begin a contact
    direction = [1.0, -0.03, 0.0]   # direction of travel (any length)
    clearance_m = 0.05          # how far ahead [m]
"""

from __future__ import annotations

from ..simulation.contact_filter import LeadFilter
from .keypaths import join
from .reader import _BAD, _Reader
from .text import type_name

#: [contact_filter] key -> what it holds.
FILTER_KEYS = {
    "rule": '"lead": a listed point may begin a contact only where it leads the others',
    "points": "the joint points the rule compares, e.g. [\"O1\", \"O3\"]",
    "direction": "direction of travel (any length)",
    "clearance_m": "how far a point must lead the others, in m",
}


def read_contact_filter(r: _Reader, top: dict, model):
    """The LeadFilter of [contact_filter], None without the table, _BAD on a problem (each named by key path)."""
    if "contact_filter" not in top:
        return None
    ft = r.table(top["contact_filter"], "contact_filter", FILTER_KEYS, "a [contact_filter] table")
    if ft is None:
        return _BAD
    rule = r.get(ft, "contact_filter", "rule", "str", required=True, what=FILTER_KEYS["rule"])
    if rule not in (_BAD, "lead"):
        r.add("contact_filter.rule", f"unknown rule {rule!r}; use \"lead\"")
        rule = _BAD
    direction = r.get(ft, "contact_filter", "direction", "vector3", required=True, what=FILTER_KEYS["direction"])
    clearance = r.get(ft, "contact_filter", "clearance_m", "number", required=True, what=FILTER_KEYS["clearance_m"])
    points = _points(r, ft, model)
    if _BAD in (rule, direction, clearance, points) or model is None or model is _BAD:
        return _BAD
    return LeadFilter(model, points, direction, clearance)


def _points(r: _Reader, ft: dict, model):
    """0-based joint indices of contact_filter.points ("O1" .. "O<n+1>"), _BAD on a problem."""
    path = join("contact_filter", "points")
    raw = ft.get("points")
    if not isinstance(raw, list) or len(raw) < 2 or not all(isinstance(p, str) for p in raw):
        r.add(path, f"expected an array of >= 2 joint names such as [\"O1\", \"O3\"], got {type_name(raw)}")
        return _BAD
    if model is None or model is _BAD:
        return _BAD
    names = [f"O{j + 1}" for j in range(model.n_joints)]
    unknown = [p for p in raw if p not in names]
    if unknown or len(set(raw)) != len(raw):
        r.add(path, f"{raw} must name distinct joint points of this chain: {', '.join(names)}")
        return _BAD
    return [names.index(p) for p in raw]
