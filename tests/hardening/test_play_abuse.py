"""`careful play` and `careful replay` under abuse in a real terminal: nothing played is lost.

Researchers collect demonstrations from people once, so a lost session is lost data. Each test
runs the real command in a terminal of its own (`tests/tmux_terminal.py`).

| test                                          | what it proves                                     |
|-----------------------------------------------|----------------------------------------------------|
| `test_sigkill_mid_episode_...`                | SIGKILL loses no committed step; the unfinished    |
|                                               | episode still counts                               |
| `test_two_games_started_at_once_...`          | same second, player and folder: two files          |
| `test_an_unwritable_recordings_folder_...`    | refused at start (exit 2, one line), no screen     |
| `test_resizing_during_play_...`               | too-small message comes and goes; a hold across    |
|                                               | the shrink is cancelled, steps before and after    |
|                                               | are recorded; a storm of resizes leaves the screen |
|                                               | whole; stale COLUMNS/LINES do not fool it          |
| `test_kitty_release_and_repeat_...`           | play reads them (exact holds), never crashes       |
| `test_holding_two_arrows_at_once_...`         | two held arrows, L U L U: every committed move is  |
|                                               | on screen and in the file                          |
| `test_replay_survives_resizing_and_kitty_...` | replay: resizes and kitty sequences, no crash      |

A move is "committed" when the screen shows it ("step N/200" with no hold being entered), and
the game writes a step before it draws it, so the file must hold every step the screen showed.
Under load a held key's autorepeat can stall past the release timeout and split one hold into
two moves of the same direction; the tests then compare runs of directions, never fewer moves.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from datetime import datetime
from itertools import groupby
from pathlib import Path

import pytest
from hardening_checks import tiny_filesystem
from play_fixtures import corner_world, corner_world_toml, write_two_episodes
from tmux_terminal import SIZE, TIMEOUT_S, Terminal, needs_tmux, terminal

from careful_tui.screens.play import minimum_size as play_minimum_size
from irl_core.recordings.demonstrations import Demonstrations, Recording, read_recording
from irl_core.worlds.world import world_from_dict

WORLD_TOML = corner_world_toml("abuse")
# The smallest window play fits in for this world (the gauge's cost and slip columns decide the width).
PLAY_NEEDS = play_minimum_size(world_from_dict(tomllib.loads(WORLD_TOML)))
SMALL = (60, 20)  # too small for play (PLAY_NEEDS) and for replay (80x21)
STEP = re.compile(r"step (\d+)/200")
# Stale sizes in the environment, as a launcher leaves them (pytest imports readline, which
# puts COLUMNS and LINES in the environment its subprocesses inherit): the game must ask the
# terminal instead, or it draws at 80x24 and never sees a resize.
STALE_SIZE = {"COLUMNS": "80", "LINES": "24"}
HELD_S = 0.3  # a kitty press held this long, then released: shorter than the first-repeat timeout


# ---------------------------------------------------------------------------- the play screen


def fills_the_window(screen: str) -> bool:
    """Whether the key bar is on the window's last line (not on line 24, as LINES=24 would say)."""
    lines = screen.splitlines()
    return len(lines) >= SIZE[1] and "quit" in lines[SIZE[1] - 1]


def drawn(screen: str) -> bool:
    """The first frame is on the screen, down to its key bar (not a frame still being drawn)."""
    return "carefulness" in screen and "quit" in screen


def play_args(tmp_path: Path, *extra: str) -> list[str]:
    world = tmp_path / "abuse.toml"
    world.write_text(WORLD_TOML)
    return ["play", "--world", str(world), "--out", str(tmp_path / "rec"), "--player", "abuse", "--seed", "3", *extra]


def shown_step(screen: str) -> int | None:
    """The "step N/200" of the running episode, or None (between episodes, too small)."""
    match = STEP.search(screen)
    return None if match is None else int(match.group(1))


def settle(term: Terminal, at_least: int) -> int:
    """The step count once at least `at_least` moves are shown and no hold is being entered.

    "last move" is the idle panel; while a hold is being entered it shows the live level. The
    count must hold still for a moment, so no key is still on its way.
    """
    def idle(screen: str) -> bool:
        return "last move" in screen and (shown_step(screen) or 0) >= at_least

    end = time.monotonic() + TIMEOUT_S
    while time.monotonic() < end:
        count = shown_step(term.wait_for(idle))
        time.sleep(0.3)
        screen = term.screen()
        if idle(screen) and shown_step(screen) == count:
            return count
    raise AssertionError(f"the step count never settled; the screen was:\n{term.screen()}")


