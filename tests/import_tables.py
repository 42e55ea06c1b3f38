"""Trial tables for `careful import`'s tests: a lab's table and its column map, careful's own export's map, and a
session played as `careful play` records it."""

import csv
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from irl_core.play.game import Game
from irl_core.recordings.lines import SessionHeader
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.mdp import DIRECTIONS
from irl_core.worlds.world import World

SHORT = World(name="short", layout="......\n......\n......\n.CCCCG\n", levels=4, max_steps=8,
              rewards={"C": -1000.0, "G": 100.0})
SHORT_TIME = World(name="short-time", layout="......\n......\n......\n.CCCCG\n", care="time", max_steps=8,
                   rewards={"C": -1000.0, "G": 100.0})
SHORT_STEADY = SHORT.model_copy(update={"name": "short-steady", "slip": "none"})

# The map of careful's own CSV export: what a round trip imports with.
EXPORT_MAP = """\
participant = "player"
episode = "episode"
t = "t"
state = ["row", "col"]
next_state = ["next_row", "next_col"]
action = "direction"
rt_ms = "hold_ms"
{level}
[actions]
up = "up"
right = "right"
down = "down"
left = "left"
"""

# A lab's own table: x the column, y the row counted from the bottom, arrows, seconds.
LAB_MAP = """\
participant = "subject"
episode = "trial"
t = "move"
state = ["x", "y"]
axes = "xy"
origin = "bottom-left"
action = "key"
rt_s = "rt"
[actions]
up = "^"
down = "v"
left = "<"
right = ">"
"""
LAB_COLUMNS = ("subject", "trial", "move", "x", "y", "key", "rt")


def play(path: Path, world: World, *, seed: int, episodes: int, player: str = "ada") -> Path:
    """A session as `careful play` records it: random moves and holds; some episodes quit."""
    header = SessionHeader(world=world, player=player, created=datetime(2026, 1, 1, tzinfo=UTC), seed=seed,
                           input={"mode": "hold"})
    rng = np.random.default_rng(seed)
    with RecordingWriter(path, header) as writer:
        game = Game(world, seed=seed, sink=writer)
        for _ in range(episodes):
            game.begin_episode()
            for _ in range(int(rng.integers(1, 12))):
                timed = world.care == "time"
                hold = float(rng.uniform(0, 5000)) if timed or rng.random() < 0.8 else None
                result = game.move(DIRECTIONS[rng.integers(4)], None if timed else int(rng.integers(1, world.levels + 1)),
                                   hold_ms=hold, exact=bool(rng.random() < 0.3))
                if result.end:
                    break
            else:
                game.quit()
    return path


def write_map(folder: Path, text: str) -> Path:
    path = folder / "map.toml"
    path.write_text(text, encoding="utf-8")
    return path


def write_lab_table(path: Path, rows: list[tuple]) -> Path:
    with open(path, "w", encoding="utf-8", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(LAB_COLUMNS)
        writer.writerows(rows)
    return path
