"""The fit view's panels as Rich text: its notes, its intervals, its policy key and its settings line.

Each is drawn from a fit (or the world) alone, with no app; `careful_tui.screens.fit` lays them out and
redraws them when the fit or its settings change. The printout's own pieces are in
`careful_tui.render.fit_printout` and `careful_tui.render.intervals`, which these share.
"""

from __future__ import annotations

from rich.console import Group
from rich.text import Text

from careful_tui.option_words import said
from careful_tui.render.fit_printout import FIT_CHECK_CODES, evaluation_line, fit_check_text, unknown_phrase
from careful_tui.render.grid import format_value
from careful_tui.render.intervals import IntervalChart, interval_readings
from careful_tui.render.palette import WARN
from irl_core.irl import FitOptions, FitResult
from irl_core.irl.choices import METHODS
from irl_core.worlds.world import World


def settings_line(result: FitResult) -> str:
    """The fit's settings in a few words: "rmax 1000 · λ 0 · β 1 · special cells"."""
    options = result.options
    parts = [f"rmax {format_value(options.rmax)}", f"λ {format_value(options.lam)}"]
    if result.beta is not None:
        parts.append(f"β {result.beta:.3g}{' (estimated)' if result.beta_auto else ''}")
    parts.append(f"{options.reward_cells} cells{', tied' if options.tie else ''}")
    return " · ".join(parts)


def notes_panel(result: FitResult) -> Group:
    """How good the fit is, its fit check, its notes and what it could not tell apart."""
    check = [fit_check_text(result)] if result.fit_check is not None else []
    return Group(Text(evaluation_line(result), style="bold"), *check,
                 *(Text(f"• {said(note)}", style=WARN) for note in result.notes if note.code not in FIT_CHECK_CODES),
                 Text(unknown_phrase(result), style="dim"))


def intervals_panel(result: FitResult, options: FitOptions) -> Group | Text:
    """The intervals' chart and a sentence per symbol when `options` shows them, else the key that does."""
    if not options.intervals:
        what = (f"every value the demonstrations allow ({result.method})"
                if METHODS[result.method].interval_kind == "identified"
                else f"a {options.confidence:.0%} confidence interval (the likelihood's curvature)"
                if result.player_model == "timing"
                else f"a {options.confidence:.0%} confidence interval (resampling episodes)")
        return Text.assemble(("press ", "dim"), ("i", "bold"), (f" to bound every fitted reward: {what}", "dim"))
    if result.intervals is None:
        return Text("The intervals could not be computed: see the notes above.", style=WARN)
    if not len(result.intervals):
        return Text("nothing was fitted, so there is nothing to bound", style="dim")
    readings = [Text(f"{line[0].upper()}{line[1:]}.") for line in interval_readings(result)]
    for line in readings:
        line.stylize("bold", 0, line.plain.index(":"))
    return Group(IntervalChart(result), Text(), *readings)


def policy_key(world: World) -> Text:
    """What the policy board's labels say, in `world`'s kind of care (levels, or a hold's seconds)."""
    if world.care == "time":
        return Text.assemble(
            ("The most frequent action in each cell\n", "bold"),
            ("  →  ", "bold"), "the direction\n",
            (" .65s ", "bold"), "the hold, its duration bin's mid-point\n",
            (" ×38 ", "bold"), "how often it was taken there\n",
            (f"Holding costs {format_value(world.cost_per_second)} a second; a longer hold slips less.", "dim"),
        )
    level = f"the carefulness level (1-{world.levels})" if world.levels > 1 else "the level (one level)"
    slip = ("a level-c move slips with probability 2^-c" if world.slip == "halving" else
            "moves never slip" if world.slip == "none" else f"moves go {world.slip_label}")
    return Text.assemble(
        ("The most frequent action in each cell\n", "bold"),
        ("  →  ", "bold"), "the direction\n",
        ("  8  ", "bold"), f"{level}\n",
        (" ×38 ", "bold"), "how often it was taken there\n",
        (f"Each level costs {format_value(world.cost_per_level)}; {slip}.", "dim"),
    )
