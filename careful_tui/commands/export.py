"""`careful export FILE... --format csv|minari|psych-ds --out PATH|DATASET_ID|DIR` (docs/environment.md; reach
recordings: docs/reach.md).

The files are read and checked with the recording reader before anything is written, so a
bad file ends the command (exit 2, one line) with no output left behind. Gymnasium and
Minari are imported only here and in `irl_core.recordings.export`'s Minari writer, never by the game.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from rich.console import Console
from rich.progress import Progress
from rich.text import Text

from careful_tui.commands.notices import warn
from careful_tui.version import app_version
from irl_core.errors import UsageError
from irl_core.recordings.demonstrations import Recording, read_recording
from irl_core.recordings.export import (
    check_dataset_id,
    dataset_place_problem,
    minari_dataset_path,
    one_world,
    recorded_episodes,
    write_csv,
    write_minari,
    write_psych_ds,
)
from irl_core.recordings.reach_export import write_reach_csv, write_reach_minari, write_reach_psych_ds
from irl_core.recordings.reach_reader import is_reach_recording, read_reach_recording
from irl_core.support.plural import plural
from irl_core.support.safe_files import check_output
from irl_core.support.safe_text import for_markup, printable

# Inputs at least this large (in bytes, all files together) get progress bars.
PROGRESS_FROM_BYTES = 1_000_000


def run_export(args: argparse.Namespace) -> int:
    err = Console(stderr=True, highlight=False)
    if args.format == "csv":
        out = check_output(Path(args.out), option="--out", inputs=args.files)
        if out.exists():
            raise UsageError(f"{out} already exists; export never overwrites a file, choose another --out")
        if not out.parent.is_dir():
            raise UsageError(f"{out.parent} is not a folder; create it first")
    elif args.format == "psych-ds":
        _check_new_folder(Path(args.out))
    else:
        problem = check_dataset_id(args.out)
        if problem:
            raise UsageError(problem)
        if problem := dataset_place_problem(args.out):
            raise UsageError(f"{problem}; choose another id (or a new version, -v1, -v2, ...)")

    reach = [is_reach_recording(path) for path in args.files]
    if any(reach):
        if not all(reach):
            raise UsageError(f"{printable(str(args.files[reach.index(False)]), limit=160)} is not a reach recording "
                             f"but {printable(str(args.files[reach.index(True)]), limit=160)} is: export one kind at a time")
        return _export_reaches(args, err)
    sizes = [_size(path) for path in args.files]
    with Progress(console=err, transient=True, disable=sum(sizes) < PROGRESS_FROM_BYTES) as progress:
        reading = progress.add_task("reading", total=sum(sizes))
        recordings: list[Recording] = []
        for path, size in zip(args.files, sizes):
            progress.update(reading, description=f"reading {for_markup(path.name, limit=60)}")
            recordings.append(read_recording(path))
            progress.advance(reading, size)
        for recording in recordings:
            for warning in recording.warnings:
                warn(err, warning)
        if args.format == "csv":
            summary = _export_csv(Path(args.out), recordings, progress)
        elif args.format == "psych-ds":
            summary = _export_psych_ds(Path(args.out), recordings, progress)
        else:
            summary = _export_minari(args.out, recordings, progress)
    err.print(Text(summary), soft_wrap=True)
    return 0


def _export_reaches(args: argparse.Namespace, err: Console) -> int:
    """Reach recordings (docs/reach.md, "Exporting"): a row per trial, or a Minari episode per trial."""
    recordings = [read_reach_recording(path) for path in args.files]
    for recording in recordings:
        for warning in recording.warnings:
            warn(err, warning)
    trials = sum(len(recording.steps) for recording in recordings)
    files = plural(len(recordings), "file")
    out = printable(str(args.out), limit=160)
    try:
        if args.format == "csv":
            rows = write_reach_csv(Path(args.out), recordings)
            summary = f"wrote {plural(rows, 'row')} (one per trial) from {files} to {out}"
        elif args.format == "psych-ds":
            worlds = sorted({recording.world.name for recording in recordings})
            written = write_reach_psych_ds(
                Path(args.out), recordings, name=f"careful reach recordings of {', '.join(worlds)}",
                description=(f"{plural(trials, 'trial')} recorded with careful {app_version()} (one row per reach) in "
                             f"{', '.join(worlds)}; each data file is one player of one world. variableMeasured "
                             "gives every column's unit."))
            summary = (f"wrote a Psych-DS dataset of {plural(sum(written.values()), 'row')} (one per trial) in "
                       f"{plural(len(written), 'data file')} from {files} to {out}")
        else:
            if trials == 0:
                raise UsageError("the recordings hold no trials: there is nothing to export")
            dataset = write_reach_minari(args.out, recordings, description=(
                f"{plural(trials, 'trial')} recorded in the careful reach world {recordings[0].world.name!r} by "
                f"{', '.join(sorted({r.header.player for r in recordings}))}, exported by careful {app_version()}. "
                "One episode per reach: observations the start and the endpoint, actions (aim x, aim y, duration ms)."))
            summary = (f"wrote Minari dataset {args.out}: {plural(dataset.total_episodes, 'episode')} (one per trial) "
                       f"at {printable(str(minari_dataset_path(args.out)))}; load it with minari.load_dataset({args.out!r})")
    except FileExistsError as exc:
        raise UsageError(f"--out {out}: {exc if args.format == 'minari' else 'already exists; export never overwrites'}"
                         ) from None
    except OSError as exc:
        raise UsageError(f"--out {out}: cannot write the export ({exc.strerror or exc})") from None
    err.print(Text(summary), soft_wrap=True)
    return 0


def _check_new_folder(out: Path) -> None:
    shown = printable(str(out), limit=160)
    if os.path.lexists(out):
        raise UsageError(f"--out {shown} already exists; export never overwrites, choose a new folder")
    if not out.parent.is_dir():
        raise UsageError(f"--out {shown}: the folder {printable(str(out.parent), limit=160)} does not exist; create it first")


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0  # the reader reports the file properly


def _export_csv(out: Path, recordings: list[Recording], progress: Progress) -> str:
    writing = progress.add_task("writing rows", total=sum(len(r.steps) for r in recordings))
    try:
        rows = write_csv(out, recordings, progress=lambda done: progress.update(writing, completed=done))
    except FileExistsError:
        raise UsageError(f"{out} already exists; export never overwrites a file, choose another --out") from None
    except OSError as exc:
        raise UsageError(f"{out}: cannot write the CSV file ({exc.strerror or exc})") from None
    return f"wrote {plural(rows, 'row')} (one per step) from {plural(len(recordings), 'file')} to {printable(str(out))}"


def _export_psych_ds(out: Path, recordings: list[Recording], progress: Progress) -> str:
    studies = sorted({r.header.study.name if r.header.study else r.world.name for r in recordings})
    steps = sum(len(r.steps) for r in recordings)
    name = f"careful recordings of {', '.join(studies)}"
    description = (
        f"{plural(steps, 'step')} recorded with careful {app_version()} (one row per move) by "
        f"{plural(len({r.header.player for r in recordings}), 'player')} in {', '.join(studies)}; "
        "each data file is one participant of one study (or world). variableMeasured gives every column's unit."
    )
    writing = progress.add_task("writing rows", total=steps)
    try:
        files = write_psych_ds(out, recordings, name=name, description=description,
                               progress=lambda done: progress.update(writing, completed=done))
    except FileExistsError:
        raise UsageError(f"--out {printable(str(out), limit=160)} already exists; export never overwrites, "
                         "choose a new folder") from None
    except OSError as exc:
        raise UsageError(f"--out {printable(str(out), limit=160)}: cannot write the dataset "
                         f"({exc.strerror or exc})") from None
    return (f"wrote a Psych-DS dataset of {plural(sum(files.values()), 'row')} (one per step) in "
            f"{plural(len(files), 'data file')} from {plural(len(recordings), 'file')} to {printable(str(out))}")


def _export_minari(dataset_id: str, recordings: list[Recording], progress: Progress) -> str:
    world = one_world(recordings)
    episodes = sum(len(recorded_episodes(r)) for r in recordings)
    steps = sum(len(r.steps) for r in recordings)
    names = ", ".join(r.path.name for r in recordings[:3]) + (f" and {len(recordings) - 3} more" if len(recordings) > 3 else "")
    description = (
        f"{plural(episodes, 'episode')} ({plural(steps, 'step')}) recorded in the careful world {world.name!r} by "
        f"{', '.join(sorted({r.header.player for r in recordings}))}; exported from {names} by careful {app_version()}. "
        "Observations are cells (row * cols + col), actions d * L + c - 1; infos hold the hold time of each move."
    )
    if episodes == 0:
        raise UsageError("the recordings hold no steps: there is nothing to export")
    writing = progress.add_task("writing episodes", total=episodes)
    try:
        dataset = write_minari(dataset_id, recordings, description=description,
                               progress=lambda done: progress.update(writing, completed=done))
    except FileExistsError as exc:
        raise UsageError(str(exc)) from None
    return (f"wrote Minari dataset {dataset_id}: {plural(dataset.total_episodes, 'episode')}, "
            f"{plural(dataset.total_steps, 'step')} of "
            f"world {world.name!r}, at {printable(str(minari_dataset_path(dataset_id)))}; "
            f"load it with minari.load_dataset({dataset_id!r})")
