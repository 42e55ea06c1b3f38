"""The battery's players play as their definitions say, each checked by a count over many simulated moves
with a fixed seed: ``streaky``'s lapses come in streaks of the mean length asked, ``growing``'s level
spreads by spread + growth x level, ``learning`` fears the hazard more from episode to episode as its
belief says. What the fit makes of them is bench_battery's to measure, not these tests'.
"""

import numpy as np
import pytest
from scipy.stats import norm

from irl_core.players.experts import optimal_plan, rollouts, simulate_to_file
from irl_core.players.person_like import LEVEL_KINDS, person_like
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def held_in_place(kind: str, *, episodes: int = 2000, steps: int = 60, seed: int = 3, **parameters):
    """(directions (steps, episodes), the optimal direction) of `kind` acting `steps` times in one mud cell, the
    chooser called as rollouts calls it, but with no episode ending (which would favour long streaks)."""
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    choose = person_like(mdp, kind, **parameters).choose
    s = np.full(episodes, mdp.state_of[(0, 0)])
    rng = np.random.default_rng(seed)
    previous, rows = np.full(episodes, -1), []
    for _ in range(steps):
        previous = choose(s, previous, rng, np.arange(episodes))
        rows.append(mdp.direction[previous])
    return np.array(rows), int(mdp.direction[optimal_plan(mdp).greedy[s[0]]])


@pytest.mark.parametrize(("lapse", "streak"), [(0.1, 4.0), (0.2, 2.0)])
def test_streaky_lapses_last_the_mean_streak_asked_and_hold_their_share(lapse, streak):
    directions, best = held_in_place("streaky", lapse=lapse, streak=streak)
    off = directions != best
    # A lapse picks one of the four directions, so 3 in 4 lapses are seen: off follows off with chance
    # 3/4 x (1 - 1 / streak); the share of off steps is 3/4 x lapse.
    stay = off[1:][off[:-1]].mean()
    assert 1 / (1 - stay / 0.75) == pytest.approx(streak, rel=0.06)
    assert off.mean() == pytest.approx(0.75 * lapse, rel=0.06)


def test_loose_lapses_come_one_at_a_time_where_streaky_ones_follow_each_other():
    loose, best = held_in_place("loose")
    streaky, _ = held_in_place("streaky")
    after_loose = (loose[1:] != best)[loose[:-1] != best].mean()
    after_streaky = (streaky[1:] != best)[streaky[:-1] != best].mean()
    assert after_loose == pytest.approx(0.075, abs=0.01) and after_streaky > 0.5


def test_streaky_starts_every_episode_afresh_and_keeps_episodes_apart():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    run = rollouts(mdp, person_like(mdp, "streaky", lapse=0.3, streak=8).choose, episodes=3000, seed=4)
    first = run.t == 0
    best = optimal_plan(mdp).greedy
    off = mdp.direction[run.action] != mdp.direction[best[run.state]]
    assert off[first].mean() == pytest.approx(0.75 * 0.3, abs=0.03)  # the chain's stationary share, not carried over


def expected_sd(level: int, sd: float, levels: int) -> float:
    """The sd of clip(round(level + N(0, sd)), 1, levels) - level, summed over the integers it can land on."""
    k = np.arange(1, levels + 1)
    upper = np.where(k == levels, np.inf, k + 0.5)
    lower = np.where(k == 1, -np.inf, k - 0.5)
    p = norm.cdf(upper, level, sd) - norm.cdf(lower, level, sd)
    mean = (p * k).sum()
    return float(np.sqrt((p * (k - mean) ** 2).sum()))


def test_growing_levels_spread_by_spread_plus_growth_times_the_level_aimed_at():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    run = rollouts(mdp, person_like(mdp, "growing", spread=0.5, growth=0.3).choose, episodes=3000, seed=6)
    planned = mdp.carefulness[optimal_plan(mdp).greedy[run.state]]
    off = mdp.carefulness[run.action] - planned
    measured = 0
    for level in np.unique(planned).tolist():
        here = off[planned == level]
        if here.size < 400:
            continue
        measured += 1
        assert here.std() == pytest.approx(expected_sd(level, 0.5 + 0.3 * level, mdp.levels), rel=0.08), level
    assert measured >= 3
    sds = {level: off[planned == level].std() for level in np.unique(planned).tolist() if (planned == level).sum() >= 400}
    assert max(sds.values()) > 1.5 * min(sds.values())


def test_learning_fears_the_hazard_as_its_belief_says_and_ends_at_the_truth():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    player = person_like(mdp, "learning", lapse=0.0, spread=0.0, fear=0.1, half_life=3.0)
    run = rollouts(mdp, player.choose, episodes=400, seed=2)
    world = BUILTIN_WORLDS["mud"]
    for episode in (0, 3, 12, 399):
        belief = round(1 + (0.1 - 1) * 0.5 ** (episode / 3.0), 2)
        believed = build_mdp(world.model_copy(update={"rewards": {**world.rewards, "C": belief * world.rewards["C"]}}))
        mine = run.episode == episode
        # Without lapses or noise the episode's actions are the optimal ones of the world it believes in.
        assert np.array_equal(run.action[mine], optimal_plan(believed).greedy[run.state[mine]]), episode
    # Learning slowly, measured against the truth's plan state by state: short of it at first, on it at the end.
    slow = rollouts(mdp, person_like(mdp, "learning", fear=0.1, half_life=50.0).choose, episodes=600, seed=2)
    short = mdp.carefulness[slow.action] - mdp.carefulness[optimal_plan(mdp).greedy[slow.state]]
    loose = rollouts(mdp, person_like(mdp, "loose").choose, episodes=600, seed=2)
    as_loose = (mdp.carefulness[loose.action] - mdp.carefulness[optimal_plan(mdp).greedy[loose.state]]).mean()
    early, late = short[slow.episode < 30].mean(), short[slow.episode >= 400].mean()
    # Clipping at level 1 lifts loose's mean a little: the learner ends where loose plays all along.
    assert early < as_loose - 0.4 and abs(late - as_loose) < 0.1, (early, late, as_loose)


def test_rollouts_tell_a_chooser_each_episodes_number_in_the_recording_across_blocks(tmp_path):
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    player = person_like(mdp, "learning", lapse=0.0, spread=0.0, fear=0.0, half_life=2.0)
    simulate_to_file(tmp_path / "x.jsonl", mdp, player.choose, episodes=12, seed=1, player=player.player, block=4)
    demos = Demonstrations.read([tmp_path / "x.jsonl"])
    levels = mdp.carefulness[demos.by_episode.indices % mdp.n_actions].reshape(-1)
    first_level = [mdp.carefulness[row.indices % mdp.n_actions].mean() for row in demos.by_episode]
    # Episode 0 fears nothing (belief 0) and episode 11 almost the truth: the blocks did not restart the count.
    assert first_level[0] + 1 < first_level[-1] and levels.size > 0


@pytest.mark.parametrize(("parameters", "says"), [
    ({"streak": 0.5}, "streak is a mean number of steps, at least 1"),
    ({"lapse": 0.8, "streak": 2.0}, "a lapse share of 0.8 needs streaks of at least 4 steps"),
    ({"lapse": 1.0}, "a lapse share of 1 leaves no attentive step"),
])
def test_a_streaky_player_that_cannot_be_made_is_refused_with_a_reason(parameters, says):
    with pytest.raises(ValueError, match=says):
        person_like(build_mdp(BUILTIN_WORLDS["mud"]), "streaky", **parameters)


def test_the_battery_is_among_the_level_worlds_players():
    assert {"streaky", "growing", "learning"} <= set(LEVEL_KINDS)