def quit_game(term: Terminal) -> str:
    """Press q and wait for a clean exit; the screen after it ("recorded to ...")."""
    term.send("q")
    assert term.wait_exit() == 0
    return term.tmux("capture-pane", "-p", "-S", "-", "-t", term.name)


def the_recording(out: Path) -> Recording:
    (path,) = out.glob("*.jsonl")
    return read_recording(path)


def runs(directions: list[str]) -> list[str]:
    """Directions with repeats merged: a hold split in two still reads as one run."""
    return [direction for direction, _ in groupby(directions)]


def episode_steps(rec: Recording, episode: int) -> list:
    return [s for s in rec.steps if s.episode == episode]


def assert_consistent(rec: Recording) -> None:
    """No line is missing: steps count from t=0, each starts where the last ended, scores add up."""
    ends = {end.episode: end for end in rec.episode_ends}
    for episode in rec.episodes:
        steps = episode_steps(rec, episode)
        assert [s.t for s in steps] == list(range(len(steps)))
        score = rec.world.initial_score
        for before, step in zip([None, *steps], steps):
            if before is not None:
                assert step.state == before.next_state
            score += step.reward
            assert step.score == pytest.approx(score)
        if episode in ends:
            assert ends[episode].steps == len(steps)


# ---------------------------------------------------------------------------- the tests


@needs_tmux
def test_sigkill_mid_episode_keeps_every_committed_step(tmp_path: Path) -> None:
    out = tmp_path / "rec"
    with terminal(tmp_path, play_args(tmp_path)) as term:
        term.wait_for("carefulness")
        # Episode 1: taps of alternating arrows (each press ends the last hold) into the cliff.
        term.send("Down", "Right", "Down", "Right", "Down")
        term.wait_for("fell off the cliff")
        term.send("Space")
        term.wait_for("Episode 2 ")
        # Episode 2: a held arrow, then taps; then a hold still being entered when the kill comes.
        term.hold("Right", 0.6)
        term.send("Down", "Right", "Down")
        committed = settle(term, 4)
        term.send("Up")
        term.wait_for("held")
        os.kill(term.pid(), signal.SIGKILL)
        assert term.wait_exit() == 128 + signal.SIGKILL
        # The screen as the game last drew it: the game writes a step before it shows it.
        last_shown = shown_step(term.screen())
    assert last_shown is not None and committed <= last_shown <= committed + 1

    rec = the_recording(out)
    assert rec.warnings == []
    assert_consistent(rec)
    assert rec.episodes == [0, 1]
    first, second = episode_steps(rec, 0), episode_steps(rec, 1)
    assert [s.direction for s in first] == ["down", "right", "down", "right", "down"]
    (end,) = rec.episode_ends
    assert end.episode == 0 and end.outcome == "terminal" and end.terminal_symbol == "C"
    # The killed episode has every step the screen showed, and no end; it still counts.
    assert len(second) == last_shown
    assert runs([s.direction for s in second[:committed]]) == ["right", "down", "right", "down"]
    demos = Demonstrations.from_recordings([rec])
    assert demos.episodes == 2 and demos.steps == 5 + last_shown


def play_two_games_at_once(folder: Path) -> list[Path]:
    """Two `careful play` in `folder`, same player and output, first moves sent early in one second;
    the files written, shortest name first."""
    with terminal(folder, play_args(folder)) as one, terminal(folder, play_args(folder)) as two:
        one.wait_for("carefulness")
        two.wait_for("carefulness")
        # A session file is created at its first move: make both first moves early in one second.
        while not 0.02 < time.time() % 1 < 0.3:
            time.sleep(0.01)
        for term in (one, two):
            term.send("Down", "Right")
        for term in (one, two):
            assert settle(term, 2) == 2
        for term in (one, two):
            assert "recorded to" in quit_game(term)
    return sorted((folder / "rec").glob("*.jsonl"), key=lambda path: len(path.name))


@needs_tmux
def test_two_games_started_at_once_write_two_files(tmp_path: Path) -> None:
    # On a loaded machine the two first moves can still land in two seconds, and then the files do
    # not share a name: that run says nothing about the clash, so it is played again, up to 3 times.
    for attempt in range(3):
        folder = tmp_path / f"attempt{attempt}"
        folder.mkdir()
        paths = play_two_games_at_once(folder)
        assert len(paths) == 2, paths
        recs = [read_recording(path) for path in paths]
        created = {rec.header.created.replace(microsecond=0) for rec in recs}
        if len(created) == 1:
            break
    else:
        pytest.fail(f"in 3 attempts the first moves never fell in one second: {created}")
    stem = paths[0].stem
    assert [path.name for path in paths] == [f"{stem}.jsonl", f"{stem}-2.jsonl"]
    for rec in recs:
        assert rec.header.player == "abuse" and rec.warnings == []
        assert [s.direction for s in rec.steps] == ["down", "right"]
        assert [e.outcome for e in rec.episode_ends] == ["quit"]


