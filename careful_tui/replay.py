"""`careful replay FILE`: watch a recorded session, step by step or animated (SPEC sections 2 and 4).

The screen is the play screen's, reused: the board shows the player where the step starts
with the arrow of the recorded direction and carefulness, then where the move went (a slip
framed in the slip colour); the gauge shows the step's recorded level and hold time. A side
panel summarises the session (`irl_core.summary`), with mean carefulness by distance from
the nearest terminal cell. Where the replay is lives in `careful_tui.replay_cursor`.

Time: a Textual interval timer calls `ReplayApp.advance` once a frame while playing (two
frames a step, an episode's end held for `END_TICKS`); tests call `advance` directly and
pass a `frame_seconds` long enough that the timer never fires on its own.
"""

from __future__ import annotations

import argparse

from rich.console import Console, Group
from rich.table import Table
from rich.text import Text
from textual import events
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.driver import Driver
from textual.timer import Timer
from textual.widgets import Static

from careful_tui.grid import format_value
from careful_tui.kitty import PassiveKittyDriver
from careful_tui.reading import read_with_progress
from careful_tui.play import BAD, GOOD, NOTE, carefulness_gauge, world_board
from careful_tui.replay_cursor import Frame, ReplayCursor
from careful_tui.widgets import Arrow, Board, Gauge, KeyBar, level_colour
from careful_tui.widgets.board import MIN_CELL, SLIP_COLOUR
from careful_tui.widgets.too_small import TooSmall
from irl_core.demonstrations import Recording, Step
from irl_core.safe_text import VALUE_LIMIT, printable
from irl_core.mdp import DIRECTIONS, OFFSETS
from irl_core.game import level_costs
from irl_core.summary import SessionSummary, distance_to_terminal, outcome_label, summarise
from irl_core.world import World

FRAME_S = 0.5
SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
# Ticks an episode's end stays on screen while playing (the outcome is worth a look).
END_TICKS = 3
PANEL_WIDTH = 19
WARN = "#ffd54f"
MEAN_BAR = 5
HERE = "bold on #2a3442"


def speed_text(speed: float) -> str:
    return f"×{speed:g}"


def plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def short_warning(recording: Recording, warning: str) -> str:
    """A reader's warning without the file's name: "line 6: the last line is truncated ..."."""
    prefix = f"{recording.path}:"
    return f"line {warning.removeprefix(prefix)}" if warning.startswith(prefix) else warning


def realised_direction(step: Step) -> str | None:
    """The direction the move went ("up", ...), or None if it stayed put (off the grid, a wall)."""
    delta = (step.next_state[0] - step.state[0], step.next_state[1] - step.state[1])
    for direction, offset in zip(DIRECTIONS, OFFSETS.tolist()):
        if tuple(offset) == delta:
            return direction
    return None


def minimum_size(world: World) -> tuple[int, int]:
    """The smallest terminal (columns, rows) the replay screen fits in, for `world`."""
    gauge = Gauge(level_costs(world))
    cell_width, cell_height = MIN_CELL
    # As in replay.tcss: gauge border; board border; the panel; title and key bars; 3 status lines.
    width = (gauge.get_content_width(None, None) + 2) + (world.cols * cell_width + 2) + PANEL_WIDTH
    height = 2 + max(world.levels + 2 + 3, world.rows * cell_height + 2 + 3)
    return width, height


