"""The play and replay screens under abuse, driven by Pilot under a fake clock (deterministic).

The tmux tests (`test_play_abuse.py`) prove the same things in a real terminal; here the timing
is exact, so the tests can say which move each key event makes:

| test                                              | what it proves                              |
|---------------------------------------------------|---------------------------------------------|
| `test_two_arrows_held_at_once_...`                | the second press ends the first hold at     |
|                                                   | once; both holds keep their lengths         |
| `test_fast_interleaved_presses_...`               | L U L U is four level-1 moves               |
| `test_kitty_two_arrows_...`                       | press/repeat/release of two arrows: the     |
|                                                   | first inferred, the second exact            |
| `test_every_kitty_sequence_...`                   | every event type, modifier and malformed    |
|                                                   | variant on many keys: no crash, no stray    |
|                                                   | move                                        |
| `test_a_seeded_storm_...`                         | random keys, kitty events, resizes, ticks:  |
|                                                   | at every moment the file on disk holds      |
|                                                   | exactly the moves made, as the screen says  |
| `test_a_hold_across_a_shrink_...`                 | shrinking mid-hold cancels the hold and     |
|                                                   | says so, ignores keys while too small,      |
|                                                   | plays on after                              |
| `test_resizing_with_the_calibration_screen_open`  | no crash; play goes on                      |
| `test_tiny_terminals_...`                         | 0x0 .. 63x19, play and replay: no crash     |
| `test_two_games_in_the_same_second_...`           | two apps at once, same second, player and   |
|                                                   | folder: two files, each with its own moves  |
| `test_a_killed_writer_...`                        | SIGKILL after N moves: N steps on disk      |
| `test_replay_reads_kitty_...`                     | replay: repeats step, releases and junk do  |
|                                                   | nothing                                     |
| `test_replay_resized_while_playing_...`           | replay plays on while too small and shows   |
|                                                   | the right frame after                       |
"""

from __future__ import annotations

import asyncio
import os
import random
import signal
from collections.abc import Awaitable, Callable
from datetime import datetime
from itertools import pairwise
from pathlib import Path

import pytest
from play_fixtures import FakeClock, corner_world, write_two_episodes
from textual.pilot import Pilot
from textual.widgets import Static

import irl_core.recordings.writer
from careful_tui.app import CarefulApp, make_play_app, make_replay_app
from careful_tui.keys.kitty import KeyRelease, KittyParser
from careful_tui.screens.calibration import CalibrationScreen
from careful_tui.screens.play import minimum_size
from irl_core.play.game import Game, MoveResult
from irl_core.play.hold import HoldProfile
from irl_core.recordings.demonstrations import Recording, read_recording
from irl_core.recordings.lines import SessionHeader
from irl_core.recordings.writer import SessionRecorder

WORLD = corner_world("abuse")
PROFILE = HoldProfile(levels=14)
PERIOD = 0.033
BIG, SMALL = (100, 35), (60, 20)
ARROW_FINAL = {"up": "A", "down": "B", "right": "C", "left": "D"}


def new_app(tmp_path: Path, **options) -> tuple[CarefulApp, FakeClock, list[MoveResult]]:
    """A play app on a fake clock, and the list of every move its game makes."""
    clock = FakeClock()
    app = make_play_app(WORLD, out=tmp_path / "rec", player="abuse", seed=1, clock=clock, **options)
    moves: list[MoveResult] = []
    move = app.first_screen.game.move

    def counted(*args, **kwargs) -> MoveResult:
        moves.append(result := move(*args, **kwargs))
        return result

    app.first_screen.game.move = counted
    return app, clock, moves


def run(app, body: Callable[[Pilot], Awaitable[None]], size: tuple[int, int] = BIG) -> None:
    async def main() -> None:
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(main())


def kitty(key: str, event: int) -> str:
    """An arrow key event in kitty's protocol: 1 press, 2 repeat, 3 release."""
    return f"\x1b[1;1:{event}{ARROW_FINAL[key]}"


