"""`careful fit`: read recordings, fit the state rewards, show them (and save JSON or SVG).

`fit_from_args` reads and fits (a spinner on stderr while it runs, a progress bar while
bootstrap resamples come back); `options_from_args` builds the one `FitOptions` of a fit,
which the fit view changes to refit. `print_fit` draws a result with Rich
from pieces the fit view shares (`reward_scale`, `policy_labels`, `IntervalChart`,
`interval_readings`, `interval_title`, `evaluation_line`, `status_text`). `run_fit` ties them to the command line: with a
terminal it opens the fit view (`careful_tui.fit_view`) on the first fit, without one (or
with `--no-view`) it prints. The files are read and the first fit is made before the view
opens, so bad input ends with exit 2 and one line on stderr, and a solver that fails with
exit 1 and one line, with or without a terminal.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rich.console import Console, ConsoleOptions, Group, RenderResult
from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.style import Style
from rich.table import Table
from rich.text import Text

from careful_tui.cli import EXIT_FAILURE, EXIT_OK, UsageError
from careful_tui.figures import figure_suffix_problem
from careful_tui.grid import (
    LINEAR_THRESHOLD,
    SYMBOL_NAMES,
    WorldGrid,
    diverging_colour,
    format_value,
    signed_log_fraction,
)
from careful_tui.reading import read_with_progress
from irl_core.demonstrations import Demonstrations
from irl_core.irl import BadInputError, FitOptions, FitResult, SolverError, fit
from irl_core.safe_files import check_output, write_output
from irl_core.safe_text import printable
from irl_core.mdp import ARROWS


def load_demonstrations(paths: list[Path], err: Console) -> Demonstrations:
    """Read every recording (printing reader warnings to `err`) and pool them.

    Raises `RecordingError` for a bad file or recordings of different worlds, and
    `UsageError` when they hold no steps.
    """
    recordings = read_with_progress(paths, err)
    demos = Demonstrations.from_recordings(recordings)
    if demos.steps == 0:
        names = ", ".join(str(path) for path in paths)
        what = "the recording has" if len(paths) == 1 else "the recordings have"
        raise UsageError(f"{names}: {what} no steps, so there is nothing to fit; play or simulate some episodes first")
    return demos


def options_from_args(args: argparse.Namespace) -> FitOptions:
    """The fit's settings from `careful fit`'s parsed arguments (built once; the view refits with replace)."""
    return FitOptions(method=args.method, rmax=args.rmax, lam=args.lam, beta=args.beta,
                      reward_cells=args.reward_cells, tie=args.tie, intervals=args.intervals,
                      confidence=args.confidence, resamples=args.resamples, seed=args.seed)


def refit(demos: Demonstrations, options: FitOptions, *, progress=None) -> FitResult:
    """Fit `demos` with `options` (the fit view's refits); raises what `irl_core.irl.fit` raises."""
    return fit(demos, options, progress=progress)


def progress_phrase(stage: str, done: int, total: int | None) -> str:
    """What a long fit is doing, from its progress callback: "round 3", "interval LP 12 of 62"."""
    if stage == "rounds":
        return f"round {done}"
    return f"{'resample' if stage == 'resamples' else 'interval LP'} {done} of {total}"


def fit_from_args(args: argparse.Namespace, *, err: Console | None = None) -> tuple[Demonstrations, FitResult]:
    """The demonstrations and the fit that `careful fit` options ask for.

    A spinner runs on stderr while it fits, and a progress bar while bootstrap resamples come back.
    """
    err = err or Console(stderr=True, highlight=False)
    options = options_from_args(args)
    problem = options.problem()
    if problem:
        raise UsageError(problem)
    demos = load_demonstrations(list(args.files), err)
    columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn())
    with Progress(*columns, console=err, transient=True) as progress:
        task = progress.add_task(f"fitting ({options.describe()}) to {demos.steps} steps", total=None)

        def heard(stage: str, done: int, total: int | None) -> None:
            what = {"rounds": "lp rounds", "intervals": "interval LPs", "resamples": "resampling episodes"}[stage]
            progress.update(task, description=what, completed=done, total=total)

        try:
            result = fit(demos, options, progress=heard)
        except BadInputError as exc:
            raise UsageError(str(exc)) from None
    if options.intervals and result.intervals is None:
        for note in result.notes:
            if note.startswith("intervals not computed"):
                err.print(Text(f"warning: {note}", style="yellow"), soft_wrap=True)
    return demos, result