def summary_panel(recording: Recording, summary: SessionSummary, distance: int | None) -> Group:
    """The session at a glance; `distance` marks the current row of the carefulness table."""
    header, world = recording.header, recording.world
    about = Table.grid(padding=(0, 1))
    about.add_column(style="dim", no_wrap=True)
    about.add_column(overflow="fold")
    about.add_row("world", Text(printable(world.name, limit=VALUE_LIMIT), style="bold"))
    about.add_row("input", Text(printable(str(header.input.get("mode", "?")), limit=20)))
    player = Text(printable(header.player, limit=VALUE_LIMIT), style="bold", overflow="fold")
    created = Text(f"{header.created:%Y-%m-%d %H:%M}", style="dim")

    session = Table.grid(padding=(0, 1))
    session.add_column(justify="right", style="bold", no_wrap=True)
    session.add_column()
    session.add_row(*plural(summary.episodes, "episode").split(" ", 1))
    for label, count in sorted(summary.outcomes.items(), key=lambda item: -item[1]):
        colour = GOOD if label == "reached the goal" else BAD if label == "fell off the cliff" else NOTE
        session.add_row(Text(str(count), style=colour), Text(label, style=colour))
    session.add_row(*plural(summary.steps, "step").split(" ", 1))
    session.add_row(Text(str(summary.slips), style=SLIP_COLOUR if summary.slips else ""),
                    "slip" if summary.slips == 1 else "slips")
    score = "—" if summary.final_score is None else format_value(summary.final_score)
    session.add_row(score, Text("final score", style="dim"))

    careful = Table(box=None, padding=(0, 0), show_edge=False, header_style="dim", title_style=f"bold {NOTE}",
                    title=f"carefulness by\ndistance to {'/'.join(world.terminal)}", title_justify="left")
    careful.add_column("d", justify="right", width=2)
    careful.add_column("mean", justify="right", width=5)
    careful.add_column("", width=MEAN_BAR + 1)
    careful.add_column("n", justify="right", min_width=4)
    for d, (mean, n) in summary.carefulness_by_distance.items():
        colour = level_colour(mean, world.levels)
        bar = "▆" * max(1, round(MEAN_BAR * mean / world.levels))
        careful.add_row(str(d), Text(f"{mean:.1f}", style=f"bold {colour}"), Text(f" {bar}", style=colour),
                        str(n), style=HERE if d == distance else "")
    # Warnings first: the panel is cut at the bottom in a small terminal.
    warnings = [Text(f"⚠ {printable(short_warning(recording, warning), limit=200)}\n", style=f"bold {WARN}")
                for warning in recording.warnings]
    parts = [*warnings, player, about, created, Text(), session, Text(), careful]
    if not summary.carefulness_by_distance:
        parts.append(Text("(no steps)", style="dim"))
    return Group(*parts)


