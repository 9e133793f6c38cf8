"""The limits of one run (simulate's ``max_cpu_time``, ``max_rhs_calls``), checked from its right-hand side.

The right-hand side is where a run spends its time, so that is where the limits are checked:
each call compares its count with one integer (``check_at``); only at that count does
:meth:`Budget.check` look at the count limit and, every :data:`CPU_EVERY` calls, the CPU clock.
A run over a limit raises :class:`BudgetExceeded` inside the right-hand side; the flight phase
keeps its accepted steps (as for a failed user callback) and the run ends with status
``budget_exceeded``.

CPU time is ``time.thread_time()`` of the thread running the run, from the run's start (after
its initial checks, so a first-use compilation of the kernel is not counted): one run is
single-threaded, and a thread of a dask worker running another run beside it is not charged
to this one, as the process's clock would. A run stops at most CPU_EVERY right-hand sides
past its CPU limit (about 3-20 ms on the bundled cases).
"""

from __future__ import annotations

import sys
import time

#: Right-hand sides between two readings of the CPU clock.
CPU_EVERY = 256


class BudgetExceeded(Exception):
    """A run used up one of its limits.

    limit : the argument of simulate (``max_cpu_time`` or ``max_rhs_calls``); value : its value
    used : what the run used (CPU seconds, or right-hand sides); t : float [s], the time of the call
    """

    def __init__(self, limit: str, value, used, t: float):
        self.limit, self.value, self.used, self.t = limit, value, used, float(t)
        what = f"{limit} = {value:g} s of CPU ({used:.3g} s used)" if limit == "max_cpu_time" else \
            f"{limit} = {value} right-hand sides"
        super().__init__(f"the run used up its budget {what}")


class Budget:
    """The limits of one run: max_rhs_calls (int or None), max_cpu_time [s] (float or None).

    check_at : the right-hand-side count at which :meth:`check` must be called next (never, when
    there is no limit: sys.maxsize).
    """

    def __init__(self, max_rhs_calls: int | None = None, max_cpu_time: float | None = None):
        self.max_rhs_calls, self.max_cpu_time = max_rhs_calls, max_cpu_time
        self.cpu_start = time.thread_time()
        self.check_at = self._next(0)

    def _next(self, nfev: int) -> int:
        at = [sys.maxsize]
        if self.max_rhs_calls is not None:
            at.append(self.max_rhs_calls)
        if self.max_cpu_time is not None:
            at.append(nfev + CPU_EVERY)
        return min(at)

    def check(self, nfev: int, t: float) -> int:
        """Raise BudgetExceeded when the nfev right-hand sides made so far, or the CPU time, reach a limit;
        else return the count of the next check."""
        if self.max_rhs_calls is not None and nfev >= self.max_rhs_calls:
            raise BudgetExceeded("max_rhs_calls", self.max_rhs_calls, nfev, t)
        if self.max_cpu_time is not None:
            used = time.thread_time() - self.cpu_start
            if used >= self.max_cpu_time:
                raise BudgetExceeded("max_cpu_time", self.max_cpu_time, used, t)
        self.check_at = self._next(nfev)
        return self.check_at