async def feed(pilot: Pilot, parser: KittyParser, data: str) -> None:
    """Bytes from the terminal, through the kitty-aware parser, into the app."""
    for message in parser.feed(data):
        pilot.app.post_message(message)
    await pilot.pause()


async def settle(pilot: Pilot, clock: FakeClock) -> None:
    """Let go of everything: the release timeout passes and the hold in progress ends."""
    clock.advance(1.0)
    pilot.app.first_screen.tick()
    await pilot.pause()


async def repeats(pilot: Pilot, clock: FakeClock, key: str, count: int) -> None:
    for _ in range(count):
        clock.advance(PERIOD)
        await pilot.press(key)


def status(app: CarefulApp) -> str:
    return str(app.query_one("#status", Static).render())


def steps(app: CarefulApp) -> list[tuple]:
    """(direction, level, hold_ms, exact) of every step in the app's file."""
    (path,) = app.first_screen.recorder.paths
    return [(s.direction, s.carefulness, s.hold_ms, s.hold_exact) for s in read_recording(path).steps]


def assert_file_matches(rec: Recording, moves: list[MoveResult]) -> None:
    """The file holds every move made, in order, and no other; each episode hangs together."""
    assert rec.warnings == []
    assert rec.steps == [move.step for move in moves]
    ends = {end.episode: end for end in rec.episode_ends}
    for episode in rec.episodes:
        episode_steps = [s for s in rec.steps if s.episode == episode]
        assert [s.t for s in episode_steps] == list(range(len(episode_steps)))
        for before, after in pairwise(episode_steps):
            assert after.state == before.next_state
        if episode in ends:
            assert ends[episode].steps == len(episode_steps)


# ---------------------------------------------------------------------------- two keys at once


def test_two_arrows_held_at_once_commit_two_moves(tmp_path: Path) -> None:
    app, clock, moves = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        # Right held: a press, the initial delay, autorepeats.
        await pilot.press("right")
        clock.advance(0.5)
        await pilot.press("right")
        await repeats(pilot, clock, "right", 12)
        # Down pressed while right is still down: autorepeat now follows down.
        clock.advance(PERIOD)
        await pilot.press("down")
        assert app.first_screen.game.t == 1, "the second press ends the first hold at once"
        clock.advance(0.5)
        await pilot.press("down")
        await repeats(pilot, clock, "down", 20)
        await settle(pilot, clock)
        assert app.first_screen.game.t == 2 and "step 2/200" in status(app)

    run(app, body)
    right_ms = (0.5 + 12 * PERIOD) * 1000 + PERIOD * 1000 / 2
    down_ms = (0.5 + 20 * PERIOD) * 1000 + PERIOD * 1000 / 2
    assert steps(app) == [
        ("right", PROFILE.level_for(right_ms), pytest.approx(right_ms, abs=0.1), False),
        ("down", PROFILE.level_for(down_ms), pytest.approx(down_ms, abs=0.1), False),
    ]
    assert [PROFILE.level_for(right_ms), PROFILE.level_for(down_ms)] == [4, 6]
    assert_file_matches(read_recording(app.first_screen.recorder.paths[0]), moves)


def test_fast_interleaved_presses_are_one_move_each(tmp_path: Path) -> None:
    app, clock, moves = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("down")  # away from the top edge, so every move goes somewhere
        await pilot.press("right")
        for n, key in enumerate(["left", "up", "left", "up"], start=2):
            clock.advance(0.01)
            await pilot.press(key)
            assert app.first_screen.game.t == n
        await settle(pilot, clock)
        assert app.first_screen.game.t == 6

    run(app, body)
    assert steps(app)[2:] == [(key, 1, 0.0, False) for key in ["left", "up", "left", "up"]]
    assert [m.step.next_state for m in moves] == [(1, 0), (1, 1), (1, 0), (0, 0), (0, 0), (0, 0)]


