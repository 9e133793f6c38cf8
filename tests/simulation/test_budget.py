"""A run with a limit (simulate's max_rhs_calls, max_cpu_time) that uses it up ends with status "budget_exceeded"
and keeps what it computed: the same samples, to the bit, as the first ones of a run without a limit."""

import copy
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.case import case_from_dict
from gibbsimpact.simulation.budget import CPU_EVERY, Budget, BudgetExceeded
from gibbsimpact.simulation.status import STATUSES, STOPS

from conftest import two_link_circle_model, two_link_circle_state
from conftest import TIGHT_DOP853

CASES = Path(__file__).resolve().parents[2] / "cases"
WALLS = [gi.Circle(1.5)]


def run(t_end=2.0, **kw):
    model = two_link_circle_model()
    q0, qd0 = two_link_circle_state(model)
    return gi.simulate(model, q0, qd0, (0.0, t_end), walls=WALLS, **kw)


@pytest.fixture(scope="module")
def full():
    run(t_end=1e-3)  # the kernels loaded before anything is timed
    start = time.thread_time()
    res = run()
    res.cpu = time.thread_time() - start
    assert res.status == "finished" and res.impacts  # the limits below cut it after an impact
    assert res.nfev > 10 * CPU_EVERY  # the CPU clock is read many times in a run
    return res


def assert_prefix(res, full):
    """The stopped run's samples are the full run's first ones, ending before t_end."""
    k = res.t.size
    assert 1 < k < full.t.size
    assert np.array_equal(res.t, full.t[:k]) and np.array_equal(res.q, full.q[:k])
    assert np.array_equal(res.qdot, full.qdot[:k])
    assert res.t[-1] < full.t[-1]
    assert [i.time for i in res.impacts] == [i.time for i in full.impacts[:len(res.impacts)]]


def test_a_run_over_its_rhs_limit_keeps_its_samples(full):
    limit = int(0.6 * full.nfev)
    res = run(max_rhs_calls=limit)
    assert res.status == "budget_exceeded" and res.status in STATUSES
    assert res.nfev == limit  # the call that found the limit used up was not made
    assert f"max_rhs_calls = {limit} right-hand sides" in res.message
    assert f"stopped at t = {res.t[-1]:.9g} s of t_end = 2 s" in res.message
    assert res.settings["max_rhs_calls"] == limit and res.settings["max_cpu_time"] is None
    assert_prefix(res, full)
    assert len(res.impacts) >= 1


def test_a_run_over_its_cpu_limit_keeps_its_samples(full):
    limit = round(full.cpu / 3, 3)  # s
    start = time.thread_time()
    res = run(max_cpu_time=limit)
    used = time.thread_time() - start
    assert res.status == "budget_exceeded"
    assert f"max_cpu_time = {limit:g} s of CPU" in res.message
    used_by_loop = float(res.message.split("s of CPU (")[1].split(" s used")[0])
    assert limit <= used_by_loop <= used
    assert_prefix(res, full)


def test_a_limit_reached_in_the_solvers_first_call():
    """max_rhs_calls = 1: the solver's set-up (its first step-size guess) already finds the budget used up."""
    res = run(max_rhs_calls=1)
    assert res.status == "budget_exceeded" and res.nfev == 1
    assert res.t.tolist() == [0.0]


def test_no_limit_costs_one_comparison_per_call(full):
    """Without a limit the right-hand side compares its count with sys.maxsize and never checks again."""
    assert Budget().check_at == sys.maxsize
    assert Budget(max_cpu_time=1.0).check_at == CPU_EVERY
    assert Budget(max_rhs_calls=7, max_cpu_time=1.0).check_at == 7
    res = run(max_rhs_calls=10 * full.nfev, max_cpu_time=1e6)
    assert res.status == "finished" and np.array_equal(res.q, full.q) and res.nfev == full.nfev


def test_budget_check_raises_at_the_limit():
    b = Budget(max_rhs_calls=5)
    with pytest.raises(BudgetExceeded) as info:
        b.check(5, 0.25)
    assert (info.value.limit, info.value.value, info.value.t) == ("max_rhs_calls", 5, 0.25)
    assert STOPS["budget"][0] == "budget_exceeded"


@pytest.mark.parametrize("kw, bad", [({"max_rhs_calls": 0}, "max_rhs_calls=0 must be an integer >= 1"),
                                     ({"max_rhs_calls": 2.5}, "max_rhs_calls=2.5 must be an integer >= 1"),
                                     ({"max_rhs_calls": True}, "max_rhs_calls=True must be an integer >= 1"),
                                     ({"max_cpu_time": 0.0}, "max_cpu_time=0.0 must be a positive number"),
                                     ({"max_cpu_time": float("nan")}, "max_cpu_time=nan must be a positive number")])
def test_bad_limits_are_named(kw, bad):
    with pytest.raises(ValueError, match=bad.replace("(", r"\(").replace(".", r"\.")):
        run(**kw)


def test_a_stiff_chain_with_a_servo_is_not_a_failed_callback():
    """Link 1 of the R-Pb arm 4e7 times stiffer: DOP853's first trial steps overshoot to a non-finite state,
    where the slide's PD servo returns NaN. That is the step's failure (the solver rejects it and shrinks
    the step), not the servo's: the run goes on to t_end."""
    case = gi.load_case(CASES / "fixed_base_R_Pb_arm.toml")
    data = copy.deepcopy(case.source)
    data["links"][0]["EI_N_m2"] = 1e9
    res = case_from_dict(data, name="stiff").simulate(t_end=2e-4, **TIGHT_DOP853)
    assert res.status == "finished", res.message
