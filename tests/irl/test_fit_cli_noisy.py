"""`careful fit` on a person's kind of recording: auto, confidence intervals, evaluation, bad input."""

import json
from datetime import UTC, datetime

import numpy as np
import pytest

from careful_tui.cli import main
from irl_core.players.experts import optimal_policy
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.mdp import DIRECTIONS, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def person_like(path, *, episodes=12, seed=0):
    """Mostly the optimal direction (one move in ten elsewhere), a level within ±3 of the optimal one."""
    world = BUILTIN_WORLDS["paper"]
    mdp = build_mdp(world)
    best = optimal_policy(mdp).argmax(axis=1)
    rng = np.random.default_rng(seed)
    header = SessionHeader(world=world, player="person", created=datetime(2000, 1, 1, tzinfo=UTC), seed=seed)
    starts = [mdp.state_of[cell] for cell in world.start_cells]
    with RecordingWriter(path, header) as writer:
        for episode in range(episodes):
            s, score, total = int(rng.choice(starts)), 200.0, 0.0
            for t in range(200):
                d, c = divmod(int(best[s]), world.levels)
                if rng.random() < 0.1:
                    d = int(rng.integers(4))
                c = int(np.clip(c + 1 + rng.integers(-3, 4), 1, world.levels))
                a = d * world.levels + c - 1
                s_next, realised = mdp.move(s, a, rng)
                reward = float(mdp.reward_matrix()[s, a])
                score += reward
                total += reward
                writer.write_step(Step(episode=episode, t=t, state=mdp.cells[s], direction=DIRECTIONS[d],
                                       carefulness=c, hold_ms=None, next_state=mdp.cells[s_next],
                                       slipped=realised != d, reward=reward, score=score))
                s = s_next
                if not mdp.nonterminal[s]:
                    break
            symbol = mdp.symbols[s] if not mdp.nonterminal[s] else None
            end_reward = float(mdp.R_S[s]) if symbol else 0.0
            writer.end_episode(EpisodeEnd(episode=episode, outcome="terminal" if symbol else "step_limit",
                                          terminal_symbol=symbol, steps=t + 1, **{"return": total + end_reward},
                                          score=score + end_reward))
    return path


@pytest.fixture(scope="module")
def person_file(tmp_path_factory):
    return person_like(tmp_path_factory.mktemp("person") / "person.jsonl")


def run(capsys, *argv):
    code = main(["fit", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def test_a_person_like_recording_fits_by_default_with_an_interval_for_every_unknown(tmp_path, capsys, person_file):
    out_json = tmp_path / "fit.json"
    code, out, err = run(capsys, person_file, "--intervals", "--resamples", "40", "--no-view", "--json", out_json)
    assert code == 0, err
    data = json.loads(out_json.read_text())
    assert data["method"] == "maxent" and data["interval_kind"] == "confidence"
    assert data["options"]["beta_auto"] is True and data["options"]["beta"] > 0
    cells = [(r, c) for r, row in enumerate(data["unknown"]) for c, unknown in enumerate(row) if unknown]
    assert cells and all(data["interval"][r][c] is not None for r, c in cells)
    assert "auto chose maxent" in out and "95% confidence intervals" in out
    assert "An agent trained on this reward falls off the cliff in" in out
    ends = data["evaluation"]["ends"]
    assert set(ends) == {"C", "G"} and sum(ends.values()) == pytest.approx(1.0, abs=1e-6)


def test_the_printout_reads_an_lp_interval_as_identified(capsys, tmp_path):
    path = tmp_path / "optimal.jsonl"
    assert main(["simulate", "--world", "mud", "--policy", "optimal", "--episodes", "40", "--seed", "0",
                 "--out", str(path)]) == 0
    code, out, err = run(capsys, path, "--intervals", "--no-view")
    assert code == 0, err
    assert "auto chose lp" in out and "identified by the demonstrations" in out and "confidence" not in out


@pytest.mark.parametrize(("argv", "fragment"), [
    (["--method", "lp", "--beta", "auto"], "--beta auto needs --method maxent or auto"),
    (["--confidence", "1.2"], "--confidence must lie strictly between 0 and 1"),
    (["--confidence", "0"], "--confidence must lie strictly between 0 and 1"),
    (["--resamples", "5"], "--resamples must be at least 20"),
])
def test_bad_options_are_one_line_and_exit_2(capsys, person_file, argv, fragment):
    code, out, err = run(capsys, person_file, "--no-view", *argv)
    assert code == 2 and fragment in err and len(err.strip().splitlines()) == 1


def test_one_episode_with_intervals_warns_and_claims_no_interval(tmp_path, capsys):
    path = person_like(tmp_path / "one.jsonl", episodes=1)
    out_json = tmp_path / "fit.json"
    code, out, err = run(capsys, path, "--intervals", "--no-view", "--json", out_json)
    assert code == 0, err
    assert "warning: intervals not computed" in err and "one episode" in err
    data = json.loads(out_json.read_text())
    assert data["interval_kind"] is None and all(cell is None for row in data["interval"] for cell in row)


def test_a_ratio_of_confidence_intervals_is_read_end_to_end_not_as_a_confidence(tmp_path, capsys):
    """Per-unknown 95% intervals do not make their ratio 95% sure: the sentence says it compares ends."""
    recording = tmp_path / "noisy.jsonl"
    assert main(["simulate", "--world", "mud", "--policy", "boltzmann", "--beta", "0.5", "--episodes", "40",
                 "--seed", "0", "--out", str(recording)]) == 0
    code, out, err = run(capsys, recording, "--tie", "--intervals", "--resamples", "20", "--no-view")
    assert code == 0, err
    cliff = next(line for line in out.splitlines() if line.startswith("cliff: "))
    assert "× worse than mud's" in cliff, cliff
    assert "end to end of their 95% confidence intervals" in cliff and "× worse at 95%" not in out


def test_without_intervals_the_separation_note_speaks_of_the_fitted_rewards_not_of_intervals():
    """Per-cell points span a range over a symbol's cells; that range is no interval, and the note must not call
    it one (it did, for a fit run without --intervals)."""
    from irl_core.irl.fitting import _not_separated

    symbols, terminal = ("C", "C", "U", "U", "G"), ("C", "G")
    points = np.array([-1000.0, 220.0, 9.3, 9.8, 236.0])
    (note,) = _not_separated(symbols, np.column_stack([points, points]), {"C"}, terminal, intervals=False)
    assert "interval" not in note.sentence
    assert note.sentence.startswith("the fitted rewards do not put the catastrophe below the nuisance")
    assert "C -1e+03 to 220 reaches U 9.3 to 9.8" in note.sentence
    (note,) = _not_separated(symbols, np.column_stack([points - 50, points + 50]), {"C"}, terminal, intervals=True)
    assert note.sentence.startswith("the intervals do not separate the catastrophe from the nuisance")
    apart = np.array([[-1200.0, -900.0], [-1100.0, -800.0], [-40.0, -20.0], [-35.0, -25.0], [80.0, 120.0]])
    assert _not_separated(symbols, apart, {"C"}, terminal, intervals=True) == []