def test_kitty_two_arrows_end_the_first_by_the_second_press_and_the_second_by_its_release(tmp_path: Path) -> None:
    app, clock, moves = new_app(tmp_path)
    parser = KittyParser()

    async def body(pilot: Pilot) -> None:
        await feed(pilot, parser, kitty("right", 1))
        clock.advance(0.5)
        for _ in range(6):
            await feed(pilot, parser, kitty("right", 2))
            clock.advance(0.04)
        # Down pressed over right: right ends now, by inference (its release comes later).
        await feed(pilot, parser, kitty("down", 1))
        assert app.first_screen.game.t == 1
        clock.advance(0.5)
        for _ in range(3):
            await feed(pilot, parser, kitty("down", 2))
            clock.advance(0.05)
        await feed(pilot, parser, kitty("right", 3))  # the first key's release: not the hold's key
        assert app.first_screen.game.t == 1
        await feed(pilot, parser, kitty("down", 3))
        assert app.first_screen.game.t == 2
        # Two explicit presses of one key are two moves, however close.
        await feed(pilot, parser, kitty("left", 1))
        clock.advance(0.1)
        await feed(pilot, parser, kitty("left", 1))
        assert app.first_screen.game.t == 3
        clock.advance(0.1)
        await feed(pilot, parser, kitty("left", 3))
        await settle(pilot, clock)
        assert app.first_screen.game.t == 4 and app.is_running

    run(app, body)
    # Right: the press, 0.5 s, 6 repeats 40 ms apart; the last repeat at 700 ms, + half a period.
    # Left pressed twice without a release between: the first has no repeat, so it is a tap.
    assert steps(app) == [("right", PROFILE.level_for(720.0), pytest.approx(720.0), False),
                          ("down", PROFILE.level_for(650.0), pytest.approx(650.0), True),
                          ("left", 1, 0.0, False), ("left", 1, pytest.approx(100.0), True)]
    assert_file_matches(read_recording(app.first_screen.recorder.paths[0]), moves)


def kitty_zoo() -> list[str]:
    """Kitty key sequences of every event type and modifier, valid or not, on many keys.

    Presses and repeats of q and c are left out (they quit and calibrate, as they should), and
    so are the bracketed-paste brackets (200~, 201~: what lies between is text, not keys); one
    paste of key sequences is in.
    """
    events = ["", ":1", ":2", ":3", ":0", ":4", ":9", ":99999999999999999999", "::3", ":3:3"]
    mods = ["", "1", "2", "5", "9", "65", "129", "0", "65536", "x"]
    keys = [f"1;{{}}{final}" for final in "ABCDHFPQRS"] + [f"{code};{{}}u" for code in
                                                         (97, 65, 32, 13, 27, 9, 127, 57441, 0, 1114112, 55296)]
    keys += [f"{code};{{}}~" for code in (2, 3, 5, 6, 15, 24)]
    zoo = []
    for key in keys:
        for mod in mods:
            for event in events:
                zoo.append("\x1b[" + key.format(mod + event))
    for code in (113, 99):  # q and c: releases only
        zoo += [f"\x1b[{code};1:3u", f"\x1b[{code};5:3u", f"\x1b[{code}:81;2:3u"]
    zoo += ["\x1b[200~\x1b[1;1:3C\x1b[1;1:1B\x1b[201~",  # a paste: text, not keys
            "\x1b[97;1:1;97u", "\x1b[97;1:3;97:98u", "\x1b[97;;97u", "\x1b[;1:3u",  # text fields
            "\x1b[1;1:", "\x1b[1;", "\x1b[", "\x1b[1;1:3",  # cut short
            "\x1b[1;1:3\x1b[B", "\x1b\x1b[1;1:3C", "\x1b[1;1:3CC", "\x1b[1;1:3~"]  # run together
    return zoo


