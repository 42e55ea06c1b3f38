"""`careful experiment`: the paper's experiments, printed, drawn and written to a folder.

Writes into `--out`: every figure as PDF and as PNG (300 dpi), drawn with matplotlib for a
paper (`careful_tui.render.figures`), `summary.json` and `report.md`, which shows the PNGs.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from rich.console import Console, Group, RenderableType
from rich.panel import Panel
from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from careful_tui.render.grid import WorldGrid, action_label, format_value, symbol_legend
from irl_core.errors import UsageError
from irl_core.experiment.run import FULL, NOISY_CONFIDENCE, QUICK, ExperimentResult, Figure, interval_caption
from irl_core.experiment.run import run_experiment as run_stages
from irl_core.irl import FitOptions
from irl_core.support.safe_files import check_output, check_output_folder, write_output
from irl_core.support.safe_text import for_markup, printable


def figure_panel(figure: Figure) -> Panel:
    labels = {cell: action_label(*action, levels=figure.world.levels) for cell, action in figure.policy.items()}
    grid = WorldGrid(figure.world, values=figure.values, labels=labels)
    parts: list[RenderableType] = [grid, symbol_legend(figure.world)]
    if figure.caption:
        parts.append(Text(figure.caption, style="italic"))
    return Panel(Group(*parts), title=figure.title, expand=False)


def estimates_table(result: ExperimentResult) -> Table:
    table = Table(title="Cliff and goal: fitted against the truth")
    for column in ("stage", "data", "cliff", "true", "error", "goal", "true", "error", "time"):
        table.add_column(column, justify="right" if column not in ("stage", "data") else "left")
    for e in result.estimates:
        table.add_row(
            e.stage, e.data,
            format_value(e.cliff), format_value(e.true_cliff), f"{e.cliff_error:.0%}",
            format_value(e.goal), format_value(e.true_goal), f"{e.goal_error:.0%}",
            f"{e.seconds:.2f} s",
        )
    return table


def intervals_table(result: ExperimentResult) -> Table:
    table = Table(title="What carefulness buys: identified sets (every reward the demonstrations allow) and "
                        "95% confidence intervals (noisy experts)")
    for column in ("world", "kind", "cliff interval", "width", "mud interval", "width", "cliff vs mud", "time"):
        table.add_column(column)
    for s in result.separations:
        table.add_row(
            s.world, s.kind, f"{s.cliff[0]:.0f} .. {s.cliff[1]:.0f}", f"{s.cliff_width:.0f}",
            f"{s.mud[0]:.0f} .. {s.mud[1]:.0f}", f"{s.mud_width:.0f}",
            "[green]separated[/]" if s.separated else "[red]overlap[/]", f"{s.seconds:.2f} s",
        )
    return table


VERDICT_STYLES = {"supported": "green", "not supported": "red", "mixed": "yellow"}


def claims_lines(result: ExperimentResult) -> list[Text]:
    """The paper's claims as this run judges them: "(a) ...: supported. <numbers> <discussion>"."""
    lines = []
    for claim in result.claims:
        line = Text(f"({claim.key}) {claim.statement}: ")
        line.append(claim.verdict, style=f"bold {VERDICT_STYLES[claim.verdict]}")
        line.append(". " + " ".join([claim.evidence, *claim.discussion]))
        lines.append(line)
    return lines


FIGURE_FORMATS = (".pdf", ".png")
REPORT_FILES = ("summary.json", "report.md")


def write_figures(result: ExperimentResult, out: Path) -> None:
    """Every figure of `result` as `<key>.pdf` and `<key>.png` in `out`."""
    for figure in result.figures:
        write_figure(figure, result=result, out=out, rmax=FitOptions().rmax)


def write_figure(figure: Figure, *, result: ExperimentResult, out: Path, rmax: float) -> None:
    """One figure as `<key>.pdf` and `<key>.png` in `out`."""
    # Imported here, not above: matplotlib loads only when figures are drawn (a test checks it).
    from careful_tui.render.figures.experiment_figures import draw_experiment_figure
    from careful_tui.render.figures.style import save_figure

    drawn = draw_experiment_figure(figure, result, rmax=rmax)
    for suffix in FIGURE_FORMATS:
        save_figure(drawn, out / f"{figure.key}{suffix}")


