"""Numbers JSON cannot hold never get in or out: flags, worlds, experts that did not converge, huge runs.

`--rmax inf`, `--lambda inf`, `--beta inf/1e308`, `--seed -1` and a world whose costs overflow are
refused with exit 2 and one line; a Boltzmann expert with a huge but finite beta is a finite
policy; value iteration that stops at its cap is not recorded as an expert; simulate rolls out
a block of episodes at a time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hardening_checks import RAW_CONTROL, assert_refused, careful, recording

import irl_core.players.experts as experts
from irl_core.errors import NotConverged
from irl_core.players.experts import optimal_policy, rollouts, simulate_to_file, write_rollouts
from irl_core.recordings.demonstrations import read_recording
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import soft_value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS, World

SIMULATE = ["simulate", "--world", "paper", "--policy", "boltzmann", "--episodes", "2"]


@pytest.mark.parametrize(("flag", "value"), [
    ("--rmax", "inf"), ("--rmax", "nan"), ("--lambda", "inf"), ("--lambda", "nan"),
    ("--beta", "inf"), ("--beta", "1e308"), ("--rmax", "-inf"),
])
def test_fit_refuses_numbers_json_cannot_hold(tmp_path, capsys, flag, value):
    rec = recording(tmp_path / "a.jsonl", episodes=1)
    assert_refused(*careful(capsys, "fit", rec, "--no-view", f"{flag}={value}"), flag, "finite")


@pytest.mark.parametrize(("flag", "value", "problem"), [
    ("--beta", "inf", "finite"), ("--beta", "1e308", "finite"), ("--beta", "nan", "finite"),
    ("--seed", "-1", "from 0 to 2**64 - 1"), ("--seed", str(2**64), "from 0 to 2**64 - 1"),
])
def test_simulate_refuses_bad_numbers(tmp_path, capsys, flag, value, problem):
    args = {"--beta": "1", "--seed": "0", flag: value}
    line = assert_refused(*careful(capsys, *SIMULATE, "--beta", args["--beta"], "--seed", args["--seed"],
                                   "--out", tmp_path / "o.jsonl"), flag, problem)
    assert "usage" not in line and list(tmp_path.iterdir()) == []


def test_play_refuses_a_negative_seed(tmp_path, capsys):
    assert_refused(*careful(capsys, "play", "--out", tmp_path / "rec", "--seed", "-1"), "--seed")
    assert not (tmp_path / "rec").exists()


def test_a_huge_finite_beta_is_a_finite_near_greedy_policy(tmp_path, capsys):
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    policy = soft_value_iteration(mdp, beta=1e300).policy
    assert np.isfinite(policy).all() and np.allclose(policy.sum(axis=1), 1.0)
    assert np.array_equal(policy.argmax(axis=1), optimal_policy(mdp).argmax(axis=1))
    status, _, err = careful(capsys, *SIMULATE, "--beta", "1e300", "--seed", "0", "--out", tmp_path / "o.jsonl")
    assert status == 0, err
    text = (tmp_path / "o.jsonl").read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert len(read_recording(tmp_path / "o.jsonl").episodes) == 2


@pytest.mark.parametrize(("line", "problem"), [
    ("cost_per_level = 1e308", "the most careful move may cost at most"),
    ("cost_per_level = 1e11", "the most careful move may cost at most"),
    ("[rewards]\nG = 1e308", "rewards are at most"),
    ("initial_score = -1e300", "initial_score"),
    ("max_steps = 9223372036854775807", "max_steps"),
])
def test_a_world_whose_numbers_overflow_is_refused(tmp_path, capsys, line, problem):
    world = tmp_path / "w.toml"
    world.write_text(f'layout = """\n...\n.CG\n"""\n{line}\n')
    assert_refused(*careful(capsys, "simulate", "--world", world, "--policy", "optimal", "--episodes", "2",
                            "--seed", "0", "--out", tmp_path / "o.jsonl"), "w.toml", problem)
    assert not (tmp_path / "o.jsonl").exists()


def test_value_iteration_stopped_at_its_cap_is_not_an_expert(tmp_path, capsys):
    world = tmp_path / "slow.toml"
    # Staying on U forever is worth 1e7: the values creep up by gamma^k and never settle in 10,000 sweeps.
    world.write_text('layout = """\nU.\n"""\ngamma = 0.9999999\ncost_per_level = 0.0\n[rewards]\nU = 1.0\n')
    line = assert_refused(*careful(capsys, "simulate", "--world", world, "--policy", "optimal", "--episodes", "2",
                                   "--seed", "0", "--out", tmp_path / "o.jsonl"), "did not converge", "10,000 sweeps")
    assert "gamma = 0.9999999" in line and not (tmp_path / "o.jsonl").exists()
    with pytest.raises(NotConverged):
        optimal_policy(build_mdp(World(layout="U.\n", gamma=0.9999999, cost_per_level=0.0, rewards={"U": 1.0})))


def test_simulate_rolls_out_a_block_at_a_time_and_numbers_episodes_on(tmp_path, monkeypatch):
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    policy = optimal_policy(mdp)
    sizes = []
    real = experts.rollouts
    monkeypatch.setattr(experts, "rollouts", lambda *a, **k: sizes.append(k["episodes"]) or real(*a, **k))
    ended = simulate_to_file(tmp_path / "b.jsonl", mdp, policy, episodes=10, seed=5, player="x", block=4)
    assert sizes == [4, 4, 2] and sum(ended.values()) == 10
    rec = read_recording(tmp_path / "b.jsonl")
    assert rec.episodes == list(range(10)) and [e.episode for e in rec.episode_ends] == list(range(10))


def test_one_block_writes_the_same_bytes_as_one_rollout(tmp_path):
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    policy = optimal_policy(mdp)
    simulate_to_file(tmp_path / "a.jsonl", mdp, policy, episodes=30, seed=2, player="x", block=100)
    write_rollouts(tmp_path / "b.jsonl", mdp, rollouts(mdp, policy, episodes=30, seed=2), player="x", seed=2)
    assert (tmp_path / "a.jsonl").read_bytes() == (tmp_path / "b.jsonl").read_bytes()


def test_no_step_line_holds_a_number_json_cannot(tmp_path):
    text = recording(tmp_path / "a.jsonl", world="mud", episodes=50).read_text()
    assert "NaN" not in text and "Infinity" not in text and not RAW_CONTROL.search(text)
    assert all(math.isfinite(s.score) for s in read_recording(tmp_path / "a.jsonl").steps)


def test_long_episodes_make_smaller_blocks(tmp_path, monkeypatch):
    # 1,000,000 steps allowed per episode: a block of 10,000 episodes could hold 1e10 steps.
    mdp = build_mdp(World(layout="...\n.CG\n", max_steps=1_000_000, start=(0, 0)))
    sizes = []
    real = experts.rollouts
    monkeypatch.setattr(experts, "rollouts", lambda *a, **k: sizes.append(k["episodes"]) or real(*a, **k))
    simulate_to_file(tmp_path / "b.jsonl", mdp, optimal_policy(mdp), episodes=5, seed=0, player="x")
    assert sizes == [2, 2, 1]
