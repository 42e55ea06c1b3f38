"""Play when the disk turns against it: a deleted recordings folder, a full or read-only disk.

The recorder (unit tests) and `careful play` in a real terminal (tmux):
- the folder deleted mid-session: recreated, every step so far written to a new session file,
  the player told, and the game goes on; what `careful play` prints at the end names real files;
- a full disk or a read-only folder at the first move: the game stops, exit 2 and one line,
  and no empty recording is left behind;
- a name that is not UTF-8 text: refused before a file exists.
"""

from __future__ import annotations

import shutil
import subprocess
from datetime import UTC, datetime
from pathlib import Path

import pytest
from hardening_checks import RAW_CONTROL, fill, tiny_filesystem
from tmux_terminal import needs_tmux, terminal

from irl_core.play.game import Game
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.lines import SessionHeader
from irl_core.recordings.writer import RecordingWriter, SessionRecorder
from irl_core.worlds.world import World

WALK = World(name="walk", layout="....\n.CCG\n", levels=3, slip="none", start=(0, 0), rewards={"C": -100.0, "G": 10.0})
WORLD_TOML = 'name = "walk"\nlayout = """\n....\n.CCG\n"""\nlevels = 3\nslip = "none"\nstart = [0, 0]\n'


def header(player: str = "p") -> SessionHeader:
    return SessionHeader(world=WALK, player=player, created=datetime(2026, 1, 2, tzinfo=UTC), seed=0)


def test_a_folder_deleted_mid_episode_is_recreated_with_every_step(tmp_path):
    folder = tmp_path / "rec"
    recorder = SessionRecorder(folder, header())
    game = Game(WALK, seed=0, sink=recorder)
    game.begin_episode()
    for direction in ("right", "right", "right", "down"):
        game.move(direction, 1)  # ends at the goal
    game.begin_episode()
    game.move("right", 1)
    first = recorder.path
    shutil.rmtree(folder)
    game.move("right", 2)
    assert recorder.lost == [first]  # (the new file may take the same name: the old one is gone)
    assert recorder.notices == [f"recording deleted: every step so far is saved again in {recorder.path.name}"]
    game.quit()
    recorder.close()
    (path,) = recorder.paths
    rec = read_recording(path)
    assert [(s.episode, s.t) for s in rec.steps] == [(0, 0), (0, 1), (0, 2), (0, 3), (1, 0), (1, 1)]
    assert [e.outcome for e in rec.episode_ends] == ["terminal", "quit"]


def test_a_folder_deleted_between_episodes_is_caught_at_close(tmp_path):
    folder = tmp_path / "rec"
    recorder = SessionRecorder(folder, header())
    game = Game(WALK, seed=0, sink=recorder)
    game.begin_episode()
    game.move("down", 1)
    game.quit()
    shutil.rmtree(folder)
    recorder.close()
    (path,) = recorder.paths
    assert path.exists() and len(read_recording(path).steps) == 1 and recorder.lost


def test_a_full_disk_at_the_first_line_leaves_no_file(tmp_path):
    with tiny_filesystem(tmp_path / "disk") as folder:
        fill(folder)
        with pytest.raises(OSError):
            RecordingWriter(folder / "r.jsonl", header())
        assert sorted(p.name for p in folder.iterdir()) == ["filler"]


def test_a_name_that_is_not_utf8_is_refused_before_the_file_exists(tmp_path):
    with pytest.raises(ValueError, match="not UTF-8"):
        RecordingWriter(tmp_path / "r.jsonl", header(player="a\udcff"))
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_plays_no_move(tmp_path):
    class Broken:
        def write_step(self, step):
            raise OSError(28, "No space left on device")

        def end_episode(self, end):
            raise OSError(28, "No space left on device")

    game = Game(WALK, seed=0, sink=Broken())
    game.begin_episode()
    with pytest.raises(OSError):
        game.move("right", 1)
    assert (game.t, game.cell, game.score) == (0, (0, 0), WALK.initial_score)


# ---------------------------------------------------------------------------- in a terminal


def play_args(tmp_path: Path, out: Path) -> list[str]:
    world = tmp_path / "walk.toml"
    world.write_text(WORLD_TOML)
    return ["play", "--world", str(world), "--out", str(out), "--player", "faults", "--seed", "1"]


@needs_tmux
def test_play_recreates_a_deleted_folder_and_says_so(tmp_path):
    out = tmp_path / "rec"
    with terminal(tmp_path, play_args(tmp_path, out)) as term:
        term.wait_for("carefulness")
        term.send("Right")
        term.wait_for("step 1/")
        shutil.rmtree(out)
        term.send("Right")
        screen = term.wait_for("recording deleted")
        term.wait_for("step 2/")
        term.send("q")
        assert term.wait_exit() == 0
        screen = term.history()
    (path,) = out.glob("*.jsonl")
    rec = read_recording(path)
    assert [(s.t, s.direction) for s in rec.steps] == [(0, "right"), (1, "right")]
    assert [e.outcome for e in rec.episode_ends] == ["quit"]
    assert f"recorded to {path}" in screen.splitlines() and "was deleted during the session" in screen


@needs_tmux
@pytest.mark.parametrize("fault", ["full", "read-only"])
def test_play_on_a_disk_that_fails_at_the_first_move_exits_2(tmp_path, fault):
    with tiny_filesystem(tmp_path / "disk") as out:
        with terminal(tmp_path, play_args(tmp_path, out)) as term:
            term.wait_for("carefulness")
            if fault == "full":
                fill(out)
            else:
                done = subprocess.run(["mount", "-o", "remount,ro", str(out)], capture_output=True)
                if done.returncode != 0:
                    pytest.skip("cannot remount the tmpfs read-only")
            term.send("Right")
            status = term.wait_exit()
            screen = term.history()
            assert status == 2, screen
        lines = [line for line in screen.splitlines() if line.startswith("careful play:")]
        assert len(lines) == 1 and "cannot write the recording" in lines[0] and "the game stopped" in lines[0] and "the game stopped" in lines[0]
        assert ("No space left" if fault == "full" else "Read-only") in screen.replace("\n", "")
        assert "Traceback" not in screen and not RAW_CONTROL.search(screen)
        assert not list(out.glob("*.jsonl"))  # no empty recording left behind
