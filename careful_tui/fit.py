"""`careful fit`: read recordings, fit the state rewards, print them (and save JSON or SVG).

The work is split so that the interactive fit view can plug in later: `fit_from_args`
reads and fits (a spinner on stderr while it runs), `print_fit` draws a result with Rich,
and `run_fit` ties them to the command line. Bad input ends with exit 2 and one line on
stderr; a solver that fails ends with exit 1 and one line.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from rich.console import Console, Group
from rich.table import Table
from rich.text import Text

from careful_tui.cli import EXIT_FAILURE, EXIT_OK, UsageError
from careful_tui.grid import WorldGrid, format_value
from irl_core.demonstrations import Demonstrations, read_recording
from irl_core.irl import BadInputError, FitResult, SolverError, fit

ARROWS = {"up": "↑", "right": "→", "down": "↓", "left": "←"}


def load_demonstrations(paths: list[Path], err: Console) -> Demonstrations:
    """Read every recording (printing reader warnings to `err`) and pool them.

    Raises `RecordingError` for a bad file or recordings of different worlds, and
    `UsageError` when they hold no steps.
    """
    recordings = [read_recording(path) for path in paths]
    for recording in recordings:
        for warning in recording.warnings:
            err.print(Text(f"warning: {warning}", style="yellow"), soft_wrap=True)
    demos = Demonstrations.from_recordings(recordings)
    if demos.steps == 0:
        names = ", ".join(str(path) for path in paths)
        what = "the recording has" if len(paths) == 1 else "the recordings have"
        raise UsageError(f"{names}: {what} no steps, so there is nothing to fit; play or simulate some episodes first")
    return demos


def fit_from_args(args: argparse.Namespace, *, err: Console | None = None) -> tuple[Demonstrations, FitResult]:
    """The demonstrations and the fit that `careful fit` options ask for."""
    err = err or Console(stderr=True, highlight=False)
    demos = load_demonstrations(list(args.files), err)
    label = f"fitting ({args.method}{', with intervals' if args.intervals else ''}) to {demos.steps} steps"
    try:
        with err.status(label, spinner="dots"):
            result = fit(
                demos,
                method=args.method,
                rmax=args.rmax,
                lam=args.lam,
                beta=args.beta,
                reward_cells=args.reward_cells,
                tie=args.tie,
                intervals=args.intervals,
            )
    except BadInputError as exc:
        raise UsageError(str(exc)) from None
    return demos, result


def run_fit(args: argparse.Namespace) -> int:
    """`careful fit`: always prints for now; the interactive fit view will take over with a terminal."""
    err = Console(stderr=True, highlight=False)
    for option, path in (("--json", args.json), ("--svg", args.svg)):
        if path is not None and not path.parent.is_dir():
            raise UsageError(f"{option} {path}: the folder {path.parent} does not exist; create it first")
    try:
        demos, result = fit_from_args(args, err=err)
    except SolverError as exc:
        err.print(Text(f"careful fit: {exc}", style="bold red"), soft_wrap=True)
        return EXIT_FAILURE
    if args.json is not None:
        text = json.dumps(result.to_json(), indent=2, allow_nan=False) + "\n"
        _write("--json", args.json, lambda: args.json.write_text(text, encoding="utf-8"))
    console = Console(record=args.svg is not None, highlight=False)
    print_fit(console, demos, result)
    if args.svg is not None:
        title = f"careful fit: {result.method} on {result.world.name}"
        _write("--svg", args.svg, lambda: console.save_svg(str(args.svg), title=title))
    return EXIT_OK


def _write(option: str, path: Path, write) -> None:
    try:
        write()
    except OSError as exc:
        raise UsageError(f"{option} {path}: cannot write the file ({exc.strerror or exc})") from None


def print_fit(console: Console, demos: Demonstrations, result: FitResult) -> None:
    """The reward grid (beside the world's own), the intervals, the policy and the status."""
    world = result.world
    files = f"{demos.files} file{'s' * (demos.files != 1)}"
    console.print(
        Text.assemble(
            ("careful fit", "bold"),
            f": {result.method} on ",
            (world.name, "bold"),
            f" from {files}, {demos.episodes} episodes, {demos.steps} steps",
        )
    )
    console.print(reward_grids(result, width=console.width))
    console.print(Text(_unknown_phrase(result), style="dim"))
    if result.intervals is not None and len(result.intervals):
        console.print(interval_table(result))
        for line in interval_readings(result):
            console.print(Text(line), soft_wrap=True)
    console.print(policy_grid(result))
    console.print(status_text(result), soft_wrap=True)


def reward_grids(result: FitResult, *, width: int) -> Table:
    """The fitted R_S and, when the world defines rewards, the true R_S beside it (one colour scale).

    Side by side when `width` allows, else one above the other.
    """
    world = result.world
    fitted = result.reward_grid
    true = result.true_reward_grid
    scale = float(np.nanmax(np.abs(np.concatenate([fitted.ravel(), true.ravel()]))))
    scale = scale if scale > 0 else 1.0
    grids = [Group(Text("fitted R_S", style="bold"), WorldGrid(world, values=fitted, scale=scale))]
    if world.rewards:
        grids.append(Group(Text("true R_S (world file)", style="bold"), WorldGrid(world, values=true, scale=scale)))
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


def _unknown_phrase(result: FitResult) -> str:
    options = result.options
    cells = "every cell" if options["reward_cells"] == "all" else "the non-ground cells (ground is 0)"
    return f"fitted: {cells}{', one value per symbol' if options['tie'] else ''}; the action cost is known"


def interval_table(result: FitResult) -> Table:
    """One row per unknown: fitted and true values, the interval and what it means."""
    rmax = result.options["rmax"]
    table = Table(title="How far the demonstrations pin each reward (min and max over the lp constraints)")
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


def interval_reading(low: float, high: float, rmax: float) -> str:
    """A plain sentence for one interval; an end at ±rmax is no bound at all."""
    open_low, open_high = low <= -rmax * (1 - 1e-9), high >= rmax * (1 - 1e-9)
    if open_low and open_high:
        return "not bounded by the demonstrations"
    if open_low:
        return f"at most {format_value(high)}; no lower bound"
    if open_high:
        return f"at least {format_value(low)}; no upper bound"
    return f"between {format_value(low)} and {format_value(high)}"


def interval_readings(result: FitResult) -> list[str]:
    """For each pair of symbols: whether every interval of one lies below every interval of the other."""
    groups: dict[str, list[tuple[float, float]]] = {}
    for symbol, interval in zip(result.unknowns.symbols, result.intervals):
        groups.setdefault(symbol, []).append((float(interval[0]), float(interval[1])))
    symbols = list(groups)
    lines = []
    for i, a in enumerate(symbols):
        for b in symbols[i + 1 :]:
            top_a, bottom_a = max(h for _, h in groups[a]), min(lo for lo, _ in groups[a])
            top_b, bottom_b = max(h for _, h in groups[b]), min(lo for lo, _ in groups[b])
            if top_a < bottom_b:
                lines.append(f"{a} is worse than {b} under every reward the demonstrations allow.")
            elif top_b < bottom_a:
                lines.append(f"{b} is worse than {a} under every reward the demonstrations allow.")
            else:
                lines.append(f"{a} and {b} overlap: the demonstrations cannot tell which is worse.")
    return lines


def policy_grid(result: FitResult) -> Group:
    """The most frequent demonstrated action per cell: arrow, carefulness level and count."""
    labels = {
        cell: f"{ARROWS[p.direction]}{p.carefulness} ×{_count(p.count)}" for cell, p in result.policy_cells().items()
    }
    title = Text.assemble(("demonstrated policy", "bold"), "  (most frequent action: direction, level ×count)")
    return Group(title, WorldGrid(result.world, labels=labels))


def _count(count: int) -> str:
    """A count that fits a cell: 31, 743, 12k."""
    return str(count) if count < 1000 else f"{count // 1000}k"


def status_text(result: FitResult) -> Text:
    text = Text.assemble(
        "status: ",
        (result.status, "bold green" if result.status == "optimal" else "bold yellow"),
        f" in {result.elapsed_s:.2f} s",
    )
    for note in result.notes:
        text.append(f"\nnote: {note}", style="yellow")
    return text
