"""careful/Careful-v0: Gymnasium's checker, the MDP's dynamics, rewards, seeding, rendering."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.utils.env_checker import check_env
from scipy.stats import chisquare

import irl_core.worlds.env  # noqa: F401  (registers careful/Careful-v0)
from irl_core.errors import WorldError
from irl_core.play.game import Game
from irl_core.worlds.env import ENV_ID, CarefulEnv, cell_observation
from irl_core.worlds.mdp import action_index, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS, World


class Lines:
    """A recording sink that keeps the lines in memory."""

    def __init__(self):
        self.steps, self.ends = [], []

    def write_step(self, step):
        self.steps.append(step)

    def end_episode(self, end):
        self.ends.append(end)


def checker_warnings(env):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    return [str(w.message) for w in caught]


@pytest.mark.parametrize("space", ["discrete", "multidiscrete"])
@pytest.mark.parametrize("name", list(BUILTIN_WORLDS))
def test_the_checker_passes_without_warnings(name, space):
    env = gym.make(ENV_ID, world=name, action_space=space, render_mode="ansi")
    assert checker_warnings(env.unwrapped) == []
    world = BUILTIN_WORLDS[name]
    assert env.observation_space == gym.spaces.Discrete(world.rows * world.cols)
    L = world.levels
    expected = gym.spaces.Discrete(4 * L) if space == "discrete" else gym.spaces.MultiDiscrete([4, L])
    assert env.action_space == expected


def test_the_checker_would_report_a_broken_environment():
    class Int32Observations(CarefulEnv):
        def reset(self, *, seed=None, options=None):
            obs, info = super().reset(seed=seed, options=options)
            return np.int32(obs), info

    assert any("np.int64" in w for w in checker_warnings(Int32Observations("paper")))


def test_make_by_module_path_registers_on_import():
    env = gym.make("irl_core.worlds.env:careful/Careful-v0", world="mud")
    assert env.unwrapped.world == BUILTIN_WORLDS["mud"]


@pytest.mark.parametrize(
    ("world", "cell", "direction", "carefulness"),
    [
        ("paper", (2, 2), "right", 2),  # four distinct outcomes, one of them the cliff
        ("paper", (0, 0), "up", 1),  # up and left are blocked: both stay, 2/3 in all
        ("mud", (1, 1), "down", 3),
    ],
)
def test_transition_frequencies_match_the_mdp(world, cell, direction, carefulness):
    env = CarefulEnv(world)
    mdp = env.mdp
    a = action_index(direction, carefulness, mdp.levels)
    row = mdp.P[mdp.state_of[cell] * mdp.n_actions + a]
    outcomes, probs = row.indices, row.data
    observation_of = {cell_observation(mdp.cells[s], env.world.cols): k for k, s in enumerate(outcomes)}
    counts = np.zeros(len(outcomes))
    n = 4000
    env.reset(seed=2024)
    for _ in range(n):
        env.reset(options={"start": list(cell)})
        obs, *_ = env.step(a)
        counts[observation_of[obs]] += 1  # a KeyError here is a move the MDP cannot make
    expected = n * probs
    sigma = np.sqrt(n * probs * (1 - probs))
    assert np.all(np.abs(counts - expected) <= 3 * sigma), (counts, expected)
    assert chisquare(counts, expected).pvalue > 1e-3


def test_the_terminal_reward_arrives_on_the_step_that_enters_the_cell():
    env = CarefulEnv("paper-maxent")  # no slip: each move goes where it is aimed
    env.reset(seed=0, options={"start": [2, 1]})
    obs, reward, terminated, truncated, info = env.step(action_index("down", 1, 1))
    assert (obs, reward, terminated, truncated) == (3 * 6 + 1, -1.0 - 1000.0, True, False)
    assert info["cell"].tolist() == [3, 1]
    with pytest.raises(ResetNeeded):
        env.step(0)

    env.reset(options={"start": [2, 5]})
    obs, reward, terminated, truncated, _ = env.step(action_index("down", 1, 1))
    assert (obs, reward, terminated, truncated) == (23, -1.0 + 100.0, True, False)

    env.reset(options={"start": [0, 0]})
    assert env.step(action_index("right", 1, 1))[1:4] == (-1.0, False, False)


def test_a_non_ground_cell_pays_its_reward_when_left():
    env = CarefulEnv("mud")
    env.reset(seed=0, options={"start": [1, 1]})
    assert env.step(action_index("up", 4, 14))[1] == -30.0 - 4.0


def test_the_step_limit_truncates():
    world = World(name="short", layout="..\n.G\n", levels=2, slip="none", max_steps=3, start=(0, 0))
    env = CarefulEnv(world)
    env.reset(seed=0)
    up = action_index("up", 2, 2)
    results = [env.step(up)[2:4] for _ in range(3)]
    assert results == [(False, False), (False, False), (False, True)]
    with pytest.raises(ResetNeeded):
        env.step(up)


def rollout(env, seed, steps=60):
    env.action_space.seed(seed)
    obs, _ = env.reset(seed=seed)
    trace = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        trace += [obs, reward, info["slipped"]]
        if terminated or truncated:
            obs, _ = env.reset()
            trace.append(obs)
    return trace


def test_same_seed_same_episodes_other_seed_other_episodes():
    assert rollout(CarefulEnv("paper"), 5) == rollout(CarefulEnv("paper"), 5)
    assert rollout(CarefulEnv("paper"), 5) != rollout(CarefulEnv("paper"), 6)


def test_both_action_spaces_are_the_same_moves():
    flat = CarefulEnv("paper")
    pairs = CarefulEnv("paper", action_space="multidiscrete")
    flat.reset(seed=3)
    pairs.reset(seed=3)
    for a in [0, 13, 14, 30, 55, 20, 41]:
        d, c0 = divmod(a, 14)
        got_flat, got_pairs = flat.step(a), pairs.step(np.array([d, c0]))
        assert got_flat[:4] == got_pairs[:4]
        assert got_flat[4]["carefulness"] == got_pairs[4]["carefulness"] == c0 + 1
        if got_flat[2]:
            break


def test_the_environment_replays_the_game_and_its_return_is_the_score_change():
    """With the same seed and moves, the game and the environment see the same world."""
    world = BUILTIN_WORLDS["paper"]
    seed = 11
    moves = [("right", 3), ("down", 1), ("down", 2), ("left", 1), ("right", 9)] * 8
    sink = Lines()
    game = Game(world, seed=seed, sink=sink)
    env = CarefulEnv(world)
    obs, _ = env.reset(seed=seed)
    for episode in range(3):
        start = game.begin_episode()
        if episode:
            obs, _ = env.reset()
        assert obs == cell_observation(start, world.cols)
        env_return = 0.0
        for direction, c in moves:
            result = game.move(direction, c)
            obs, reward, terminated, truncated, info = env.step(action_index(direction, c, world.levels))
            env_return += reward
            assert obs == cell_observation(result.step.next_state, world.cols)
            assert info["slipped"] == result.step.slipped
            if terminated or truncated:
                break
        end = result.end or game.quit()
        assert terminated == (end.outcome == "terminal")
        assert env_return == pytest.approx(end.return_)
        assert env_return == pytest.approx(end.score - world.initial_score)
        recorded = sum(s.reward for s in sink.steps if s.episode == episode)
        terminal_reward = world.reward_of(end.terminal_symbol) if end.terminal_symbol else 0.0
        assert env_return == pytest.approx(recorded + terminal_reward)
    assert {e.outcome for e in sink.ends} >= {"terminal"}


@pytest.mark.parametrize("start", [[3, 1], [3, 5], [4, 0], [0, 6], [-1, 0], [1], [1, 2, 3], "a", {"row": 1}, None])
def test_a_start_option_must_be_a_non_terminal_cell(start):
    env = CarefulEnv("paper")
    if start is None:  # no start given: the world's own start distribution
        assert env.reset(seed=1, options={"start": None})[0] in range(24)
        return
    with pytest.raises(ValueError, match="start"):
        env.reset(seed=1, options={"start": start})


def test_a_start_option_sets_the_first_cell():
    env = CarefulEnv("paper")
    obs, info = env.reset(seed=1, options={"start": (1, 4)})
    assert obs == 10 and info == {"cell": pytest.approx(np.array([1, 4])), "carefulness": 0, "slipped": False}


def test_the_world_may_be_a_name_a_file_a_world_or_its_fields(tmp_path):
    world = BUILTIN_WORLDS["mud"]
    path = tmp_path / "my.toml"
    path.write_text(world.to_toml(), encoding="utf-8")
    assert CarefulEnv(world).world == world
    assert CarefulEnv(str(path)).world == world
    assert CarefulEnv(world.model_dump(mode="json")).world == world
    with pytest.raises(WorldError, match="no world named"):
        CarefulEnv("no-such-world")
    with pytest.raises(ValueError, match="action_space"):
        CarefulEnv("paper", action_space="box")


def test_ansi_render_draws_the_board_and_the_last_move():
    env = CarefulEnv("paper-maxent", render_mode="ansi")
    env.reset(seed=0, options={"start": [2, 3]})
    assert env.render() == "......\n......\n...@..\n.CCCCG\nstep 0 of 200, return 0\n"
    env.step(action_index("up", 1, 1))
    assert env.render().splitlines()[1:] == ["...@..", "......", ".CCCCG",
                                             "step 1 of 200, return -1; last move up at carefulness 1"]
    assert CarefulEnv("paper").render() is None


def test_a_layout_with_control_characters_is_not_a_world():
    # Cells are printable symbols, so no rendering of a world can send a control sequence.
    with pytest.raises(ValueError, match="control or invisible character"):
        World(name="odd", layout="..\x1b\n..G\n", rewards={"G": 1.0}, start=(0, 0))


def test_an_action_outside_the_space_is_refused():
    env = CarefulEnv("paper-simple")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="not an action"):
        env.step(4)
    assert build_mdp(env.world).n_actions == 4
