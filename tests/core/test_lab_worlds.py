"""Other labs' tasks as world files: a fixed slip split and moves into a wall dropped (docs/worlds.md, "A task from
another lab"), each rule followed by the game, the simulators, the reader, the Gymnasium env and the fit."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from careful_tui.cli import main
from irl_core.errors import RecordingError, WorldError
from irl_core.play.game import Game
from irl_core.players.experts import optimal_policy, rollouts, write_rollouts
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import SessionRecorder
from irl_core.worlds.env import CarefulEnv
from irl_core.worlds.mdp import DIRECTIONS, build_mdp
from irl_core.worlds.moves import moves_of
from irl_core.worlds.world import World, load_world, world_from_dict

# A slippery grid as another lab wrote it: 0.76 the chosen way, 0.09 / 0.05 / 0.10 to the others in the order
# left, up, right, down (the chosen one left out); a move into a wall or off the grid is not made.
SPLIT = {"intended": 0.76, "others": [0.09, 0.05, 0.10]}
LAB_TOML = '''name = "slippery"
layout = """
.....
.#.#.
.....
.C.CG
"""
levels = 1
cost_per_level = 0
slip = {intended = 0.76, others = [0.09, 0.05, 0.10]}
bump = "drop"
start = [0, 0]
max_steps = 60
[rewards]
C = -10.0
G = 10.0
'''


def lab_world(**changes) -> World:
    return world_from_dict({**load_world_text(LAB_TOML).model_dump(), **changes})


def load_world_text(text: str) -> World:
    import tomllib

    return world_from_dict(tomllib.loads(text))


class ListSink:
    def __init__(self) -> None:
        self.lines: list[Step | EpisodeEnd] = []

    def write_step(self, step: Step) -> None:
        self.lines.append(step)

    def end_episode(self, end: EpisodeEnd) -> None:
        self.lines.append(end)


# ------------------------------------------------------------------ the world file


def test_the_split_gives_the_others_in_the_order_left_up_right_down_without_the_chosen_one():
    split = lab_world().direction_split()[0]  # [chosen, realised], both in action order up, right, down, left
    by_name = {(DIRECTIONS[d], DIRECTIONS[k]): split[d, k] for d in range(4) for k in range(4)}
    # chosen up: left 0.09, right 0.05, down 0.10; chosen left: up 0.09, right 0.05, down 0.10
    assert by_name["up", "up"] == by_name["left", "left"] == 0.76
    assert (by_name["up", "left"], by_name["up", "right"], by_name["up", "down"]) == (0.09, 0.05, 0.10)
    assert (by_name["left", "up"], by_name["left", "right"], by_name["left", "down"]) == (0.09, 0.05, 0.10)
    assert (by_name["down", "left"], by_name["down", "up"], by_name["down", "right"]) == (0.09, 0.05, 0.10)
    assert (by_name["right", "left"], by_name["right", "up"], by_name["right", "down"]) == (0.09, 0.05, 0.10)
    assert lab_world(levels=3).slip_chances == pytest.approx((0.24, 0.24, 0.24))


def test_a_lab_world_reads_back_from_its_toml_and_a_stay_worlds_header_is_as_before():
    world = lab_world()
    assert load_world_text(world.to_toml()) == world
    assert world.model_dump()["bump"] == "drop" and world.model_dump()["slip"]["intended"] == 0.76
    # bump = "stay" is the default and a header leaves it out: a recording of an old world is the same bytes.
    assert "bump" not in lab_world(bump="stay").model_dump() and "bump" not in lab_world(bump="stay").to_toml()


@pytest.mark.parametrize("line, named", [
    ("slip = {intended = 0.76, others = [0.09, 0.05, 0.11]}", "slip.others"),
    ("slip = {intended = 0.76, others = [0.14, 0.10]}", "slip.others"),
    ("slip = {intended = 0.76, others = [0.09, 0.05, 0.05, 0.05]}", "slip.others"),
    ("slip = {intended = 1.06, others = [-0.06, 0.0, 0.0]}", "slip.others[0]"),
    ("slip = {intended = -0.1, others = [0.5, 0.3, 0.3]}", "slip.intended"),
    ("slip = {intended = 0.76}", "slip.others"),
    ("slip = {intended = 0.76, others = [0.09, 0.05, 0.10], spread = 1}", "slip.spread"),
    ('slip = "sometimes"', "slip"),
    ('bump = "bounce"', "bump"),
    ("bump = 1", "bump"),
])
def test_a_bad_slip_or_bump_refuses_the_world_file_in_one_line_naming_the_field(tmp_path, capsys, line, named):
    path = tmp_path / "bad.toml"
    text = "\n".join(row for row in LAB_TOML.splitlines() if not row.startswith(line.split(" ")[0] + " "))
    path.write_text(text.replace("start = [0, 0]", f"{line}\nstart = [0, 0]"))
    assert main(["worlds", "--show", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err and f"{named}:" in err


def test_a_time_world_keeps_the_stay_rule_and_its_own_slip():
    with pytest.raises(WorldError, match="bump"):
        world_from_dict({"layout": "..G\n", "care": "time", "bump": "drop"})
    with pytest.raises(WorldError, match="slip"):
        world_from_dict({"layout": "..G\n", "care": "time", "slip": SPLIT})


def test_careful_worlds_show_prints_the_rules(capsys, tmp_path):
    path = tmp_path / "slippery.toml"
    path.write_text(LAB_TOML)
    assert main(["worlds", "--show", str(path)]) == 0
    out = capsys.readouterr().out
    assert "slip 0.76/0.09/0.05/0.1, bump drop" in out
    assert "the chosen way 0.76, the others 0.09 / 0.05 / 0.1 (in the order left, up, right, down" in out
    assert "bump: drop: a move into a wall or off the grid is not made and not recorded" in out
    assert "step limit: 60 steps" in out and "moves cost nothing" in out


@settings(max_examples=40, deadline=None)
@given(chances=st.lists(st.integers(0, 20), min_size=4, max_size=4).filter(lambda c: sum(c) > 0),
       bump=st.sampled_from(["stay", "drop"]), walls=st.lists(st.booleans(), min_size=6, max_size=6))
def test_every_split_and_bump_rule_gives_rows_of_p_that_sum_to_one_and_a_drop_world_no_needless_stay(chances, bump,
                                                                                                    walls):
    total = sum(chances)
    slip = {"intended": chances[0] / total, "others": [c / total for c in chances[1:]]}
    # Fix the rounding so the four sum to 1 exactly as the file's check asks (within 1e-9).
    slip["intended"] = 1.0 - sum(slip["others"])
    middle = "".join("#" if wall else "." for wall in walls)
    world = world_from_dict({"layout": f"......\n{middle}\n.CCCCG\n", "levels": 2, "slip": slip, "bump": bump,
                             "rewards": {"C": -10.0, "G": 1.0}})
    mdp = build_mdp(world)
    S, A = mdp.n_states, mdp.n_actions
    P = mdp.P.toarray().reshape(S, A, S)
    np.testing.assert_allclose(P.sum(axis=2), 1.0, atol=1e-12)
    moves = moves_of(mdp)
    X = np.random.default_rng(0).normal(size=(S, A))
    np.testing.assert_allclose(moves.pulled_back(X), np.einsum("sa,sat->t", X, P), atol=1e-10)
    for s in np.flatnonzero(mdp.nonterminal):
        for a in range(A):
            can_move = (mdp.split[a] * mdp.leads[s]).sum() > 0
            if bump == "drop" and can_move:
                assert P[s, a, s] == 0.0  # every step that is made leaves the cell
            elif bump == "stay":
                assert P[s, a, s] == pytest.approx(mdp.split[a][~mdp.leads[s]].sum())


# ------------------------------------------------------------------ the game


def test_a_dropped_move_makes_no_step_and_leaves_count_score_and_cell_alone():
    sink = ListSink()
    game = Game(lab_world(slip="none"), seed=0, sink=sink)
    game.begin_episode()
    assert game.move("up", 1) is None and game.move("left", 1) is None  # off the grid from the top-left corner
    assert sink.lines == [] and game.t == 0 and game.score == 200.0 and game.cell == (0, 0)
    result = game.move("down", 1)
    assert result is not None and result.step.next_state == (1, 0) and game.t == 1
    assert game.move("right", 1) is None  # into the wall at (1, 1)
    assert len(sink.lines) == 1


def test_a_stay_world_records_the_same_move_as_a_step_that_stays():
    sink = ListSink()
    game = Game(lab_world(slip="none", bump="stay"), seed=0, sink=sink)
    game.begin_episode()
    result = game.move("up", 1)
    assert result is not None and result.step.next_state == result.step.state == (0, 0) and game.t == 1


def play_episodes(world: World, sink, *, episodes: int, seed: int) -> int:
    """Play the optimal policy through the game, pressing again after a dropped move; returns the drops."""
    mdp = build_mdp(world)
    policy = optimal_policy(mdp)
    game, dropped = Game(world, seed=seed, sink=sink), 0
    for _ in range(episodes):
        game.begin_episode()
        while game.live:
            assert game.cell is not None
            d, c = divmod(int(policy[mdp.state_of[game.cell]].argmax()), world.levels)
            if game.move(DIRECTIONS[d], c + 1) is None:
                dropped += 1
    return dropped


def test_a_drop_worlds_episodes_hold_no_step_that_stays_and_step_limits_count_made_steps():
    sink = ListSink()
    dropped = play_episodes(lab_world(), sink, episodes=60, seed=3)
    steps = [line for line in sink.lines if isinstance(line, Step)]
    ends = [line for line in sink.lines if isinstance(line, EpisodeEnd)]
    assert dropped > 0 and len(ends) == 60
    assert all(step.next_state != step.state for step in steps)
    assert sum(end.steps for end in ends) == len(steps)


def transition_counts(world: World, *, presses: int, seed: int) -> np.ndarray:
    """(S, A, S) where the game's steps went, counted from each acting cell and action, pressing each key until
    `presses` steps were made: the game's own sampling and drops, not P."""
    mdp = build_mdp(world)
    counts = np.zeros((mdp.n_states, mdp.n_actions, mdp.n_states))
    game = Game(world.model_copy(update={"max_steps": 10**6}), seed=seed, sink=ListSink())
    for s in np.flatnonzero(mdp.nonterminal):
        for a in range(mdp.n_actions):
            d, c = divmod(a, world.levels)
            made = tries = 0
            while made < presses and tries < 50 * presses:
                tries += 1
                if not game.live:
                    game.begin_episode()
                game.cell = mdp.cells[s]
                result = game.move(DIRECTIONS[d], c + 1)
                if result is not None:
                    counts[s, a, mdp.state_of[result.step.next_state]] += 1
                    made += 1
                    if result.end is not None:
                        game.begin_episode()
    return counts


