"""A fit's evaluation (planning for the fitted and the true reward, then following both plans to
their ends) asks the fit's stop check before each of its planning's policy solves and around each
of the ends' sparse solves: on a 64x64 world it once took 3 to 6 s with no check, the last pause
before a stopped fit could end. Counted in solves (each followed by one backup P V), not seconds."""

import sys

import numpy as np
import pytest
from planning_sweeps import count_sweeps

from bench.worlds import cliff_world
from irl_core.irl import Stopped, evaluation, fit
from irl_core.irl.evaluation import evaluate, policy_ends
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.support.stopping import stop_when
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS


@pytest.fixture(scope="module")
def cliff():
    return build_mdp(cliff_world(16, 16))


def careless(mdp):
    """The world's rewards with the cliff at -1: a fitted reward whose agent walks along the edge."""
    R_S = mdp.R_S.copy()
    R_S[np.array([s == "C" for s in mdp.symbols] + [False])] = -1.0
    return R_S


def test_an_evaluation_told_to_stop_after_n_solves_stops_there(cliff, monkeypatch):
    solves = count_sweeps(monkeypatch)
    evaluate(cliff, careless(cliff))
    whole = solves[0]  # the agent's policy iteration (from nothing), then the optimum's
    assert whole >= 6
    for n in (1, whole // 2, whole - 1):
        solves[0] = 0
        with stop_when(lambda: solves[0] >= n), pytest.raises(Stopped):
            evaluate(cliff, careless(cliff))
        assert solves[0] == n


def test_policy_ends_asks_before_and_after_each_sparse_solve(cliff, monkeypatch):
    solves = []

    def noted(name):
        real = getattr(evaluation, name)

        def solve(*args):
            solves.append(name)
            return real(*args)

        return solve

    for name in ("ending_probabilities", "policy_evaluation"):
        monkeypatch.setattr(evaluation, name, noted(name))
    actions = value_iteration(cliff).greedy
    for told_after, done in [(None, []), ("ending_probabilities", ["ending_probabilities"]),
                             ("policy_evaluation", ["ending_probabilities", "policy_evaluation"])]:
        solves.clear()
        with stop_when(lambda: told_after is None or told_after in solves), pytest.raises(Stopped):
            policy_ends(cliff, actions)
        assert solves == done


def test_a_check_that_never_says_yes_is_asked_and_changes_nothing(cliff, monkeypatch):
    asked = [0]

    def never() -> bool:
        asked[0] += 1
        return False

    solves = count_sweeps(monkeypatch)
    plain = evaluate(cliff, careless(cliff))
    with stop_when(never):
        checked = evaluate(cliff, careless(cliff))
    assert checked == plain
    # Once before each policy solve of the two plannings, three times in each of the two policy_ends.
    assert asked[0] == solves[0] // 2 + 2 * 3


def test_a_fit_told_to_stop_during_its_evaluation_stops_there(monkeypatch):
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    sweeps = count_sweeps(monkeypatch)
    evaluating = []
    fit_module = sys.modules["irl_core.irl.fitting"]
    real = fit_module.evaluate

    def watched(*args, **kwargs):
        evaluating.append(True)
        sweeps[0] = 0
        return real(*args, **kwargs)

    monkeypatch.setattr(fit_module, "evaluate", watched)
    assert fit(demos, method="lp").evaluation is not None and sweeps[0] >= 2  # the evaluation's policy solves
    evaluating.clear()
    with pytest.raises(Stopped):
        fit(demos, method="lp", stop=lambda: bool(evaluating) and sweeps[0] >= 1)
    assert sweeps[0] == 1
