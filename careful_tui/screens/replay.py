"""`careful replay FILE...`: watch recorded sessions, step by step or animated (recordings/README.md and docs/index.md).

The screen is the play screen's, reused: the board shows the player where the step starts
with the arrow of the recorded direction and carefulness, then where the move went (a slip
framed in the slip colour); the gauge shows the step's recorded level and hold time. A side
panel summarises the session (`irl_core.recordings.summary`), with mean carefulness by distance from
the nearest terminal cell. Where the replay is lives in `irl_core.recordings.replay_cursor`.

Several files are watched one after another, each in its own world: the title and the panel
say which file (n of m) is on screen, and coming to a file recorded in another world than the
last one recomposes the screen for it.

Time: a Textual interval timer calls `ReplayScreen.advance` once a frame while playing (two
frames a step, an episode's end held for `END_TICKS`); tests call `advance` directly and
pass a `frame_seconds` long enough that the timer never fires on its own.
"""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual import events
from textual.app import ComposeResult
from textual.binding import Binding
from textual.reactive import var
from textual.screen import Screen
from textual.timer import Timer
from textual.widgets import Static

from careful_tui.render.grid import format_value
from careful_tui.render.palette import NOTE, SLIP, WARN, level_colour
from careful_tui.render.session import outcome_colour, outcome_text, summary_panel
from careful_tui.screens.game_layout import compose_game
from careful_tui.screens.game_layout import minimum_size as game_minimum_size
from careful_tui.widgets import Arrow, Board, Gauge
from careful_tui.widgets.too_small import TooSmall
from irl_core.play.input_modes import INPUT_MODES
from irl_core.recordings.demonstrations import Recording
from irl_core.recordings.lines import Step
from irl_core.recordings.replay_cursor import Frame, ReplayCursor, ReplayFiles
from irl_core.recordings.summary import distance_to_terminal, outcome_code, summarise
from irl_core.support.plural import plural
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.mdp import DIRECTIONS, OFFSETS
from irl_core.worlds.world import World

FRAME_S = 0.5
SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
# Ticks an episode's end stays on screen while playing (the outcome is worth a look).
END_TICKS = 3
PANEL_WIDTH = 19
# The session panel's share of the columns beside the gauge (the stylesheet's 1fr to the board's 3fr), past its
# least width.
PANEL_SHARE = 0.25
# Files left out that the notice on screen names (stderr names them all).
SKIPPED_SHOWN = 3


def speed_text(speed: float) -> str:
    return f"×{speed:g}"


def realised_direction(step: Step) -> str | None:
    """The direction the move went ("up", ...), or None if it stayed put (off the grid, a wall)."""
    delta = (step.next_state[0] - step.state[0], step.next_state[1] - step.state[1])
    for direction, offset in zip(DIRECTIONS, OFFSETS.tolist()):
        if tuple(offset) == delta:
            return direction
    return None


def minimum_size(world: World) -> tuple[int, int]:
    """The smallest terminal (columns, rows) the replay screen fits in, for `world`."""
    # As in replay.tcss: the gauge's border only; the session panel; the hold info under the gauge.
    return game_minimum_size(world, side_padding=2, panel_width=PANEL_WIDTH, panel_share=PANEL_SHARE, side_lines=3)