def test_every_kitty_sequence_never_crashes_and_moves_only_on_arrows(tmp_path: Path) -> None:
    app, clock, moves = new_app(tmp_path)
    parser = KittyParser()
    zoo = kitty_zoo()
    assert len(zoo) > 2000

    async def body(pilot: Pilot) -> None:
        for start in range(0, len(zoo), 50):
            await feed(pilot, parser, "".join(zoo[start:start + 50]))
            clock.advance(0.05)
            app.first_screen.tick()
            if not app.first_screen.game.live:
                await pilot.press("space")
        await settle(pilot, clock)
        assert app.is_running and isinstance(app.screen, type(app.default_screen))

    run(app, body)
    rec = read_recording(app.first_screen.recorder.paths[0])
    assert_file_matches(rec, moves)
    assert moves, "plain arrows (and arrows with caps/num lock) in the zoo move"
    assert {m.step.direction for m in moves} <= {"up", "right", "down", "left"}


# ---------------------------------------------------------------------------- a storm


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_seeded_storm_keeps_the_file_and_the_screen_in_step(tmp_path: Path, seed: int) -> None:
    """Random legacy and kitty key events, junk, resizes, clock jumps and ticks; after each, the
    file on disk (still open, as after a crash) holds exactly the moves made, and the screen's
    step count is the file's.

    The key events go from the parser straight to the app's handlers (what Textual's dispatch
    calls), so that a few hundred of them take a second; the tests above go through Pilot.
    """
    app, clock, moves = new_app(tmp_path)
    parser = KittyParser()
    rng = random.Random(seed)
    arrows = list(ARROW_FINAL)
    width, height = minimum_size(WORLD)
    sizes = [BIG, BIG, SMALL, (width, height), (width - 1, height), (1, 1), (80, 24)]
    zoo = kitty_zoo()

    def send(data: str) -> None:
        for event in parser.feed(data):
            if isinstance(event, KeyRelease):
                app.first_screen.on_key_release(event)
            else:
                app.first_screen.on_key(event)

    def check() -> None:
        if not moves:
            assert app.first_screen.recorder.paths == []
            return
        rec = read_recording(app.first_screen.recorder.paths[-1])
        assert_file_matches(rec, moves)
        game = app.first_screen.game
        if game.live:
            assert sum(s.episode == game.episode for s in rec.steps) == game.t
            assert f"step {game.t}/{WORLD.max_steps}" in status(app)
        else:
            assert rec.episode_ends[-1] == game.last_end

    async def body(pilot: Pilot) -> None:
        for _ in range(400):
            action = rng.choice(["legacy"] * 4 + ["kitty"] * 3 + ["wait"] * 3 + ["resize", "junk", "space"])
            key = rng.choice(arrows)
            if action == "legacy":
                send(f"\x1b[{ARROW_FINAL[key]}")
            elif action == "kitty":
                send(kitty(key, rng.choice([1, 2, 2, 3])))
            elif action == "wait":
                clock.advance(rng.choice([0.01, PERIOD, 0.05, 0.1, 0.3, 0.8]))
                app.first_screen.tick()
            elif action == "resize" and rng.random() < 0.3:
                await pilot.resize_terminal(*rng.choice(sizes))
                await pilot.pause()
            elif action == "junk":
                send(rng.choice(zoo))
            else:
                send(" ")
            check()
        await pilot.resize_terminal(*BIG)
        await settle(pilot, clock)
        check()
        await pilot.press("q")

    run(app, body)
    assert app.return_code == 0 and not app.first_screen.game.live
    rec = read_recording(app.first_screen.recorder.paths[-1])
    assert_file_matches(rec, moves)
    assert len(moves) > 30 and len(rec.episodes) > 1 and any(s.hold_exact for s in rec.steps)
    assert rec.episode_ends[-1].episode == rec.steps[-1].episode, "quitting ends the last episode"


# ---------------------------------------------------------------------------- resizing


