"""`careful study run`: check the study and the participant, run them through it, then say what
was recorded and where they stand."""

from __future__ import annotations

import argparse
import sys

from careful_tui.app import make_study_app
from careful_tui.commands.play import say_recorded, time_world_playable, write_problem
from careful_tui.errors import require_terminal
from careful_tui.keys.kitty import KittyDriver
from irl_core.errors import StudyError, UsageError
from irl_core.recordings.writer import check_writable
from irl_core.studies.participant_lock import participant_lock
from irl_core.studies.study import LoadedStudy, check_participant, grid_world, load_study, read_protocol
from irl_core.support.plural import plural
from irl_core.support.safe_text import printable


def run_study_run(args: argparse.Namespace) -> int:
    """`careful study run STUDY.toml --participant ID` (exit 0 also when they had finished already);
    one session per participant at a time (`participant_lock`)."""
    try:
        study = load_study(args.study)
        for index, world in enumerate(study.worlds):  # reach worlds are played in a browser only
            grid_world(world, f"{study.path}: worlds[{index}]: careful study run")
        check_participant(args.participant)
        with participant_lock(study, args.participant, holder="careful study run"):
            return _run_participant(study, args)
    except StudyError as exc:
        raise UsageError(str(exc)) from None


def _run_participant(study: LoadedStudy, args: argparse.Namespace) -> int:
    protocol = read_protocol(study, args.participant)
    name = printable(study.study.name, limit=80)
    if protocol.finished:
        report_problems(protocol.problems)
        print(f"participant {args.participant} has finished study {name!r}: every episode is recorded in "
              f"{printable(str(protocol.folder))}; nothing is left to play")
        return 0
    # The study's folder, not the participant's: that is made at the first move, so a participant
    # who leaves before it leaves no empty folder for the report to count.
    for folder, what in ((study.out, "the study's out folder"), (protocol.folder, "the participant's folder")):
        if folder.exists() and not folder.is_dir():
            raise UsageError(f"{printable(str(folder))} is a file, not {what}; move it away")
    target = protocol.folder if protocol.folder.is_dir() else study.out
    try:
        check_writable(target)
    except OSError as exc:
        raise UsageError(f"cannot write recordings to {printable(str(target))} "
                         f"({exc.strerror or exc}); check the study's out folder") from None
    require_terminal("study run")
    for world in study.worlds:
        if world.care == "time":
            time_world_playable(world.name, study.study.input)
    app = make_study_app(study, args.participant, driver_class=KittyDriver)
    flow = app.first_screen.flow
    try:
        app.run()
    finally:
        flow.quit()
    for session in flow.sessions:
        say_recorded(session.recorder)
    if flow.write_error is not None:
        raise UsageError(f"cannot write the recording in {printable(str(protocol.folder))} ({write_problem(flow.write_error)}); "
                         "the study stopped; run the same command to go on from the last finished episode")
    print(standing(study, args.participant))
    return 0


def standing(study: LoadedStudy, participant: str) -> str:
    """Where the participant stands now, in one line."""
    protocol = read_protocol(study, participant)
    report_problems(protocol.problems)
    name = printable(study.study.name, limit=80)
    if protocol.finished:
        return f"participant {participant} has finished study {name!r}"
    done, total = protocol.progress
    return (f"participant {participant}: {done} of {plural(total, 'episode')} of study {name!r} done; "
            "run the same command to go on")


def report_problems(problems: tuple[str, ...]) -> None:
    for problem in problems:
        print(f"warning: {printable(problem)}", file=sys.stderr)
