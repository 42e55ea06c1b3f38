"""`careful study run` driven by keys (Pilot, digits input, a fake clock): instructions, each block
on the play screen, the screens between, the end; the files and their headers; quitting and
resuming; the command's answers for a finished participant and bad input."""

from __future__ import annotations

import asyncio
import io
from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from play_fixtures import FakeClock
from rich.console import Console
from study.study_run_files import RIGHT, write_study
from textual.pilot import Pilot
from textual.widgets import Static

from careful_tui.app import CarefulApp, make_study_app
from careful_tui.cli import main
from careful_tui.screens.play import PlayScreen
from careful_tui.screens.study import StudyScreen
from careful_tui.widgets.too_small import TooSmall
from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.study import load_study, read_protocol

ENDING_MOVE = {"right": "right", "left": "left"}


def new_app(path: Path, participant: str = "p01") -> CarefulApp:
    return make_study_app(load_study(path), participant, clock=FakeClock(), seed=5)


def run(app: CarefulApp, body: Callable[[Pilot], Awaitable[None]]) -> None:
    async def go() -> None:
        async with app.run_test(size=(100, 35)) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(go())


def shown(app: CarefulApp) -> str:
    """The study screen's text as plain text."""
    console = Console(width=100, file=io.StringIO(), record=True)
    console.print(app.first_screen.query_one("#study-text", Static).content)
    return console.export_text()


def play_screen(app: CarefulApp) -> PlayScreen:
    assert isinstance(app.screen, PlayScreen), type(app.screen)
    return app.screen


def status(app: CarefulApp) -> str:
    return str(app.screen.query_one("#status", Static).render())


async def play_episode(pilot: Pilot, level: str) -> None:
    """Type a level and the move that ends the current world's episode."""
    for key in level:
        await pilot.press(key)
    await pilot.press(ENDING_MOVE[play_screen(pilot.app).world.name])
    await pilot.pause()


async def play_block(pilot: Pilot, levels: str) -> None:
    """Play the block's episodes, one per level, and go on after the last."""
    for i, level in enumerate(levels):
        if i:
            await pilot.press("space")
        await play_episode(pilot, level)
    assert "Press space to go on." in status(pilot.app)
    await pilot.press("space")
    await pilot.pause()


def files_by_block(folder: Path) -> dict[tuple[int, str], list]:
    blocks: dict[tuple[int, str], list] = {}
    for path in sorted(folder.glob("*.jsonl")):
        recording = read_recording(path)
        blocks.setdefault((recording.header.study.world_index, recording.header.study.phase), []).append(recording)
    return blocks


