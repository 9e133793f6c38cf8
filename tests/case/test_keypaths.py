"""Key paths: one grammar for the reader's messages and for sweeps (gibbsimpact.case.keypaths).

The reader spells every problem's key path with keypaths.join; a sweep reads key paths with
keypaths.resolve. The round trip below holds the two to each other on the published cases."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest

from gibbsimpact.case import CaseError, case_from_dict
from gibbsimpact.case.keypaths import PathProblem, assign, join, key_path, resolve, schema_key, split, within

CASES = Path(__file__).resolve().parents[2] / "cases"
PA_ARM = tomllib.loads((CASES / "fixed_base_R_Pa_arm.toml").read_text())


@pytest.mark.parametrize("path,tokens", [
    ("restitution", ["restitution"]),
    ("time.t_end_s", ["time", "t_end_s"]),
    ("links[2].EI_N_m2", ["links", 1, "EI_N_m2"]),
    ("links[1].modes[2].kind", ["links", 0, "modes", 1, "kind"]),
    ("initial.coordinates.theta_-1_deg", ["initial", "coordinates", "theta_-1_deg"]),
])
def test_split_and_key_path_are_inverse(path, tokens):
    assert split(path) == tokens
    assert key_path(*tokens) == path
    assert join(key_path(*tokens[:-1]), tokens[-1]) == path


def test_the_shell_form_resolves_to_the_bracket_form():
    assert split("links.2.EI_N_m2") == ["links", "2", "EI_N_m2"]  # an entry only where the case has an array
    assert resolve(PA_ARM, "links.2.EI_N_m2") == resolve(PA_ARM, "links[2].EI_N_m2") == (
        "links[2].EI_N_m2", ("links", 1, "EI_N_m2"))
    assert resolve(PA_ARM, "links.2.joint.range_m") == ("links[2].joint.range_m", ("links", 1, "joint", "range_m"))
    # A missing table on the way is allowed: assign creates it.
    path, tokens = resolve(PA_ARM, "output.dpi")
    data = copy.deepcopy(PA_ARM)
    del data["output"]
    assign(data, tokens, 300)
    assert path == "output.dpi" and data["output"] == {"dpi": 300}


@pytest.mark.parametrize("key,path,message", [
    ("", "", "a key path is a non-empty string"),
    ("links..EI_N_m2", "links..EI_N_m2", "not a key path"),
    ("links[1", "links[1", "not a key path"),
    ("links[3].EI_N_m2", "links[3]", "no such entry: the case has 2 links (numbered from 1)"),
    ("links[0].EI_N_m2", "links[0]", "no such entry"),
    ("links.EI_N_m2", "links", "is an array of 2 tables; give the entry number from 1, e.g. links[1].EI_N_m2"),
    ("time[1].t_end_s", "time[1]", "time is a table, not an array of tables"),
    ("walls[1].radius_m", "walls", "no such array of tables in the case"),
    ("restitution.x", "restitution", "is the number 0.5, not a table: nothing to set below it"),
])
def test_paths_that_name_no_value(key, path, message):
    data = {**PA_ARM, "restitution": 0.5}
    with pytest.raises(PathProblem) as info:
        resolve(data, key)
    assert info.value.path == path and message in info.value.message, info.value


def test_schema_key_and_within():
    assert schema_key("links[2].modes[1].number") == "links.modes.number"
    assert within("links[1].EI_N_m2", "links[1]") and within("links[1].modes[2]", "links[1].modes")
    assert within("links[1]", "links[1]") and not within("links[12].EI_N_m2", "links[1]")


# Keys of the R-Pa arm that the reader refuses, one at a time: (key path, value); None deletes it.
WRONG = [
    ("restitution", 2.0), ("links[2].EI_N_m2", "stiff"), ("links[1].elements", -1),
    ("links[2].joint.range_m", [0.9, 0.1]), ("links[2].joint.type", "P"), ("links[2].joint.angle_deg", True),
    ("inputs[3].stiffness_N_per_m", -1.0), ("initial.coordinates.d_2_m", 5.0), ("solver.rtol", 1.0),
    ("time.t_end_s", None), ("base.type", None), ("links[1].lenght_m", 1.0),
]


@pytest.mark.parametrize("key,value", WRONG, ids=[k for k, _ in WRONG])
def test_every_path_the_reader_reports_resolves_to_the_key_changed(key, value):
    # The reader writes the path (keypaths.join); resolve reads it back to the very key edited.
    data = copy.deepcopy(PA_ARM)
    _, tokens = resolve(data, key)
    if value is None:
        node = data
        for tok in tokens[:-1]:
            node = node[tok]
        del node[tokens[-1]]
    else:
        assign(data, tokens, value)
    with pytest.raises(CaseError) as info:
        case_from_dict(data)
    paths = [p for p, _ in info.value.problems]
    assert key in paths, info.value.problems
    assert all(resolve(data, p)[1][: len(tokens)] == tokens for p in paths if within(p, key))
    assert resolve(data, key.replace("[", ".").replace("]", "")) == resolve(data, key)  # the shell form
