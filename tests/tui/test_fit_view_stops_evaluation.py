"""Closing the fit view while the fit evaluates its answer (planning for the fitted reward and
following the plan, 3 to 6 s on a 64x64 world) ends the fit there, instead of the app waiting
for an evaluation nobody will see. Counted in sweeps, not seconds."""

from __future__ import annotations

import asyncio
import sys
import threading

import careful_tui.screens.fit
from careful_tui.screens.careful_app import CarefulApp
from careful_tui.screens.fit import FitScreen
from irl_core.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.irl import FitOptions, Stopped
from irl_core.mdp import build_mdp
from irl_core.world import BUILTIN_WORLDS
from planning_sweeps import count_sweeps


def test_closing_the_view_during_the_evaluation_ends_the_fit(monkeypatch):
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    sweeps = count_sweeps(monkeypatch)
    fit_module = sys.modules["irl_core.irl.fit"]
    real_evaluate, real_fit = fit_module.evaluate, careful_tui.screens.fit.fit
    stops, ended = [], []
    evaluating, over = threading.Event(), threading.Event()

    def held_evaluate(*args):
        # The view closes while the evaluation is under way: hold it at its start until then.
        evaluating.set()
        for _ in range(1000):
            if stops[0]():
                break
            threading.Event().wait(0.01)
        sweeps[0] = 0
        return real_evaluate(*args)

    def watched_fit(demos, options, *, progress=None, stop=None):
        stops.append(stop)
        try:
            real_fit(demos, options, progress=progress, stop=stop)
            ended.append("finished")
        except Stopped:
            ended.append("stopped")
            raise
        finally:
            over.set()

    monkeypatch.setattr(fit_module, "evaluate", held_evaluate)
    monkeypatch.setattr(careful_tui.screens.fit, "fit", watched_fit)
    app = CarefulApp(FitScreen(demos, FitOptions(method="lp")))  # no result yet: the view fits on opening
    reached = []

    async def go():
        async with app.run_test(size=(180, 50)) as pilot:
            for _ in range(500):
                await pilot.pause(0.01)
                if evaluating.is_set():
                    break
            reached.append(evaluating.is_set())
        # Leaving the app closes the view in the middle of the evaluation.

    asyncio.run(go())
    assert over.wait(60)
    assert reached == [True]
    assert ended == ["stopped"] and sweeps[0] == 0  # not one sweep of its planning after the view closed