def test_a_hold_across_a_shrink_is_cancelled_and_keys_wait_while_too_small(tmp_path: Path) -> None:
    app, clock, moves = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("right")
        clock.advance(0.5)
        await pilot.press("right")
        await repeats(pilot, clock, "right", 4)
        assert app.first_screen.input.current() is not None
        await pilot.resize_terminal(*SMALL)
        await pilot.pause()
        assert app.screen.has_class("-too-small")
        # The hold being entered when the window shrank is dropped, and the player is told.
        assert app.first_screen.input.current() is None
        assert "The move being entered was cancelled." in str(app.query_one("#too-small", Static).render())
        # The key is still down, but the window is too small to play in: the repeats do nothing.
        await repeats(pilot, clock, "right", 10)
        await pilot.press("down")
        await settle(pilot, clock)
        assert app.first_screen.game.t == 0 and moves == [], "a hold cut short by a shrink is no move"
        await pilot.resize_terminal(*BIG)
        await pilot.pause()
        shown = status(app)
        assert not app.screen.has_class("-too-small") and "step 0/200" in shown
        assert "Move cancelled (window too small)." in shown
        await pilot.press("down")
        await settle(pilot, clock)
        assert app.first_screen.game.t == 1

    run(app, body)
    assert steps(app) == [("down", 1, 0.0, False)]


def test_resizing_with_the_calibration_screen_open(tmp_path: Path) -> None:
    app, clock, moves = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("c")
        assert isinstance(app.screen, CalibrationScreen)
        for size in [SMALL, (1, 1), (0, 0), BIG, SMALL]:
            await pilot.resize_terminal(*size)
            await pilot.pause()
        await pilot.press("escape")
        await pilot.resize_terminal(*BIG)
        await pilot.pause()
        assert not isinstance(app.screen, CalibrationScreen) and not app.screen.has_class("-too-small")
        await pilot.press("right")
        await settle(pilot, clock)
        assert app.first_screen.game.t == 1

    run(app, body)
    assert [m.step.direction for m in moves] == ["right"]


TINY = [(0, 0), (1, 1), (2, 1), (1, 2), (10, 3), (63, 19), (64, 18), (79, 21), (80, 20)]


@pytest.mark.parametrize("size", [(0, 0), (1, 1), (63, 19)])
def test_tiny_terminals_never_crash_play_or_replay(tmp_path: Path, size: tuple[int, int]) -> None:
    """Start in a tiny terminal, pass through every tiny size, play a move in between."""
    app, clock, _ = new_app(tmp_path)

    async def play(pilot: Pilot) -> None:
        assert app.screen.has_class("-too-small")
        await pilot.press("right")
        await settle(pilot, clock)
        assert app.first_screen.game.t == 0
        for tiny in TINY:
            await pilot.resize_terminal(*tiny)
        await pilot.resize_terminal(*BIG)
        await pilot.pause()
        await pilot.press("right")
        await settle(pilot, clock)
        # A move being entered when the window shrinks is cancelled.
        await pilot.press("right")
        await pilot.resize_terminal(*size)
        await settle(pilot, clock)
        assert app.first_screen.game.t == 1

    run(app, play, size=size)
    replay = make_replay_app(read_recording(app.first_screen.recorder.paths[0]), playing=True, frame_seconds=3600)

    async def watch(pilot: Pilot) -> None:
        assert replay.screen.has_class("-too-small")
        for tiny in TINY:
            replay.first_screen.advance()
            await pilot.resize_terminal(*tiny)
        await pilot.press("left", "home", "end", "plus", "space")
        await pilot.resize_terminal(*BIG)
        await pilot.pause()
        assert not replay.screen.has_class("-too-small")

    run(replay, watch, size=size)


# ---------------------------------------------------------------------------- two games, a kill