def test_a_participant_goes_through_instructions_practice_main_and_both_worlds(tmp_path: Path) -> None:
    path = write_study(tmp_path)
    app = new_app(path)
    flow = app.first_screen
    seen: dict[str, str] = {}

    async def body(pilot: Pilot) -> None:
        assert isinstance(app.screen, StudyScreen) and flow.stage == "instructions"
        seen["instructions"] = shown(app)
        await pilot.press("space")
        await pilot.pause()
        assert play_screen(app).world.name == "right"
        assert "Practice episode 1 of 1" in status(app)
        await play_block(pilot, "3")
        assert flow.stage == "practice_over"
        seen["practice_over"] = shown(app)
        await pilot.press("space")
        await pilot.pause()
        assert "Episode 1 of 2" in status(app)
        await play_block(pilot, "24")
        assert flow.stage == "next_world"
        seen["next_world"] = shown(app)
        await pilot.press("space")
        await pilot.pause()
        assert play_screen(app).world.name == "left"
        await play_block(pilot, "9")
        await pilot.press("space")
        await pilot.pause()
        await play_block(pilot, "15")
        assert flow.stage == "end" and isinstance(app.screen, StudyScreen)
        seen["end"] = shown(app)
        await pilot.press("space")  # leaves
        await pilot.pause()

    run(app, body)
    assert app.return_code == 0 or app.return_code is None
    text = seen["instructions"]
    assert "[bold]This is not markup[/bold] \\x1b[31m" in text  # as text, the escape shown, not obeyed
    assert "You will play 2 worlds. In each: 1 practice episode, then 2 episodes that count." in text
    assert "costs more points and slips less" in text and "Type the level" in text
    assert "Practice is over." in seen["practice_over"] and "2 episodes of this world that count" in seen["practice_over"]
    assert "World 1 of 2 is done." in seen["next_world"] and "World 2 of 2 (left): practice episode 1 of 1" in seen["next_world"]
    assert "3 of 10" not in seen["next_world"] and "3 of 6 episodes done." in seen["next_world"]
    assert "That is the end of the study. Thank you!" in seen["end"] and "All 6 episodes" in seen["end"]

    blocks = files_by_block(tmp_path / "data" / "p01")
    assert sorted(blocks) == [(0, "main"), (0, "practice"), (1, "main"), (1, "practice")]
    levels = {(0, "practice"): [3], (0, "main"): [2, 4], (1, "practice"): [9], (1, "main"): [1, 5]}
    for key, (recording,) in blocks.items():
        header = recording.header
        assert header.player == "p01" and header.study.participant == "p01" and header.study.name == "pilot"
        assert header.world.name == ("right", "left")[key[0]]
        assert recording.episodes == list(range(len(levels[key])))
        assert [step.carefulness for step in recording.steps] == levels[key]
        assert all(end.outcome == "terminal" for end in recording.episode_ends)
    assert read_protocol(load_study(path), "p01").finished


def test_q_mid_episode_keeps_it_as_quit_and_the_next_run_replays_it_with_the_next_number(tmp_path: Path) -> None:
    path = write_study(tmp_path, practice=0)
    app = new_app(path)

    async def first_run(pilot: Pilot) -> None:
        await pilot.press("space")
        await play_episode(pilot, "2")   # main episode 1 of 2 of world 0: done
        await pilot.press("space")
        await pilot.press("4", "up")     # episode 2: a bump into the edge, the episode goes on
        await pilot.pause()
        assert play_screen(app).game.live
        await pilot.press("q")

    run(app, first_run)
    (recording,) = files_by_block(tmp_path / "data" / "p01")[(0, "main")]
    kept = recording.path.read_bytes()
    assert [(end.episode, end.outcome) for end in recording.episode_ends] == [(0, "terminal"), (1, "quit")]

    again = new_app(path)
    seen: dict[str, str] = {}

    async def second_run(pilot: Pilot) -> None:
        seen["instructions"] = shown(again)
        await pilot.press("space")
        await pilot.pause()
        screen = play_screen(again)
        assert "Episode 2 of 2" in status(again)
        assert screen.game.episode == 2  # the quit episode's number (1) is not used again
        await play_block(pilot, "5")
        assert again.first_screen.stage == "next_world"

    run(again, second_run)
    assert "Welcome back: 1 of 4 episodes are done. You go on with: World 1 of 2 (right): episode 2 of 2." in seen["instructions"]
    recordings = files_by_block(tmp_path / "data" / "p01")[(0, "main")]
    (first,) = [r for r in recordings if r.path == recording.path]
    (second,) = [r for r in recordings if r.path != recording.path]
    assert first.path.read_bytes() == kept  # the first run's file is untouched
    assert second.episodes == [2] and [s.carefulness for s in second.steps] == [5]
    block = read_protocol(load_study(path), "p01").blocks[0]
    assert (block.done, block.interrupted, block.next_episode) == (2, 1, 3)


def test_a_shuffled_order_plays_the_worlds_in_the_participants_order(tmp_path: Path) -> None:
    path = write_study(tmp_path, practice=0)
    path.write_text(path.read_text().replace('order = "fixed"', 'order = "shuffled"'))
    study = load_study(path)
    # Ids whose shuffled order starts with the second world and with the first (worked out from
    # the SHA-256 rule, see tests/study/test_study_file.py).
    order = {participant: read_protocol(study, participant).order for participant in ("a", "b", "c", "d")}
    participant = next(p for p, o in order.items() if o == (1, 0))
    app = make_study_app(study, participant, clock=FakeClock(), seed=5)

    async def body(pilot: Pilot) -> None:
        await pilot.press("space")
        await pilot.pause()
        assert play_screen(app).world.name == "left"
        assert "world 1 of 2 (left)" in str(app.screen.query_one("#title", Static).render())

    run(app, body)


