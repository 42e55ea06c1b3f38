"""The play screen's words: the status under the board and the hold's numbers under the gauge.

Both draw from their reactives, which the play screen binds to its own (`data_bind`): a change
of the game marks them for a repaint and Textual renders each once in the next frame, however
many of their reactives the change set. `render` reads the reactives as they are now, so what
it returns is always the current state, drawn or not.
"""

from __future__ import annotations

from rich.text import Text
from textual.reactive import reactive
from textual.widgets import Static

from careful_tui.render.grid import format_value
from careful_tui.render.palette import GOOD, WARN, level_colour
from careful_tui.render.session import outcome_colour, outcome_text
from irl_core.play.game import MoveResult
from irl_core.play.input_modes import InputMode
from irl_core.play.session import EpisodeNames, HoldView
from irl_core.recordings.lines import EpisodeEnd
from irl_core.recordings.summary import outcome_code
from irl_core.worlds.world import World


def mode_help(mode: InputMode, levels: int) -> str:
    """Under the gauge before the first move: how to choose a level in `mode` (the key bar says
    it too), with an example (`InputMode.gauge_help`)."""
    return "arrows: move" if levels == 1 else mode.gauge_help(min(3, levels))


class GameStatus(Static):
    """Three lines under the board: the episode, its step and score, the last episode's end (or
    a hint) and a message; after an episode, how it ended, the message and what space does."""

    episode: reactive[int] = reactive(0)
    step: reactive[int] = reactive(0)
    score: reactive[float] = reactive(0.0)
    live: reactive[bool] = reactive(False)
    last_end: reactive[EpisodeEnd | None] = reactive(None)
    message: reactive[Text] = reactive(Text)
    all_played: reactive[bool] = reactive(False)

    def __init__(self, world: World, names: EpisodeNames, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.world = world
        self.names = names

    def render(self) -> Text:
        names, end = self.names, self.last_end
        status = Text()
        if self.live or end is None:
            status.append(f"{names.word} {names.number(self.episode)}", style="bold")
            status.append(f"   step {self.step}/{self.world.max_steps}   score ", style="dim")
            status.append(format_value(self.score),
                          style="bold " + (GOOD if self.score >= self.world.initial_score else WARN))
            status.append("\n")
            if end is not None:
                status.append(f"Last {names.word.lower()} ({names.number(end.episode)}): ", style="dim")
                status.append(outcome_text(end), style=outcome_colour(outcome_code(end)))
                status.append(f", score {format_value(end.score)}", style="dim")
            elif self.world.care == "time":
                status.append("Hold longer to be more careful: it costs more and slips less.", style="dim")
            elif self.world.levels > 1:
                status.append("Careful moves cost more; they slip no less." if self.world.slip_is_fixed
                              else "Careful moves cost more and slip less.", style="dim")
            else:  # one level: no carefulness to choose
                status.append("Move with the arrow keys.", style="dim")
            status.append("\n")
            status.append_text(self.message)
            return status
        colour = outcome_colour(outcome_code(end))
        status.append(f"{names.word} {names.number(end.episode)}: ", style="bold")
        status.append(f"{outcome_text(end)}!", style=f"bold {colour}")
        status.append("   score ", style="dim")
        status.append(format_value(end.score), style=f"bold {colour}")
        status.append("\n")
        status.append_text(self.message)
        status.append("\n")
        status.append("Press space to go on." if self.all_played else "Press space for the next episode.", style="dim")
        return status


class HoldInfo(Static):
    """Under the gauge: the level and cost of the move being entered (and in a mode that times
    holds how long it has been held); between moves the last move, or before the first how to choose a level."""

    hold: reactive[HoldView | None] = reactive(None)
    last_move: reactive[MoveResult | None] = reactive(None)

    def __init__(self, world: World, mode: InputMode, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.world = world
        self.mode = mode

    def render(self) -> Text:
        if self.world.care == "time":
            return self._render_time()
        levels, view = self.world.levels, self.hold
        if view is not None:
            text = Text.assemble(
                ("level ", "dim"), (f"{view.level}", f"bold {level_colour(view.level, levels)}"),
                ("  cost ", "dim"), (format_value(self.world.cost_per_level * view.level), "bold"),
            )
            if self.mode.times_holds:
                text.append(f"\nheld {view.held_ms:.0f} ms", style="dim")
            return text
        if self.last_move is None:
            return Text(mode_help(self.mode, levels), style="dim")
        step = self.last_move.step
        text = Text.assemble(("last move\n", "dim"), (f"{step.direction} ", "bold"),
                             (f"level {step.level}", f"bold {level_colour(step.level, levels)}"))
        if step.hold_ms is not None and self.mode.times_holds:
            text.append(f"\n{step.hold_ms:.0f} ms" + (" (exact)" if step.hold_exact else ""), style="dim")
        return text

    def _render_time(self) -> Text:
        """A time world: no levels and no costs per level; the held time only if the world shows it."""
        view, shows = self.hold, self.world.show_hold
        if view is not None:
            return Text(f"held {view.held_ms:.0f} ms", style="bold") if shows else Text("holding…", style="dim")
        if self.last_move is None:
            return Text("hold an arrow:\nlonger = careful\nand costlier", style="dim")
        step = self.last_move.step
        text = Text.assemble(("last move\n", "dim"), (f"{step.direction}", "bold"))
        if shows and step.hold_ms is not None:
            text.append(f"\nheld {step.hold_ms:.0f} ms", style="dim")
        return text
