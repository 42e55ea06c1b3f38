"""Replaying several files: which file is on screen, the file keys, playing on into the next file,
each file in its own world; and the command reading a folder in time order, leaving bad files out."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from test_replay_app import run, text  # the Pilot helpers of the one-file replay tests
from textual.pilot import Pilot
from textual.widgets import Static

import careful_tui.commands.replay as replay_command
from careful_tui.app import CarefulApp, make_replay_app
from careful_tui.cli import main
from careful_tui.commands.replay import name_order, recording_paths
from careful_tui.screens.replay import END_TICKS
from careful_tui.widgets import Board, Gauge, KeyBar
from irl_core.recordings.demonstrations import Recording, read_recording
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.world import World

SAMPLE = Path(__file__).parents[2] / "recordings" / "samples" / "sample-expert-paper.jsonl"
# A small world of its own: right, right to the goal.
LANE = World(name="lane", layout="..G\n", levels=3, start=(0, 0), rewards={"G": 100.0})


def lane_header(player: str = "lane-player", created: datetime = datetime(2026, 1, 2, 3, 4, tzinfo=UTC)):
    return SessionHeader(world=LANE, player=player, created=created, seed=0, input={"mode": "digits"})


def write_lane(path: Path, *, episodes: int = 1, header: SessionHeader | None = None) -> Path:
    """`episodes` episodes of two steps (levels 1 then 3) to the goal."""
    with RecordingWriter(path, header or lane_header()) as writer:
        for episode in range(episodes):
            score = 200.0
            for t, (state, level) in enumerate([((0, 0), 1), ((0, 1), 3)]):
                score -= level
                writer.write_step(Step(episode=episode, t=t, state=state, direction="right", carefulness=level,
                                       next_state=(0, state[1] + 1), slipped=False, reward=-float(level),
                                       score=score))
            writer.end_episode(EpisodeEnd(episode=episode, outcome="terminal", terminal_symbol="G", steps=2,
                                          return_=score + 100 - 200, score=score + 100))
    return path


def shown(app: CarefulApp) -> tuple[str, str, int, str]:
    """(title, panel title, the board's world, the gauge's number of levels)."""
    panel = app.query_one("#summary", Static)
    return text(app, "#title"), str(panel.border_title), app.query_one(Board).world.name, len(app.query_one(Gauge).costs)


def keys(app: CarefulApp) -> dict[str, str]:
    return {what: key for key, what in app.query_one(KeyBar).keys}


def two_worlds(tmp_path: Path) -> CarefulApp:
    # The sample (paper world, 3 episodes), then a lane of one episode.
    recordings = [read_recording(SAMPLE), read_recording(write_lane(tmp_path / "lane.jsonl"))]
    return make_replay_app(*recordings, frame_seconds=3600)


def test_the_file_keys_go_from_file_to_file_each_in_its_own_world(tmp_path: Path) -> None:
    app = two_worlds(tmp_path)

    async def body(pilot: Pilot) -> None:
        title, panel, world, levels = shown(app)
        assert "file 1/2 sample-expert-paper.jsonl · 3 episodes, 17 steps" in title
        assert (panel, world, levels) == ("session 1/2", "paper", 14)
        assert keys(app)["file"] == "PgUp PgDn" and "jump" not in keys(app)
        await pilot.press("pagedown")
        await pilot.pause()
        title, panel, world, levels = shown(app)
        assert "file 2/2 lane.jsonl · 1 episode, 2 steps" in title
        assert (panel, world, levels) == ("session 2/2", "lane", 3)
        assert "lane-player" in text(app, "#summary") and "digits input" in text(app, "#hold-info")
        assert app.query_one(Board).player == (0, 0) and "Episode 1/1" in text(app, "#status")
        # The keys survive the new world: the jump keys (unlisted now) and the bracket keys.
        await pilot.press("end")
        assert app.first_screen.cursor.at_end and "reached the goal!" in text(app, "#status")
        await pilot.press("left_square_bracket")
        await pilot.pause()
        assert shown(app)[2] == "paper" and app.first_screen.files.place == (0, 0)
        await pilot.press("right_square_bracket", "pageup")
        await pilot.pause()
        assert shown(app)[2] == "paper" and app.first_screen.files.place == (0, 0)

    run(app, body)


def test_file_keys_faster_than_the_screen_recomposes_end_on_the_right_world(tmp_path: Path) -> None:
    app = two_worlds(tmp_path)

    async def body(pilot: Pilot) -> None:
        for keys in (["pagedown", "pageup"] * 5, ["pagedown", "pageup"] * 4 + ["pagedown"]):
            for key in keys:
                await app.first_screen.run_action(
                    "go('next_file')" if key == "pagedown" else "go('previous_file')")
            await pilot.pause()
            await pilot.pause()
            screen = app.first_screen
            world = "lane" if keys[-1] == "pagedown" else "paper"
            assert screen.world.name == world and shown(app)[2] == world and len(app.query(Board)) == 1
            assert f"file {screen.files.index + 1}/2" in text(app, "#title")
            assert app.query_one(Board).player == screen.cursor.frame.player

    run(app, body)


def test_stepping_on_from_a_files_end_is_the_next_files_start_and_back(tmp_path: Path) -> None:
    app = two_worlds(tmp_path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("end")
        assert "file 1/2" in text(app, "#title") and "reached the goal!" in text(app, "#status")
        await pilot.press("right")
        await pilot.pause()
        assert shown(app)[2] == "lane" and app.query_one(Board).player == (0, 0)
        await pilot.press("left")
        await pilot.pause()
        assert shown(app)[2] == "paper" and app.first_screen.cursor.at_end
        # Episode keys too: the next episode after the sample's last is the lane's first.
        await pilot.press("up")
        await pilot.pause()
        assert shown(app)[2] == "lane"
        await pilot.press("down")
        await pilot.pause()
        assert shown(app)[2] == "paper" and app.first_screen.cursor.frame.index == 2

    run(app, body)


def test_playing_goes_on_into_the_next_file_and_stops_at_the_last_frame(tmp_path: Path) -> None:
    first = read_recording(write_lane(tmp_path / "a.jsonl"))
    second = read_recording(write_lane(tmp_path / "b.jsonl", episodes=2))
    app = make_replay_app(first, second, frame_seconds=3600)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        await pilot.press("space")
        for _ in range(4):  # before and after each of the two steps
            screen.advance()
        assert screen.cursor.frame.phase == "end" and screen.files.index == 0
        # The file's last episode end is held like any episode end, then the next file starts.
        for _ in range(END_TICKS - 1):
            screen.advance()
            assert screen.files.index == 0
        screen.advance()
        await pilot.pause()
        assert screen.files.place == (1, 0) and screen.playing and "file 2/2" in text(app, "#title")
        for _ in range(50):
            screen.advance()
        await pilot.pause()
        assert screen.files.at_end and not screen.playing
        # Space at the very end starts again from the first file.
        await pilot.press("space")
        await pilot.pause()
        assert screen.files.place == (0, 0) and screen.playing and "file 1/2" in text(app, "#title")

    run(app, body)


def test_one_file_shows_no_file_keys_or_count(tmp_path: Path) -> None:
    app = make_replay_app(read_recording(write_lane(tmp_path / "lane.jsonl")), frame_seconds=3600)

    async def body(pilot: Pilot) -> None:
        assert "file" not in keys(app) and keys(app)["jump"] == "home end"
        assert "file 1/1" not in text(app, "#title") and shown(app)[1] == "session"
        await pilot.press("pagedown")
        assert app.first_screen.cursor.at_start

    run(app, body)


def test_files_left_out_are_named_once_on_screen(tmp_path: Path) -> None:
    skipped = ["bad.jsonl:3: carefulness: 15 is above the world's 14 levels; left out"]
    app = make_replay_app(read_recording(SAMPLE), skipped=skipped, frame_seconds=3600)

    async def body(pilot: Pilot) -> None:
        assert [(n.title, n.message) for n in app._notifications] == [("left out: 1 file", skipped[0])]

    run(app, body)
    # Many: the first three as text (a control character escaped), and how many more.
    skipped = [f"bad-{n}.jsonl: the file is empty: no session header; left out" for n in range(5)]
    skipped[0] = "bad\x1b[31m.jsonl:1: not valid JSON; left out"
    app = make_replay_app(read_recording(SAMPLE), skipped=skipped, frame_seconds=3600)

    async def body(pilot: Pilot) -> None:
        ((title, message),) = [(n.title, n.message) for n in app._notifications]
        assert title == "left out: 5 files" and "\x1b" not in message
        assert message.splitlines() == ["bad\\x1b[31m.jsonl:1: not valid JSON; left out", *skipped[1:3],
                                         "and 2 more (each named on stderr)"]

    run(app, body)


# ---------------------------------------------------------------------------- the command


def test_a_folders_files_come_in_the_order_careful_play_recorded_them(tmp_path: Path) -> None:
    folder = tmp_path / "participant"
    start = datetime(2026, 11, 30, 9, 59, 58, tzinfo=UTC)
    written = []
    # Sessions two seconds apart over a minute's turn, then twelve in one second (-2 ... -12).
    for seconds in (0, 2, 4):
        header = lane_header("p01", start + timedelta(seconds=seconds))
        written.append(write_lane_in(folder, header))
    for _ in range(12):
        written.append(write_lane_in(folder, lane_header("p01", start + timedelta(seconds=9))))
    assert [p.name for p in written[3:6]] == ["20261130-100007-p01.jsonl", "20261130-100007-p01-2.jsonl",
                                               "20261130-100007-p01-3.jsonl"]
    (folder / "notes.txt").write_text("not a recording")
    assert recording_paths([folder]) == written
    assert sorted(written, key=name_order) == written and sorted(written) != written


def write_lane_in(folder: Path, header: SessionHeader) -> Path:
    with RecordingWriter.create_in(folder, header) as writer:
        return writer.path


@pytest.fixture
def watched(monkeypatch) -> list[tuple[list[Recording], list[str]]]:
    """What the replay command would open on screen: its recordings and the files left out."""
    opened: list[tuple[list[Recording], list[str]]] = []

    class Opened:
        def run(self) -> None:
            pass

    def fake_app(*recordings: Recording, skipped=(), **_options) -> Opened:
        opened.append((list(recordings), list(skipped)))
        return Opened()

    monkeypatch.setattr(replay_command, "require_terminal", lambda command: None)
    monkeypatch.setattr(replay_command, "make_replay_app", fake_app)
    return opened


def test_bad_and_empty_files_are_named_and_the_others_replay(tmp_path: Path, capsys, watched) -> None:
    folder = tmp_path / "folder"
    folder.mkdir()
    good = [write_lane(folder / "1-first.jsonl"), write_lane(folder / "3-third.jsonl")]
    bad = write_lane(folder / "2-bad.jsonl")
    bad.write_text(bad.read_text().replace('"carefulness": 3', '"carefulness": 9', 1))
    (folder / "4-empty.jsonl").write_bytes(b"")
    extra = write_lane(tmp_path / "extra.jsonl")

    assert main(["replay", str(extra), str(folder)]) == 0
    err = capsys.readouterr().err
    assert f"{bad}:3: carefulness: 9 is above the world's 3 levels; left out" in err
    assert f"{folder / '4-empty.jsonl'}: the file is empty: no session header; left out" in err
    assert len(err.strip().splitlines()) == 2
    ((recordings, skipped),) = watched
    assert [r.path for r in recordings] == [extra, *good]
    assert len(skipped) == 2 and skipped[0].startswith(f"{bad}:3: carefulness")


def test_nothing_to_replay_is_an_error(tmp_path: Path, capsys, watched) -> None:
    empty_folder = tmp_path / "none"
    empty_folder.mkdir()
    assert main(["replay", str(empty_folder)]) == 2
    assert "none: no recordings (*.jsonl files) in this folder" in capsys.readouterr().err
    (tmp_path / "a.jsonl").write_text("{")
    (tmp_path / "b.jsonl").write_bytes(b"")
    assert main(["replay", str(tmp_path / "a.jsonl"), str(tmp_path / "b.jsonl")]) == 2
    err = capsys.readouterr().err
    assert "a.jsonl:1: not valid JSON" in err and "careful replay: none of the 2 files can be replayed" in err
    # One file on its own that cannot be read: its error, as ever.
    assert main(["replay", str(tmp_path / "a.jsonl")]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"careful replay: {tmp_path / 'a.jsonl'}:1: not valid JSON (Expecting property name enclosed in double quotes)"]
    assert not watched