def test_calibration_is_not_offered_and_the_help_names_digits_in_a_digits_study(tmp_path: Path) -> None:
    app = new_app(write_study(tmp_path))

    async def body(pilot: Pilot) -> None:
        await pilot.press("space")
        await pilot.pause()
        screen = play_screen(app)
        help_text = str(screen.query_one("#hold-info", Static).render())
        assert help_text.startswith("level, then arrow") and "hold" not in help_text
        assert not screen.check_action("calibrate", ())
        await pilot.press("c")
        await pilot.pause()
        assert app.screen is screen  # no calibration screen

    run(app, body)


def test_a_finished_participant_is_told_so_and_bad_input_is_one_line(tmp_path: Path, capsys) -> None:
    path = write_study(tmp_path, practice=0)
    app = new_app(path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("space")
        await play_block(pilot, "12")
        await pilot.press("space")
        await play_block(pilot, "34")

    run(app, body)
    capsys.readouterr()
    assert main(["study", "run", str(path), "--participant", "p01"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("participant p01 has finished study 'pilot'") and "nothing is left to play" in out

    (tmp_path / "data" / "p03").write_text("not a folder")
    (tmp_path / "other.toml").write_text(path.read_text().replace('out = "data"', 'out = "pilot.toml"'))
    for argv, fragment in [
        (["study", "run", str(path), "--participant", "p02"], "needs an interactive terminal"),
        (["study", "run", str(path), "--participant", "p03"], "is a file, not the participant's folder"),
        (["study", "run", str(path), "--participant", "../x"], "cannot name a folder"),
        (["study", "run", str(path), "--participant", "report"], "is taken"),
        (["study", "run", str(tmp_path / "missing.toml"), "--participant", "p01"], "cannot read the study file"),
        (["study", "run", str(tmp_path / "other.toml"), "--participant", "p01"], "is a file, not the study's out folder"),
    ]:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert fragment in err and err.count("\n") == 1
    assert not (tmp_path / "data" / "p02").exists()  # no empty folder for the report to count


@pytest.mark.parametrize(("argv", "fragment"), [
    (["study", "run", "--help"], "running the same participant again goes on where they stopped"),
    (["study", "--help"], "'careful study run' takes one participant through the study"),
])
def test_help_explains_running_a_participant(argv: list[str], fragment: str, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert fragment in out and "not built yet" not in out


def test_tiny_terminals_never_crash_the_study_screens(tmp_path: Path) -> None:
    app = new_app(write_study(tmp_path))

    async def body(pilot: Pilot) -> None:
        for size in [(1, 1), (0, 0), (10, 3), (100, 35)]:
            await pilot.resize_terminal(*size)
            await pilot.pause()
        await pilot.press("space")
        await play_block(pilot, "3")
        for size in [(1, 1), (20, 5), (100, 35)]:
            await pilot.resize_terminal(*size)
            await pilot.pause()
        assert app.first_screen.stage == "practice_over" and "Practice is over." in shown(app)
        await pilot.press("space")
        await pilot.pause()
        assert "Episode 1 of 2" in status(app)
        await pilot.resize_terminal(20, 5)
        await pilot.pause()
        told = str(app.screen.query_one(TooSmall).render())
        assert "careful study run needs" in told and "careful play" not in told

    run(app, body)


def test_a_calibration_in_a_hold_study_carries_over_to_the_next_world_with_its_levels(tmp_path: Path) -> None:
    path = write_study(tmp_path, practice=0)
    path.write_text(path.read_text().replace('input = "digits"', 'input = "hold"').replace("episodes = 2", "episodes = 1"))
    clock = FakeClock()
    app = make_study_app(load_study(path), "p01", clock=clock, seed=5)

    async def tap(pilot: Pilot, key: str) -> None:
        """A tap (level 1), ended by the silence after it."""
        await pilot.press(key)
        clock.now += 1.0
        play_screen(app).tick()
        await pilot.pause()

    async def body(pilot: Pilot) -> None:
        await pilot.press("space")
        await pilot.pause()
        await pilot.press("c")
        calibration = app.screen
        await pilot.press("up")
        clock.now += 0.4
        for _ in range(8):
            await pilot.press("up")
            clock.now += 0.03
        clock.now += 0.5
        calibration.tick()
        await pilot.press("enter")
        await tap(pilot, "right")
        await pilot.press("space")  # the block's one episode is played: go on
        await pilot.pause()
        assert app.first_screen.stage == "next_world"
        await pilot.press("space")
        await pilot.pause()
        profile = play_screen(app).profile
        assert profile.calibrated and profile.levels == 9
        await tap(pilot, "left")

    run(app, body)
    blocks = files_by_block(tmp_path / "data" / "p01")
    for key in [(0, "main"), (1, "main")]:
        (recording,) = blocks[key]
        assert recording.header.input["calibrated"] is True
        assert recording.header.input["initial_delay_ms"] == pytest.approx(400.0)
    assert [step.carefulness for step in blocks[(1, "main")][0].steps] == [1]


def test_a_long_study_name_is_cut_so_the_title_keeps_the_world_and_the_phase(tmp_path: Path) -> None:
    """The play screen shows at most 60 characters of its heading; long study and world names are
    cut, not the "world 1 of 2 (...) · practice" the participant needs."""
    path = write_study(tmp_path)
    path.write_text(path.read_text().replace('name = "pilot"', 'name = "carefulness-pilot-spring-2026-group-b"'))
    (tmp_path / "right.toml").write_text(RIGHT.replace('name = "right"', 'name = "right-hand-goal-next-to-start"'))
    app = new_app(path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("space")
        await pilot.pause()
        title = str(app.screen.query_one("#title", Static).render())
        heading = title.split(" · player ")[0]
        assert heading == "carefulness-pilot-s… · world 1 of 2 (right-hand…) · practice"

    run(app, body)


def test_a_study_without_carefulness_levels_does_not_explain_them(tmp_path: Path) -> None:
    """Worlds of one level (``paper-simple``, a control condition) have no level to choose: the
    instructions say so instead of describing the gauge and how to type a level."""
    path = write_study(tmp_path)
    path.write_text(path.read_text().replace('worlds = ["right.toml", "left.toml"]', 'worlds = ["paper-simple"]'))
    app = new_app(path)
    seen: dict[str, str] = {}

    async def body(pilot: Pilot) -> None:
        seen["instructions"] = shown(app)

    run(app, body)
    text = " ".join(seen["instructions"].split())
    assert "You will play 1 world: 1 practice episode, then 2 episodes that count." in text
    assert "Move with the arrow keys." in text
    assert "carefulness level" not in text and "gauge" not in text and "Type the level" not in text


def test_long_instructions_are_shown_whole(tmp_path: Path) -> None:
    """A consent text of a few pages is shown to its end (the screen scrolls), not cut at 4,000 characters."""
    path = write_study(tmp_path)
    paragraphs = "\n".join(f"Paragraph {i}: the rules of payment and consent, read them with care." for i in range(80))
    text = path.read_text()
    start = text.index('instructions = """') + len('instructions = """')
    path.write_text(text[:start] + paragraphs + text[text.index('"""', start):])
    app = new_app(path)
    seen: dict[str, str] = {}

    async def body(pilot: Pilot) -> None:
        seen["instructions"] = shown(app)

    run(app, body)
    assert len(paragraphs) > 5000
    assert "Paragraph 79: the rules of payment and consent, read them with care." in seen["instructions"]
    assert "characters)" not in seen["instructions"]
