"""Reading reach recordings (docs/reach.md): a strict reader that names file, line and field.

A reach recording is a ``session`` header whose world says ``care = "reach"``, then one ``step`` line a
trial. Each line is checked against the world and the lines before it: episodes count up, ``t`` is 0
(a trial is one reach), the duration lies within the world's ``min_ms`` to ``max_ms``, the circles listed
are those holding the endpoint, the reward is what the world scores and the score adds the rewards up.
A last line cut off without its newline (a crash mid-write) is skipped with a warning.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np
from pydantic import ValidationError

from irl_core.errors import EmptyRecording, RecordingError
from irl_core.recordings.demonstrations import (
    MAX_LINE_BYTES,
    check_header,
    json_problem,
    line_error,
    line_object,
    open_recording,
)
from irl_core.recordings.reach_lines import ReachHeader, ReachStep
from irl_core.support.safe_files import open_regular, read_problem
from irl_core.worlds.reach import ReachWorld

_BOM = b"\xef\xbb\xbf"
# A reward or score that differs from the world's by less than this (relative to its size) is the same
# number written with rounding.
_TOLERANCE = 1e-6


@dataclass
class ReachRecording:
    """One reach session as read: its header, its trials in order and any warnings."""

    path: Path
    header: ReachHeader
    steps: list[ReachStep] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def world(self) -> ReachWorld:
        return self.header.world


@dataclass(frozen=True)
class Reaches:
    """The trials of one or more reach recordings of one world, as arrays (n trials).

    aims (n, 2), durations (n,) in ms, endpoints (n, 2), in file order; `files` how many files they came from.
    """

    world: ReachWorld
    aims: np.ndarray
    durations: np.ndarray
    endpoints: np.ndarray
    files: int

    @property
    def trials(self) -> int:
        return len(self.durations)


def is_reach_recording(path: str | Path) -> bool:
    """Whether `path`'s first line is a session header of a reach world (anything unreadable is not: the
    grid reader says why)."""
    try:
        with open_regular(Path(path)) as file:
            first = file.readline(MAX_LINE_BYTES + 1)
        header = json.loads(first.removeprefix(_BOM).decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return False
    return isinstance(header, dict) and isinstance(header.get("world"), dict) and header["world"].get("care") == "reach"


def read_reach_recording(path: str | Path, *, keep: Callable[[ReachStep], None] | None = None) -> ReachRecording:
    """Read and check one reach recording; `RecordingError` naming file, line and field of the first problem.

    `keep`, if given, is handed each checked trial in place of `ReachRecording.steps` (left empty), so that a
    caller wanting arrays holds no line objects: a million trials are about 1.4 GB of them."""
    path = Path(path)
    with open_recording(path) as file:
        try:
            return _read(path, file, keep)
        except OSError as exc:
            raise RecordingError(path, None, None, f"cannot read the file ({read_problem(exc)})") from None


def _read(path: Path, file: BinaryIO, keep: Callable[[ReachStep], None] | None) -> ReachRecording:
    recording: ReachRecording | None = None
    last: ReachStep | None = None
    number = 0
    while data := file.readline(MAX_LINE_BYTES + 1):
        number += 1
        if not data.endswith(b"\n") and len(data) > MAX_LINE_BYTES:
            raise RecordingError(path, number, None, f"the line is longer than {MAX_LINE_BYTES >> 20} MB")
        text = (data.removeprefix(_BOM) if number == 1 else data).rstrip(b"\n").rstrip(b"\r")
        if not text.strip():
            continue
        try:
            obj = json.loads(text.decode("utf-8"))
        except (ValueError, RecursionError) as exc:
            if not data.endswith(b"\n") and recording is not None:
                recording.warnings.append(f"{path}:{number}: the last line is truncated and was skipped")
                break
            raise RecordingError(path, number, None, json_problem(exc)) from None
        obj = line_object(obj, path, number)
        if recording is None:
            check_header(obj, path, number)
            try:
                recording = ReachRecording(path, ReachHeader.model_validate(obj))
            except ValidationError as exc:
                raise line_error(path, number, exc, obj) from None
            continue
        if obj.get("kind") != "step":
            raise RecordingError(path, number, "kind", "a reach recording holds step lines only, one a trial")
        try:
            step = ReachStep.model_validate(obj)
        except ValidationError as exc:
            raise line_error(path, number, exc, obj) from None
        _check(recording.world, last, step, path, number)
        last = step
        if keep is None:
            recording.steps.append(step)
        else:
            keep(step)
    if recording is None:
        raise EmptyRecording(path, None, None, "the file is empty: no session header")
    return recording


def _check(world: ReachWorld, last: ReachStep | None, step: ReachStep, path: Path, number: int) -> None:
    """That `step` agrees with the world and the trial before it (`last`)."""
    if last is not None and step.episode <= last.episode:
        raise RecordingError(path, number, "episode", f"{step.episode} does not come after episode {last.episode}")
    if step.t != 0:
        raise RecordingError(path, number, "t", f"{step.t}, but a trial is one reach: t is 0")
    if not world.min_ms <= step.duration_ms <= world.max_ms:
        raise RecordingError(path, number, "duration_ms", f"{step.duration_ms:g} is outside the world's "
                             f"{world.min_ms:g} to {world.max_ms:g} ms (min_ms to max_ms)")
    held = world.regions_holding(step.endpoint)
    if list(step.regions) != held:
        raise RecordingError(path, number, "regions", f"{list(step.regions)}, but the endpoint "
                             f"{list(step.endpoint)} lies in {held}")
    if not _same(step.reward, expected := world.score_of(step.endpoint, step.duration_ms)):
        raise RecordingError(path, number, "reward", f"{step.reward:g}, but the world scores this reach {expected:g}")
    if not _same(step.score, total := (last.score if last else 0.0) + step.reward):
        raise RecordingError(path, number, "score", f"{step.score:g}, but the rewards so far add up to {total:g}")


def _same(written: float, expected: float) -> bool:
    return math.isclose(written, expected, rel_tol=_TOLERANCE, abs_tol=_TOLERANCE)


def read_reaches(paths: Iterable[str | Path]) -> tuple[Reaches, list[str]]:
    """Every trial of reach recordings of one world, pooled, and the readers' warnings.

    Raises `RecordingError` for a bad file, a file of another world, or no trial at all."""
    aims: list[tuple[float, float]] = []
    durations: list[float] = []
    endpoints: list[tuple[float, float]] = []

    def keep(step: ReachStep) -> None:
        aims.append(step.aim)
        durations.append(step.duration_ms)
        endpoints.append(step.endpoint)

    recordings = [read_reach_recording(path, keep=keep) for path in paths]
    first = recordings[0]
    for recording in recordings[1:]:
        if recording.world != first.world:
            raise RecordingError(recording.path, 1, "world", f"not the world of {first.path}: one world at a time")
    if not durations:
        raise RecordingError(first.path, None, None, "no trials, so there is nothing to fit; simulate some first")
    reaches = Reaches(
        world=first.world,
        aims=np.array(aims, dtype=float).reshape(-1, 2),
        durations=np.array(durations, dtype=float),
        endpoints=np.array(endpoints, dtype=float).reshape(-1, 2),
        files=len(recordings),
    )
    return reaches, [warning for recording in recordings for warning in recording.warnings]
