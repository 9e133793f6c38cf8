"""[time], [solver], [output] and the keywords of Case.simulate that override them
(gibbsimpact.case.run_options): the same ranges and rules for both."""

from __future__ import annotations


import pytest

import gibbsimpact as gi
from gibbsimpact.case import CaseError
from case_texts import GOOD, write, problems_of, DROP


def test_ranges_and_choices(tmp_path):
    text = GOOD.replace("restitution = 1.0", "restitution = 1.5")
    text = text.replace('type = "circle"', 'type = "ellipse"')
    text = text.replace("t_end_s = 0.1", "t_start_s = 0.2\nt_end_s = 0.1")
    text += '\n[solver]\nmethod = "Euler"\nrtol = -1e-8\nzeno_count = 2.5\n'
    err = problems_of(tmp_path, text)
    d = dict(err.problems)
    assert d["restitution"] == "must be in [0, 1] (1 = elastic, 0 = plastic), got 1.5"
    assert d["walls[1].type"].startswith("unknown wall type 'ellipse'")
    assert d["time.t_end_s"] == "must be after t_start_s = 0.2 s, got 0.1"
    assert d["solver.method"].startswith("unknown method 'Euler'")
    assert d["solver.rtol"] == "must be in [1e-13, 0.1] (solve_ivp cannot go below 2.2e-14), got -1e-8"
    assert d["solver.zeno_count"] == "expected an integer, got the number 2.5"


@pytest.mark.parametrize("key,kw", [("output_dt_s", "output_dt"), ("max_step_s", "max_step")])
def test_at_most_1e7_samples_or_steps(tmp_path, key, kw):
    # t_end_s = 0.1 s: 1e7 intervals of 1e-8 s.
    case = gi.load_case(write(tmp_path, GOOD + f"\n[solver]\n{key} = 1e-8\n"))
    assert case.solver[kw] == 1e-8
    err = problems_of(tmp_path, GOOD + f"\n[solver]\n{key} = 0.99e-8\n")
    (path, msg), = err.problems
    assert path == f"solver.{key}"
    assert msg.startswith(f"(time.t_end_s - time.t_start_s) / solver.{key} = 0.1 s / 9.9e-9 s = 1.0101e7 ")
    assert msg.endswith(f"make solver.{key} at least 1e-8 s or shorten the time span")


def test_simulate_overrides_are_held_to_the_ranges(tmp_path):
    case = gi.load_case(write(tmp_path, GOOD))
    with pytest.raises(CaseError) as info:
        case.simulate(t_end=-1.0, rtol=1.0, method="Euler")
    d = dict(info.value.problems)
    assert set(d) == {"t_end", "rtol", "method"}
    assert d["rtol"] == "must be in [1e-13, 0.1] (solve_ivp cannot go below 2.2e-14), got 1"
    assert d["t_end"] == "must be after time.t_start_s = 0 s, got -1"
    with pytest.raises(CaseError) as info:
        case.simulate_kwargs(output_dt=1e-12)
    (path, msg), = info.value.problems
    assert path == "output_dt" and msg.startswith("(time.t_end_s - time.t_start_s) / output_dt = 0.1 s / 1e-12 s")
    assert case.simulate_kwargs(t_end=0.5, output_dt=None)["output_dt"] is None


def test_boolean_solver_keys_can_be_overridden(tmp_path):
    # link_contacts is the one boolean [solver] key: overriding it used to raise KeyError.
    case = gi.load_case(write(tmp_path, GOOD))
    assert case.simulate_kwargs(link_contacts=False)["link_contacts"] is False
    with pytest.raises(CaseError) as info:
        case.simulate_kwargs(link_contacts="no")
    assert dict(info.value.problems) == {"link_contacts": "expected true or false, got the string 'no'"}


def test_joint_limit_solver_keys(tmp_path):
    from gibbsimpact.case.schema import _SOLVER_CHOICES
    from gibbsimpact.simulation.joint_limits import JOINT_LIMIT_MODES

    assert tuple(_SOLVER_CHOICES["joint_limit"]) == JOINT_LIMIT_MODES
    case = gi.load_case(write(tmp_path, DROP + '\n[solver]\njoint_limit = "impact"\njoint_restitution = 1.0\n'))
    assert case.solver == {"joint_limit": "impact", "joint_restitution": 1.0}
    kw = case.simulate_kwargs(joint_limit="stop")
    assert kw["joint_limit"] == "stop" and kw["joint_restitution"] == 1.0
    d = dict(problems_of(tmp_path, DROP + '\n[solver]\njoint_limit = "bounce"\njoint_restitution = 1.5\n').problems)
    assert d["solver.joint_limit"] == ("unknown value 'bounce'; use 'stop' (end the run with status joint_limit) or "
                                       "'impact' (an end-stop impact)")
    assert d["solver.joint_restitution"] == "must be in [0, 1] (1 = elastic, 0 = plastic), got 1.5"
    problems = dict(case.override_problems(joint_limit="bounce", joint_restitution=2.0))
    assert problems["joint_limit"].startswith("unknown value 'bounce'")
    assert problems["joint_restitution"].startswith("must be in [0, 1]")
    with pytest.raises(CaseError, match="joint_limit: unknown value 'bounce'"):
        case.simulate_kwargs(joint_limit="bounce")


def test_limit_solver_keys(tmp_path):
    """[solver] max_cpu_time_s and max_rhs_calls: simulate's limits, held to their ranges, overridable."""
    case = gi.load_case(write(tmp_path, GOOD + "\n[solver]\nmax_cpu_time_s = 60.0\nmax_rhs_calls = 500\n"))
    assert case.solver == {"max_cpu_time": 60.0, "max_rhs_calls": 500}
    assert case.simulate_kwargs(max_rhs_calls=10)["max_rhs_calls"] == 10
    assert case.simulate(max_rhs_calls=10).status == "budget_exceeded"
    d = dict(problems_of(tmp_path, GOOD + "\n[solver]\nmax_cpu_time_s = 0.0\nmax_rhs_calls = 2.5\n").problems)
    assert d["solver.max_cpu_time_s"] == "must be in [0.001, 1e9] s (a millisecond to about 30 years), got 0"
    assert d["solver.max_rhs_calls"] == "expected an integer, got the number 2.5"