@pytest.mark.parametrize("bump", ["drop", "stay"])
def test_the_fits_mdp_is_where_the_games_steps_go(bump, tmp_path, capsys):
    world = lab_world(bump=bump, levels=2, cost_per_level=0.5)
    # The MDP a fit builds: from the world a recording's header holds, read back through careful fit's JSON.
    path = tmp_path / "rec.jsonl"
    mdp0 = build_mdp(world)
    write_rollouts(path, mdp0, rollouts(mdp0, optimal_policy(mdp0), episodes=20, seed=0), player="expert:optimal",
                   seed=0)
    assert main(["fit", str(path), "--no-view", "--json", str(tmp_path / "fit.json")]) == 0
    capsys.readouterr()
    fitted_world = world_from_dict(json.loads((tmp_path / "fit.json").read_text())["world"])
    assert fitted_world == world
    mdp = build_mdp(fitted_world)
    n = 800
    counts = transition_counts(world, presses=n, seed=1)
    acting = np.flatnonzero(mdp.nonterminal)
    P = mdp.P.toarray().reshape(mdp.n_states, mdp.n_actions, mdp.n_states)[acting]
    seen = counts[acting] / n
    # Each entry within 5 binomial standard errors (about 4,000 entries: a false alarm is below 1 in 10^3).
    tolerance = 5 * np.sqrt(P * (1 - P) / n) + 1e-12
    assert np.all(np.abs(seen - P) <= tolerance), np.abs(seen - P).max()
    stays = np.einsum("sas->sa", counts[:, :, :])[acting]
    assert (stays.sum() == 0) == (bump == "drop")


