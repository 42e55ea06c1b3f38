"""`careful fit`: read recordings, fit the state rewards, show them (and save JSON or SVG).

`fit_from_args` reads and fits (a spinner on stderr while it runs, a progress bar while
bootstrap resamples come back); `options_from_args` builds the one `FitOptions` of a fit,
which the fit view changes to refit. `run_fit` ties them to the command line: with a
terminal it opens the fit view (`careful_tui.screens.fit`) on the first fit, without one (or
with `--no-view`) it prints (`careful_tui.render.fit_printout`). The files are read and the first fit is made before the view
opens, so bad input ends with exit 2 and one line on stderr, and a solver that fails with
exit 1 and one line, with or without a terminal.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.text import Text

import irl_core.irl.choices as choices
from careful_tui.arguments import options_from_args
from careful_tui.commands.fit_reach import run_reach_fit
from careful_tui.commands.notices import ignored, warn
from careful_tui.commands.reading import read_with_progress
from careful_tui.errors import EXIT_FAILURE, EXIT_OK
from careful_tui.option_words import said
from careful_tui.render.figures import figure_suffix_problem
from careful_tui.render.fit_printout import fit_page_svg, print_fit
from irl_core.errors import CalibrationError, UsageError
from irl_core.irl import BadInputError, FitOptions, FitResult, SolverError, fit
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.recordings.reach_reader import is_reach_recording
from irl_core.support.plural import plural
from irl_core.support.safe_files import check_output, write_output
from irl_core.support.safe_text import printable


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


def fit_from_args(args: argparse.Namespace, *, err: Console | None = None, printout: bool = False,
                  before_fit: Callable[[Demonstrations], None] | None = None) -> tuple[Demonstrations, FitResult]:
    """The demonstrations and the fit that `careful fit` options ask for.

    A spinner runs on stderr while it fits, and a progress bar while bootstrap resamples come back.
    `before_fit(demos)` runs once the recordings are read, before the fit.
    For the `printout` (no view) it warns of options the fit does not use: before fitting, or
    for a chooser (--method auto) after it, once the method is known.
    """
    err = err or Console(stderr=True, highlight=False)
    options = options_from_args(args)
    problem = options.problem()
    if problem:
        raise UsageError(said(problem))
    chooser = choices.method(options.method).chooser
    if printout and not chooser:
        for warning in ignored_options(options, options.method):
            warn(err, warning)
    demos = load_demonstrations(list(args.files), err)
    if options.calibration is not None and (why := options.calibration.mismatch(options, demos.mdp.world)):
        raise CalibrationError(f"{printable(str(args.calibration), limit=160)}: {why}")
    if before_fit is not None:  # a command's checks of its own options against the recordings' world
        before_fit(demos)
    columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn())
    with Progress(*columns, console=err, transient=True) as progress:
        task = progress.add_task(f"fitting ({options.describe()}) to {plural(demos.steps, 'step')}", total=None)

        def show_progress(stage: str, done: int, total: int | None) -> None:
            what = {"rounds": "lp rounds", "intervals": "interval LPs", "resamples": "resampling episodes"}[stage]
            progress.update(task, description=what, completed=done, total=total)

        try:
            result = fit(demos, options, progress=show_progress)
        except BadInputError as exc:
            raise UsageError(said(exc)) from None
    if options.intervals and result.intervals is None:
        for note in result.notes:
            if note.code == "intervals_not_computed":
                warn(err, said(note))
    if printout and chooser:
        for warning in ignored_options(options, result.method):
            warn(err, warning)
    return demos, result


# The options only resampling uses (maxent's and loss's intervals): each flag and its `FitOptions` field.
RESAMPLING = (("--confidence", "confidence"), ("--resamples", "resamples"), ("--seed", "seed"))


def ignored_options(options: FitOptions, method: str) -> list[str]:
    """A warning per group of options a fit by `method` (a fitting method's name) does not use.

    An option left at its default is never named: ignoring it changes nothing. The fit view uses
    them all (its keys switch methods and turn intervals on), so only the printout asks.
    """
    default = FitOptions()
    used = choices.method(method)
    chosen = f" (method auto chose {method})" if choices.method(options.method).chooser else ""
    resampling = [flag for flag, name in RESAMPLING if getattr(options, name) != getattr(default, name)]
    warnings = []
    if options.calibration is not None and not options.intervals:
        warnings.append(ignored(["--calibration"], "with --intervals"))
    if resampling and not options.intervals:
        warnings.append(ignored(resampling, "with --intervals"))
    elif resampling and used.interval_kind != "confidence":
        warnings.append(ignored(resampling, f"to {_names(kind='confidence', owning=True)} intervals, which resample episodes "
                                            f"({method}'s is every value the demonstrations allow){chosen}"))
    if options.beta is not None and not used.uses_beta:
        warnings.append(ignored(["--beta"], f"to {_names(uses_beta=True)}{chosen}"))
    if options.player_model is not None and not used.uses_beta:
        warnings.append(ignored(["--player-model"], f"to {_names(uses_beta=True)}, whose model of the player it is{chosen}"))
    if options.lam != default.lam and not used.uses_lambda:
        warnings.append(ignored(["--lambda"], f"to {_names(uses_lambda=True)}{chosen}"))
    return warnings


def _names(*, kind: str | None = None, uses_beta: bool | None = None, uses_lambda: bool | None = None,
           owning: bool = False) -> str:
    """The fitting methods with an interval `kind`, or that use beta or lambda: "lp and loss", "loss's and maxent's"."""
    ending = "'s" if owning else ""
    names = [m.name + ending for m in choices.METHODS.values() if not m.chooser
             and (kind is None or m.interval_kind == kind)
             and (uses_beta is None or m.uses_beta == uses_beta)
             and (uses_lambda is None or m.uses_lambda == uses_lambda)]
    return " and ".join([", ".join(names[:-1]), names[-1]]) if len(names) > 1 else names[0]


def wants_view(args: argparse.Namespace) -> bool:
    """Open the fit view: standard input and output are a terminal and `--no-view` was not given."""
    return not args.no_view and sys.stdin.isatty() and sys.stdout.isatty()


def run_fit(args: argparse.Namespace) -> int:
    """`careful fit`: fit, write --json and --figure, then open the fit view (a terminal) or print (--svg of the printout)."""
    err = Console(stderr=True, highlight=False)
    if any(is_reach_recording(path) for path in args.files):
        return run_reach_fit(args, err, view=wants_view(args))
    if spread_flags := [flag for flag, used in (("--spread-known", args.spread_known),
                                                ("--spread-law", args.spread_law is not None)) if used]:
        warn(err, ignored(spread_flags, "to reach worlds"))
    if args.figure is not None and (problem := figure_suffix_problem(args.figure)):
        raise UsageError(problem)
    outputs: dict[Path, str] = {}
    for option, path in (("--json", args.json), ("--svg", args.svg), ("--figure", args.figure)):
        if path is not None:
            check_output(path, option=option, inputs=args.files)
            if (earlier := outputs.setdefault(path.resolve(), option)) != option:
                raise UsageError(f"{option} and {earlier} both name {printable(str(path), limit=160)}: "
                                 "one would overwrite the other; choose two paths")
    view = wants_view(args)
    try:
        demos, result = fit_from_args(args, err=err, printout=not view)
    except SolverError as exc:
        err.print(Text(f"careful fit: {said(exc)}", style="bold red"), soft_wrap=True)
        return EXIT_FAILURE
    if args.json is not None:
        text = json.dumps(result.to_json(), indent=2, allow_nan=False) + "\n"
        write_output(args.json, text, option="--json", inputs=args.files)
    if args.figure is not None:
        # Imported here for start-up speed: matplotlib loads only when a figure is asked for.
        from careful_tui.render.figures.fit_figure import fit_figure
        from careful_tui.render.figures.style import save_figure

        save_figure(fit_figure(result), args.figure, option="--figure", inputs=args.files)
    if view:
        # Imported here for start-up speed: Textual loads only when the view opens.
        from careful_tui.app import make_fit_app
        from careful_tui.keys.kitty import PassiveKittyDriver

        # The kitty-aware driver: Textual's own crashes on key-event sequences some terminals send.
        app = make_fit_app(args, demos, result, driver_class=PassiveKittyDriver)
        app.run()
        for path in dict.fromkeys(app.first_screen.saved):
            print(f"saved {printable(str(path))}")
        return EXIT_OK
    console = Console(highlight=False)
    print_fit(console, demos, result)
    if args.svg is not None:
        title = f"careful fit: {result.method} on {printable(result.world.name, limit=80)}"
        write_output(args.svg, fit_page_svg(demos, result, width=console.width, title=title), option="--svg",
                     inputs=args.files)
    return EXIT_OK