def wants_view(args: argparse.Namespace) -> bool:
    """Open the fit view: standard input and output are a terminal and `--no-view` was not given."""
    return not args.no_view and sys.stdin.isatty() and sys.stdout.isatty()


def run_fit(args: argparse.Namespace) -> int:
    """`careful fit`: fit, write --json and --figure, then open the fit view (a terminal) or print (--svg of the printout)."""
    err = Console(stderr=True, highlight=False)
    if args.figure is not None and (problem := figure_suffix_problem(args.figure)):
        raise UsageError(problem)
    for option, path in (("--json", args.json), ("--svg", args.svg), ("--figure", args.figure)):
        if path is not None:
            check_output(path, option=option, inputs=args.files)
    try:
        demos, result = fit_from_args(args, err=err)
    except SolverError as exc:
        err.print(Text(f"careful fit: {exc}", style="bold red"), soft_wrap=True)
        return EXIT_FAILURE
    if args.json is not None:
        text = json.dumps(result.to_json(), indent=2, allow_nan=False) + "\n"
        write_output(args.json, text, option="--json", inputs=args.files)
    if args.figure is not None:
        from careful_tui.figures.fit_figure import fit_figure
        from careful_tui.figures.style import save_figure

        save_figure(fit_figure(result), args.figure, option="--figure", inputs=args.files)
    if wants_view(args):
        from careful_tui.fit_view import FitApp
        from careful_tui.kitty import PassiveKittyDriver

        # The kitty-aware driver: Textual's own crashes on key-event sequences some terminals send.
        app = FitApp.from_args(args, demos, result, driver_class=PassiveKittyDriver)
        app.run()
        for path in dict.fromkeys(app.saved):
            print(f"saved {printable(str(path))}")
        return EXIT_OK
    console = Console(record=args.svg is not None, highlight=False)
    print_fit(console, demos, result)
    if args.svg is not None:
        title = f"careful fit: {result.method} on {printable(result.world.name, limit=80)}"
        write_output(args.svg, console.export_svg(title=title), option="--svg", inputs=args.files)
    return EXIT_OK


def print_fit(console: Console, demos: Demonstrations, result: FitResult) -> None:
    """The reward grid (beside the world's own), the intervals, the policy and the status."""
    world = result.world
    files = f"{demos.files} file{'s' * (demos.files != 1)}"
    console.print(
        Text.assemble(
            ("careful fit", "bold"),
            f": {method_phrase(result)} on ",
            (printable(world.name, limit=80), "bold"),
            f" from {files}, {demos.episodes} episodes, {demos.steps} steps",
        )
    )
    console.print(reward_grids(result, width=console.width))
    console.print(Text(unknown_phrase(result), style="dim"))
    if result.intervals is not None and len(result.intervals):
        console.print(interval_table(result))
        console.print(IntervalChart(result))
        for line in interval_readings(result):
            console.print(Text(line), soft_wrap=True)
    console.print(policy_grid(result))
    console.print(Text(evaluation_line(result)), soft_wrap=True)
    console.print(status_text(result), soft_wrap=True)


def reward_scale(result: FitResult) -> float:
    """The magnitude that gets the strongest colour: the largest |R_S|, fitted or true."""
    values = np.concatenate([result.reward_grid.ravel(), result.true_reward_grid.ravel()])
    scale = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 0.0
    return scale if scale > 0 else 1.0