def how_to_read(result: ExperimentResult) -> list[str]:
    """A paragraph on what the figures' marks mean, with this run's scale and bound."""
    from careful_tui.render.figures.experiment_figures import shared_scale  # matplotlib: only when drawn

    vmax, rmax = shared_scale(result), FitOptions().rmax
    lines = ["Each figure is a PDF (fonts embedded) and a PNG (300 dpi), a third of a page wide. "
             f"Rewards share one colour scale, symmetric-log from -{vmax:.0f} to {vmax:.0f} (white is 0, "
             "red worse, blue better); terminal cells are outlined, walls hatched. "
             "A fitted reward is a point estimate: the one reward its method picked, not every reward "
             "that fits the data (the interval plots show those). "
             "A policy is an arrow per cell whose width and number give the carefulness level."]
    kinds = {s.kind for s in result.separations}
    if kinds:
        lines[0] += (" In an interval plot (labelled with its kind) each bar is a symbol's interval, the dot "
                     "the fit's estimate (mean over the symbol's cells) and the tick the world's value.")
    if "identified" in kinds:
        lines[0] += (" An identified set's bar is every value the demonstrations allow; a triangle marks an end "
                     f"at ±{rmax:.0f}, where the data set no bound.")
    if "confidence" in kinds:
        lines[0] += (f" A confidence interval's bar is a {NOISY_CONFIDENCE:.0%} bootstrap interval: it covers "
                     "sampling noise only, and its axis ends just beyond the values drawn.")
    return lines


def report_markdown(result: ExperimentResult) -> str:
    lines = ["# careful experiment", "",
             "The paper's experiments (Hanslope & Aitchison), rerun by `careful experiment`.", "",
             "## Cliff and goal, fitted against the truth", "",
             "| stage | data | cliff | true | error | goal | true | error | time |",
             "|---|---|---|---|---|---|---|---|---|"]
    for e in result.estimates:
        lines.append(f"| {e.stage} | {e.data} | {e.cliff:.1f} | {e.true_cliff:.0f} | {e.cliff_error:.0%} | "
                     f"{e.goal:.1f} | {e.true_goal:.0f} | {e.goal_error:.0%} | {e.seconds:.2f} s |")
    lines += ["", "## Intervals: what carefulness buys", "",
              "Identified: every value the demonstrations allow (lp, optimal experts). Confidence: a 95% "
              "bootstrap interval (maxent with beta estimated, noisy experts); it covers sampling noise only.", "",
              "| world | kind | data | cliff interval | mud interval | separated | time |",
              "|---|---|---|---|---|---|---|"]
    for s in result.separations:
        lines.append(f"| {s.world} | {s.kind} | {s.data} | {s.cliff[0]:.0f} .. {s.cliff[1]:.0f} | "
                     f"{s.mud[0]:.0f} .. {s.mud[1]:.0f} | {'yes' if s.separated else 'no'} | {s.seconds:.2f} s |")
    lines += [""] + [f"- {s.world} ({s.kind}): {interval_caption(s)}" for s in result.separations]
    if result.claims:
        lines += ["", "## The paper's claims, against this run", "",
                  "Each claim of the paper this run tests, and whether this run's numbers support it.", "",
                  *(f"- {claim.text()}" for claim in result.claims)]
    lines += ["", "## Figures", "", *how_to_read(result), ""]
    for figure in result.figures:
        lines += [f"### {figure.title}", "", f"![{figure.title}]({figure.key}.png)", "",
                  f"{figure.caption} ([PDF]({figure.key}.pdf))".lstrip(), ""]
    if result.notes:
        lines += ["## Notes", "", *(f"- {note}" for note in result.notes), ""]
    lines += [f"Total time: {result.seconds:.1f} s.", ""]
    return "\n".join(lines)


def run_experiment(args: argparse.Namespace) -> int:
    out: Path = check_output_folder(args.out, option="--out")
    if out.exists() and not out.is_dir():
        raise UsageError(f"{out} is a file; --out needs a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create {out}: {exc.strerror}") from None
    if args.recordings is not None and not args.recordings.is_dir():
        raise UsageError(f"--recordings {args.recordings}: not a folder")
    for name in REPORT_FILES:  # refused before the stages run, not after
        check_output(out / name, option="--out")
    console = Console()
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                  console=Console(stderr=True), transient=True) as progress:
        task = progress.add_task("starting", total=None)
        result = run_stages(sizes=QUICK if args.quick else FULL, recordings=args.recordings, seed=args.seed,
                            progress=lambda stage: progress.update(task, description=for_markup(stage)))
    for figure in result.figures:
        console.print(figure_panel(figure))
    write_figures(result, out)
    console.print(estimates_table(result))
    console.print(intervals_table(result))
    if result.claims:
        console.print(Text("The paper's claims, against this run:", style="bold"))
        for line in claims_lines(result):
            console.print(line)
    for note in result.notes:  # text, never markup: a note may name a file
        console.print(Text(f"note: {printable(note, limit=400)}", style="dim"))
    summary, report = REPORT_FILES
    write_output(out / summary, json.dumps(result.summary(), indent=2) + "\n", option="--out")
    write_output(out / report, report_markdown(result), option="--out")
    console.print(Text(f"done in {result.seconds:.1f} s; figures, summary.json and report.md are in "
                       f"{printable(str(out), limit=160)}/"), soft_wrap=True)
    return 0
