"""`careful experiment` says what its numbers show: captions change with the numbers."""

import json
from datetime import UTC, datetime

import numpy as np

from careful_tui.cli import main
from irl_core.experiment.run import Estimate, Separation, interval_caption, severity
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.mdp import DIRECTIONS, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def estimate(cliff, goal=100.0):
    return Estimate(stage="s", method="m", data="d", cliff=cliff, goal=goal, true_cliff=-1000.0, true_goal=100.0,
                    seconds=0.0)


def test_the_cliff_caption_follows_the_estimate():
    assert "severity is recovered" in severity(estimate(-950.0))
    assert "not recovered" in severity(estimate(-100.0)) and "10.0x too mild" in severity(estimate(-100.0))
    assert "not recovered: fitted 20, not even negative" in severity(estimate(20.0))
    assert "too severe" in severity(estimate(-3000.0))
    assert "goal is not recovered" in severity(estimate(-950.0, goal=-5.0))


def test_a_cliff_the_bound_set_is_not_called_recovered():
    """The loss stage on 10 noisy episodes put 3 of 4 cliff cells at -rmax = -1000: their mean
    (-957) is near the truth because the bound is the truth, not because the data said so."""
    bound_set = Estimate(stage="s", method="m", data="d", cliff=-956.7, goal=100.0, true_cliff=-1000.0,
                         true_goal=100.0, seconds=0.0, cliff_cells=4, cliff_at_bound=3, cliff_inside=-827.0,
                         rmax=1000.0)
    caption = severity(bound_set)
    assert "recovered" not in caption.replace("not recovered", "")
    assert "3 of its 4 cells are at the fit's bound (-1000)" in caption
    assert "the one the data set is -827 (17% off)" in caption
    every = severity(Estimate(stage="s", method="m", data="d", cliff=-1000.0, goal=100.0, true_cliff=-1000.0,
                              true_goal=100.0, seconds=0.0, cliff_cells=4, cliff_at_bound=4, rmax=1000.0))
    assert "recovered" not in every.replace("not recovered", "") and "every cell" in every
    one = severity(Estimate(stage="s", method="m", data="d", cliff=-981.0, goal=90.0, true_cliff=-1000.0,
                            true_goal=100.0, seconds=0.0, cliff_cells=4, cliff_at_bound=1, cliff_inside=-975.0,
                            rmax=1000.0))
    assert "1 of its 4 cells is at the fit's bound (-1000)" in one and "the 3 the data set average -975" in one


def test_the_interval_caption_follows_the_intervals():
    apart = Separation("mud", (-1000.0, -600.0), (-50.0, -10.0), 0.0)
    overlap = Separation("mud-simple", (-1000.0, 30.0), (-100.0, 40.0), 0.0, kind="confidence")
    assert "disjoint: the cliff is shown to be worse" in interval_caption(apart)
    assert "identified by the demonstrations" in interval_caption(apart)
    assert "overlapping" in interval_caption(overlap) and "95% confidence" in interval_caption(overlap)


def test_an_interval_end_at_the_bound_is_said_to_be_the_bounds():
    at_bound = Separation("mud-simple", (-5000.0, -4756.0), (-173.0, -87.0), 0.0, kind="confidence", rmax=5000.0)
    inside = Separation("mud", (-1397.0, -579.0), (-88.0, -25.0), 0.0, kind="confidence", rmax=5000.0)
    assert "the cliff's -5000 is the bound of the fit, not a value the data set" in interval_caption(at_bound)
    assert "bound" not in interval_caption(inside)


def careless_person(folder):
    """A person who walks at random, at level 1, in paper: nothing about the cliff can be learnt."""
    world = BUILTIN_WORLDS["paper"]
    mdp = build_mdp(world)
    rng = np.random.default_rng(0)
    header = SessionHeader(world=world, player="careless", created=datetime(2000, 1, 1, tzinfo=UTC), seed=0)
    with RecordingWriter(folder / "careless.jsonl", header) as writer:
        for episode in range(6):
            s, score = mdp.state_of[(0, 0)], 200.0
            for t in range(60):
                d = int(rng.integers(4))
                s_next, realised = mdp.move(s, d * world.levels, rng)
                score -= 1.0
                writer.write_step(Step(episode=episode, t=t, state=mdp.cells[s], direction=DIRECTIONS[d], carefulness=1,
                                       next_state=mdp.cells[s_next], slipped=realised != d, reward=-1.0, score=score))
                s = s_next
                if not mdp.nonterminal[s]:
                    break
            symbol = None if mdp.nonterminal[s] else mdp.symbols[s]
            writer.end_episode(EpisodeEnd(episode=episode, outcome="terminal" if symbol else "step_limit",
                                          terminal_symbol=symbol, steps=t + 1, **{"return": -(t + 1.0)}, score=score))


def test_a_careless_persons_recordings_are_reported_as_not_recovering_the_cliff(tmp_path, capsys):
    people = tmp_path / "people"
    people.mkdir()
    careless_person(people)
    # A file that cannot be read is named in the notes, as text: its name is not markup.
    lines = (people / "careless.jsonl").read_text().splitlines()
    (people / "[bold]broken.jsonl").write_text("\n".join([lines[0], '{"kind": "step"', *lines[2:]]) + "\n")
    out = tmp_path / "exp"
    assert main(["experiment", "--quick", "--recordings", str(people), "--out", str(out)]) == 0
    printed = capsys.readouterr().out.replace("\n", "")
    assert "[bold]broken.jsonl:2: not valid JSON" in printed and "left out" in printed
    summary = json.loads((out / "summary.json").read_text())
    loss = {e["stage"]: e for e in summary["estimates"]}["loss, noisy"]
    assert "human episodes" in loss["data"]
    report = (out / "report.md").read_text()
    caption = report.split("### Figure 8")[1].split("###")[0]
    assert loss["cliff_error"] > 0.25 and "not recovered" in caption
    assert "simulated noisy experts" not in report


def test_an_unreadable_recording_in_the_folder_is_named_in_the_notes(tmp_path):
    from irl_core.experiment.run import human_sessions

    people = tmp_path / "people"
    people.mkdir()
    careless_person(people)
    lines = (people / "careless.jsonl").read_text().splitlines()
    lines[3] = lines[3].replace('"carefulness": 1', '"carefulness": 99')
    (people / "broken.jsonl").write_text("\n".join(lines) + "\n")
    found, left_out = human_sessions(people, BUILTIN_WORLDS["paper"])
    assert [path.name for path in found] == ["careless.jsonl"]
    assert len(left_out) == 1 and "broken.jsonl:4: carefulness" in left_out[0]


def test_a_missing_recordings_folder_is_bad_input(tmp_path, capsys):
    assert main(["experiment", "--quick", "--recordings", str(tmp_path / "none"), "--out", str(tmp_path / "e")]) == 2
    assert "not a folder" in capsys.readouterr().err