class ReplayApp(App[None]):
    """The replay screen for one recording (the CLI and the tests build it the same way).

    Args:
        recording: the session to watch.
        playing: start playing at once (the CLI does; the tests start paused).
        frame_seconds: seconds a frame stays on screen at speed ×1.
        driver_class: the terminal driver (the CLI passes `PassiveKittyDriver`: a replay has
            no use for key releases, but must survive a terminal that sends them).
    """

    CSS_PATH = ["play.tcss", "replay.tcss"]
    TITLE = "careful replay"
    ENABLE_COMMAND_PALETTE = False
    BINDINGS = [
        Binding("space", "toggle_play", "play/pause", priority=True),
        Binding("right", "forward", "step", priority=True),
        Binding("left", "back", "step back", priority=True),
        Binding("up,n", "next_episode", "next episode", priority=True),
        Binding("down,p", "previous_episode", "previous episode", priority=True),
        Binding("plus,equals_sign", "faster", "faster", priority=True),
        Binding("minus,underscore", "slower", "slower", priority=True),
        Binding("home", "to_start", "start", priority=True),
        Binding("end", "to_end", "end", priority=True),
        Binding("q,ctrl+c,ctrl+q", "quit", "quit", priority=True),
    ]

    def __init__(self, recording: Recording, *, playing: bool = False, frame_seconds: float = FRAME_S,
                 driver_class: type[Driver] | None = None) -> None:
        super().__init__(driver_class=driver_class)
        self.recording = recording
        self.world = recording.world
        self.cursor = ReplayCursor.from_recording(recording)
        self.summary = summarise(recording)
        self.distances = distance_to_terminal(self.world)
        self.playing = playing
        self.frame_seconds = frame_seconds
        self.speed_index = SPEEDS.index(1.0)
        self._end_ticks = 0
        self._too_small = False
        self._timer: Timer | None = None
        self._panel_shows: tuple[int | None] | None = None

    @property
    def speed(self) -> float:
        return SPEEDS[self.speed_index]

    # ------------------------------------------------------------------ layout

    def compose(self) -> ComposeResult:
        yield Static(id="title")
        with Horizontal(id="main"):
            with Vertical(id="side"):
                yield carefulness_gauge(self.world)
                yield Static(id="hold-info")
            with Vertical(id="right"):
                yield world_board(self.world)
                yield Static(id="status")
            panel = Static(id="summary")
            panel.border_title = "session"
            yield panel
        yield TooSmall(id="too-small")
        yield KeyBar(id="keys")

    def on_mount(self) -> None:
        self.query_one("#title", Static).update(Text.assemble(
            ("careful replay", f"bold {NOTE}"), " · ", (printable(self.recording.path.name, limit=VALUE_LIMIT), "bold"),
            (f" · {plural(self.summary.episodes, 'episode')}, {plural(self.summary.steps, 'step')}", "dim"),
        ))
        self._start_timer()
        for warning in self.recording.warnings:
            self.notify(printable(warning, limit=400), title="recording", severity="warning", timeout=10, markup=False)
        self._check_size(*self.size)
        self.show()

    def on_resize(self, event: events.Resize) -> None:
        self._check_size(event.size.width, event.size.height)

    def _check_size(self, width: int, height: int) -> None:
        self._too_small = self.query_one(TooSmall).check(width, height, minimum_size(self.world),
                                                         command="careful replay")
        self.query_one(KeyBar).show(self._keys())

    def _start_timer(self) -> None:
        if self._timer is not None:
            self._timer.stop()
        self._timer = self.set_interval(self.frame_seconds / self.speed, self.advance, pause=not self.playing)

    # ------------------------------------------------------------------ playing

    def advance(self) -> None:
        """One tick of playback: the next frame (an episode's end stays `END_TICKS` ticks).

        Playback stops at the last frame. Does nothing while paused.
        """
        if not self.playing:
            return
        frame = self.cursor.frame
        if frame is not None and frame.phase == "end" and self._end_ticks < END_TICKS - 1 and not self.cursor.at_end:
            self._end_ticks += 1
            return
        self._end_ticks = 0
        self.cursor.forward()
        if self.cursor.at_end:
            self._set_playing(False)
        self.show()

    def _set_playing(self, playing: bool) -> None:
        self.playing = playing
        if self._timer is not None:
            if playing:
                self._timer.reset()
                self._timer.resume()
            else:
                self._timer.pause()

    def action_toggle_play(self) -> None:
        """Play or pause; playing from the last frame starts again from the first."""
        if not self.playing and self.cursor.at_end:
            self.cursor.to_start()
        self._end_ticks = 0
        self._set_playing(not self.playing and len(self.cursor) > 1)
        self.show()

    def _move(self, moved: bool) -> None:
        self._end_ticks = 0
        if moved:
            self.show()

    def action_forward(self) -> None:
        self._move(self.cursor.forward())

    def action_back(self) -> None:
        self._move(self.cursor.back())

    def action_next_episode(self) -> None:
        self._move(self.cursor.next_episode())

    def action_previous_episode(self) -> None:
        self._move(self.cursor.previous_episode())

    def action_to_start(self) -> None:
        self._move(self.cursor.to_start())

    def action_to_end(self) -> None:
        self._move(self.cursor.to_end())

    def action_faster(self) -> None:
        self._set_speed(self.speed_index + 1)

    def action_slower(self) -> None:
        self._set_speed(self.speed_index - 1)

    def _set_speed(self, index: int) -> None:
        index = max(0, min(index, len(SPEEDS) - 1))
        if index != self.speed_index:
            self.speed_index = index
            self._start_timer()
            self.show()

    # ------------------------------------------------------------------ drawing

    def show(self) -> None:
        """Draw the current frame: board, gauge, hold time, status, panel and keys."""
        frame = self.cursor.frame
        board, gauge = self.query_one(Board), self.query_one(Gauge)
        step = None if frame is None else frame.step
        board.player = None if frame is None else frame.player
        board.arrow = (Arrow(step.direction, step.carefulness, self.world.levels)
                       if step is not None and frame.phase == "before" else None)
        slipped = step is not None and step.slipped and frame.phase == "after"
        board.highlight = {step.next_state: SLIP_COLOUR} if slipped else {}
        gauge.level = None if step is None else step.carefulness
        gauge.fill = 0.0 if step is None else float(step.carefulness)
        self.query_one("#hold-info", Static).update(self._hold_info(step), layout=False)
        self.query_one("#status", Static).update(self._status(frame), layout=False)
        distance = None if frame is None or frame.player is None else self.distances.get(frame.player)
        if self._panel_shows != (distance,):
            self._panel_shows = (distance,)
            self.query_one("#summary", Static).update(summary_panel(self.recording, self.summary, distance),
                                                      layout=False)
        self.query_one(KeyBar).show(self._keys())

    def _hold_info(self, step: Step | None) -> Text:
        if step is None:
            return Text()
        level = step.carefulness
        text = Text.assemble(
            ("level ", "dim"), (f"{level}", f"bold {level_colour(level, self.world.levels)}"),
            ("  cost ", "dim"), (format_value(self.world.cost_per_level * level), "bold"),
        )
        mode = self.recording.header.input.get("mode")
        if mode == "hold" and step.hold_ms is not None:
            text.append(f"\nheld {step.hold_ms:.0f} ms", style="dim")
            if step.hold_exact:
                text.append(" exact", style=f"bold {NOTE}")
        elif mode is not None:
            text.append(f"\n{mode} input", style="dim")
        return text

    def _status(self, frame: Frame | None) -> Text:
        status = Text()
        if frame is None:
            status.append("This recording has no steps.", style="bold")
            return status
        steps = len(frame.episode.steps)
        status.append(f"Episode {frame.index + 1}/{len(self.cursor.episodes)}", style="bold")
        step = frame.step
        if step is not None:
            status.append(f"   step {frame.t + 1}/{steps}", style="dim")
            score = step.score if frame.phase == "after" else step.score - step.reward
            status.append("   score ", style="dim")
            status.append(format_value(score), style="bold")
            status.append("\n")
            status.append_text(self._move_text(frame, step))
        else:
            end = frame.episode.end
            status.append(f"   {plural(steps, 'step')}\n", style="dim")
            if end is None:
                status.append("unfinished: the recording stops here", style=f"bold {WARN}")
            else:
                colour = GOOD if end.terminal_symbol == "G" else BAD if end.outcome == "terminal" else NOTE
                status.append(f"{outcome_label(end.outcome, end.terminal_symbol, self.world)}!", style=f"bold {colour}")
                status.append("   score ", style="dim")
                status.append(format_value(end.score), style=f"bold {colour}")
        status.append("\n")
        status.append("▶ playing" if self.playing else "‖ paused", style=f"bold {NOTE}" if self.playing else "dim")
        status.append(f"   speed {speed_text(self.speed)}", style="dim")
        return status

    def _move_text(self, frame: Frame, step: Step) -> Text:
        colour = level_colour(step.carefulness, self.world.levels)
        if frame.phase == "before":
            return Text.assemble((f"{step.direction} ", "bold"), (f"at level {step.carefulness}", f"bold {colour}"),
                                 (f"   reward {format_value(step.reward)}", "dim"))
        if not step.slipped:
            return Text.assemble(("went ", "dim"), (step.direction, "bold"))
        # Newer recordings say which way the move went; for older ones it is read off the cells,
        # where a slip into a wall or off the grid leaves no direction to read.
        went = step.realised or realised_direction(step)
        if went is None:
            where = f"stayed put instead of going {step.direction}"
        elif step.next_state == step.state:
            where = f"went {went} into the edge instead of {step.direction}"
        else:
            where = f"went {went} instead of {step.direction}"
        return Text.assemble(("slipped! ", f"bold {SLIP_COLOUR}"), where)

    def _keys(self) -> list[tuple[str, str]]:
        if self._too_small:
            return [("q", "quit")]
        return [("space", "pause" if self.playing else "play"), ("←→", "step"), ("↑↓", "episode"),
                ("+-", speed_text(self.speed)), ("home end", "jump"), ("q", "quit")]


def run_replay(args: argparse.Namespace) -> int:
    """`careful replay FILE`: read the recording (bad files are reported without a terminal), then watch it."""
    from careful_tui.cli import require_terminal

    (recording,) = read_with_progress([args.file], Console(stderr=True, highlight=False))
    require_terminal("replay")
    ReplayApp(recording, playing=True, driver_class=PassiveKittyDriver).run()
    return 0
