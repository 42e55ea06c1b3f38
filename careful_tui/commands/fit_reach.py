"""`careful fit` on reach recordings (docs/reach.md): read them, fit each symbol's points and the spread law,
write --json and draw --figure, then open the reach fit view (a terminal) or print the answer (--no-view).
--spread-law holds the spread law at a calibration's; without it, own-noise recordings beside their
calibration say in a note that it is there."""

from __future__ import annotations

import argparse
import json

from rich.console import Console

from careful_tui.arguments import FIT_FLAGS, fit_inputs, options_from_args
from careful_tui.commands.notices import ignored, warn
from careful_tui.errors import EXIT_FAILURE, EXIT_OK
from careful_tui.option_words import said
from careful_tui.render.figures import figure_suffix_problem
from careful_tui.render.reach_fit import print_reach_fit
from irl_core.errors import BadInputError, SolverError, UsageError
from irl_core.reach.calibration import calibration_beside, read_spread_law, study_worlds
from irl_core.reach.fit import Note, fit_reaches
from irl_core.recordings.reach_reader import is_reach_recording, read_reaches
from irl_core.support.safe_files import check_output, write_output
from irl_core.support.safe_text import printable

# The fit options a reach fit uses; the others are for grid worlds and are ignored with a warning.
USED = ("confidence", "known", "intervals")


def run_reach_fit(args: argparse.Namespace, err: Console, *, view: bool) -> int:
    """Fit reach recordings as `careful fit` asks (every file must be one), and open the view if `view`."""
    for path in args.files:
        if not is_reach_recording(path):
            raise UsageError(f"{printable(str(path), limit=160)} is not a reach recording; careful fit fits the "
                             "recordings of one world at a time")
    if args.svg is not None:
        raise UsageError("--svg: there is no text picture of a reach fit; --figure draws one, --json writes the answer")
    if args.figure is not None and (wrong_suffix := figure_suffix_problem(args.figure)):
        raise UsageError(wrong_suffix)
    options = options_from_args(args)
    if problem := options.problem():
        raise UsageError(said(problem))
    unused = [flag.flag for flag in FIT_FLAGS if flag.field not in USED
              and getattr(args, flag.field) != flag.kwargs.get("default", False)]
    if unused:
        warn(err, ignored(unused, "to grid worlds"))
    if args.spread_known and args.spread_law is not None:
        raise UsageError("--spread-known and --spread-law: give one spread law (the world's, or the file's)")
    inputs = fit_inputs(args)
    for option, path in (("--json", args.json), ("--figure", args.figure)):
        if path is not None:
            check_output(path, option=option, inputs=inputs)
    reaches, warnings = read_reaches(args.files)
    for warning in warnings:
        warn(err, warning)
    known = dict(options.known)
    if strange := sorted(set(known) - set(reaches.world.symbols)):
        raise UsageError(f"--known {printable(strange[0])}: the reach world has no circle of that symbol "
                         f"(its symbols: {', '.join(reaches.world.symbols)})")
    indices = study_worlds(args.files)
    spread_law = (None if args.spread_law is None
                  else read_spread_law(args.spread_law, reaches.world, world_indices=indices.values()))
    try:
        fit = fit_reaches(reaches, spread_known=args.spread_known, confidence=options.confidence, known=known,
                          spread_law=spread_law)
    except BadInputError as exc:
        raise UsageError(said(exc)) from None
    except SolverError as exc:
        err.print(f"careful fit: {said(exc)}", style="bold red", markup=False, soft_wrap=True)
        return EXIT_FAILURE
    if spread_law is None and (calibration := calibration_beside(indices, reaches.world)) is not None:
        shown = printable(str(calibration), limit=160)
        law = ("used the world's law" if fit.spread.known
               else "fitted the law to the recorded aims, which for a pointer are its endpoints")
        fit.notes.append(Note("calibration_unused", f"the participant's own spread law, from their calibration block, "
                              f"is in {shown}; this fit {law}: add --spread-law {shown} to hold it at theirs"))
    if args.json is not None:
        write_output(args.json, json.dumps(fit.to_json(), indent=2, allow_nan=False) + "\n", option="--json",
                     inputs=inputs)
    if args.figure is not None:
        # Imported here for start-up speed: matplotlib loads only when a figure is asked for.
        from careful_tui.render.figures.reach_figure import reach_fit_figure
        from careful_tui.render.figures.style import save_figure

        save_figure(reach_fit_figure(fit, reaches), args.figure, option="--figure", inputs=inputs)
    if view:
        # Imported here for start-up speed: Textual loads only when the view opens.
        from careful_tui.app import make_reach_fit_app
        from careful_tui.keys.kitty import PassiveKittyDriver

        app = make_reach_fit_app(args, fit, reaches, driver_class=PassiveKittyDriver)
        app.run()
        for path in dict.fromkeys(app.first_screen.saved):
            print(f"saved {printable(str(path))}")
        return EXIT_OK
    print_reach_fit(Console(highlight=False), fit)
    return EXIT_OK