# ------------------------------------------------------------------ the simulators and the env


def test_simulated_players_on_a_drop_world_never_stay_and_go_where_p_says():
    world = lab_world()
    mdp = build_mdp(world)
    rng = np.random.default_rng(0)
    policy = rng.random((mdp.n_states, mdp.n_actions))
    policy /= policy.sum(axis=1, keepdims=True)
    result = rollouts(mdp, policy, episodes=3000, seed=2)
    assert not np.any(result.state == result.next_state)
    counts = np.zeros((mdp.n_states, mdp.n_actions, mdp.n_states))
    np.add.at(counts, (result.state, result.action, result.next_state), 1)
    n = counts.sum(axis=2, keepdims=True)
    P = mdp.P.toarray().reshape(counts.shape)
    enough = n[..., 0] >= 200
    tolerance = 5 * np.sqrt(P * (1 - P) / np.maximum(n, 1)) + 1e-12
    assert enough.sum() > 20 and np.all((np.abs(counts / np.maximum(n, 1) - P) <= tolerance)[enough])


def test_the_gymnasium_env_of_a_drop_world_never_stays():
    env = CarefulEnv(lab_world(max_steps=10**5))
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(400):
        before = env._state
        after, _, terminated, truncated, _ = env.step(int(rng.integers(4)))
        assert after != before
        if terminated or truncated:
            env.reset()


