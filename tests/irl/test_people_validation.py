"""The person-like players play as docs/people.md says: the optimal direction about nine times in ten,
the level's spread as specified (loose: the same whatever is at stake; timed: growing with the level;
hasty: held short), inverted care that runs against the danger, a reckless player at level 1.

These are the players bench/bench_people.py fits; what the fit makes of them is the bench's to
measure, not these tests'.
"""

import numpy as np
import pytest

from irl_core.play.hold import HoldProfile
from irl_core.players.experts import Rollouts, optimal_plan, rollouts
from irl_core.players.person_like import LEVEL_KINDS, intended_hold_ms, level_of_hold, person_like
from irl_core.recordings.summary import distance_to_terminal
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

WORLDS = ("mud", "walls")
EPISODES = 1500


def played(world: str, kind: str, seed: int = 5, **parameters):
    """(mdp, rollouts, optimal action per state) for `EPISODES` episodes of `kind` in `world`."""
    mdp = build_mdp(BUILTIN_WORLDS[world])
    player = person_like(mdp, kind, **parameters)
    return mdp, rollouts(mdp, player.choose, episodes=EPISODES, seed=seed), optimal_plan(mdp).greedy


def chosen(mdp, run: Rollouts) -> tuple[np.ndarray, np.ndarray]:
    """(steps,) chosen direction and level of every step."""
    return mdp.direction[run.action], mdp.carefulness[run.action]


def optimal_share(mdp, run: Rollouts, best: np.ndarray) -> float:
    return float(np.mean(chosen(mdp, run)[0] == mdp.direction[best[run.state]]))


@pytest.mark.parametrize("world", WORLDS)
@pytest.mark.parametrize("kind", ["loose", "timed", "hasty", "inverted"])
def test_a_person_like_player_goes_the_optimal_way_about_nine_times_in_ten(world, kind):
    mdp, run, best = played(world, kind)
    assert 0.86 <= optimal_share(mdp, run, best) <= 0.97


@pytest.mark.parametrize("world", WORLDS)
def test_loose_levels_spread_by_about_1_75_levels_whatever_is_at_stake(world):
    mdp, run, best = played(world, "loose")
    planned = mdp.carefulness[best[run.state]]
    off = chosen(mdp, run)[1] - planned
    high, low = planned >= 7, (planned >= 3) & (planned <= 4)  # low enough that clipping at 1 barely bites
    assert abs(off.mean()) < 0.3
    assert 1.55 <= off[high].std() <= 1.95 and 1.5 <= off[low].std() <= 1.95
    assert abs(off[high].std() - off[low].std()) < 0.3


def test_a_wider_spread_is_a_wider_spread():
    mdp, narrow, best = played("mud", "loose", spread=0.5)
    _, wide, _ = played("mud", "loose", spread=3.0)
    spread = [np.std(chosen(mdp, run)[1] - mdp.carefulness[best[run.state]]) for run in (narrow, wide)]
    assert spread[0] < 0.7 and spread[1] > 2.0


def test_timed_levels_are_the_levels_of_hold_times_as_the_game_counts_them():
    profile = HoldProfile()
    holds = np.arange(0.0, 3000.0, 7.5)
    assert level_of_hold(holds, 14).tolist() == [profile.level_for(h) for h in holds]
    levels = np.arange(1, 15)
    assert level_of_hold(intended_hold_ms(levels), 14).tolist() == levels.tolist()


@pytest.mark.parametrize("world", WORLDS)
def test_timed_levels_spread_more_where_more_care_is_planned(world):
    mdp, run, best = played(world, "timed")
    planned = mdp.carefulness[best[run.state]]
    off = chosen(mdp, run)[1] - planned
    assert off[planned >= 7].std() > 1.4 * off[(planned >= 3) & (planned <= 4)].std()
    assert abs(np.median(off)) < 0.5


@pytest.mark.parametrize("world", WORLDS)
def test_timed_lapses_repeat_the_previous_direction(world):
    mdp, run, best = played(world, "timed")
    order = np.lexsort((run.t, run.episode))
    episode, t, direction = run.episode[order], run.t[order], mdp.direction[run.action[order]]
    lapsed = (t > 0) & (direction != mdp.direction[best[run.state[order]]])
    assert lapsed.sum() > 200
    previous = np.roll(direction, 1)
    assert (direction[lapsed] == previous[lapsed]).all() and (episode[lapsed] == np.roll(episode, 1)[lapsed]).all()