def run_play_in_a_terminal(cwd: Path, out: str) -> tuple[int, str, bytes]:
    """`careful play --out OUT` with a pseudo-terminal for input and output: status, stderr, screen."""
    master, slave = os.openpty()
    try:
        process = subprocess.Popen([sys.executable, "-m", "careful_tui.cli", "play", "--out", out], cwd=cwd,
                                   stdin=slave, stdout=slave, stderr=subprocess.PIPE, text=True)
        os.close(slave)
        slave = -1
        try:
            _, err = process.communicate(timeout=TIMEOUT_S)  # a bound on its exit: Python's start at load 8 took 30 s
        except subprocess.TimeoutExpired:
            process.kill()
            process.communicate()
            pytest.fail(f"careful play --out {out} started instead of refusing the folder")
        os.set_blocking(master, False)
        screen = b""
        while True:
            try:
                chunk = os.read(master, 65536)
            except (BlockingIOError, OSError):
                break
            if not chunk:
                break
            screen += chunk
        return process.returncode, err, screen
    finally:
        os.close(master)
        if slave != -1:
            os.close(slave)


@contextmanager
def read_only_folder(folder: Path) -> Iterator[str]:
    """`folder` made read-only: by chmod 555, or (for root, who writes there anyway) as a read-only
    tmpfs. Yields the problem the refusal names."""
    folder.mkdir()
    folder.chmod(0o555)
    try:
        (folder / "probe").touch()
    except PermissionError:
        try:
            yield "Permission denied"
        finally:
            folder.chmod(0o755)
        return
    (folder / "probe").unlink()
    folder.chmod(0o755)
    with tiny_filesystem(folder, read_only=True):
        yield "Read-only file system"


@pytest.mark.parametrize(("case", "problem"), [
    ("a file", "is a file, not a folder"),
    ("under a file", "Not a directory"),
    ("deep under a file", "Not a directory"),
    ("a dangling link", "is a link to nothing"),
    ("read-only", None),
    ("under read-only", None),
])
def test_an_unwritable_recordings_folder_is_refused_at_start(tmp_path: Path, case: str, problem: str | None) -> None:
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a folder")
    (tmp_path / "link").symlink_to(tmp_path / "unmounted" / "drive")
    out = {"a file": "file.txt", "under a file": "file.txt/sub", "deep under a file": "file.txt/a/b",
           "a dangling link": "link", "read-only": "ro", "under read-only": "ro/sub"}[case]
    if problem is None:
        context = read_only_folder(tmp_path / "ro")
    else:
        (tmp_path / "ro").mkdir()
        context = nullcontext(problem)
    with context as problem:
        status, err, screen = run_play_in_a_terminal(tmp_path, out)
        left_in_ro = list((tmp_path / "ro").iterdir())
    assert status == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("careful play: ") and out in err and problem in err and "--out" in err
    assert "Traceback" not in err
    # Refused before the game drew anything: no alternate screen, nothing written anywhere.
    assert b"\x1b[?1049h" not in screen and screen == b""
    assert blocker.read_text() == "not a folder"
    assert not (tmp_path / "unmounted").exists()
    assert left_in_ro == []


@needs_tmux
def test_resizing_during_play_loses_nothing(tmp_path: Path) -> None:
    """Passed 40 runs of 40 after the fix (20 of them with two busy loops on the two cores). Before
    it, 4 runs of 8 failed: 3 left blank but for the title by the storm (`test_play_abuse_resize.py`
    reproduces that deterministically), 1 reading a first frame still being drawn."""
    out = tmp_path / "rec"
    too_small = "careful play needs {}x{}".format(*PLAY_NEEDS)
    with terminal(tmp_path, play_args(tmp_path), env=STALE_SIZE) as term:
        assert fills_the_window(term.wait_for(drawn))
        term.send("Down", "Right")
        assert settle(term, 2) == 2
        # Shrink in the middle of a hold: the hold is cancelled, no move (the gauge was not seen).
        term.send("Down")
        time.sleep(0.5)
        term.repeat("Down", 0.3)
        term.resize(*SMALL)
        term.repeat("Down", 0.3)
        term.wait_for(too_small)
        # Arrows while the window is too small move nobody.
        term.send("Left")
        term.send("Up")
        time.sleep(0.8)
        term.resize(*SIZE)
        screen = term.wait_for("Episode 1 ")
        assert "Make the window larger" not in screen
        during = settle(term, 2)
        if during == 2:  # else a stalled autorepeat split the hold, and a part was made before the shrink
            assert "Move cancelled" in term.screen()
        # A storm of resizes, down to a single cell and back, none waited for.
        width, height = PLAY_NEEDS
        for size in [SMALL, SIZE, (1, 1), (30, 10), SIZE, PLAY_NEEDS, (width - 1, height), (width, height - 1), SMALL, SIZE]:
            term.resize(*size)
        term.wait_for(lambda s: "Episode 1 " in s and "Make the window larger" not in s)
        assert settle(term, during) == during
        term.send("Right", "Up")
        after = settle(term, during + 2)
        quit_game(term)

    rec = the_recording(out)
    assert_consistent(rec)
    assert len(rec.steps) == after and rec.episode_ends[0].steps == after
    directions = [s.direction for s in rec.steps]
    assert directions[:2] == ["down", "right"]
    assert runs(directions[2:during]) in ([], ["down"]) and directions[during:] == ["right", "up"]


