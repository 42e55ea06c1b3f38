"""Playing a time world (docs/timing.md): the hold from key-down to key-up is the move's care, no gauge shows,
and a terminal without key-ups is told so instead of having its holds guessed."""

from __future__ import annotations

import asyncio
import statistics
from pathlib import Path

import numpy as np
import pytest
from play_fixtures import FakeClock
from textual.widgets import Static
from tmux_terminal import terminal

from careful_tui.app import make_play_app
from careful_tui.keys.kitty import KeyRelease, KittyParser
from careful_tui.widgets import Gauge
from irl_core.recordings.demonstrations import read_recording
from irl_core.worlds.world import BUILTIN_WORLDS, world_from_dict

ARROW_FINAL = {"up": "A", "down": "B", "right": "C", "left": "D"}
SHOWN = world_from_dict({**BUILTIN_WORLDS["mud-time"].model_dump(), "show_hold": True, "start": [2, 2]})


def kitty(key: str, event: int) -> str:
    """An arrow key event in kitty's protocol: 1 press, 2 repeat, 3 release."""
    return f"\x1b[1;1:{event}{ARROW_FINAL[key]}"


def test_a_hold_timed_by_its_release_is_the_moves_care_and_no_gauge_shows(tmp_path: Path):
    clock = FakeClock()
    app = make_play_app(SHOWN, out=tmp_path / "rec", player="p", seed=1, clock=clock)
    parser = KittyParser()

    async def main() -> None:
        async with app.run_test(size=(100, 35)) as pilot:
            await pilot.pause()
            assert not app.query_one(Gauge).display
            screen = app.first_screen

            async def hold(key: str, seconds: float) -> None:
                for event in parser.feed(kitty(key, 1)):
                    screen.on_key(event)
                clock.advance(seconds / 2)
                screen.tick()
                await pilot.pause()
                held = str(app.query_one("#hold-info", Static).render())
                assert "held" in held and "level" not in held
                clock.advance(seconds / 2)
                for event in parser.feed(kitty(key, 3)):
                    assert isinstance(event, KeyRelease)
                    screen.on_key_release(event)
                await pilot.pause()

            await hold("up", 0.15)
            await hold("left", 1.8)
            info = str(app.query_one("#hold-info", Static).render())
            assert "held 1800 ms" in info and "level" not in info and "cost" not in info
            await pilot.press("q")

    asyncio.run(main())
    (path,) = app.first_screen.recorder.paths
    steps = read_recording(path).steps
    assert [(s.direction, s.carefulness, s.hold_ms, s.hold_exact, s.bin) for s in steps] == [
        ("up", None, 150.0, True, int(SHOWN.bin_of(150.0))), ("left", None, 1800.0, True, int(SHOWN.bin_of(1800.0)))]


def test_a_terminal_without_key_ups_is_told_in_one_line_and_nothing_is_recorded(tmp_path: Path):
    with terminal(tmp_path, ["play", "--world", "mud-time", "--out", "rec"], env={"CAREFUL_KEY_RELEASES": ""}) as term:
        assert term.wait_exit() == 2
        shown = " ".join(term.history().split())
    assert "'mud-time' is a time world" in shown and "does not report key-ups" in shown and "careful serve" in shown
    assert not (tmp_path / "rec").exists() or not any((tmp_path / "rec").iterdir())


def test_a_time_recording_replays_exports_and_becomes_a_dataset(tmp_path: Path, monkeypatch, capsys):
    import csv

    import minari

    from careful_tui.cli import main

    recording = tmp_path / "t.jsonl"
    assert main(["simulate", "--world", "mud-time", "--policy", "timing", "--episodes", "6", "--seed", "2",
                 "--out", str(recording)]) == 0
    steps = read_recording(recording).steps
    assert main(["export", str(recording), "--format", "csv", "--out", str(tmp_path / "t.csv")]) == 0
    with open(tmp_path / "t.csv", newline="") as file:
        rows = list(csv.DictReader(file))
    assert [(r["carefulness"], float(r["hold_ms"]), int(r["bin"])) for r in rows] == [
        ("", s.hold_ms, s.bin) for s in steps]
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    assert main(["export", str(recording), "--format", "minari", "--out", "careful/time-v0"]) == 0
    dataset = minari.load_dataset("careful/time-v0")
    first = next(iter(dataset.iterate_episodes()))
    # The action is the environment's: direction * bins + bin.
    assert first.actions[0] == ["up", "right", "down", "left"].index(steps[0].direction) * 16 + steps[0].bin


