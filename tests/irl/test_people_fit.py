"""The default fit on person-like play: the player model, its choice, the fit check, the advice on failure."""

from __future__ import annotations

import numpy as np
import pytest

from irl_core.irl import fit
from irl_core.irl.choices import PLAYER_MODELS, Player
from irl_core.irl.fit_check import fit_check, terminal_distance
from irl_core.irl.people.choice import choose_player_model
from irl_core.irl.people.fit import fit_player
from irl_core.irl.people.likelihood import log_likelihood
from irl_core.irl.qmap import build_unknowns
from irl_core.irl.result import InfeasibleError
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.players.person_like import person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def _played(kind: str, *, episodes: int = 30, seed: int = 0, world: str = "mud"):
    mdp = build_mdp(BUILTIN_WORLDS[world])
    return demonstrations_of(mdp, rollouts(mdp, person_like(mdp, kind).choose, episodes=episodes,
                                           rng=np.random.default_rng([seed, 7])))


@pytest.fixture(scope="module")
def loose_fit():
    return fit(_played("loose"), tie=True)


def test_the_default_fit_of_loose_play_puts_the_goal_above_zero_and_the_cliff_below_the_mud(loose_fit):
    value = dict(zip(loose_fit.labels, loose_fit.theta))
    assert value["C"] < value["U"] < 0 < value["G"]
    assert loose_fit.player_model in ("person", "naive")
    assert loose_fit.evaluation.agent.ends["C"] <= 0.01


def test_the_json_names_the_player_model_its_parameters_and_the_fit_check(loose_fit):
    out = loose_fit.to_json()
    assert out["options"]["player_model"] == loose_fit.player_model
    assert 0 < out["options"]["sigma"] and 0 < out["options"]["lapse"] < 0.5
    assert out["fit_check"]["passed"] in (True, False)
    assert {s["name"] for s in out["fit_check"]["statistics"]} >= {"mean episode length", "episodes ending in C"}
    assert "player_model" in out["note_codes"]


def test_the_paper_s_maxent_baseline_is_unchanged_when_asked_for_by_name():
    demos = _played("loose", episodes=10)
    result = fit(demos, method="maxent")
    assert result.player_model == "boltzmann" and result.beta == 1.0
    assert result.to_json()["options"]["player_model"] == "boltzmann"


def test_two_episodes_get_the_simplest_model_and_a_note_not_an_error():
    demos = _played("loose", episodes=2)
    result = fit(demos)
    assert result.player_model == "ends"
    assert any(n.code == "player_model" and "cannot be split into folds" in str(n) for n in result.notes)


def _well_specified(mdp, seed):
    """Episodes of a player drawn from the person model itself, at the world's true rewards."""
    model = PLAYER_MODELS["person"]
    plan = log_likelihood(mdp, np.zeros((mdp.n_states, mdp.n_actions)), mdp.R_S, model=model,
                          player=Player(beta=3.0, sigma=1.5, lapse=0.08), gradient=False).plan
    return demonstrations_of(mdp, rollouts(mdp, plan.observed, episodes=30, rng=np.random.default_rng(seed)))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_fit_check_passes_on_a_player_the_model_contains(seed):
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = _well_specified(mdp, seed)
    unknowns = build_unknowns(mdp, tie=True)
    solution = fit_player(mdp, unknowns, demos.counts, model=PLAYER_MODELS["person"], rmax=1000.0)
    check = fit_check(mdp, solution.plan.observed, demos.by_episode, demos.episode_facts, seed=seed)
    assert check.passed, check.summary()


def test_the_fit_check_fails_on_care_no_reward_explains():
    demos = _played("inverted")
    result = fit(demos, tie=True)
    assert result.fit_check is not None and result.fit_check.passed is False
    failed = {s.name for s in result.fit_check.failed}
    assert any(name.startswith("mean carefulness") for name in failed)
    assert any(n.code == "fit_check_failed" for n in result.notes)


def test_a_fit_check_without_a_finished_episode_says_it_cannot_run():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=5, seed=0, max_steps=1))
    facts = demos.episode_facts
    unfinished = type(facts)(start=facts.start, length=facts.length, end=("quit",) * len(facts.end))
    check = fit_check(mdp, optimal_policy(mdp), demos.by_episode, unfinished)
    assert check.passed is None and "no recorded episode ran to its end" in check.summary()


def test_terminal_distance_counts_moves_to_the_nearest_terminal_cell():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    distance = mdp.grid_of(terminal_distance(mdp)[:-1])
    assert distance[3, 1] == 0 and distance[2, 1] == 1 and distance[0, 0] == 4 and distance[3, 0] == 1


def test_held_out_episodes_prefer_a_model_of_people_for_loose_play():
    demos = _played("loose")
    mdp = demos.mdp
    choice = choose_player_model(mdp, build_unknowns(mdp, tie=True), demos.by_episode, rmax=1000.0)
    assert choice.held_out["person"] > choice.held_out["boltzmann"] + 10
    assert choice.name in ("person", "naive")


def test_lp_on_noisy_play_does_not_advise_a_larger_bound():
    with pytest.raises(InfeasibleError) as caught:
        fit(_played("loose", episodes=20), method="lp")
    assert "{rmax}" not in caught.value.sentence
    assert "however large" in str(caught.value) and "noisy play" in str(caught.value)


def test_lp_infeasible_only_within_a_small_bound_still_advises_raising_it():
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    with pytest.raises(InfeasibleError) as caught:
        fit(demos, method="lp", rmax=1.0)
    assert "{rmax}" in caught.value.sentence


def test_a_big_worlds_people_fit_on_two_processes_is_the_fit_on_one():
    # The candidates' default starts, the folds' refits and the checks after the fit (held bounds, fit check) go to
    # a process pool from PEOPLE_PARALLEL_STATES states: the same numbers, to the last digit, and the same notes.
    from bench.worlds import cliff_world
    from irl_core.irl import FitOptions
    from irl_core.irl.fitters import PEOPLE_PARALLEL_STATES
    from irl_core.players.experts import demonstrations_of, rollouts
    from irl_core.players.person_like import person_like

    mdp = build_mdp(cliff_world(10, 12))
    assert mdp.n_states >= PEOPLE_PARALLEL_STATES
    demos = demonstrations_of(mdp, rollouts(mdp, person_like(mdp, "loose").choose, episodes=30, seed=0))
    one, two = (fit(demos, FitOptions(), workers=workers) for workers in (1, 2))
    assert one.player_model == two.player_model
    assert one.theta.tolist() == two.theta.tolist()
    assert [str(note) for note in one.notes] == [str(note) for note in two.notes]
    assert any(note.code == "unreached" for note in one.notes)  # held rewards' bounds were computed