def reward_grids(result: FitResult, *, width: int) -> Table:
    """The fitted R_S and, when the world defines rewards, the true R_S beside it (one colour scale).

    Side by side when `width` allows, else one above the other.
    """
    world = result.world
    scale = reward_scale(result)
    grids = [Group(Text("fitted R_S", style="bold"), WorldGrid(world, values=result.reward_grid, scale=scale))]
    if world.rewards:
        grids.append(Group(Text("true R_S (world file)", style="bold"),
                           WorldGrid(world, values=result.true_reward_grid, scale=scale)))
    gap = 4
    grid_width = world.cols * WorldGrid(world).cell_width
    side_by_side = len(grids) * grid_width + (len(grids) - 1) * gap <= width
    table = Table.grid(padding=(0, gap))
    if side_by_side:
        for _ in grids:
            table.add_column(min_width=grid_width)
        table.add_row(*grids)
    else:
        table.add_column(min_width=grid_width)
        for grid in grids:
            table.add_row(grid)
    return table


def unknown_phrase(result: FitResult) -> str:
    """Which rewards were fitted: "fitted: the non-ground cells (ground is 0); the action cost is known"."""
    options = result.options
    cells = "every cell" if options.reward_cells == "all" else "the non-ground cells (ground is 0)"
    return f"fitted: {cells}{', one value per symbol' if options.tie else ''}; the action cost is known"


def interval_table(result: FitResult) -> Table:
    """One row per unknown: fitted and true values, the interval and what it means."""
    rmax = result.rmax
    table = Table(title=interval_title(result))
    for name, justify in (("unknown", "left"), ("fitted", "right"), ("true", "right"),
                          ("low", "right"), ("high", "right"), ("reading", "left")):
        table.add_column(name, justify=justify)
    first_state = np.asarray(result.unknowns.basis.argmax(axis=0)).ravel()
    for label, value, state, (low, high) in zip(result.labels, result.theta, first_state, result.intervals):
        true = format_value(float(result.mdp.R_S[state])) if result.world.rewards else "-"
        table.add_row(
            Text(label), format_value(float(value)), true, format_value(float(low)), format_value(float(high)),
            interval_reading(low, high, rmax),
        )
    return table


def interval_title(result: FitResult) -> str:
    """What the intervals are: identified by the demonstrations (lp) or a confidence interval."""
    if result.interval_kind == "confidence":
        options = result.options
        return (f"{options.confidence:.0%} confidence intervals ({options.resamples} resamples of "
                f"{result.demos.episodes} episodes)")
    return "identified by the demonstrations: every value each reward can take"


def _open_ends(low: float, high: float, rmax: float) -> tuple[bool, bool]:
    """Whether each end of an interval sits at the ±rmax bound (no bound from the demonstrations)."""
    return low <= -rmax * (1 - 1e-9), high >= rmax * (1 - 1e-9)


def interval_reading(low: float, high: float, rmax: float) -> str:
    """A plain sentence for one interval; an end at ±rmax is no bound at all."""
    open_low, open_high = _open_ends(low, high, rmax)
    if open_low and open_high:
        return "not bounded by the demonstrations"
    if open_low:
        return f"at most {format_value(high)}; no lower bound"
    if open_high:
        return f"at least {format_value(low)}; no upper bound"
    return f"between {format_value(low)} and {format_value(high)}"


def interval_span(low: float, high: float, rmax: float) -> str:
    """An interval in a few characters: "-49.3..-14.8", "≤ -661", "≥ 89.7", "any"."""
    open_low, open_high = _open_ends(low, high, rmax)
    if open_low and open_high:
        return "any"
    if open_low:
        return f"≤ {format_value(high)}"
    if open_high:
        return f"≥ {format_value(low)}"
    return f"{format_value(low)}..{format_value(high)}"


def symbol_name(symbol: str) -> str:
    return SYMBOL_NAMES.get(symbol, symbol)


def symbol_intervals(result: FitResult) -> dict[str, tuple[float, float]]:
    """Per symbol (in the order the unknowns first use it): the lowest low and highest high of its unknowns."""
    hulls: dict[str, tuple[float, float]] = {}
    for symbol, (low, high) in zip(result.unknowns.symbols, result.intervals):
        old_low, old_high = hulls.get(symbol, (np.inf, -np.inf))
        hulls[symbol] = (min(old_low, float(low)), max(old_high, float(high)))
    return hulls