class ReplayScreen(Screen[None]):
    """The replay screen for one or more recordings, watched in the order given (the CLI and
    the tests build its app with `careful_tui.app.make_replay_app`).

    Args:
        recordings: the sessions to watch, each in its own world.
        skipped: one line per file that could not be read (shown once, as a notification).
        playing: start playing at once (the CLI does; the tests start paused).
        frame_seconds: seconds a frame stays on screen at speed ×1.
    """

    TITLE = "careful replay"
    STEP = Binding.Group("step")
    EPISODE = Binding.Group("episode")
    SPEED = Binding.Group("speed")
    JUMP = Binding.Group("jump")
    FILE = Binding.Group("file")
    BINDINGS = [
        Binding("space", "toggle_play('pause')", "pause", priority=True),
        Binding("space", "toggle_play('play')", "play", priority=True),
        Binding("left", "go('back')", "step back", key_display="←", priority=True, group=STEP),
        Binding("right", "go('forward')", "step", key_display="→", priority=True, group=STEP),
        Binding("up,n", "go('next_episode')", "next episode", key_display="↑", priority=True, group=EPISODE),
        Binding("down,p", "go('previous_episode')", "previous episode", key_display="↓", priority=True, group=EPISODE),
        Binding("plus,equals_sign", "faster", "faster", key_display="+", priority=True, group=SPEED),
        Binding("minus,underscore", "slower", "slower", key_display="-", priority=True, group=SPEED),
        Binding("home", "go('to_start')", "start", priority=True, group=JUMP),
        Binding("end", "go('to_end')", "end", priority=True, group=JUMP),
        # With several files the file keys take the jump keys' place in the key bar (80 columns
        # hold one of the two chips); the jump keys still work, unlisted.
        Binding("home", "go('to_start', 'unlisted')", "start", priority=True, show=False),
        Binding("end", "go('to_end', 'unlisted')", "end", priority=True, show=False),
        Binding("pageup,left_square_bracket", "go('previous_file')", "previous file", key_display="PgUp",
                priority=True, group=FILE),
        Binding("pagedown,right_square_bracket", "go('next_file')", "next file", key_display="PgDn",
                priority=True, group=FILE),
    ]

    # What is on screen: playing or paused, the speed, and the place (file, frame). Their
    # watchers redraw; `set_reactive` in __init__ sets them before there is anything to draw.
    playing: var[bool] = var(False, init=False)
    speed_index: var[int] = var(SPEEDS.index(1.0), init=False)
    place: var[tuple[int, int]] = var((0, 0), init=False)

    def __init__(self, recordings: Sequence[Recording], *, skipped: Sequence[str] = (), playing: bool = False,
                 frame_seconds: float = FRAME_S) -> None:
        super().__init__()
        self.files = ReplayFiles(recordings)
        self.skipped = list(skipped)
        self.set_reactive(ReplayScreen.playing, playing)
        self.frame_seconds = frame_seconds
        self._end_ticks = 0
        self._timer: Timer | None = None
        self._too_small = False
        self._warned: set[int] = set()
        self._recomposing = False
        self._distances_world: World | None = None
        self._read_file()

    @property
    def speed(self) -> float:
        return SPEEDS[self.speed_index]

    @property
    def cursor(self) -> ReplayCursor:
        """Where the replay is in the file on screen."""
        return self.files.cursor

    @property
    def recording(self) -> Recording:
        """The file on screen."""
        return self.files.recording

    @property
    def world(self) -> World:
        return self.files.recording.world

    def _read_file(self) -> None:
        """The summary of the file on screen, and its world's distances (kept while the world stays)."""
        if self._distances_world != self.world:
            # One MDP per world: the distances the panel and the summary both use.
            self.distances = distance_to_terminal(self.world)
            self._distances_world = self.world
        self.summary = summarise(self.recording, distances=self.distances)
        self._file_shown: int | None = None
        self._panel_shows: tuple[int | None] | None = None

    # ------------------------------------------------------------------ layout

    def compose(self) -> ComposeResult:
        self._composed_world = self.world
        yield from compose_game(self.world, panel=Static(id="summary"))

    def on_mount(self) -> None:
        self._start_timer()
        if self.skipped:
            lines = [printable(line, limit=200) for line in self.skipped[:SKIPPED_SHOWN]]
            if len(self.skipped) > SKIPPED_SHOWN:
                lines.append(f"and {len(self.skipped) - SKIPPED_SHOWN} more (each named on stderr)")
            self.notify("\n".join(lines), title=f"left out: {plural(len(self.skipped), 'file')}",
                        severity="warning", timeout=15, markup=False)
        self._check_size(*self.app.size)
        self.draw()

    def _enter_file(self) -> None:
        """The replay has come to another file: its summary, and the screen recomposed (after
        this returns) if the file's world is not the one on screen."""
        self._read_file()
        if self._recomposing:
            return  # the recomposition under way ends in the world of the file on screen then
        if self._composed_world != self.world:
            self._recomposing = True
            self.call_next(self._recompose_for_world)
        else:
            self._check_size(*self.app.size)

    async def _recompose_for_world(self) -> None:
        await self.recompose()
        if self.is_attached and self._composed_world != self.world:
            # The replay went on to a file of yet another world while this one was composed.
            self.call_next(self._recompose_for_world)
            return
        self._recomposing = False
        self._check_size(*self.app.size)
        self.draw()

    def _show_file(self) -> None:
        """The title and the panel's name for the file on screen, and its warnings (once per file)."""
        index, count = self.files.index, len(self.files)
        title = Text.assemble(("careful replay", f"bold {NOTE}"), " · ")
        if count > 1:
            title.append(f"file {index + 1}/{count} ", style=f"bold {NOTE}")
        title.append_text(Text.assemble(
            (printable(self.recording.path.name, limit=VALUE_LIMIT), "bold"),
            (f" · {plural(self.summary.episodes, 'episode')}, {plural(self.summary.steps, 'step')}", "dim"),
        ))
        self.query_one("#title", Static).update(title)
        self.query_one("#summary", Static).border_title = "session" if count == 1 else f"session {index + 1}/{count}"
        if index not in self._warned:
            self._warned.add(index)
            for warning in self.recording.warnings:
                self.notify(printable(warning, limit=400), title="recording", severity="warning", timeout=10,
                            markup=False)

    def on_resize(self, event: events.Resize) -> None:
        self._check_size(event.size.width, event.size.height)

    def _check_size(self, width: int, height: int) -> None:
        if self._recomposing:
            return
        self._too_small = self.query_one(TooSmall).check(width, height, minimum_size(self.world),
                                                         command="careful replay")
        self.refresh_bindings()

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
        if frame is not None and frame.phase == "end" and self._end_ticks < END_TICKS - 1 and not self.files.at_end:
            self._end_ticks += 1
            return
        self._end_ticks = 0
        self.files.forward()
        self.place = self.files.place
        if self.files.at_end:
            self.playing = False

    def watch_playing(self, playing: bool) -> None:
        if self._timer is not None:
            if playing:
                self._timer.reset()
                self._timer.resume()
            else:
                self._timer.pause()
        self.refresh_bindings()
        self.draw()

    def watch_speed_index(self) -> None:
        self._start_timer()
        self.draw()

    def watch_place(self, old: tuple[int, int], new: tuple[int, int]) -> None:
        if old[0] != new[0]:
            self._enter_file()
        self.draw()

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """Space says what it does now: pause while playing, play while paused. The file keys
        are there when there are several files, and then the jump keys are unlisted."""
        if action == "toggle_play" and parameters:
            return parameters == (("pause",) if self.playing else ("play",))
        if action == "go" and parameters and parameters[0] in ("next_file", "previous_file"):
            return len(self.files) > 1
        if action == "go" and parameters and parameters[0] in ("to_start", "to_end"):
            return (parameters[1:] == ("unlisted",)) == (len(self.files) > 1)
        return super().check_action(action, parameters)

    def action_toggle_play(self, shown: str = "") -> None:
        """Play or pause; playing from the last frame starts again from the first file's first
        (`shown`: what the key bar called it)."""
        if not self.playing and self.files.at_end:
            self.files.go_to_file(0)
            self.place = self.files.place
        self._end_ticks = 0
        self.playing = not self.playing and not self.files.at_end

    def action_go(self, move: str, listed: str = "") -> None:
        """Move (`forward`, `back`, `next_episode`, `previous_episode`, `to_start`, `to_end`,
        `next_file`, `previous_file`: `ReplayFiles`' moves) and show where the replay is
        (`listed` is "unlisted" for the jump keys the key bar leaves out: see `check_action`)."""
        getattr(self.files, move)()
        self._end_ticks = 0
        self.place = self.files.place

    def action_faster(self) -> None:
        self.speed_index = min(self.speed_index + 1, len(SPEEDS) - 1)

    def action_slower(self) -> None:
        self.speed_index = max(self.speed_index - 1, 0)

    # ------------------------------------------------------------------ drawing

    def draw(self) -> None:
        """Draw the current frame: board, gauge, hold time, status, panel and keys (the watchers
        call it; while the screen is recomposed for another world, the recomposition draws)."""
        if self._recomposing:
            return
        if self._file_shown != self.files.index:
            self._file_shown = self.files.index
            self._show_file()
        frame = self.cursor.frame
        board, gauge = self.query_one(Board), self.query_one(Gauge)
        step = None if frame is None else frame.step
        phase = None if frame is None else frame.phase
        board.player = None if frame is None else frame.player
        board.arrow = (Arrow(step.direction, step.level, self.world.levels)
                       if step is not None and phase == "before" else None)
        board.highlight = {step.next_state: SLIP} if step is not None and step.slipped and phase == "after" else {}
        gauge.level = None if step is None else step.level
        gauge.fill = 0.0 if step is None else float(step.level)
        self.query_one("#hold-info", Static).update(self._hold_info(step), layout=False)
        self.query_one("#status", Static).update(self._status(frame), layout=False)
        distance = None if frame is None or frame.player is None else self.distances.get(frame.player)
        if self._panel_shows != (distance,):
            self._panel_shows = (distance,)
            self.query_one("#summary", Static).update(summary_panel(self.recording, self.summary, distance),
                                                      layout=False)
        self.refresh_bindings()

    def _hold_info(self, step: Step | None) -> Text:
        if step is None:
            return Text()
        if self.world.care == "time" and step.hold_ms is not None:
            # A time world: the hold is the care; no level, and the cost of the exact hold.
            text = Text.assemble(("held ", "dim"), (f"{step.hold_ms:.0f} ms", "bold"),
                                 ("\ncost ", "dim"), (format_value(float(self.world.hold_cost(step.hold_ms))), "bold"))
            if step.hold_exact:
                text.append(" exact", style=f"bold {NOTE}")
            return text
        level = step.level
        text = Text.assemble(
            ("level ", "dim"), (f"{level}", f"bold {level_colour(level, self.world.levels)}"),
            ("  cost ", "dim"), (format_value(self.world.level_costs[level - 1]), "bold"),
        )
        mode = self.recording.header.input.get("mode")
        timed = mode in INPUT_MODES and INPUT_MODES[mode].times_holds  # a file may name a mode this version lacks
        if timed and step.hold_ms is not None:
            text.append(f"\nheld {step.hold_ms:.0f} ms", style="dim")
            if step.hold_exact:
                text.append(" exact", style=f"bold {NOTE}")
        elif mode is not None:
            text.append(f"\n{printable(str(mode), limit=20)} input", style="dim")
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
                colour = outcome_colour(outcome_code(end))
                status.append(f"{outcome_text(end)}!", style=f"bold {colour}")
                status.append("   score ", style="dim")
                status.append(format_value(end.score), style=f"bold {colour}")
        status.append("\n")
        status.append("▶ playing" if self.playing else "‖ paused", style=f"bold {NOTE}" if self.playing else "dim")
        status.append(f"   speed {speed_text(self.speed)}", style="dim")
        return status

    def _move_text(self, frame: Frame, step: Step) -> Text:
        colour = level_colour(step.level, self.world.levels)
        if frame.phase == "before":
            care = (f"held {step.hold_ms:.0f} ms" if self.world.care == "time" and step.hold_ms is not None
                    else f"at level {step.carefulness}")
            return Text.assemble((f"{step.direction} ", "bold"), (care, f"bold {colour}"),
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
        return Text.assemble(("slipped! ", f"bold {SLIP}"), where)
