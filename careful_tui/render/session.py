"""A session as Rich text: how an episode ended, a world's legend, and a recording's summary panel.

The play and replay screens share these; they draw nothing themselves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from careful_tui.render.grid import OTHER_SYMBOL_COLOUR, SYMBOL_COLOURS, SYMBOL_NAMES, diverging_colour, format_value
from careful_tui.render.palette import BAD, GOOD, HERE, NOTE, SLIP, WARN, level_colour
from irl_core.recordings.demonstrations import Recording
from irl_core.recordings.lines import EpisodeEnd
from irl_core.recordings.summary import SessionSummary, outcome_code
from irl_core.support.plural import plural
from irl_core.support.safe_text import VALUE_LIMIT, for_markup, printable
from irl_core.worlds.world import World

MEAN_BAR = 5


def outcome_text(end: EpisodeEnd | None) -> str:
    """How an episode ended, for a person: "reached the goal", "fell off the cliff", ..."""
    return outcome_words(outcome_code(end))


def outcome_words(code: str) -> str:
    """An `irl_core.recordings.summary.outcome_code` in words, the one wording play, replay and the summary use."""
    words = {"quit": "quit", "step_limit": "ran out of steps", "unfinished": "unfinished",
             "G": "reached the goal", "C": "fell off the cliff"}
    return words.get(code) or f"ended on {SYMBOL_NAMES.get(code, repr(code))}"


def outcome_colour(code: str) -> str:
    """The colour of an `irl_core.recordings.summary.outcome_code`: the goal good, any other terminal cell
    bad, an episode that ended without one (quit, out of steps, unfinished) a note."""
    if code == "G":
        return GOOD
    return NOTE if code in ("quit", "step_limit", "unfinished") else BAD


@dataclass(frozen=True)
class LegendEntry:
    """One symbol of a board's legend: its name, its reward as shown (None: rewards not shown), whether
    reaching it ends the episode."""

    symbol: str
    name: str
    reward: str | None
    ends: bool


def legend_entries(world: World, *, show_rewards: bool = True) -> list[LegendEntry]:
    """The board's legend, the one both front ends draw (the terminal's `legend`, the browser's view), so that a
    study's participants are told the same whichever they use: the world's rewarded symbols, each named, with
    its reward when `show_rewards` (a study's ``show_rewards``), and whether it ends the episode."""
    return [LegendEntry(symbol, SYMBOL_NAMES.get(symbol, printable(symbol)),
                        format_value(reward) if show_rewards else None, symbol in world.terminal)
            for symbol, reward in world.rewards.items()]


def legend(world: World, *, scale: float | None = None, show_rewards: bool = True) -> Text:
    """One line of `legend_entries`: "■ cliff -1000 · ■ goal 100 (ends)", each swatch the colour of its
    cells: the symbol's, or its reward's on `scale` when the board is coloured by value
    (`grid.diverging_colour`)."""
    text = Text()
    for entry in legend_entries(world, show_rewards=show_rewards):
        if text:
            text.append(" · ")
        colour = (SYMBOL_COLOURS.get(entry.symbol, OTHER_SYMBOL_COLOUR) if scale is None
                  else diverging_colour(world.rewards[entry.symbol], scale))
        text.append("■ ", style=colour)
        text.append(entry.name if entry.reward is None else f"{entry.name} {entry.reward}")
        if entry.ends:
            text.append(" (ends)", style="dim")
    return text


def short_warning(recording: Recording, warning: str) -> str:
    """A reader's warning without the file's name: "line 6: the last line is truncated ..."."""
    prefix = f"{recording.path}:"
    return f"line {warning.removeprefix(prefix)}" if warning.startswith(prefix) else warning


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
    for code, count in sorted(summary.outcomes.items(), key=lambda item: -item[1]):
        colour = outcome_colour(code)
        session.add_row(Text(str(count), style=colour), Text(outcome_words(code), style=colour))
    session.add_row(*plural(summary.steps, "step").split(" ", 1))
    session.add_row(Text(str(summary.slips), style=SLIP if summary.slips else ""),
                    "slip" if summary.slips == 1 else "slips")
    score = "—" if summary.final_score is None else format_value(summary.final_score)
    session.add_row(score, Text("final score", style="dim"))

    timed = world.care == "time"  # a time world's care is its hold, in ms, on a log bar up to the longest hold
    what = "hold (ms)" if timed else "carefulness"
    careful = Table(box=None, padding=(0, 0), show_edge=False, header_style="dim", title_style=f"bold {NOTE}",
                    title=f"{what} by\ndistance to {for_markup('/'.join(world.terminal))}", title_justify="left")
    careful.add_column("d", justify="right", width=2)
    careful.add_column("mean", justify="right", width=5)
    careful.add_column("", width=MEAN_BAR + 1)
    careful.add_column("n", justify="right", min_width=4)
    for d, (mean, n) in summary.carefulness_by_distance.items():
        share = (np.log1p(mean / 20) / np.log1p(world.max_hold_ms / 20)) if timed else mean / world.levels
        colour = level_colour(1 + share * (world.levels - 1) if timed else mean, world.levels)
        bar = "▆" * max(1, round(MEAN_BAR * share))
        careful.add_row(str(d), Text(f"{mean:.0f}" if timed else f"{mean:.1f}", style=f"bold {colour}"),
                        Text(f" {bar}", style=colour), str(n), style=f"bold on {HERE}" if d == distance else "")
    # Warnings first: the panel is cut at the bottom in a small terminal.
    warnings = [Text(f"⚠ {printable(short_warning(recording, warning), limit=200)}\n", style=f"bold {WARN}")
                for warning in recording.warnings]
    parts: list[RenderableType] = [*warnings, player, about, created, Text(), session, Text(), careful]
    if not summary.carefulness_by_distance:
        parts.append(Text("(no steps)", style="dim"))
    return Group(*parts)
