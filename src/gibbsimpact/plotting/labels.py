"""Texts of the figures: coordinate names in mathtext, the contacts of an impact, the footnote,
titles and the early-stop status."""

from __future__ import annotations

import re
import textwrap

import numpy as np

from ..simulation.contact_points import describe_point as _point_description


# --------------------------------------------------------------------------
# Labels

def _tex(name: str, dot: bool = False) -> str:
    """Mathtext label of a coordinate name: theta_-1 -> theta_{-1}, delta_1_2 -> delta_{1,2}, d_2 -> d_{2}."""
    if name.startswith("theta_"):
        sym, sub = r"\theta", name[6:]
    elif name.startswith("delta_"):
        sym, sub = r"\delta", name[6:].replace("_", ",")
    elif name.startswith("d_"):
        sym, sub = "d", name[2:]
    else:
        sym, sub = "X", name[1:]
    if dot:
        sym = r"\dot{" + sym + "}"
    return f"${sym}_{{{sub}}}$"


#: Points closer than this, relative to max(1 m, their distance from the origin), are one point of a
#: drawing: the links of a tree leaving one joint, welds at x = 0, two branches ending at one tip.
SAME_POINT = 1e-9


def coincident_groups(P) -> list[list[int]]:
    """The points P (n, 3) or paths P (K, n, 3) [m] that coincide, grouped: points j and k share a group when
    |P_j - P_k| <= SAME_POINT max(1, |P|) at every sample. Returns lists of 0-based indices, ascending, each
    point in exactly one, ordered by their first member (a point alone is a group of one)."""
    P = np.asarray(P, dtype=float)
    P = P[None] if P.ndim == 2 else P
    tol = SAME_POINT * max(1.0, float(np.abs(P).max(initial=0.0)))
    groups, seen = [], set()
    for j in range(P.shape[1]):
        if j not in seen:
            far = np.linalg.norm(P - P[:, j:j + 1], axis=2).max(axis=0)  # (n,) over the samples
            groups.append([k for k in range(j, P.shape[1]) if k not in seen and far[k] <= tol])
            seen.update(groups[-1])
    return groups


def _shared_label(js) -> str:
    """Mathtext label of the coincident points js (1-based, ascending): '$O_{2}$', '$O_{2} = O_{3}$', or
    for three or more consecutive numbers the range '$O_{1}$\u2013$O_{6}$' (short: it sits in a crowd of links),
    else '$O_{2} = O_{5} = O_{7}$'."""
    js = list(js)
    if len(js) > 2 and js == list(range(js[0], js[-1] + 1)):
        return f"$O_{{{js[0]}}}$\u2013$O_{{{js[-1]}}}$"
    return "$" + " = ".join(f"O_{{{j}}}" for j in js) + "$"


def _joint_list(joints, P=None) -> str:
    """'O2+O4' for the joint contacts of one impact; those at one point (P (n, 3) [m], the contact points
    at the impact; coincident_groups) joined by '=' instead: 'O2=O3+O4' (one point touching, not two)."""
    joints = [int(j) for j in joints]
    if P is None or len(joints) < 2:
        return "+".join(f"O{j}" for j in joints)
    groups = coincident_groups(np.asarray(P, dtype=float)[[j - 1 for j in joints]])
    return "+".join("=".join(f"O{joints[k]}" for k in g) for g in groups)


def _is_stop(wall) -> bool:
    """True for an end-stop contact (a prismatic joint at an end of its range: wall index -1)."""
    return int(wall) < 0


def _sample_index(result, time: float) -> int:
    """Index of the first sample at or after ``time`` (an impact time: the state before the impact)."""
    return min(int(np.searchsorted(result.t, time, side="left")), len(result.t) - 1)


def _sample_at(result, time: float) -> np.ndarray:
    """q at the first sample at or after ``time`` (an impact time: the state before the impact)."""
    return result.q[_sample_index(result, time)]


def _stop_label(result, joint: int, q) -> str:
    """'stop i (d_min)' / 'stop i (d_max)' for an end-stop impact of prismatic joint i at q, or
    'stop i' when it is another limit (a carriage at the end of a Pb link's protruding part)."""
    model = result.model
    jt = model.chain.joints[joint - 1] if 1 <= joint <= model.n_links else None
    if jt is None or not jt.spec.prismatic:
        return f"stop {joint}"
    d = float(q[model.theta_index[joint - 1]])
    lo, hi = jt.range
    tol = 1e-3 * (hi - lo)
    if abs(d - lo) <= tol:
        return f"stop {joint} (d_min)"
    if abs(d - hi) <= tol:
        return f"stop {joint} (d_max)"
    return f"stop {joint}"


