"""Reading recordings for a command: warnings on stderr, and a progress bar for big files."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, DownloadColumn, Progress, TextColumn, TimeRemainingColumn

from careful_tui.commands.notices import warn
from irl_core.recordings.demonstrations import Recording, read_recordings

# Below this many bytes in all, reading takes under a second or so: no bar.
PROGRESS_FROM_BYTES = 32 << 20


def read_with_progress(paths: list[Path], err: Console) -> list[Recording]:
    """Read `paths` (`irl_core.recordings.demonstrations.read_recordings`), printing its warnings to `err`.

    Raises what `read_recordings` raises (`RecordingError`).
    """
    total = 0
    for path in paths:
        try:
            total += path.stat().st_size
        except OSError:
            pass
    with Progress(TextColumn("reading recordings"), BarColumn(), DownloadColumn(), TimeRemainingColumn(),
                  console=err, transient=True, disable=total < PROGRESS_FROM_BYTES) as progress:
        task = progress.add_task("reading", total=total)
        recordings, warnings = read_recordings(paths, progress=lambda done: progress.advance(task, done))
    for warning in warnings:
        warn(err, warning)
    return recordings