KITTY_JUNK = [
    b"\x1b[1;1:3A",  # release of up, never pressed
    b"\x1b[97;1:3u",  # release of a
    b"\x1b[1;1:2D",  # a repeat of left with no hold: the tail of a hold already committed
    b"\x1b[1;1:9C",  # an unknown event type
    b"\x1b[99999999u",  # a code point outside Unicode
    b"\x1b[1;1:1:1C",  # too many sub-fields
    b"\x1b[97:65;2:3u",  # release of shift+a with an alternate key
    b"\x1b[113;1:3u",  # release of q: must not quit
]


def kitty(key: str, event: int) -> bytes:
    """An arrow key event in kitty's protocol: 1 press, 2 repeat, 3 release."""
    final = {"up": "A", "down": "B", "right": "C", "left": "D"}[key]
    return f"\x1b[1;1:{event}{final}".encode()


@needs_tmux
def test_kitty_release_and_repeat_sequences_never_crash_play(tmp_path: Path) -> None:
    out = tmp_path / "rec"
    with terminal(tmp_path, play_args(tmp_path)) as term:
        term.wait_for("carefulness")
        for junk in KITTY_JUNK:
            term.send_bytes(junk)
        term.send("Left")  # a plain tap behind the junk: the parser still reads keys
        assert settle(term, 1) == 1
        # Press, a pause shorter than the first-repeat timeout, release: an exact hold. The pause starts once the
        # game shows the hold being entered, so the release arrives at least 300 ms after the press however late
        # a loaded machine delivers either (no upper bound: a late release is a longer hold).
        term.send_bytes(kitty("right", 1))
        term.wait_for(lambda s: "last move" not in s and "cost" in s)
        time.sleep(HELD_S)
        term.send_bytes(kitty("right", 3))
        screen = term.wait_for("(exact)")
        assert shown_step(screen) == 2
        # A repeat and a release after the hold ended start nothing.
        term.send_bytes(kitty("right", 2) + kitty("right", 3))
        # Two arrows, kitty style: down held, right pressed over it, down released, then right.
        term.send_bytes(kitty("down", 1))
        time.sleep(0.3)
        for _ in range(4):
            term.send_bytes(kitty("down", 2))
            time.sleep(0.03)
        term.send_bytes(kitty("right", 1))
        for _ in range(4):
            term.send_bytes(kitty("right", 2))
            time.sleep(0.03)
        term.send_bytes(kitty("down", 3) + kitty("right", 3))
        for junk in KITTY_JUNK:
            term.send_bytes(junk)
        shown = settle(term, 4)
        quit_game(term)

    rec = the_recording(out)
    assert_consistent(rec)
    assert len(rec.steps) == shown == 4
    assert [s.direction for s in rec.steps] == ["left", "right", "down", "right"]
    assert [s.hold_exact for s in rec.steps[:3]] == [False, True, False]
    assert rec.steps[1].hold_ms >= HELD_S * 1000 - 1  # the press and the release were at least 300 ms apart


@needs_tmux
def test_holding_two_arrows_at_once_records_every_move(tmp_path: Path) -> None:
    out = tmp_path / "rec"
    with terminal(tmp_path, play_args(tmp_path)) as term:
        term.wait_for("carefulness")
        # Right held; Down pressed while Right is still down: autorepeat follows Down.
        term.hold("Right", 0.4)
        term.hold("Down", 0.4)
        first = settle(term, 2)
        # Fast interleaved presses: each ends the one before at once.
        term.send("Left", "Up", "Left", "Up")
        shown = settle(term, first + 4)
        quit_game(term)

    rec = the_recording(out)
    assert_consistent(rec)
    assert len(rec.steps) == shown
    directions = [s.direction for s in rec.steps]
    assert runs(directions[:first]) == ["right", "down"]
    assert directions[first:] == ["left", "up", "left", "up"]
    assert all(s.carefulness == 1 and s.hold_ms == 0 for s in rec.steps[first:])
    assert rec.steps[0].carefulness >= 2


