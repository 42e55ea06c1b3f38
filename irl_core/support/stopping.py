"""Stopping work whose answer is no longer wanted, from inside its long loops.

`fit(stop=...)` hands its check to this thread for the length of the fit (`stop_when`), and
the inner loops ask it: HiGHS at every simplex or IPX iteration (`irl.highs`), maxent before
every solve of its soft Bellman equations (`irl.maxent`), value iteration at every sweep and
the fit's evaluation before and after each of its sparse solves (`planning`,
`irl.evaluation`). Once the check says True they raise `Stopped`. A process pool's workers
(the bootstrap's refits, the study report's fits: `run_in_pool`) run under their parent's
stop signal the same way, and the parent asks its own check while it waits for them.
The check lives on the thread, not in every function's arguments, because the loops that ask
it sit several calls below `fit` (L-BFGS-B's objective, a bootstrap's refit, the evaluation's
planning), and because two fits on two threads (the fit view's old one and its new one) must
each hear only their own. It sits beside `planning`, below `irl`, so that both can import it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from irl_core.errors import Stopped

_stop_check = threading.local()


@contextmanager
def stop_when(check: Callable[[], bool]) -> Iterator[None]:
    """Within the block, the work on this thread stops at its solvers' next check once `check()`
    is true, raising `Stopped`: how a thread that fits (the fit view's) or a pool's worker is
    stopped when its answer is no longer wanted. (On the main thread HiGHS also stops for Ctrl+C.)"""
    previous = getattr(_stop_check, "check", None)
    _stop_check.check = check
    try:
        yield
    finally:
        _stop_check.check = previous


def stop_check() -> Callable[[], bool] | None:
    """This thread's check, or None outside `stop_when`."""
    return getattr(_stop_check, "check", None)


def stop_if_asked() -> None:
    """Raise `Stopped` if this thread's check says so (nothing outside `stop_when`)."""
    check = stop_check()
    if check is not None and check():
        raise Stopped()
