"""Watching the fits the fit view starts: how the stop tests see whether a fit ran to its end or
was stopped, and with which stop check."""

import asyncio
import threading
from collections.abc import Callable
from dataclasses import dataclass, field

import careful_tui.screens.fit
from irl_core.irl import Stopped


@dataclass
class WatchedFits:
    """stops: each fit's stop check; ended: "finished" or "stopped" per fit; over: set as one ends."""

    stops: list = field(default_factory=list)
    ended: list[str] = field(default_factory=list)
    over: threading.Event = field(default_factory=threading.Event)


def watch_view_fits(monkeypatch) -> WatchedFits:
    """Make the fit view's `fit` record how each fit it starts ends."""
    watched = WatchedFits()
    real_fit = careful_tui.screens.fit.fit

    def watched_fit(demos, options, *, progress=None, stop=None):
        watched.stops.append(stop)
        try:
            real_fit(demos, options, progress=progress, stop=stop)
            watched.ended.append("finished")
        except Stopped:
            watched.ended.append("stopped")
            raise
        finally:
            watched.over.set()

    monkeypatch.setattr(careful_tui.screens.fit, "fit", watched_fit)
    return watched


def close_the_view_when(app, reached: Callable[[], bool], *, seen: Callable[[], object]) -> object:
    """Run the fit view's `app` until `reached()` (looked at every 10 ms, at most 5 s), then close
    it, in the middle of whatever its fit is doing; `seen()` as it was when the view closed."""
    closed_on = []

    async def go():
        async with app.run_test(size=(180, 50)) as pilot:
            for _ in range(500):
                await pilot.pause(0.01)
                if reached():
                    break
        # Once the app has closed (its screens told their fits to stop), not when it was asked to: on a
        # busy machine the fit went on through another evaluation in between (CI, session 10).
        closed_on.append(seen())

    asyncio.run(go())
    return closed_on[0]