def _low_to_high(hulls: dict[str, tuple[float, float]]) -> list[str]:
    """Symbols by the top of their interval, then its bottom."""
    return sorted(hulls, key=lambda symbol: (hulls[symbol][1], hulls[symbol][0]))


# A symbol whose every allowed value is this many times below another's worst is "catastrophic next to" it.
CATASTROPHIC_RATIO = 10.0


def interval_readings(result: FitResult) -> list[str]:
    """One sentence per symbol, lowest first: its interval and how it stands against the next symbol up.

    e.g. "cliff: at most -661; no lower bound; catastrophic next to mud's -49.3..-14.8 (at least
    13× worse under every reward the demonstrations allow)"; a confidence interval says "at 95%
    confidence" instead. A symbol's interval spans those of all its cells.
    """
    rmax = result.rmax
    confident = result.interval_kind == "confidence"
    sure = f"at {result.options.confidence:.0%} confidence" if confident else "under every reward the demonstrations allow"
    hulls = symbol_intervals(result)
    order = _low_to_high(hulls)
    lines = []
    for below, above in zip(order, [*order[1:], None]):
        low, high = hulls[below]
        line = f"{symbol_name(below)}: {interval_reading(low, high, rmax)}"
        if above is not None:
            above_low, above_high = hulls[above]
            other = f"{symbol_name(above)}'s {interval_span(above_low, above_high, rmax)}"
            ratio = high / above_low if high < above_low < 0 else 0.0
            if high >= above_low:
                who = "at this confidence the data" if confident else "the demonstrations"
                line += f"; overlaps {other}: {who} cannot tell which is worse"
            elif ratio >= CATASTROPHIC_RATIO:
                line += f"; catastrophic next to {other} (at least {ratio:.0f}× worse {sure})"
            elif ratio > 0:
                line += f"; at least {ratio:.1f}× worse than {other}{' ' + sure if confident else ''}"
            else:
                line += f"; below {other}"
        lines.append(line)
    return lines


