"""A user callback that fails mid-run (an input that raises or returns NaN, a progress callable that raises)
ends the run with status "callback_failed", a message naming the callback, the coordinate and the time,
and the Result of everything computed until then: the same samples, to the bit, as a run whose
callback does not fail."""

import importlib

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.forces import CallbackError
from gibbsimpact.simulation.progress import Clock

from conftest import two_link_circle_model, two_link_circle_state

gsim = importlib.import_module("gibbsimpact.simulation.simulate")
T_FAIL = 0.05  # s
WALLS = [gi.Circle(1.5)]


def torque(t, q, qd):
    return 0.3 * np.sin(7.0 * t)


def run(inputs, t_end=0.12, **kw):
    model = two_link_circle_model()
    q0, qd0 = two_link_circle_state(model)
    return gi.simulate(model, q0, qd0, (0.0, t_end), walls=WALLS, inputs=inputs, **kw)


def assert_prefix(res, full):
    """The failed run's samples are the full run's first ones, and it stopped at its last accepted step."""
    k = res.t.size
    assert 1 < k < full.t.size
    assert np.array_equal(res.t, full.t[:k]) and np.array_equal(res.q, full.q[:k])
    assert np.array_equal(res.qdot, full.qdot[:k])
    assert res.t[-1] <= T_FAIL < full.t[k]  # the step that reached past T_FAIL was not accepted


@pytest.mark.parametrize("failure", ["raises", "nan"])
def test_a_named_input_that_fails_mid_run_keeps_the_trajectory(failure):
    def bad(t, q, qd):
        if t > T_FAIL:
            if failure == "raises":
                raise RuntimeError("motor driver offline")
            return float("nan")
        return torque(t, q, qd)

    full = run({"theta_2": torque})
    res = run({"theta_2": bad})
    assert full.status == "finished"
    assert res.status == "callback_failed"
    assert "inputs['theta_2'] (on theta_2) failed at t = " in res.message
    t_fail = float(res.message.split("failed at t = ")[1].split(" s")[0])
    # A trial time of the first step past T_FAIL (printed to 9 significant digits).
    assert T_FAIL < t_fail <= full.t[res.t.size] * (1 + 1e-9)
    assert ("RuntimeError('motor driver offline')" if failure == "raises" else "returned nan") in res.message
    assert "the results up to t = " in res.message
    assert_prefix(res, full)


def test_a_vector_input_that_returns_nan_names_the_coordinate():
    model = two_link_circle_model()
    k = model.coordinate_names.index("theta_1")

    def Q(t, q, qd):
        out = np.zeros(model.n_dof)
        out[k] = np.nan if t > T_FAIL else torque(t, q, qd)
        return out

    def Q_ok(t, q, qd):
        out = np.zeros(model.n_dof)
        out[k] = torque(t, q, qd)
        return out

    full, res = run(Q_ok), run(Q)
    assert res.status == "callback_failed"
    assert "inputs(t, q, qdot) (on theta_1) failed at t = " in res.message and "returned nan" in res.message
    assert_prefix(res, full)


def test_a_progress_callable_that_raises_stops_the_run(monkeypatch):
    monkeypatch.setattr(gsim, "Clock", lambda progress: Clock(progress, every=0.0))
    calls = []

    def progress(t, n_impacts):
        calls.append(t)
        if t > T_FAIL:
            raise OSError("the notebook's widget is gone")

    full = run({"theta_2": torque})
    res = run({"theta_2": torque}, progress=progress)
    assert res.status == "callback_failed"
    assert res.message.startswith("progress failed at t = ") and "OSError" in res.message
    assert_prefix(res, full)


def test_a_failure_at_the_initial_state_is_still_bad_input():
    # Called once at t0 before the run starts: a ValueError naming the input (nothing simulated).
    with pytest.raises(ValueError, match=r"inputs\['theta_2'\] failed when called at the initial state"):
        run({"theta_2": lambda t, q, qd: 1 / 0})


def test_callback_error_names_what_failed():
    e = CallbackError("inputs['d_2']", "d_2", 0.25, "returned inf")
    assert str(e) == "inputs['d_2'] (on d_2) failed at t = 0.25 s: returned inf"
    assert (e.callback, e.coordinate, e.t, e.cause) == ("inputs['d_2']", "d_2", 0.25, "returned inf")
