"""Reading values and collecting problems (gibbsimpact.case.reader): every kind of bad value gives its
own message with the key path; several problems come in one CaseError."""

from __future__ import annotations

import math

import pytest

import gibbsimpact as gi
from gibbsimpact.case import CaseError, case_from_dict
from case_texts import GOOD, write, problems_of


def test_unknown_key_names_path_and_suggestion(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("length_m = 1.0", "length_m = 1.0\nlenght_m = 2.0"))
    assert err.problems == [("links[1].lenght_m", "unknown key (did you mean 'length_m'?)")]
    assert "links[1].lenght_m: unknown key" in str(err)


def test_missing_key(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("EI_N_m2 = 20.0\n", ""))
    assert len(err.problems) == 1
    path, msg = err.problems[0]
    assert path == "links[1].EI_N_m2" and msg.startswith("missing")


def test_missing_sections(tmp_path):
    text = GOOD.split("[[links]]")[0].replace("gravity_m_per_s2 = [0.0, -9.81, 0.0]\n", "")
    err = problems_of(tmp_path, text)
    paths = [p for p, _ in err.problems]
    assert paths == ["gravity_m_per_s2", "links", "time"]


def test_wrong_type(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("length_m = 1.0", 'length_m = "1.0"'))
    assert err.problems == [("links[1].length_m", "expected a number, got the string '1.0'")]


def test_wrong_type_vector_and_bool(tmp_path):
    text = GOOD.replace("gravity_m_per_s2 = [0.0, -9.81, 0.0]", "gravity_m_per_s2 = [0.0, -9.81]")
    text = text.replace("restitution = 1.0", "restitution = true")
    err = problems_of(tmp_path, text)
    assert ("gravity_m_per_s2", "expected an array of 3 numbers, got an array of 2") in err.problems
    assert ("restitution", "expected a number, got the boolean true") in err.problems


def test_negative_length(tmp_path):
    err = problems_of(tmp_path, GOOD.replace("length_m = 1.0", "length_m = -1.0"))
    assert err.problems == [("links[1].length_m", "must be in [1e-6, 1e6] m (a micrometre to 1000 km), got -1")]


def test_several_problems_in_one_error(tmp_path):
    text = GOOD.replace("length_m = 1.0", "length_m = -1.0")
    text = text.replace("radius_m = 1.5", "radius_m = 1.5\ncolor = 'grey'")
    text = text.replace("t_end_s = 0.1", 't_end_s = "soon"')
    text = text.replace("EI_N_m2 = 20.0\n", "")
    err = problems_of(tmp_path, text)
    paths = [p for p, _ in err.problems]
    assert paths == ["links[1].length_m", "links[1].EI_N_m2", "walls[1].color", "time.t_end_s"]
    first = str(err).splitlines()[0]
    assert first.endswith("case.toml: 4 problems:")
    assert len(str(err).splitlines()) == 5


def test_invalid_toml_and_missing_file(tmp_path):
    err = problems_of(tmp_path, "name = \n")
    assert "not valid TOML" in str(err)
    with pytest.raises(FileNotFoundError):
        gi.load_case(tmp_path / "nope.toml")


def test_a_result_file_given_as_a_case_names_what_it_is(tmp_path):
    # `gibbsimpact show result.npz` said "not UTF-8 text": name the file's kind and the way to read it.
    import numpy as np

    np.savez(tmp_path / "result.npz", t=np.zeros(2))
    with pytest.raises(CaseError, match=r"a result file \(NPZ archive\), not a case file: .*gibbsimpact.load_result"):
        gi.load_case(tmp_path / "result.npz")


def test_case_error_is_value_error():
    assert issubclass(CaseError, ValueError)
    with pytest.raises(ValueError):
        case_from_dict({"links": 3})


def test_integers_beyond_the_double_range_are_too_large(tmp_path):
    huge = "1" + "0" * 400
    text = GOOD.replace("length_m = 1.0", f"length_m = {huge}").replace("[0.0, -9.81, 0.0]", f"[0.0, -{huge}, 0.0]")
    text = text.replace('direction = "y"', f'direction = "y", number = {huge}')
    d = dict(problems_of(tmp_path, text).problems)
    assert d["links[1].length_m"] == ("too large for a number: must be in [1e-6, 1e6] m (a micrometre to 1000 km), "
                                      "got 1e400")
    assert d["gravity_m_per_s2"].startswith("too large for a number: must be in [-1e4, 1e4] m/s^2")
    assert d["links[1].modes[1].number"].startswith("too large for a number: must be in [1, 50]")


def test_nan_and_inf(tmp_path):
    text = GOOD.replace("length_m = 1.0", "length_m = nan").replace("t_end_s = 0.1", "t_end_s = inf")
    d = dict(problems_of(tmp_path, text).problems)
    assert d["links[1].length_m"].endswith("got nan") and d["time.t_end_s"].endswith("got inf")
    case = gi.load_case(write(tmp_path, GOOD + "\n[solver]\nmax_step_s = inf\n"))
    assert case.solver["max_step"] == math.inf  # no limit: the one key where inf is a value
