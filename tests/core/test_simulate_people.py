"""`careful simulate --policy loose|timed|hasty|inverted|reckless`: person-like players recorded as computer
experts are, so every command reads them; their options set them, or are named as ignored."""

import numpy as np
import pytest

from careful_tui.cli import main
from irl_core.experiment.run import human_sessions
from irl_core.irl import fit
from irl_core.players.person_like import KINDS, TIME_KINDS
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.worlds.mdp import action_index, build_mdp


def careful_simulate(capsys, tmp_path, name, *extra) -> tuple:
    out = tmp_path / name
    try:
        code = main(["simulate", "--out", str(out), *map(str, extra)])
    except SystemExit as exc:  # argparse refuses a bad option's value
        code = exc.code
    return code, out, capsys.readouterr().err


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_person_like_player_writes_a_recording_the_reader_takes_with_possible_moves(capsys, tmp_path, kind):
    # A player that holds for a time plays a time world; the others a world of levels.
    world = "mud-time" if kind in TIME_KINDS else "walls"
    code, out, err = careful_simulate(capsys, tmp_path, f"{kind}.jsonl", "--world", world, "--policy", kind,
                                      "--episodes", "40", "--seed", "3")
    assert code == 0 and "wrote 40 episodes" in err
    recording = read_recording(out)
    assert recording.header.player.startswith(f"person:{kind}(") and recording.header.seed == 3
    assert len(recording.episode_ends) == 40
    mdp = build_mdp(recording.world)
    for step in recording.steps:
        row = mdp.P[mdp.state_of[step.state] * mdp.n_actions + action_index(step.direction, step.level, mdp.levels)]
        assert row[0, mdp.state_of[step.next_state]] > 0


def test_a_person_like_recording_is_a_persons_and_fits_like_one(capsys, tmp_path):
    code, out, _ = careful_simulate(capsys, tmp_path, "loose.jsonl", "--world", "mud", "--policy", "loose",
                                    "--episodes", "20", "--seed", "1")
    assert code == 0
    recording = read_recording(out)
    # the experiment's human stage takes every recording not played by an `expert:`
    assert human_sessions(tmp_path, recording.world)[0] == [out]
    result = fit(Demonstrations.from_recordings([recording]), method="auto")
    assert result.method == "maxent"  # a person's noisy play, not one optimal policy


def test_the_same_seed_writes_the_same_bytes(capsys, tmp_path):
    args = ("--world", "mud", "--policy", "timed", "--episodes", "30")
    a = careful_simulate(capsys, tmp_path, "a.jsonl", *args, "--seed", "7")[1]
    b = careful_simulate(capsys, tmp_path, "b.jsonl", *args, "--seed", "7")[1]
    c = careful_simulate(capsys, tmp_path, "c.jsonl", *args, "--seed", "8")[1]
    assert a.read_bytes() == b.read_bytes() != c.read_bytes()


def test_options_set_the_player_and_its_name(capsys, tmp_path):
    code, out, err = careful_simulate(capsys, tmp_path, "r.jsonl", "--world", "mud", "--policy", "reckless",
                                      "--lapse", "0", "--episodes", "30", "--seed", "0")
    recording = read_recording(out)
    assert code == 0 and recording.header.player == "person:reckless(lapse=0)" and "warning" not in err
    assert {step.carefulness for step in recording.steps} == {1}
    code, out, _ = careful_simulate(capsys, tmp_path, "h.jsonl", "--world", "mud", "--policy", "hasty",
                                    "--temperature", "2", "--bias", "0", "--spread", "0", "--episodes", "5",
                                    "--seed", "0")
    assert read_recording(out).header.player == "person:hasty(temperature=2, bias=0, spread=0)"


@pytest.mark.parametrize(("policy", "options", "wanted"), [
    ("loose", ["--beta", "2"], ["warning: --beta applies only to --policy boltzmann; ignored"]),
    ("timed", ["--spread", "2"], ["warning: --spread applies only to --policy loose, hasty, inverted, streaky, growing and "
                                       "learning; ignored"]),
    ("optimal", ["--weber", "0.3", "--bias", "1"], ["warning: --weber applies only to --policy timed and timing; ignored",
                                                    "warning: --bias applies only to --policy hasty; ignored"]),
    ("boltzmann", ["--lapse", "0.2"],
     ["warning: --lapse applies only to --policy loose, timed, inverted, reckless, timing, steady, streaky, growing "
      "and learning; ignored"]),
    ("inverted", ["--lapse", "0.2", "--spread", "1"], []),
    ("loose", ["--streak", "3", "--fear", "0.5"], ["warning: --streak applies only to --policy streaky; ignored",
                                                   "warning: --fear applies only to --policy learning; ignored"]),
    ("learning", ["--fear", "0.5", "--half-life", "2", "--spread", "1"], []),
])
def test_an_option_the_player_does_not_take_is_named_and_ignored(capsys, tmp_path, policy, options, wanted):
    code, out, err = careful_simulate(capsys, tmp_path, "x.jsonl", "--world", "mud", "--policy", policy, *options,
                                      "--episodes", "2", "--seed", "0")
    assert code == 0 and out.exists()
    assert [line for line in err.splitlines() if line.startswith("warning:")] == wanted


@pytest.mark.parametrize(("option", "value"), [("--lapse", "1.5"), ("--spread", "-1"), ("--temperature", "0")])
def test_a_bad_parameter_is_refused_before_anything_is_written(capsys, tmp_path, option, value):
    code, out, err = careful_simulate(capsys, tmp_path, "x.jsonl", "--world", "mud", "--policy", "hasty", option,
                                      value, "--episodes", "2", "--seed", "0")
    assert code == 2 and not out.exists() and option in err and len(err.strip().splitlines()) == 1


def test_a_lapse_of_zero_follows_the_optimal_directions(capsys, tmp_path):
    from irl_core.players.experts import optimal_plan

    code, out, _ = careful_simulate(capsys, tmp_path, "l.jsonl", "--world", "walls", "--policy", "loose",
                                    "--lapse", "0", "--episodes", "30", "--seed", "2")
    assert code == 0
    recording = read_recording(out)
    mdp = build_mdp(recording.world)
    best = optimal_plan(mdp).greedy
    directions = np.array([mdp.direction[best[mdp.state_of[step.state]]] for step in recording.steps])
    assert [("up", "right", "down", "left")[d] for d in directions] == [step.direction for step in recording.steps]


@pytest.mark.parametrize("kind, world", [("timing", "walls"), ("timed", "mud-time")])
def test_a_player_on_the_wrong_kind_of_world_is_one_line(capsys, tmp_path, kind, world):
    code, out, err = careful_simulate(capsys, tmp_path, "x.jsonl", "--world", world, "--policy", kind,
                                      "--episodes", "5", "--seed", "1")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "time world" in err and not out.exists()