def _point_name(model, j: int, walls=()) -> str:
    """'O2' for contact point j (1-based) of model.contact_point_names; 'link 1' (or 'link 1.2', its cell 2)
    for a link column (contacts.Contacts: the columns after the P points, contacts.link_column_cells)."""
    from ..simulation.contacts import link_column_cells, link_column_name

    P = model.n_joints
    if j <= P:
        return f"O{j}"
    cells = link_column_cells(model, walls)
    return link_column_name(*cells[j - P - 1]) if j - P - 1 < len(cells) else f"point {j}"


def _point_label(model, j: int, same=()) -> str:
    """Legend label of contact point O_j (1-based): '$O_{3}$ (tip of link 2)'; with ``same`` (the 1-based
    points that coincide with it, j among them) '$O_{1}$\u2013$O_{6}$ (joint 1 on the base)'."""
    return f"{_shared_label(same or (j,))} ({_point_description(model, j)})"


def _contacts_text(result, rec) -> str:
    """The contacts of an impact: 'O2' for a joint point at a wall, 'link 1' for a link's span,
    'stop 2 (d_max)' for an end stop."""
    walls = tuple(rec.wall) if len(rec.wall) == len(rec.joints) else (0,) * len(rec.joints)
    if not any(_is_stop(w) for w in walls) and all(j <= result.model.n_joints for j in rec.joints):
        if len(rec.joints) < 2:
            return _joint_list(rec.joints)
        k = _sample_index(result, rec.time)
        return _joint_list(rec.joints, result.model_at(k).joint_positions(result.q[k]))
    q = _sample_at(result, rec.time)
    return "+".join(_stop_label(result, int(j), q) if _is_stop(w) else _point_name(result.model, int(j), result.walls)
                    for j, w in zip(rec.joints, walls))


def _split_contacts(rec):
    """(wall contacts [(contact point j, normal (3,), where it touched (3,) or None)], end-stop joints [i])
    of an impact record. The point is ImpactRecord.points (None in older files: then O_j)."""
    walls = tuple(rec.wall) if len(rec.wall) == len(rec.joints) else (0,) * len(rec.joints)
    normals = np.asarray(rec.normals, dtype=float).reshape(-1, 3)
    points = getattr(rec, "points", None)
    hits, stops = [], []
    for c, (j, w) in enumerate(zip(rec.joints, walls)):
        if _is_stop(w):
            stops.append(int(j))
        else:
            hits.append((int(j), normals[c] if c < len(normals) else np.zeros(3),
                         None if points is None else np.asarray(points[c], dtype=float)))
    return hits, stops


def _status_line(result, width: int = 150) -> str:
    """'' for a finished run; else the status, the time reached and the message, shortened to
    ``width`` characters (parenthetical remarks dropped first)."""
    if result.status == "finished":
        return ""
    head = f"STOPPED EARLY ({result.status}) at t = {float(result.t[-1]):.6g} s: "
    msg, prev = str(result.message), None
    while msg != prev:  # innermost first, so that nested remarks go whole
        msg, prev = re.sub(r"\s*\([^()]*\)", "", msg), msg
    return head + textwrap.shorten(msg, max(20, width - len(head)), placeholder=" ...")


def _title(result, what, case_name=None, width_in: float = 9.5):
    """Figure title; a run that stopped early gets its status below, wrapped to the figure width."""
    title = f"{case_name}: {what}" if case_name else what
    per_line = int(12.5 * width_in)  # characters of a 10 pt line
    status = _status_line(result, width=2 * per_line)
    lines = textwrap.wrap(status, per_line)
    if len(lines) > 2:
        lines = [lines[0], textwrap.shorten(" ".join(lines[1:]), per_line, placeholder=" ...")]
    return "\n".join(textwrap.wrap(title, int(1.1 * per_line)) + lines)


def _wrap_note(note: str, width_in: float, fontsize: float = 7.0) -> str:
    """``note`` broken into lines that fit a figure ``width_in`` inches wide (0.55 em per character:
    textwrap, not matplotlib's wrap=True, which renders the text word by word to measure it)."""
    return "\n".join(textwrap.wrap(note, max(40, int(width_in * 72.0 / (0.55 * fontsize)))))


def _status_box(ax, result):
    """The early-stop status in a red box in the top left corner of ``ax`` (drawing into given axes)."""
    status = _status_line(result, width=90)
    if status:
        text = "\n".join(textwrap.wrap(status, 60))
        put = ax.text2D if ax.name == "3d" else ax.text
        put(0.01, 0.99, text, transform=ax.transAxes, fontsize=7, color="darkred", va="top", ha="left", zorder=20,
            bbox={"boxstyle": "round", "fc": "#fde0dc", "ec": "darkred", "alpha": 0.9})