# ------------------------------------------------------------------ recordings and the fit


def header(world: World) -> SessionHeader:
    return SessionHeader(world=world, player="tester", created=datetime(2000, 1, 1, tzinfo=UTC), seed=0)


def test_a_played_drop_world_recording_reads_back_and_is_refitted(tmp_path, capsys):
    world = lab_world(levels=3, cost_per_level=1.0)
    recorder = SessionRecorder(tmp_path / "rec", header(world))
    play_episodes(world, recorder, episodes=40, seed=5)
    recorder.close()
    (path,) = recorder.paths
    recording = read_recording(path)
    assert recording.world == world and len(recording.steps) > 100
    assert all(step.next_state != step.state for step in recording.steps)
    assert main(["fit", str(path), "--no-view", "--json", str(tmp_path / "fit.json")]) == 0
    capsys.readouterr()
    fit = json.loads((tmp_path / "fit.json").read_text())
    reward = np.array(fit["reward"], dtype=float)
    assert fit["world"]["bump"] == "drop" and fit["status"] == "optimal"
    assert reward[3, 1] < reward[3, 4] and reward[3, 3] < reward[3, 4]  # both cliffs below the goal


def lines_of(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def rewrite(path: Path, lines: list[dict]) -> Path:
    out = path.with_name("edited.jsonl")
    out.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return out


def test_the_reader_refuses_a_step_that_stays_in_a_drop_world_and_a_direction_the_split_never_takes(tmp_path):
    world = lab_world(slip={"intended": 0.8, "others": [0.2, 0.0, 0.0]})  # chosen right: only left besides
    recorder = SessionRecorder(tmp_path / "rec", header(world))
    game = Game(world, seed=0, sink=recorder)
    game.begin_episode()
    while game.move("right", 1) is None:
        pass
    recorder.close()
    (path,) = recorder.paths
    lines = lines_of(path)
    step = next(line for line in lines if line["kind"] == "step")
    assert step["state"] == [0, 0] and step["next_state"] == [0, 1] and step["realised"] == "right"
    stay = dict(step, next_state=[0, 0], realised=None)
    with pytest.raises(RecordingError, match=r"next_state: .*bump = \"drop\""):
        read_recording(rewrite(path, [lines[0], stay]))
    down = dict(step, next_state=[1, 0], realised="down", slipped=True)
    with pytest.raises(RecordingError, match=r"next_state: the world cannot move from \[0, 0\] to \[1, 0\]"):
        read_recording(rewrite(path, [lines[0], down]))
    # In a stay world the same stay is a move the world makes (a slip left, off the grid), but not by way of up,
    # which this split never takes for a move chosen right.
    lines[0]["world"].pop("bump")
    left = dict(step, next_state=[0, 0], realised="left", slipped=True)
    assert read_recording(rewrite(path, [lines[0], left])).steps[0].next_state == (0, 0)
    up = dict(left, realised="up")
    with pytest.raises(RecordingError, match=r"realised: up: a step chosen right from \[0, 0\] never goes that way"):
        read_recording(rewrite(path, [lines[0], up]))


def test_a_drop_move_in_the_play_session_says_so_and_records_nothing(tmp_path):
    from irl_core.play.session import PlayOptions, new_session

    made = new_session(lab_world(slip="none"), out=tmp_path / "rec", seed=1,
                       options=PlayOptions(input_mode="digits"), app_version="test")
    made.start()
    assert made.press("up").moves == ()
    assert made.view().message.text == "up: blocked, no move made" and made.view().step == 0
    assert [move.step.next_state for move in made.press("down").moves] == [(1, 0)]
    made.quit()
    (path,) = made.recorder.paths
    assert [step.direction for step in read_recording(path).steps] == ["down"]


def test_load_world_reads_the_lab_file(tmp_path):
    path = tmp_path / "slippery.toml"
    path.write_text(LAB_TOML)
    assert load_world(path) == lab_world()


def test_the_manuals_worked_example_is_this_world_and_shows_as_the_manual_says(tmp_path, capsys):
    manual = (Path(__file__).parents[2] / "docs" / "worlds.md").read_text("utf-8")
    section = manual.split("## A task from another lab", 1)[1].split("\n## ", 1)[0]
    toml = section.split("```toml\n", 1)[1].split("```", 1)[0]
    shown = section.split("```text\n", 1)[1].split("```", 1)[0]
    assert load_world_text(toml) == lab_world()
    path = tmp_path / "slippery.toml"
    path.write_text(toml)
    assert main(["worlds", "--show", str(path)]) == 0
    out = capsys.readouterr().out
    for line in shown.strip().splitlines():
        assert line in out