def test_two_games_in_the_same_second_write_two_files(tmp_path: Path, monkeypatch) -> None:
    instant = datetime(2026, 3, 4, 5, 6, 7).astimezone()

    class Frozen(datetime):
        @classmethod
        def now(cls, tz=None):
            return instant

    monkeypatch.setattr(irl_core.recordings.writer, "datetime", Frozen)
    one, one_clock, one_moves = new_app(tmp_path)
    two, two_clock, two_moves = new_app(tmp_path)

    async def drive(app: CarefulApp, clock: FakeClock, keys: list[str]) -> None:
        async with app.run_test(size=BIG) as pilot:
            await pilot.pause()
            for key in keys:
                await pilot.press(key)
                await asyncio.sleep(0)  # let the other game take its turn
            await settle(pilot, clock)
            await pilot.press("q")

    async def both() -> None:
        await asyncio.gather(drive(one, one_clock, ["down", "right", "down"]),
                             drive(two, two_clock, ["right", "down"]))

    asyncio.run(both())
    names = sorted(path.name for path in (tmp_path / "rec").iterdir())
    assert names == ["20260304-050607-abuse-2.jsonl", "20260304-050607-abuse.jsonl"]
    for app, moves in [(one, one_moves), (two, two_moves)]:
        (path,) = app.first_screen.recorder.paths
        rec = read_recording(path)
        assert_file_matches(rec, moves)
        assert [e.outcome for e in rec.episode_ends] == ["quit"]
    assert [len(one_moves), len(two_moves)] == [3, 2]


def test_a_killed_writer_leaves_every_step_on_disk(tmp_path: Path) -> None:
    """What `careful play` does per move, in a child killed with SIGKILL before it closes anything."""
    header = SessionHeader(world=WORLD, player="abuse", created=datetime.now().astimezone(), seed=5)
    recorder = SessionRecorder(tmp_path / "rec", header)
    game = Game(WORLD, seed=5, sink=recorder)
    game.begin_episode()
    pid = os.fork()
    if pid == 0:  # the child: play, then die without closing or syncing anything
        try:
            for direction in ["down", "right", "up", "right", "down", "down", "left"]:
                game.move(direction, 3, hold_ms=812.0)
        finally:
            os.kill(os.getpid(), signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
    (path,) = (tmp_path / "rec").iterdir()
    rec = read_recording(path)
    assert rec.warnings == [] and rec.episode_ends == []
    assert [s.direction for s in rec.steps] == ["down", "right", "up", "right", "down", "down", "left"]
    assert rec.episodes == [0]


# ---------------------------------------------------------------------------- replay


def replay_recording(tmp_path: Path) -> Recording:
    return read_recording(write_two_episodes(tmp_path / "rec", WORLD))


def test_replay_reads_kitty_repeats_as_keys_and_drops_releases(tmp_path: Path) -> None:
    app = make_replay_app(replay_recording(tmp_path), frame_seconds=3600)
    parser = KittyParser()

    async def body(pilot: Pilot) -> None:
        await feed(pilot, parser, kitty("right", 3) + "\x1b[113;1:3u" + "\x1b[1;1:9C" + "\x1b[99999999u")
        assert app.first_screen.cursor.position == 0 and app.is_running
        await feed(pilot, parser, kitty("right", 2) + kitty("right", 2))
        assert app.first_screen.cursor.position == 2
        await feed(pilot, parser, kitty("right", 1) + kitty("right", 3))
        assert app.first_screen.cursor.position == 3
        await feed(pilot, parser, kitty("up", 1))
        assert app.first_screen.cursor.frame.index == 1
        zoo = kitty_zoo()
        for start in range(0, len(zoo), 50):
            await feed(pilot, parser, "".join(zoo[start:start + 50]))
        assert app.is_running

    run(app, body)


def test_replay_resized_while_playing_plays_on_and_shows_the_right_frame(tmp_path: Path) -> None:
    app = make_replay_app(replay_recording(tmp_path), playing=True, frame_seconds=3600)

    async def body(pilot: Pilot) -> None:
        app.first_screen.advance()
        await pilot.resize_terminal(*SMALL)
        await pilot.pause()
        assert app.screen.has_class("-too-small")
        for _ in range(3):
            app.first_screen.advance()
        await pilot.resize_terminal(*BIG)
        await pilot.pause()
        assert not app.screen.has_class("-too-small") and app.first_screen.cursor.position == 4
        text = str(app.query_one("#status", Static).render())
        assert "Episode 1/2" in text and "step 3/4" in text and "playing" in text

    run(app, body)
