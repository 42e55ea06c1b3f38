"""Watching the fits the fit view starts: how the stop tests see whether a fit ran to its end or
was stopped, and with which stop check."""

import threading
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