@pytest.mark.parametrize("world", WORLDS)
def test_hasty_holds_short_and_errs_where_a_wrong_direction_costs_little(world):
    mdp, run, best = played(world, "hasty")
    planned = mdp.carefulness[best[run.state]]
    off = chosen(mdp, run)[1] - planned
    assert -2.2 <= off.mean() <= -1.2 and 0.6 <= off[planned >= 7].std() <= 1.2
    q = optimal_plan(mdp).Q.reshape(mdp.n_states, 4, mdp.levels).max(axis=2)
    ranked = np.sort(q, axis=1)
    gap = (ranked[:, -1] - ranked[:, -2])[run.state]
    right = chosen(mdp, run)[0] == mdp.direction[best[run.state]]
    assert right[gap > 20].mean() > 0.99 and right[gap < 2].mean() < 0.85


@pytest.mark.parametrize("world", WORLDS)
def test_inverted_care_runs_against_the_danger(world):
    mdp, run, best = played(world, "inverted")
    level = chosen(mdp, run)[1]
    distance = distance_to_terminal(mdp.world)
    steps_away = np.array([distance[mdp.cells[s]] for s in run.state])
    cliff_next_door = np.array([any(mdp.symbols[n] == "C" for n in mdp.neighbour[s]) for s in run.state])
    assert level[cliff_next_door].mean() + 4 < level[steps_away >= 3].mean()
    assert np.corrcoef(level, mdp.carefulness[best[run.state]])[0, 1] < -0.8
    _, loose, _ = played(world, "loose")
    assert np.corrcoef(chosen(mdp, loose)[1], mdp.carefulness[best[loose.state]])[0, 1] > 0.6


@pytest.mark.parametrize("world", WORLDS)
def test_reckless_plays_level_one_and_a_quarter_of_its_moves_at_random(world):
    mdp, run, best = played(world, "reckless")
    assert (chosen(mdp, run)[1] == 1).all()
    assert 0.78 <= optimal_share(mdp, run, best) <= 0.85  # 3/4 + 1/4 x 1/4 of random moves that happen to be right
    ends = [mdp.symbols[s] for s in run.final_state]
    assert ends.count("C") > 0.3 * EPISODES


def test_the_same_seed_plays_the_same_episodes():
    for kind in LEVEL_KINDS:
        _, first, _ = played("walls", kind, seed=11)
        _, again, _ = played("walls", kind, seed=11)
        _, other, _ = played("walls", kind, seed=12)
        assert np.array_equal(first.action, again.action) and np.array_equal(first.state, again.state)
        assert not np.array_equal(first.action[:500], other.action[:500])


def test_a_player_names_itself_with_its_parameters():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    assert person_like(mdp, "loose").player == "person:loose(lapse=0.1, spread=1.75)"
    assert person_like(mdp, "timed", weber=0.4).player == "person:timed(lapse=0.1, weber=0.4)"
    assert person_like(mdp, "reckless").player == "person:reckless(lapse=0.25)"


@pytest.mark.parametrize(("kind", "parameters", "says"), [
    ("careless", {}, "unknown person-like player 'careless'"),
    ("loose", {"weber": 0.2}, "the loose player has no parameter weber"),
    ("loose", {"lapse": 1.5}, "lapse is a probability"),
    ("hasty", {"temperature": 0.0}, "temperature must be positive"),
    ("timed", {"weber": -1.0}, "weber must be zero or more"),
])
def test_a_player_that_cannot_be_made_is_refused_with_a_reason(kind, parameters, says):
    with pytest.raises(ValueError, match=says):
        person_like(build_mdp(BUILTIN_WORLDS["mud"]), kind, **parameters)


def test_a_person_like_study_has_its_participants_and_one_reckless_one_last(tmp_path):
    from irl_core.studies.simulated import write_person_like_study
    from irl_core.studies.study import load_study, read_participant

    study = load_study(write_person_like_study(tmp_path / "s", participants=4, episodes=6))
    assert [world.name for world in study.worlds] == ["mud", "walls"]
    players = {}
    for participant in ("p01", "p02", "p03", "p04", "p05"):
        read = read_participant(study, participant)
        assert not read.problems and [tag.phase for tag, _ in read.recordings] == ["main", "main"]
        assert all(len(recording.episode_ends) == 6 for _, recording in read.recordings)
        players[participant] = {recording.header.input["expert"].split("(")[0] for _, recording in read.recordings}
        levels = {step.carefulness for _, recording in read.recordings for step in recording.steps}
        assert (levels == {1}) == (participant == "p05")
    assert players == {"p01": {"person:loose"}, "p02": {"person:timed"}, "p03": {"person:hasty"},
                       "p04": {"person:loose"}, "p05": {"person:reckless"}}
    with pytest.raises(FileExistsError):
        write_person_like_study(tmp_path / "s")
