"""Play, replay and the fit view redraw in full after a storm of resizes: deterministic, through a
driver that draws into a model of a terminal.

In a real terminal a storm of resizes ending at the size it began at reaches the app as one
resize to the size it is already laid out at (Textual keeps only the last size), while the
terminal has cropped what it showed to the storm's smallest size. Textual's layout then finds
nothing changed and repaints nothing: the tmux resize test saw a screen blank but for its title
about 1 run in 4. Here the storm is exact: the model terminal is cropped to 1x1 and grown back,
then the app gets the one resize a driver would send; the screen it then shows must be whole.
"""

from __future__ import annotations

import asyncio
import io
import re
from collections.abc import Callable
from pathlib import Path

import pytest
from rich.console import Console
from test_play_abuse import write_replay_recording
from textual import events
from textual.driver import Driver
from textual.geometry import Size
from textual.pilot import Pilot

from careful_tui.app import CarefulApp, make_fit_app, make_play_app, make_replay_app
from careful_tui.cli import build_parser
from careful_tui.commands.fit import fit_from_args
from irl_core.recordings.demonstrations import read_recording
from irl_core.worlds.world import World

SIZE = (100, 35)
WORLD = World(name="abuse", layout="......\n......\n......\n.CCCCG\n", levels=14, slip="none", start=(0, 0),
              rewards={"C": -1000.0, "G": 100.0})
# What the driver reads: cursor moves, other control sequences (skipped), text.
_CONTROL = re.compile(r"\x1b\[(?P<params>[0-9;?<=>]*)(?P<final>[@-~])|\x1b\][^\x07\x1b]*(?:\x07|\x1b\\)|\x1b[^\[\]]")


class ModelTerminal:
    """The characters a terminal shows, from what an app writes (colours and modes ignored).

    Resizing crops to the top-left corner, as a terminal does: what is cut off is gone.
    """

    def __init__(self, size: tuple[int, int]) -> None:
        self.width, self.height = size
        self.rows = [[" "] * self.width for _ in range(self.height)]
        self.x = self.y = 0

    def resize(self, width: int, height: int) -> None:
        self.rows = [(row[:width] + [" "] * max(0, width - len(row))) for row in self.rows[:height]]
        self.rows += [[" "] * width for _ in range(height - len(self.rows))]
        self.width, self.height = width, height
        self.x, self.y = min(self.x, width - 1), min(self.y, height - 1)

    def write(self, data: str) -> None:
        at = 0
        for match in _CONTROL.finditer(data):
            self._text(data[at:match.start()])
            at = match.end()
            if match["final"] == "H":
                row, _, column = (match["params"] or "1;1").partition(";")
                self.y, self.x = int(row or 1) - 1, int(column or 1) - 1
            elif match["final"] == "J" and match["params"] == "2":
                self.rows = [[" "] * self.width for _ in range(self.height)]
        self._text(data[at:])

    def _text(self, text: str) -> None:
        for char in text:
            if char == "\r":
                self.x = 0
            elif char == "\n":
                self.y += 1
            elif char >= " " and 0 <= self.y < self.height:
                if 0 <= self.x < self.width:
                    self.rows[self.y][self.x] = char
                self.x += 1

    def lines(self) -> list[str]:
        return ["".join(row).rstrip() for row in self.rows]


def drawing_into(terminal: ModelTerminal) -> type[Driver]:
    """A driver class that draws into `terminal` and reports its size at the start (no input)."""

    class ModelDriver(Driver):
        def write(self, data: str) -> None:
            terminal.write(data)

        def start_application_mode(self) -> None:
            size = Size(terminal.width, terminal.height)
            self._app.post_message(events.Resize(size, size))

        def disable_input(self) -> None:
            pass

        def stop_application_mode(self) -> None:
            pass

    return ModelDriver


def whole(lines: list[str], marker: str) -> bool:
    """The screen shows `marker` and its key bar on the last line (a full frame)."""
    return any(marker in line for line in lines) and "quit" in lines[-1]


async def storm_then_check(app: CarefulApp, terminal: ModelTerminal, marker: str,
                           storm: list[tuple[int, int]]) -> list[str]:
    """Run `app` on `terminal`, resize the terminal through `storm` unseen (it ends at SIZE), then
    send the one resize a driver would: the lines shown once the app is idle again."""
    shown: list[str] = []

    async def pilot(pilot: Pilot) -> None:
        for _ in range(200):
            await pilot.pause(0.02)
            if whole(terminal.lines(), marker):
                break
        assert whole(terminal.lines(), marker), "\n".join(terminal.lines())
        for size in storm:
            terminal.resize(*size)
        app.post_message(events.Resize(Size(*SIZE), Size(*SIZE)))
        for _ in range(5):
            await pilot.pause(0.02)
        shown.extend(terminal.lines())
        app.exit()

    await asyncio.wait_for(app.run_async(auto_pilot=pilot), timeout=30)
    return shown


def play(tmp_path: Path, driver: type[Driver]) -> CarefulApp:
    return make_play_app(WORLD, out=tmp_path / "rec", player="abuse", seed=1, driver_class=driver)


def replay(tmp_path: Path, driver: type[Driver]) -> CarefulApp:
    return make_replay_app(read_recording(write_replay_recording(tmp_path)), driver_class=driver)


def fit_view(tmp_path: Path, driver: type[Driver]) -> CarefulApp:
    args = build_parser().parse_args(["fit", str(write_replay_recording(tmp_path))])
    demos, result = fit_from_args(args, err=Console(file=io.StringIO()))
    return make_fit_app(args, demos, result, driver_class=driver)


@pytest.mark.parametrize("storm", [[(1, 1), SIZE], [(60, 20), (1, 1), (30, 10), (64, 19), SIZE]],
                         ids=["1x1-and-back", "many"])
@pytest.mark.parametrize(("make", "marker"), [(play, "carefulness"), (replay, "Episode 1/2"),
                                             (fit_view, "demonstrated policy")], ids=["play", "replay", "fit"])
def test_a_storm_of_resizes_seen_as_one_to_the_same_size_redraws_everything(
        tmp_path: Path, make: Callable[[Path, type[Driver]], CarefulApp], marker: str,
        storm: list[tuple[int, int]]) -> None:
    terminal = ModelTerminal(SIZE)
    shown = asyncio.run(storm_then_check(make(tmp_path, drawing_into(terminal)), terminal, marker, storm))
    assert whole(shown, marker), "\n".join(shown)
    assert shown[0].lstrip().startswith("careful ")