def test_a_study_with_a_time_world_refuses_taps_and_a_terminal_without_key_ups(tmp_path: Path):
    import pytest

    from irl_core.errors import StudyError
    from irl_core.studies.study import load_study

    (tmp_path / "tap.toml").write_text('name = "t"\nworlds = ["mud", "mud-time"]\ninput = "tap"\nout = "data"\n')
    with pytest.raises(StudyError, match=r"input: 'tap' cannot play worlds\[1\], a time world"):
        load_study(tmp_path / "tap.toml")
    (tmp_path / "hold.toml").write_text('name = "t"\nworlds = ["mud-time"]\nout = "data"\n')
    with terminal(tmp_path, ["study", "run", "hold.toml", "--participant", "p1"],
                  env={"CAREFUL_KEY_RELEASES": ""}) as term:
        assert term.wait_exit() == 2
        shown = " ".join(term.history().split())
    assert "'mud-time' is a time world" in shown and "does not report key-ups" in shown


def test_a_time_world_studys_report_cells_give_the_geometric_mean_hold_next_to_danger_not_a_level(tmp_path: Path):
    from irl_core.players.experts import rollouts, session_header, write_rollouts
    from irl_core.players.person_like import person_like
    from irl_core.recordings.lines import StudyTag
    from irl_core.studies.report_cells import gather
    from irl_core.studies.study import load_study
    from irl_core.worlds.mdp import build_mdp

    (tmp_path / "study.toml").write_text('name = "t"\nworlds = ["mud-time"]\npractice_episodes = 0\nepisodes = 4\n'
                                         'out = "data"\n')
    study = load_study(tmp_path / "study.toml")
    mdp = build_mdp(study.worlds[0])
    player = person_like(mdp, "timing")
    folder = study.participant_folder("p1")
    folder.mkdir(parents=True)
    header = session_header(mdp, player=player.player, seed=0).model_copy(
        update={"player": "p1", "study": StudyTag(name="t", participant="p1", phase="main", world_index=0)})
    write_rollouts(folder / "p1-0-w0-main.jsonl", mdp, rollouts(mdp, player.choose, episodes=4, seed=0),
                   player=player.player, seed=0, header=header)
    (cell,) = [c for c in gather(study).cells if c.participant == "p1"]
    steps = read_recording(folder / "p1-0-w0-main.jsonl").steps
    near = {(2, 1), (2, 2), (2, 3), (2, 4), (3, 0), (2, 5)}
    holds = [max(s.hold_ms, 1.0) for s in steps if s.state in near]
    # The hold is the care there: its geometric mean (as the report's figure), not a level (a time world has none).
    assert cell.careful_next_to_terminal is None and holds
    assert cell.hold_ms_next_to_terminal == pytest.approx(statistics.geometric_mean(holds))


def test_a_time_world_studys_care_figure_shows_each_participants_geometric_mean_hold_by_distance(tmp_path: Path):
    """Not the duration bins as "carefulness levels": the hold in ms, geometric mean per distance, checked against
    the recordings' own holds."""
    from careful_tui.render.figures.study_figures import report_figures
    from irl_core.players.experts import rollouts, session_header, write_rollouts
    from irl_core.players.person_like import person_like
    from irl_core.recordings.lines import StudyTag
    from irl_core.recordings.summary import distance_to_terminal
    from irl_core.studies.report import CellFit
    from irl_core.studies.report_cells import gather
    from irl_core.studies.study import load_study
    from irl_core.worlds.mdp import build_mdp

    (tmp_path / "study.toml").write_text('name = "t"\nworlds = ["mud-time"]\npractice_episodes = 0\nepisodes = 4\n'
                                         'out = "data"\n')
    study = load_study(tmp_path / "study.toml")
    mdp = build_mdp(study.worlds[0])
    player = person_like(mdp, "timing")
    for i, who in enumerate(("p1", "p2")):
        folder = study.participant_folder(who)
        folder.mkdir(parents=True)
        header = session_header(mdp, player=player.player, seed=i).model_copy(
            update={"player": who, "study": StudyTag(name="t", participant=who, phase="main", world_index=0)})
        write_rollouts(folder / f"{who}-0-w0-main.jsonl", mdp, rollouts(mdp, player.choose, episodes=4, seed=i),
                       player=player.player, seed=i, header=header)
    data = gather(study)
    figures = dict(report_figures(data, [CellFit(error="none")] * len(data.cells)))
    figure = figures["carefulness-w0-mud-time"]
    assert "hold by distance to danger" in figure.get_suptitle() and "geometric mean hold" in figure.get_suptitle()
    assert figure._supylabel.get_text() == "hold (ms), geometric mean"
    p1 = next(ax for ax in figure.axes if ax.get_visible() and ax.get_title() == "p1")
    assert p1.get_yscale() == "log"
    distance = distance_to_terminal(study.worlds[0])
    steps = read_recording(study.participant_folder("p1") / "p1-0-w0-main.jsonl").steps
    by_distance: dict[int, list[float]] = {}
    for step in steps:
        by_distance.setdefault(distance[step.state], []).append(max(step.hold_ms, 1.0))
    x, y = p1.containers[0].lines[0].get_data()  # the error bars' own line (the faint pooled one is also drawn)
    expected = [float(np.exp(np.mean(np.log(by_distance[d])))) for d in sorted(by_distance)]
    assert list(x) == sorted(by_distance) and np.allclose(y, expected)
