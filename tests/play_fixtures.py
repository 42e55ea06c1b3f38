"""Shared play-test fixtures: a clock the test moves by hand, the small corner world the play
tests use, a two-episode recording of it for replay tests, and a Pilot runner for the app tests."""

from __future__ import annotations

import asyncio
import tomllib
from collections.abc import Awaitable, Callable
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from irl_core.play.game import Game
from irl_core.recordings.lines import SessionHeader
from irl_core.recordings.writer import SessionRecorder
from irl_core.worlds.world import World, world_from_dict

if TYPE_CHECKING:  # the headless session tests import this module and must not load Textual
    from textual.app import App
    from textual.pilot import Pilot


class FakeClock:
    """A clock the test moves by hand: it reads `now` (seconds)."""

    def __init__(self, now: float = 1000.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds


def corner_world_toml(name: str) -> str:
    """A 4x6 world file: start top-left; the cliff is the bottom row but its ends; the goal is bottom-right."""
    return f'''\
name = "{name}"
layout = """
......
......
......
.CCCCG
"""
levels = 14
slip = "none"
start = [0, 0]
[rewards]
C = -1000.0
G = 100.0
'''


def corner_world(name: str = "abuse") -> World:
    return world_from_dict(tomllib.loads(corner_world_toml(name)))


def write_two_episodes(folder: Path, world: World, *, created: datetime | None = None) -> Path:
    """A recording in `folder` of two quit episodes in `world`: down, down, down, right, then right,
    right, down, at levels 1, 2, 3, ... with hold times of 100 ms per level. The session starts at
    `created` (default now); the file is named after it."""
    created = datetime.now().astimezone() if created is None else created
    header = SessionHeader(world=world, player="abuse", created=created, seed=0)
    recorder = SessionRecorder(folder, header)
    game = Game(world, seed=0, sink=recorder)
    for moves in (["down", "down", "down", "right"], ["right", "right", "down"]):
        game.begin_episode()
        for level, direction in enumerate(moves, start=1):
            game.move(direction, level, hold_ms=100.0 * level)
    game.quit()
    recorder.close()
    (path,) = recorder.paths
    return path


def run_pilot(app: App, body: Callable[[Pilot], Awaitable[None]], size: tuple[int, int] = (100, 35)) -> None:
    """Run `app` headless at `size` and drive it with `body` once it has settled."""
    async def main() -> None:
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(main())
