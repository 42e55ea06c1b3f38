"""`careful replay FILE... | FOLDER`: read the recordings, then watch them one after another."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from rich.console import Console

from careful_tui.app import make_replay_app
from careful_tui.commands.notices import warn
from careful_tui.commands.reading import read_with_progress
from careful_tui.errors import require_terminal
from careful_tui.keys.kitty import PassiveKittyDriver
from irl_core.errors import RecordingError, UsageError
from irl_core.recordings.demonstrations import Recording
from irl_core.support.safe_text import printable


def name_order(path: Path) -> tuple:
    """A sort key: by name, numbers by value (`s-2` before `s-10`, `s` before `s-2`).

    `careful play` names a file by the time it started (`YYYYMMDD-HHMMSS-PLAYER.jsonl`, then
    `-2`, `-3`, ... for another session of that player in the same second), so in a folder of
    its files this order is the order they were recorded.
    """
    parts = re.split(r"(\d+)", path.stem)
    return [int(part) if i % 2 else part for i, part in enumerate(parts)], path.name


def recording_paths(given: list[Path]) -> list[Path]:
    """The files to replay: each file as given, each folder's `*.jsonl` files in `name_order`.

    Raises:
        UsageError: a folder without `*.jsonl` files.
    """
    paths: list[Path] = []
    for path in given:
        if path.is_dir():
            found = sorted(path.glob("*.jsonl"), key=name_order)
            if not found:
                raise UsageError(f"{printable(str(path), limit=200)}: no recordings (*.jsonl files) in this folder")
            paths.extend(found)
        else:
            paths.append(path)
    return paths


def read_replayable(paths: list[Path], err: Console) -> tuple[list[Recording], list[str]]:
    """Read `paths` one at a time; a file that cannot be read (or is empty) is named on `err` with
    its line and field, and left out. Returns the recordings and a line per file left out.

    Raises:
        RecordingError: `paths` is a single file and it cannot be read.
        UsageError: no file can be read.
    """
    recordings: list[Recording] = []
    skipped: list[str] = []
    for path in paths:
        try:
            recordings.extend(read_with_progress([path], err))
        except RecordingError as exc:
            if len(paths) == 1:
                raise
            skipped.append(f"{exc}; left out")
            warn(err, skipped[-1])
    if not recordings:
        raise UsageError(f"none of the {len(paths)} files can be replayed (each is named above)")
    return recordings, skipped


def run_replay(args: argparse.Namespace) -> int:
    """`careful replay FILE...`: read the recordings (bad files are reported without a terminal),
    then watch them in order."""
    err = Console(stderr=True, highlight=False)
    recordings, skipped = read_replayable(recording_paths(args.files), err)
    require_terminal("replay")
    make_replay_app(*recordings, skipped=skipped, playing=True, driver_class=PassiveKittyDriver).run()
    return 0