@dataclass
class IntervalChart:
    """Every unknown's interval as a bar on the reward colours' signed-log axis, from -rmax to rmax.

    ● marks the fitted value, ○ the world's own (◉ both); ◀ or ▶ at an end of a bar means the
    demonstrations do not bound it there (the bar runs into ±rmax). Rows are grouped by symbol,
    lowest symbol first (as `interval_readings`). The bars take the width they are given.
    """

    result: FitResult

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        result = self.result
        rmax = float(result.rmax)
        true = result.unknowns.true_theta(result.mdp) if result.world.rewards else None
        symbols = _low_to_high(symbol_intervals(result))
        rows = sorted(range(len(result.labels)), key=lambda j: (symbols.index(result.unknowns.symbols[j]), j))
        spans = [interval_span(float(lo), float(hi), rmax) for lo, hi in result.intervals]
        # Tied unknowns are named by their symbol: "cliff" reads better than "C".
        labels = [symbol_name(s) for s in result.unknowns.symbols] if result.options.tie else result.labels
        label_width = max(map(len, labels), default=0)
        span_width = max(map(len, spans), default=0)
        # An odd number of positions puts 0 in the middle.
        room = options.max_width - label_width - span_width - 4
        axis = max(21, room if room % 2 else room - 1)
        for j in rows:
            low, high = (float(v) for v in result.intervals[j])
            line = Text(f"{labels[j]:<{label_width}}  ", no_wrap=True, overflow="crop")
            line.append_text(self._bar(axis, rmax, low, high, float(result.theta[j]),
                                       None if true is None else float(true[j])))
            line.append(f"  {spans[j]:>{span_width}}", style="bold")
            yield line
        indent = " " * (label_width + 2)
        yield Text(indent) + _axis_ticks(axis, rmax)
        yield Text.assemble(indent, ("● fitted  ○ true  ◉ both  ", "dim"),
                            ("━", diverging_colour(-rmax, rmax)), ("━", diverging_colour(rmax, rmax)),
                            (f" {self._what()}  ◀ ▶ no bound", "dim"))

    def _what(self) -> str:
        if self.result.interval_kind == "confidence":
            return f"{self.result.options.confidence:.0%} confidence"
        return "allowed"

    @staticmethod
    def _bar(axis: int, rmax: float, low: float, high: float, fitted: float, true: float | None) -> Text:
        def at(value: float) -> int:
            return round((signed_log_fraction(value, rmax) + 1) / 2 * (axis - 1))

        chars = ["─"] * axis
        styles = [Style(color="#3a4452")] * axis
        chars[axis // 2] = "┼"
        start, end = at(low), at(high)
        for i in range(start, end + 1):
            chars[i] = "━"
            value = signed_log_value(i / (axis - 1) * 2 - 1, rmax)
            styles[i] = Style(color=diverging_colour(value, rmax), bold=True)
        open_low, open_high = _open_ends(low, high, rmax)
        if open_low:
            chars[start] = "◀"
        if open_high:
            chars[end] = "▶"
        marks = {at(fitted): "●"}
        if true is not None:
            marks[at(true)] = "◉" if at(true) in marks else "○"
        for i, glyph in marks.items():
            chars[i] = glyph
            styles[i] = Style(color="#ffffff", bold=True)
        text = Text()
        for char, style in zip(chars, styles):
            text.append(char, style)
        return text


def signed_log_value(fraction: float, scale: float) -> float:
    """The value that `careful_tui.grid.signed_log_fraction` maps to `fraction` in [-1, 1]."""
    return float(np.sign(fraction) * LINEAR_THRESHOLD * np.expm1(abs(fraction) * np.log1p(scale / LINEAR_THRESHOLD)))


def _axis_ticks(axis: int, rmax: float) -> Text:
    """Labels under the axis: -rmax, the powers of ten between, 0 and up to rmax, where they fit."""
    powers = [10.0**k for k in range(1, 16) if 10.0**k < rmax / 2]
    values = [-rmax, *(-p for p in reversed(powers)), 0.0, *powers, rmax]
    line = [" "] * axis
    for value in values:
        label = format_value(value)
        centre = round((signed_log_fraction(value, rmax) + 1) / 2 * (axis - 1))
        left = min(max(0, centre - len(label) // 2), axis - len(label))
        span = range(max(0, left - 1), min(axis, left + len(label) + 1))
        if all(line[i] == " " for i in span):
            line[left : left + len(label)] = label
    return Text("".join(line), style="dim")


def policy_labels(result: FitResult) -> dict[tuple[int, int], str]:
    """Per demonstrated cell, the most frequent action: "→8 ×38" (direction, carefulness level, count)."""
    cells = result.policy_cells().items()
    return {cell: f"{ARROWS[p.direction]}{p.carefulness} ×{_count(p.count)}" for cell, p in cells}


def policy_grid(result: FitResult) -> Group:
    """The most frequent demonstrated action per cell: arrow, carefulness level and count."""
    title = Text.assemble(("demonstrated policy", "bold"), "  (most frequent action: direction, level ×count)")
    return Group(title, WorldGrid(result.world, labels=policy_labels(result)))


def _count(count: int) -> str:
    """A count that fits a cell: 31, 743, 12k."""
    return str(count) if count < 1000 else f"{count // 1000}k"


def status_text(result: FitResult, *, times: bool = True, notes: Iterable[str] | None = None) -> Text:
    """"status: optimal in 0.07 s" and a line per note (`notes`: the result's, unless given)."""
    text = Text.assemble(
        "status: ",
        (result.status, "bold green" if result.status == "optimal" else "bold yellow"),
        f" in {result.elapsed_s:.2f} s" if times else "",
    )
    for note in result.notes if notes is None else notes:
        text.append(f"\nnote: {note}", style="yellow")
    return text


def method_phrase(result: FitResult) -> str:
    """The method used, and that auto chose it: "maxent (chosen by auto, beta 0.53 estimated)"."""
    details = []
    if result.options.method == "auto":
        details.append("chosen by auto")
    if result.method == "maxent":
        details.append(f"beta {result.beta:.3g}{' estimated' if result.beta_auto else ''}")
    return f"{result.method} ({', '.join(details)})" if details else result.method


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