def write_replay_recording(tmp_path: Path, *, created: datetime | None = None) -> Path:
    return write_two_episodes(tmp_path / "rec", corner_world(), created=created)


@needs_tmux
def test_replay_survives_resizing_and_kitty_sequences(tmp_path: Path) -> None:
    path = write_replay_recording(tmp_path)
    before = path.read_bytes()
    too_small = "careful replay needs 80x21"
    with terminal(tmp_path, ["replay", str(path)], env=STALE_SIZE) as term:
        assert fills_the_window(term.wait_for(lambda s: "Episode 1/2" in s and "quit" in s))
        # Paused whatever the machine's speed: at the last frame playback stops by itself (Space would start it
        # again from the first if a slow start had let it end already: CI saw that at load 4-5).
        term.send_bytes(b"--")
        term.send("End")
        term.wait_for(lambda s: "×0.25" in s and "paused" in s)
        term.send("Home")
        term.wait_for("step 1/4")
        term.resize(*SMALL)
        term.wait_for(too_small)
        term.resize(*SIZE)
        screen = term.wait_for("step 1/4")
        assert "Make the window larger" not in screen
        # Playing through a storm of resizes.
        term.send("Space")
        for size in [SMALL, SIZE, (1, 1), (30, 10), SIZE, (80, 21), (79, 21), SMALL, SIZE]:
            term.resize(*size)
        term.wait_for(lambda s: "Episode" in s and "Make the window larger" not in s)
        term.send("End")  # paused at the end, however far playback went during the storm
        term.wait_for(lambda s: "Episode 2/2" in s and "paused" in s)
        term.send("Home")
        term.wait_for("step 1/4")
        # Kitty sequences: junk and releases are dropped, a repeat or a press steps like a key.
        for junk in KITTY_JUNK:
            term.send_bytes(junk)
        term.send_bytes(kitty("right", 3))
        term.send_bytes(kitty("right", 2) + kitty("right", 2))
        term.wait_for("step 2/4")
        term.send_bytes(kitty("right", 1) + kitty("right", 3) + kitty("right", 1) + kitty("right", 3))
        term.wait_for("step 3/4")
        term.resize(*SMALL)
        term.wait_for(too_small)
        term.send_bytes(kitty("up", 1) + kitty("up", 3))
        term.resize(*SIZE)
        term.wait_for("Episode 2/2")
        term.send("q")
        assert term.wait_exit() == 0
    assert path.read_bytes() == before


@needs_tmux
def test_replay_of_a_folder_steps_from_file_to_file_and_names_a_bad_one(tmp_path: Path) -> None:
    # Two sessions of one player started in the same second: the second is named ...-abuse-2.jsonl.
    # The start is fixed so that a second boundary between the two cannot split them.
    created = datetime.now().astimezone()
    first = write_replay_recording(tmp_path, created=created)
    second = write_replay_recording(tmp_path, created=created)
    assert second.name == first.name.replace(".jsonl", "-2.jsonl")
    bad = tmp_path / "rec" / "zz-bad.jsonl"
    bad.write_text('{"kind": "session", "schema": 1}\n')
    before = {path: path.read_bytes() for path in (first, second, bad)}
    with terminal(tmp_path, ["replay", "rec"]) as term:
        screen = term.wait_for(f"file 1/2 {first.name}")
        assert "left out: 1 file" in term.wait_for("left out: 1 file")
        term.send("Space")
        term.wait_for("paused")
        term.send("PageDown")
        screen = term.wait_for(f"file 2/2 {second.name}")
        assert "session 2/2" in screen and "PgUp PgDn" in screen and "file" in screen.splitlines()[-1]
        term.send("Home", "Right", "Right")
        term.wait_for("step 2/4")
        term.send("[")
        term.wait_for(f"file 1/2 {first.name}")
        term.send("]")
        term.wait_for(f"file 2/2 {second.name}")
        term.send("PageUp")
        term.wait_for(f"file 1/2 {first.name}")
        term.send("q")
        assert term.wait_exit() == 0
        # The line naming the bad file was printed before the screen opened.
        assert "warning: rec/zz-bad.jsonl:1: world: missing; left out" in term.history()
    assert {path: path.read_bytes() for path in before} == before
