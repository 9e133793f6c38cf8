"""A case file into a Case (gibbsimpact.case.builders): the published cases, walls, inputs, and
problems reported once, at the key to change."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

from gibbsimpact.case import CaseError, case_from_dict
from gibbsimpact.case.keypaths import within
from gibbsimpact.model.elements import MAX_ELEMENTS

CASES = Path(__file__).resolve().parents[2] / "cases"
CASE_FILES = sorted(CASES.glob("*.toml"))


# -- problems that stand on their own (issue 23 item 11) -------------------------------------

def every_coordinate(data: dict) -> dict:
    """data with every coordinate and rate of its model in [initial.coordinates] / [initial.velocities],
    each in the model's own unit (an FE node slope in rad), so that every key there is checked."""
    case = case_from_dict(data)
    m, init = case.model, data.setdefault("initial", {})
    for table, values, suffix, com in (("coordinates", case.q0, "", "center_of_mass_m"),
                                       ("velocities", case.qdot0, "_per_s", "center_of_mass_velocity_m_per_s")):
        init[table] = {f"{n}_{u}{suffix}": float(v) for n, u, v in zip(m.coordinate_names, m.coordinate_units, values)
                       if not (com in init and n in ("X1", "X2", "X3"))}
    case_from_dict(data)  # still a valid case
    return data


def _setter(k, *keys, value=None, delete=False):
    """An edit of data['links'][k][keys...] (k None: of data[keys...]) that sets value or deletes the key."""
    def edit(data):
        node = data if k is None else data["links"][k]
        for key in keys[:-1]:
            node = node.setdefault(key, {})
        if delete:
            del node[keys[-1]]
        else:
            node[keys[-1]] = value
    return edit


def wrong_keys(data: dict) -> dict:
    """{kind: [(key path, edit)]}: one wrong key each, of the kinds that keep the chain from being
    built: elements, EI_N_m2, a joint's type or range, a missing base.type."""
    out = {"elements": [], "EI_N_m2": [], "joint.type": [], "joint.range_m": [], "base.type": []}
    for k, link in enumerate(data["links"]):
        p = f"links[{k + 1}]"
        for v in (-1, MAX_ELEMENTS + 1, 2.5, "4", True) + ((2,) if "modes" in link else ()):  # 2: with modes
            out["elements"].append((f"{p}.elements", _setter(k, "elements", value=v)))
        for v in (-1.0, 0.0, 1e16, "stiff", [1.0], [20.0, -1.0]):
            out["EI_N_m2"].append((f"{p}.EI_N_m2", _setter(k, "EI_N_m2", value=v)))
        out["EI_N_m2"].append((f"{p}.EI_N_m2", _setter(k, "EI_N_m2", delete=True)))
        for v in ("P", "pb", "X", 1, ""):
            out["joint.type"].append((f"{p}.joint.type", _setter(k, "joint", "type", value=v)))
        joint = link.get("joint", {"type": "R"})
        if joint["type"] == "R":  # a revolute joint has no range
            out["joint.range_m"].append((f"{p}.joint.range_m", _setter(k, "joint", value={"type": "R", "range_m": [0.1, 0.2]})))
            continue
        lo, hi = joint["range_m"]
        for v in ([hi, lo], [lo], "far", [lo, 100.0], [0.0 if joint["type"] == "Pb" else -1.0, hi]):
            out["joint.range_m"].append((f"{p}.joint.range_m", _setter(k, "joint", "range_m", value=v)))
        out["joint.range_m"].append((f"{p}.joint.range_m", _setter(k, "joint", "range_m", delete=True)))
    if "type" in data.get("base", {}):
        out["base.type"].append(("base.type", _setter(None, "base", "type", delete=True)))
    else:  # a [base] table without its type
        out["base.type"].append(("base.type", _setter(None, "base", value={"position_m": [0.0, 0.0]})))
    return out


def malformed(path: Path, n: int = 40, seed: int = 23) -> list:
    """n (key path, case table) of path's case, each with one wrong key, drawn with a fixed seed:
    a kind, then a key and value of that kind."""
    good = every_coordinate(tomllib.loads(path.read_text()))
    kinds = wrong_keys(good)
    rng = np.random.default_rng(seed)
    out = []
    for kind in rng.choice(sorted(kinds), size=n):
        key, edit = kinds[kind][rng.integers(len(kinds[kind]))]
        bad = copy.deepcopy(good)
        edit(bad)
        out.append((key, bad))
    return out


@pytest.mark.parametrize("path", CASE_FILES, ids=[p.stem for p in CASE_FILES])
def test_a_link_that_cannot_be_built_blames_no_correct_key(path):
    # Every problem names the wrong key or a key within it; none blames a correct key for the
    # wrong one (e.g. "delta_1_2 takes unit m, not rad" for a correct slope of an FE link).
    blamed = []
    for key, bad in malformed(path):
        with pytest.raises(CaseError) as info:
            case_from_dict(bad)
        problems = info.value.problems
        assert any(p == key for p, _ in problems), (key, problems)
        blamed += [(key, p, m) for p, m in problems if not within(p, key)]
    assert not blamed, "\n".join(f"{key} wrong, blamed {p}: {m}" for key, p, m in blamed[:10])
