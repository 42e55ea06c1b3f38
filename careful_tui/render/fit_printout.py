"""A fit as Rich renderables: the `careful fit` printout and the pieces the fit screen shares.

`print_fit` prints the reward grid beside the world's own, the intervals
(`careful_tui.render.intervals`), the demonstrated policy, what an agent trained on the reward
does (`evaluation_line`), whether the fitted player reproduces the recordings (`fit_check_text`) and
the status.
"""

from __future__ import annotations

import io

import numpy as np
from rich.console import Console, Group
from rich.table import Table
from rich.text import Text

from careful_tui.option_words import said
from careful_tui.render.grid import ARROWS, SYMBOL_NAMES, WorldGrid, format_value
from careful_tui.render.intervals import IntervalChart, interval_readings, interval_table, shown_reward_grid
from irl_core.irl import FitResult
from irl_core.irl.choices import METHODS
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.support.plural import plural
from irl_core.support.safe_text import printable


def print_fit(console: Console, demos: Demonstrations, result: FitResult, *, soft_wrap: bool = True) -> None:
    """The reward grid (beside the world's own), the intervals, the policy and the status.

    Sentences are printed `soft_wrap` (whole lines, for the terminal or a pipe to wrap or keep);
    without it Rich wraps them at the console's width, as a page (`--svg`) needs.
    """
    world = result.world
    console.print(
        Text.assemble(
            ("careful fit", "bold"),
            f": {method_phrase(result)} on ",
            (printable(world.name, limit=80), "bold"),
            f" from {plural(demos.files, 'file')}, {plural(demos.episodes, 'episode')}, {plural(demos.steps, 'step')}",
        )
    )
    console.print(reward_grids(result, width=console.width))
    console.print(Text(unknown_phrase(result), style="dim"))
    if result.intervals is not None and len(result.intervals):
        console.print(interval_table(result))
        console.print(IntervalChart(result))
        for line in interval_readings(result):
            console.print(Text(line), soft_wrap=soft_wrap)
    console.print(policy_grid(result))
    console.print(Text(evaluation_line(result)), soft_wrap=soft_wrap)
    if result.fit_check is not None:
        console.print(fit_check_text(result), soft_wrap=soft_wrap)
    console.print(status_text(result), soft_wrap=soft_wrap)


def fit_page_svg(demos: Demonstrations, result: FitResult, *, width: int, title: str) -> str:
    """The whole fit as an SVG page, `width` columns wide (wider for a world wider than that): `careful fit --svg`,
    and the fit view's `s` (the view's screen shows only the part scrolled into sight)."""
    # A page, not a terminal: its sentences wrap at its width instead of being cut there, and it is at least as
    # wide as the world, whose grids would otherwise come in strips of columns.
    width = max(width, result.world.cols * WorldGrid(result.world).cell_width)
    page = Console(record=True, file=io.StringIO(), width=width, highlight=False)
    print_fit(page, demos, result, soft_wrap=False)
    return page.export_svg(title=title)


def reward_scale(result: FitResult) -> float:
    """The magnitude that gets the strongest colour: the largest |R_S|, fitted or true."""
    values = np.concatenate([result.reward_grid.ravel(), result.true_reward_grid.ravel()])
    scale = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 0.0
    return scale if scale > 0 else 1.0


def reward_grids(result: FitResult, *, width: int) -> Table | Group:
    """The fitted R_S and, when the world defines rewards, the true R_S beside it (one colour scale).

    Side by side when `width` allows, else one above the other (each in strips of columns if wider still).
    """
    world = result.world
    scale = reward_scale(result)
    unit = result.reward_unit
    shown, bounds = shown_reward_grid(result)  # a reward bounded on one side only shows its bound, not a point
    fitted = Text.assemble(("fitted R_S", "bold"), " (point estimate" + ("" if unit == "points" else f", {unit}")
                           + ("; ≤ ≥: bounded on one side only, no point" if bounds else "") + ")")
    grids = [Group(fitted, WorldGrid(world, values=shown, scale=scale, labels=bounds))]
    if world.rewards:
        true = "true R_S (world file" + {"points": ")", "seconds of holding": ", in seconds at its cost)"}.get(
            unit, f", {unit} as the fit)")
        grids.append(Group(Text(true, style="bold"), WorldGrid(world, values=result.true_reward_grid, scale=scale)))
    gap = 4
    grid_width = world.cols * WorldGrid(world).cell_width
    side_by_side = len(grids) * grid_width + (len(grids) - 1) * gap <= width
    if not side_by_side:
        return Group(*grids)
    table = Table.grid(padding=(0, gap))
    for _ in grids:
        table.add_column(min_width=grid_width)
    table.add_row(*grids)
    return table


def unknown_phrase(result: FitResult) -> str:
    """Which rewards were fitted: "fitted: the non-ground cells (ground is 0); the action cost is known"."""
    options = result.options
    cells = "every cell" if options.reward_cells == "all" else "the non-ground cells (ground is 0)"
    fitted = f"fitted: {cells}{', one value per symbol' if options.tie else ''}"
    curve = result.slip_curve
    held = "".join(f"; {symbol} held at {format_value(value)}" for symbol, value in result.unknowns.held)
    fitted += held
    if curve is None:
        return f"{fitted}; the action cost is known"
    slips = "the world's slip curve" if curve.known else "the slip curve learnt from the recorded slips"
    if result.reward_unit == "points":
        per_second = (result.recorded_world or result.world).cost_per_second
        return f"{fitted}; holding costs {format_value(per_second)} points a second (known); {slips}"
    return f"{fitted}; the cost of holding taken as unknown, so rewards are in seconds of holding; {slips}"


