"""Progress reporting of a simulation (simulate's ``progress`` argument): a throttle and a tqdm bar."""

from __future__ import annotations

import time
from contextlib import contextmanager

from ..dynamics.forces import CallbackError


class Clock:
    """Calls progress(t, n_impacts) at most every `every` seconds of wall time (5 times a second).

    A progress callable that raises stops the run (CallbackError "progress", with the time);
    a KeyboardInterrupt passes through as the interrupt it is.
    """

    def __init__(self, progress, every=0.2):
        self.progress, self.every, self.last, self.n_impacts = progress, every, time.monotonic(), 0

    def tick(self, t):
        if self.progress is not None:
            now = time.monotonic()
            if now - self.last >= self.every:
                self.last = now
                try:
                    self.progress(float(t), self.n_impacts)
                except Exception as exc:  # noqa: BLE001 - any failure of user code, named
                    raise CallbackError("progress", None, t, f"raised {exc!r}") from exc


class ProgressBar:
    """``progress=True``: a tqdm bar over simulated time t - t0 [s] on stderr, fed by Clock.

    tqdm is imported here, when a bar is asked for. The solver calls the
    right-hand side at trial times that can step back, so the bar only moves forward.
    """

    def __init__(self, t0: float, t_end: float):
        from tqdm.auto import tqdm

        self.t0 = t0
        self.bar = tqdm(total=t_end - t0, desc="simulate", unit="s", leave=True,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g} / {total:.4g} s "
                                   "[{elapsed}<{remaining}{postfix}]")
        self.bar.set_postfix_str("impacts: 0", refresh=False)

    def __call__(self, t: float, n_impacts: int):
        self.bar.set_postfix_str(f"impacts: {n_impacts}", refresh=False)
        step = min(t - self.t0, self.bar.total) - self.bar.n
        if step > 0:
            self.bar.update(step)
        else:
            self.bar.refresh()

    def close(self):
        self.bar.close()


@contextmanager
def progress_reporter(progress, t0: float, t_end: float):
    """The callable progress(t, n_impacts) for simulate's ``progress`` argument, or None; closes a bar at the end.

    progress : None or False (nothing), True (a tqdm bar on stderr), or a callable.
    """
    if progress is None or progress is False:
        yield None
    elif progress is True:
        bar = ProgressBar(t0, t_end)
        try:
            yield bar
        finally:
            bar.close()
    elif callable(progress):
        yield progress
    else:
        raise ValueError(f"simulate progress={progress!r} must be None, True (a progress bar on stderr) "
                         "or a callable progress(t, n_impacts)")
