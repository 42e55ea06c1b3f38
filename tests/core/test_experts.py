"""Computer experts and `careful simulate`: valid, possible, reproducible to the byte."""

import subprocess
import sys

import numpy as np
import pytest

from careful_tui.cli import main
from irl_core.players.experts import boltzmann_policy, optimal_policy, rollouts
from irl_core.recordings.demonstrations import read_recording
from irl_core.worlds.mdp import action_index, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def simulate(tmp_path, name, *extra):
    out = tmp_path / name
    code = main(["simulate", "--out", str(out), *extra])
    assert code == 0
    return out


def test_simulate_output_passes_the_reader_and_every_move_is_possible(tmp_path):
    out = simulate(tmp_path, "b.jsonl", "--world", "mud", "--policy", "boltzmann", "--beta", "0.5",
                   "--episodes", "50", "--seed", "3")
    recording = read_recording(out)
    mdp = build_mdp(recording.world)
    assert recording.header.player == "expert:boltzmann(beta=0.5)" and recording.header.seed == 3
    assert len(recording.episode_ends) == 50
    P = mdp.P
    for s in recording.steps:
        a = action_index(s.direction, s.carefulness, mdp.levels)
        row = P[mdp.state_of[s.state] * mdp.n_actions + a]
        assert row[0, mdp.state_of[s.next_state]] > 0


def test_scores_and_returns_add_up(tmp_path):
    recording = read_recording(simulate(tmp_path, "o.jsonl", "--world", "paper", "--policy", "optimal",
                                        "--episodes", "20", "--seed", "0"))
    world = recording.world
    for end in recording.episode_ends:
        steps = [s for s in recording.steps if s.episode == end.episode]
        assert len(steps) == end.steps and [s.t for s in steps] == list(range(end.steps))
        terminal = world.reward_of(end.terminal_symbol) if end.outcome == "terminal" else 0.0
        assert end.return_ == pytest.approx(sum(s.reward for s in steps) + terminal)
        assert end.score == pytest.approx(world.initial_score + end.return_)
        assert steps[-1].score == pytest.approx(end.score - terminal)
        assert steps[-1].next_state == tuple(steps[-1].next_state)


def test_same_seed_same_bytes_other_seed_other_bytes(tmp_path):
    args = ["--world", "paper", "--policy", "boltzmann", "--episodes", "30"]
    a = simulate(tmp_path, "a.jsonl", *args, "--seed", "7")
    b = simulate(tmp_path, "b.jsonl", *args, "--seed", "7")
    c = simulate(tmp_path, "c.jsonl", *args, "--seed", "8")
    assert a.read_bytes() == b.read_bytes() != c.read_bytes()


def test_simulate_refuses_to_overwrite(tmp_path, capsys):
    out = simulate(tmp_path, "a.jsonl", "--world", "paper", "--policy", "optimal", "--episodes", "1", "--seed", "0")
    assert main(["simulate", "--world", "paper", "--policy", "optimal", "--episodes", "1", "--seed", "0",
                 "--out", str(out)]) == 2
    assert "never overwritten" in capsys.readouterr().err


def test_optimal_expert_follows_the_optimal_policy():
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    policy = optimal_policy(mdp)
    result = rollouts(mdp, policy, episodes=500, seed=1)
    assert (policy[result.state, result.action] == 1.0).all()
    # The slip rate matches 2^-c on average.
    slipped = result.direction != mdp.direction[result.action]
    expected = (2.0 ** -mdp.carefulness[result.action]).mean()
    assert abs(slipped.mean() - expected) < 0.02


def test_boltzmann_action_frequencies_match_the_policy():
    mdp = build_mdp(BUILTIN_WORLDS["paper-maxent"])
    policy = boltzmann_policy(mdp, beta=0.1)
    demos = rollouts(mdp, policy, episodes=3000, seed=2)
    s = mdp.state_of[(0, 0)]
    at_s = demos.action[demos.state == s]
    freq = np.bincount(at_s, minlength=mdp.n_actions) / at_s.size
    np.testing.assert_allclose(freq, policy[s], atol=0.05)


def test_worlds_command_and_bad_usage_exit_codes(tmp_path):
    run = [sys.executable, "-m", "careful_tui.cli"]
    ok = subprocess.run([*run, "worlds"], capture_output=True, text=True)
    assert ok.returncode == 0 and "mud-simple" in ok.stdout
    shown = subprocess.run([*run, "worlds", "--show", "mud"], capture_output=True, text=True)
    assert shown.returncode == 0 and 'U = -30.0' in shown.stdout.replace('"U"', "U")
    bad = subprocess.run([*run, "worlds", "--show", "nowhere"], capture_output=True, text=True)
    assert bad.returncode == 2 and "no world named 'nowhere'" in bad.stderr and "Traceback" not in bad.stderr
    usage = subprocess.run([*run, "simulate", "--world", "paper"], capture_output=True, text=True)
    assert usage.returncode == 2 and "required" in usage.stderr
    bad_world = tmp_path / "w.toml"
    bad_world.write_text('layout = """\n..\n...\n"""\n')
    sim = subprocess.run([*run, "simulate", "--world", str(bad_world), "--policy", "optimal", "--episodes", "1",
                          "--seed", "0", "--out", str(tmp_path / "x.jsonl")], capture_output=True, text=True)
    assert sim.returncode == 2 and "ragged" in sim.stderr and "Traceback" not in sim.stderr


def test_demonstrations_of_rollouts_equal_the_written_file(tmp_path):
    from irl_core.players.experts import demonstrations_of, write_rollouts
    from irl_core.recordings.demonstrations import Demonstrations

    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    result = rollouts(mdp, boltzmann_policy(mdp, beta=1.0), episodes=25, seed=4)
    direct = demonstrations_of(mdp, result)
    read = Demonstrations.read([write_rollouts(tmp_path / "r.jsonl", mdp, result, player="x", seed=4)])
    np.testing.assert_array_equal(direct.counts, read.counts)
    assert (direct.episodes, direct.steps) == (read.episodes, read.steps)