def policy_labels(result: FitResult) -> dict[tuple[int, int], str]:
    """Per demonstrated cell, the most frequent action: "→8 ×38" (direction, carefulness level, count); on a time
    world "→1.7 ×38", the hold in seconds at its duration bin's mid-point."""
    cells = result.policy_cells().items()
    mids = result.world.bin_mids_ms
    care = ((lambda level: _seconds(mids[level - 1]) + "s") if result.world.care == "time" else str)
    # A label wider than a cell (7 characters) puts its count on a line of its own rather than lose digits.
    return {cell: (label if len(label := f"{ARROWS[p.direction]}{care(p.carefulness)} ×{_count(p.count)}") <= 7
                   else label.replace(" ", "\n")) for cell, p in cells}


def _seconds(ms: float) -> str:
    """A hold in seconds that fits a cell: .02, .35, 1.7, 12."""
    s = ms / 1000
    return f"{s:.2f}".lstrip("0") if s < 1 else f"{s:.1f}" if s < 10 else f"{s:.0f}"


def policy_grid(result: FitResult) -> Group:
    """The most frequent demonstrated action per cell: arrow, carefulness level and count."""
    what = ("direction, hold in s (its bin's mid-point) ×count" if result.world.care == "time"
            else "direction, level ×count")
    title = Text.assemble(("demonstrated policy", "bold"), f"  (most frequent action: {what})")
    return Group(title, WorldGrid(result.world, labels=policy_labels(result)))


def _count(count: int) -> str:
    """A count that fits a cell: 31, 743, 12k."""
    return str(count) if count < 1000 else f"{count // 1000}k"


def status_text(result: FitResult, *, times: bool = True, notes: bool = True) -> Text:
    """"status: optimal in 0.07 s" and, with `notes`, a line per note (its options as flags)."""
    text = Text.assemble(
        "status: ",
        (result.status, "bold green" if result.status == "optimal" else "bold yellow"),
        f" in {result.elapsed_s:.2f} s" if times else "",
    )
    for note in result.notes if notes else ():
        if note.code in FIT_CHECK_CODES:
            continue
        text.append(f"\nnote: {said(note)}", style="yellow")
    return text


def method_phrase(result: FitResult) -> str:
    """The method used, and that auto chose it: "maxent (chosen by auto, beta 0.53 estimated)"."""
    details = []
    if METHODS[result.options.method].chooser:
        details.append(f"chosen by {result.options.method}")
    if result.player_model is not None and result.player_model != "boltzmann":
        details.append(f"player model {result.player_model}")
    if result.beta is not None:
        details.append(f"beta {result.beta:.3g}{' estimated' if result.beta_auto else ''}")
    return f"{result.method} ({', '.join(details)})" if details else result.method


# The fit check's notes, shown as their own line (`fit_check_text`) rather than among the notes.
FIT_CHECK_CODES = frozenset({"fit_check_passed", "fit_check_failed", "fit_check_not_run"})


def fit_check_text(result: FitResult) -> Text:
    """The fit check's verdict: green when the fitted player reproduces the recordings, else what it does not."""
    check = result.fit_check
    assert check is not None
    style = {True: "green", False: "bold yellow", None: "yellow"}[check.passed]
    return Text(check.summary(), style=style)


# How an episode that ends in a terminal symbol reads: "falls off the cliff".
ENDING_VERBS = {"C": "falls off the cliff", "G": "reaches the goal"}


def percent(p: float) -> str:
    """A probability as a percentage, two decimals near 0 and 1 where rare events live:
    0%, 0.04%, 0.40%, 12.5%, 99.60%, 100%."""
    if p <= 0:
        return "0%"
    if p >= 1:
        return "100%"
    if p < 0.01 or p > 0.99:
        return f"{p:.2%}"
    return f"{p:.1%}"


def evaluation_line(result: FitResult) -> str:
    """What an agent trained on the fitted reward does in the true world, against the true optimum.

    e.g. "An agent trained on this reward falls off the cliff in 0.4% of episodes and reaches the
    goal in 99.1% (the true optimum: 0.1% and 99.9%); expected discounted return 61.2 (optimum 63.0)."
    Terminal symbols without a known meaning read "ends in 'X'".
    """
    agent, optimal = result.evaluation.agent, result.evaluation.optimal
    symbols = list(agent.ends)
    # The worst outcome first: the safety question.
    symbols.sort(key=lambda sym: result.world.reward_of(sym))
    parts = []
    for i, symbol in enumerate(symbols):
        verb = ENDING_VERBS.get(symbol, f"ends in {SYMBOL_NAMES.get(symbol, repr(symbol))}")
        parts.append(f"{verb} in {percent(agent.ends[symbol])}{' of episodes' if i == 0 else ''}")
    line = "An agent trained on this reward " + " and ".join(parts)
    line += f" (the true optimum: {' and '.join(percent(optimal.ends[s]) for s in symbols)})"
    if agent.never > 1e-9:
        line += f"; {percent(agent.never)} of its episodes never end"
    line += (f"; expected discounted return {format_value(agent.expected_return)} "
             f"(optimum {format_value(optimal.expected_return)}).")
    return line


def progress_phrase(stage: str, done: int, total: int | None) -> str:
    """What a long fit is doing, from its progress callback: "round 3", "interval LP 12 of 62"."""
    if stage == "rounds":
        return f"round {done}"
    return f"{'resample' if stage == 'resamples' else 'interval LP'} {done} of {total}"
