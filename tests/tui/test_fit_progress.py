"""The fit view and `careful fit` say how far a long fit has got (rounds, interval LPs)."""

from __future__ import annotations

import asyncio
import threading

from fit_view_fits import close_the_view_when, watch_view_fits
from maxent_evaluations import count_evaluations

import careful_tui.screens.fit
from bench.fit_stage import demonstrations_for
from bench.worlds import cliff_world
from careful_tui.app import CarefulApp
from careful_tui.render.fit_printout import progress_phrase
from careful_tui.screens.fit import FitScreen
from irl_core.irl import FitOptions, Stopped, fit
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def test_progress_phrases():
    assert progress_phrase("rounds", 3, None) == "round 3"
    assert progress_phrase("intervals", 12, 62) == "interval LP 12 of 62"
    assert progress_phrase("resamples", 40, 200) == "resample 40 of 200"


def test_the_status_line_follows_a_refit_and_forgets_it_when_done(monkeypatch):
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    first = fit(demos, method="lp")
    release = threading.Event()
    real_refit = careful_tui.screens.fit.fit

    def slow_refit(demos, options, *, progress=None, stop=None):
        progress("rounds", 2, None)
        progress("intervals", 3, 8)
        release.wait(10)
        return real_refit(demos, options, progress=progress, stop=stop)

    monkeypatch.setattr(careful_tui.screens.fit, "fit", slow_refit)
    app = CarefulApp(FitScreen(demos, FitOptions(method="lp"), result=first))
    seen = []

    async def go():
        async with app.run_test(size=(180, 50)) as pilot:
            await pilot.press("i")
            for _ in range(200):
                await pilot.pause(0.02)
                if "interval LP" in str(app.first_screen._status()):
                    break
            seen.append(str(app.first_screen._status()))
            release.set()
            await app.workers.wait_for_complete()
            await pilot.pause()
            seen.append(str(app.first_screen._status()))

    asyncio.run(go())
    assert seen[0].endswith("interval LP 3 of 8")
    assert "interval LP" not in seen[1] and seen[1].startswith("✓")


def test_a_refit_no_longer_wanted_is_stopped(monkeypatch):
    """A newer refit, or closing the view, stops the fit in flight: on a 64x64 world the view
    used to wait minutes for unwanted intervals before the app could exit."""
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    first = fit(demos, method="lp")
    stopped = []

    def fit_until_stopped(demos, options, *, progress=None, stop=None):
        # As the real fit does at every LP iteration: ask, and end with Stopped once told to.
        for _ in range(1000):
            if stop():
                stopped.append(options.method)
                raise Stopped("the fit was stopped before it ended")
            threading.Event().wait(0.01)
        raise AssertionError("the fit was never told to stop")

    monkeypatch.setattr(careful_tui.screens.fit, "fit", fit_until_stopped)
    app = CarefulApp(FitScreen(demos, FitOptions(method="lp"), result=first))

    async def go():
        async with app.run_test(size=(180, 50)) as pilot:
            await pilot.press("o")
            await pilot.pause(0.1)
            await pilot.press("m")  # the loss refit is no longer wanted
            for _ in range(100):
                await pilot.pause(0.02)
                if stopped:
                    break
            assert stopped == ["loss"] and "fitting maxent" in str(app.first_screen._status())
        # Leaving the app (the view closes) stopped the maxent refit too.

    asyncio.run(go())
    assert stopped == ["loss", "maxent"]


def test_closing_the_view_stops_a_maxent_fit_inside_its_search(monkeypatch):
    """One maxent fit is one L-BFGS-B search with no progress report to stop at: closing the view
    now stops it at its next soft Bellman solve, where the app used to wait for the whole search
    (39 s on a 64x64 world). Counted in evaluations, not seconds."""
    demos = demonstrations_for(build_mdp(cliff_world(16, 16)), episodes=20, seed=0)
    evaluations = count_evaluations(monkeypatch)
    watched = watch_view_fits(monkeypatch)
    app = CarefulApp(FitScreen(demos, FitOptions(method="maxent")))  # no result yet: the view fits on opening
    # Closed in the middle of the search.
    closed_at = close_the_view_when(app, lambda: evaluations[0] >= 3, seen=lambda: evaluations[0])
    assert watched.over.wait(60)
    assert 3 <= closed_at < 50  # the whole search takes 93 evaluations on this world
    assert watched.ended == ["stopped"] and evaluations[0] <= closed_at + 1
