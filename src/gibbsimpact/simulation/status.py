"""How a run ends: every status of a Result and every stop message, in one table each.

A run ends for one *reason* (a key of :data:`STOPS`); the reason gives the Result's ``status``
and the message template that the loop fills in with the values it knows at the stop
(times in s, depths in m). The command line maps the statuses to exit codes
(``finished`` 0, ``interrupted`` 130, every other one 3); sweeps add their own
row statuses (gibbsimpact.study.sweep) for runs that never ran.
"""

from __future__ import annotations

STATUS_FINISHED = "finished"
STATUS_ZENO = "zeno"
STATUS_MAX_IMPACTS = "max_impacts"
STATUS_PENETRATION = "penetration"
STATUS_FAILED = "failed"
STATUS_JOINT_LIMIT = "joint_limit"
STATUS_INTERRUPTED = "interrupted"
STATUS_CALLBACK_FAILED = "callback_failed"
STATUS_BUDGET_EXCEEDED = "budget_exceeded"

#: Every status of a Result and what it means.
STATUSES = {
    STATUS_FINISHED: "reached t_span[1]",
    STATUS_ZENO: "an accumulation of impacts that resting contact could not resolve; stopped there",
    STATUS_MAX_IMPACTS: "the impact budget max_impacts was used up",
    STATUS_PENETRATION: "a contact point was found beyond a wall (or a joint limit) between events",
    STATUS_FAILED: "the dynamics could not go on (singular M, non-finite state, solver failure, stalled loop)",
    STATUS_JOINT_LIMIT: "a prismatic joint reached an end of its range (joint_limit='stop'), or its end-stop "
                        "impacts accumulated",
    STATUS_INTERRUPTED: "a KeyboardInterrupt (Ctrl-C, or SIGTERM in the command line) stopped the run",
    STATUS_CALLBACK_FAILED: "a function the user gave (an input, the progress callback) raised or returned a "
                            "non-finite value",
    STATUS_BUDGET_EXCEEDED: "the run used up a limit it was given (max_cpu_time, max_rhs_calls) before t_span[1]",
}

#: Why a run stopped: reason -> (status, message template). The templates' fields are the
#: values the loop passes to :func:`stop` (t: the time of the stop [s]).
STOPS = {
    "t_end": (STATUS_FINISHED, "reached t_end = {t_end:g} s"),
    "max_impacts": (STATUS_MAX_IMPACTS, "stopped after max_impacts = {max_impacts} impacts at t = {t:.9g} s"),
    "zeno": (STATUS_ZENO, "{accumulation}; stopped ({why}); results up to here are kept"),
    "integration": (STATUS_FAILED, "integration failed after t = {t:.9g} s: {error}"),
    "solver": (STATUS_FAILED, "the ODE solver failed after t = {t:.9g} s: {error}{singular}"),
    "penetration": (STATUS_PENETRATION, "a contact point went {depth:.3g} m beyond {what} between events in the "
                                        "phase starting at t = {t:.9g} s without an event firing; tighten rtol or "
                                        "set max_step"),
    "held_contact": (STATUS_FAILED, "impact at t = {t:.9g} s cannot be solved: {error}; results up to there are "
                                    "kept (prescribe fewer coordinates, or move the wall)"),
    "non_finite": (STATUS_FAILED, "state became non-finite at t = {t:.9g} s"),
    "stalled": (STATUS_FAILED, "event loop stalled at t = {t:.9g} s: {count} consecutive events without progress "
                               "in time"),
    "mode_events": (STATUS_FAILED, "stopped after {count} contact-mode events (release, slip, stick, drift) at "
                                   "t = {t:.9g} s: the resting contacts do not settle"),
    "joint_limit": (STATUS_JOINT_LIMIT, "joint {joint} reached its limit {limit} at t = {t:.9g} s; results up to "
                                        "there are kept (simulate(..., joint_limit='impact') bounces instead)"),
    "end_stop_accumulation": (STATUS_JOINT_LIMIT, "{accumulation}"),
    "interrupted": (STATUS_INTERRUPTED, "stopped by {what} at t = {t:.9g} s of t_end = {t_end:g} s; the results "
                                        "up to there are kept"),
    "callback": (STATUS_CALLBACK_FAILED, "{error}; the results up to t = {t:.9g} s are kept"),
    "budget": (STATUS_BUDGET_EXCEEDED, "{error}; stopped at t = {t:.9g} s of t_end = {t_end:g} s, the results up "
                                       "to there are kept (a stiff chain: method='Radau', or a larger limit)"),
}


def stop(reason: str, **values) -> tuple[str, str]:
    """(status, message) of a run that stops for ``reason`` (a key of STOPS), the template filled with values."""
    status, template = STOPS[reason]
    return status, template.format(**values)
