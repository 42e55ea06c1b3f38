"""Closing the fit view while the fit evaluates its answer (planning for the fitted reward and
following the plan, once 3 to 6 s on a 64x64 world) ends the fit there, instead of the app waiting
for an evaluation nobody will see. Counted in sweeps, not seconds."""

from __future__ import annotations

import sys
import threading

from fit_view_fits import close_the_view_when, watch_view_fits
from planning_sweeps import count_sweeps

from careful_tui.app import CarefulApp
from careful_tui.screens.fit import FitScreen
from irl_core.irl import FitOptions
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def test_closing_the_view_during_the_evaluation_ends_the_fit(monkeypatch):
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    sweeps = count_sweeps(monkeypatch)
    fit_module = sys.modules["irl_core.irl.fitting"]
    real_evaluate = fit_module.evaluate
    evaluating = threading.Event()
    watched = watch_view_fits(monkeypatch)

    def held_evaluate(*args, **kwargs):
        # The view closes while the evaluation is under way: hold it at its start until then.
        evaluating.set()
        for _ in range(1000):
            if watched.stops[0]():
                break
            threading.Event().wait(0.01)
        sweeps[0] = 0
        return real_evaluate(*args, **kwargs)

    monkeypatch.setattr(fit_module, "evaluate", held_evaluate)
    app = CarefulApp(FitScreen(demos, FitOptions(method="lp")))  # no result yet: the view fits on opening
    # Closed in the middle of the evaluation.
    reached = close_the_view_when(app, evaluating.is_set, seen=evaluating.is_set)
    assert watched.over.wait(60)
    assert reached is True
    assert watched.ended == ["stopped"] and sweeps[0] == 0  # not one solve of its planning after the view closed
