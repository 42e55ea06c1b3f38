"""Studies (docs/studies.md): one protocol for many participants, and where each one stands.

A study file (TOML, validated with pydantic like a world file) names the worlds, their order,
the practice and main episodes per world, the input mode and the output folder. Each
participant's recordings go to ``<out>/<ID>/``, each file's header carrying a ``study`` field
(`irl_core.recordings.demonstrations.StudyTag`) that says which world and phase it belongs to.

`read_protocol` reads what a participant's folder already holds and says what comes next, so
resuming after a crash or ``q`` neither loses nor repeats an episode:

- A study with ``calibration_block = N`` first asks N motor calibration targets; their
  ``calibration_trial`` lines are counted across the folder's files, so a participant who left
  mid-block is asked only the rest.
- The participant's sequence is, for each world in their order, a practice block
  (``practice_episodes``, left out when 0) then a main block (``episodes``).
- An episode is *done* when its ``episode_end`` says ``terminal`` or ``step_limit``.
- An *interrupted* episode (``q`` mid-way: ``episode_end`` with ``quit``; a crash: no
  ``episode_end`` at all) stays in its file but is not done: that episode is played again.
  The report leaves interrupted episodes out of every fit and counts them in its table.
- The next block is the first one, in the sequence, with fewer done episodes than it asks for.
  Episode numbers continue across a block's files, so no number is used twice.

``order = "shuffled"`` permutes the worlds per participant, reproducibly: a Fisher-Yates
shuffle whose draws are SHA-256 digests of the participant id, so the same id gets the same
order on every machine and Python version (never Python's salted ``hash()``).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from irl_core.errors import EmptyRecording, RecordingError, StudyError, WorldError
from irl_core.play.hold import MS_PER_LEVEL, TAP_MS
from irl_core.play.input_modes import DEFAULT_INPUT_MODE, input_mode
from irl_core.reach.calibration import calibration_schedule, calibration_world
from irl_core.recordings.demonstrations import Recording, read_recording
from irl_core.recordings.lines import StudyTag
from irl_core.recordings.reach_reader import ReachRecording, is_reach_recording, read_reach_recording
from irl_core.recordings.writer import slug
from irl_core.support.plural import plural
from irl_core.support.safe_files import SAFE_NAME, SAFE_NAME_RULE, read_toml, reference_problem
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.reach import REACH_WORLDS, ReachWorld, is_reach_world, load_reach_world
from irl_core.worlds.world import BUILTIN_WORLDS, World, load_world
from irl_core.worlds.world_text import describe_validation_error

Phase = Literal["practice", "main"]
# A study's world: a grid world, or a reach world (docs/reach.md: served in a browser, a trial an episode).
StudyWorld = World | ReachWorld
# The folders careful itself writes under `<out>`, and what each holds: never a participant's folder
# (`check_participant` refuses their names as ids; the report's `participant_ids` passes them by).
REPORT_FOLDER = "report"
PLAN_FOLDER = "plan"
TOOL_FOLDERS = {REPORT_FOLDER: "the study's report", PLAN_FOLDER: "careful study plan's files"}
# The report's rows of every participant together carry this id (`irl_core.studies.report.POOLED`).
POOLED = "pooled"
_MAX_STUDY_FILE_BYTES = 1 << 20
# A study names at most this many worlds (each one a block per participant), checked before any is read.
MAX_WORLDS = 1000
FINISHED_OUTCOMES = ("terminal", "step_limit")


class Exclusions(BaseModel):
    """A study file's ``[exclusions]``: who `careful study report` leaves out of the pool, fixed before the data.

    Attributes:
        fit_check_failed: leave out a participant whose fit of a world fails its fit check (on that world).
        min_main_episodes: leave out a participant with fewer finished main episodes of a world (on that world).
        max_quit_share: leave out a participant who quit more than this share of their main episodes of a world.
    """

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)

    fit_check_failed: bool = False
    min_main_episodes: int = Field(0, ge=0, le=100_000)
    max_quit_share: float = Field(1.0, ge=0.0, le=1.0)

    @property
    def any_set(self) -> bool:
        """Whether the file sets any exclusion (a field off its default)."""
        return self != Exclusions()


class Study(BaseModel):
    """A study file's fields, as docs/studies.md names them."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)

    name: str = Field(min_length=1)
    instructions: str = Field("", max_length=20_000)
    worlds: tuple[Annotated[str, Field(max_length=4096)], ...] = Field(min_length=1, max_length=MAX_WORLDS,
                                                                        strict=False)
    order: Literal["fixed", "shuffled"] = "fixed"
    practice_episodes: int = Field(1, ge=0, le=1000)
    # Targets of the motor calibration block before practice (0: no block).
    calibration_block: int = Field(0, ge=0, le=100)
    episodes: int = Field(5, ge=1, le=100_000)
    # Reaches a deadline of the calibration block of a reach world with "own" noise (docs/reach.md).
    calibration_reaches: int = Field(10, ge=1, le=1000)
    input: str = DEFAULT_INPUT_MODE
    tap_ms: float = Field(TAP_MS, ge=50.0, le=5_000.0)
    ms_per_level: float = Field(MS_PER_LEVEL, ge=20.0, le=5_000.0)
    out: str = Field("data", min_length=1)
    # Whether the board's legend gives each symbol's reward, in the terminal and the browser alike.
    show_rewards: bool = True
    exclusions: Exclusions = Field(default_factory=Exclusions)

    @field_validator("input")
    @classmethod
    def _input_is_a_registered_mode(cls, name: str) -> str:
        """The study's input mode is one of the input-mode registry's (`irl_core.play.input_modes`)."""
        return input_mode(name).name


@dataclass(frozen=True)
class LoadedStudy:
    """A study file read and checked: its fields, its worlds (read), and its output folder.

    Attributes:
        path: the study file.
        study: its fields.
        worlds: the world of each entry of ``study.worlds``, in the file's order.
        out: the output folder, relative to the study file's folder.
    """

    path: Path
    study: Study
    worlds: tuple[StudyWorld, ...]
    out: Path

    def participant_folder(self, participant: str) -> Path:
        """``<out>/<ID>/`` for a valid participant id (`check_participant`)."""
        return self.out / participant_folder_name(participant)

    @property
    def report_folder(self) -> Path:
        return self.out / REPORT_FOLDER

    @property
    def grid_worlds(self) -> tuple[World, ...]:
        """The worlds, for what takes grid worlds only (the report, the plan, simulated participants).

        Raises:
            StudyError: a world is a reach world."""
        return tuple(grid_world(world, f"{self.path}: worlds[{i}]: this command")
                     for i, world in enumerate(self.worlds))


def load_study(path: str | Path) -> LoadedStudy:
    """Read a study file; its worlds are built-in names or world files relative to it.

    Raises:
        StudyError: one line naming the file and the field (``worlds[1]: ...``).
    """
    path = Path(path)
    try:
        data = read_toml(path, what="study", limit=_MAX_STUDY_FILE_BYTES, too_big="")
    except ValueError as exc:
        raise StudyError(str(exc)) from None
    data.setdefault("name", path.stem)
    try:
        study = Study.model_validate(data)
    except ValidationError as exc:
        raise StudyError(f"{path}: {describe_validation_error(exc)}") from None
    worlds: list[StudyWorld] = []
    read: dict[str, StudyWorld] = {}
    for i, entry in enumerate(study.worlds):
        source = _world_source(entry, path.parent)
        shown = printable(entry, limit=VALUE_LIMIT)
        if not isinstance(source, str) and (problem := reference_problem(str(source))):
            raise StudyError(f"{path}: worlds[{i}]: {shown!r} is not a built-in world and cannot be a file: {problem}")
        if not isinstance(source, str) and not source.exists():
            raise StudyError(f"{path}: worlds[{i}]: {shown!r} is neither a built-in world "
                             f"({', '.join([*BUILTIN_WORLDS, *REACH_WORLDS])}) nor a world file (looked for {source})")
        try:
            # A world named twice is read once.
            worlds.append(read[entry] if entry in read else read.setdefault(entry, _load_world(source)))
        except WorldError as exc:
            raise StudyError(f"{path}: worlds[{i}]: {exc}") from None
    timed = [i for i, world in enumerate(worlds) if world.care == "time"]
    reach = [i for i, world in enumerate(worlds) if isinstance(world, ReachWorld)]
    if timed and study.input != "hold":
        # A time world's care is the hold itself, from key-down to key-up: taps or digits cannot give it.
        raise StudyError(f"{path}: input: {study.input!r} cannot play worlds[{timed[0]}], a time world (care is how "
                         'long an arrow is held): use input = "hold"')
    # The calibration block's targets are levels of the participant's first world; a time world has none
    # (docs/timing.md), nor has a reach world, so neither may come first in a study with a block.
    levelless = sorted(timed + reach)
    first_possible = levelless if study.order == "shuffled" else [i for i in levelless if i == 0]
    if study.calibration_block and first_possible:
        kind = "a time world" if first_possible[0] in timed else "a reach world"
        where = "a shuffled order may put first" if study.order == "shuffled" else "comes first"
        raise StudyError(f"{path}: calibration_block: worlds[{first_possible[0]}] is {kind} that {where}, and "
                         f"{kind} has no levels to calibrate (the block's targets are levels of the first world): set "
                         "calibration_block = 0, or put a world with levels first in a fixed order")
    return LoadedStudy(path=path, study=study, worlds=tuple(worlds), out=path.parent / study.out)


def world_files(study: LoadedStudy) -> list[Path]:
    """The world files the study reads (not its built-in worlds): inputs no output may replace."""
    return [source for entry in study.study.worlds
            if not isinstance(source := _world_source(entry, study.path.parent), str)]


def _world_source(entry: str, folder: Path) -> str | Path:
    """A built-in world's name (grid or reach) as it is; anything else is a file relative to the study file."""
    return entry if entry in BUILTIN_WORLDS or entry in REACH_WORLDS else folder / entry


def _load_world(source: str | Path) -> StudyWorld:
    """A study's world: a reach world when the name or file says ``care = "reach"``, else a grid world."""
    return load_reach_world(source) if is_reach_world(source) else load_world(source)


def grid_world(world: StudyWorld, what: str) -> World:
    """`world` as a grid world, for `what` (a command or a screen that plays or fits grid worlds only).

    Raises:
        StudyError: it is a reach world."""
    if isinstance(world, ReachWorld):
        raise StudyError(f"{what} does not take reach worlds ({printable(world.name, limit=VALUE_LIMIT)!r} is one): "
                         "a study with reach worlds is served in a browser (careful serve)")
    return world


def check_participant(participant: str) -> str:
    """A participant id usable as its own folder name; returns it.

    Raises:
        StudyError: the id is empty, too long, holds other characters than letters, digits
            and ``_ . = -``, starts with another, or is a folder careful writes (`TOOL_FOLDERS`:
            ``report``, ``plan``) or ``pooled`` (the report's rows of everyone together).
    """
    if not SAFE_NAME.fullmatch(participant):
        raise StudyError(
            f"participant id {printable(participant, limit=VALUE_LIMIT)!r} cannot name a folder: use {SAFE_NAME_RULE}"
        )
    if (folder := participant.lower()) in TOOL_FOLDERS:
        raise StudyError(f"participant id {participant!r} is taken: <out>/{folder}/ holds {TOOL_FOLDERS[folder]}")
    if participant.lower() == POOLED:
        raise StudyError(f"participant id {participant!r} is taken: the report's rows of everyone together are "
                         f"called {POOLED!r}")
    return participant


def participant_folder_name(participant: str) -> str:
    """The folder of a participant: the id itself (checked, so the slug leaves it whole)."""
    name = slug(check_participant(participant))
    assert name == participant
    return name


def world_order(study: Study, participant: str) -> list[int]:
    """The indices into ``study.worlds`` in the order this participant plays them.

    ``fixed``: the file's order. ``shuffled``: a Fisher-Yates shuffle, its i-th draw the
    SHA-256 digest of ``"<participant>:<i>"`` (a 256-bit integer) modulo i + 1.
    """
    order = list(range(len(study.worlds)))
    if study.order == "shuffled":
        for i in range(len(order) - 1, 0, -1):
            digest = hashlib.sha256(f"{participant}:{i}".encode()).digest()
            j = int.from_bytes(digest, "big") % (i + 1)
            order[i], order[j] = order[j], order[i]
    return order


# ---------------------------------------------------------------------------- a participant's folder


@dataclass(frozen=True)
class ParticipantRecordings:
    """The study recordings in a participant's folder; `problems` names each file left out (and
    each reader warning of a file that is counted) in one line, `left_out` counts the files left out."""

    participant: str
    folder: Path
    recordings: tuple[tuple[StudyTag, Recording], ...]
    problems: tuple[str, ...]
    left_out: int = 0
    reaches: tuple[tuple[StudyTag, ReachRecording], ...] = ()


def read_participant(study: LoadedStudy, participant: str) -> ParticipantRecordings:
    """Read every ``*.jsonl`` in the participant's folder (a missing folder holds nothing).

    A file that cannot be read, is not a study recording, belongs to another study or
    participant, or was recorded in another world than the study's (the study file was
    changed) is left out with one line naming it; the others are read.
    """
    folder = study.participant_folder(participant)
    found: list[tuple[StudyTag, Recording]] = []
    reaches: list[tuple[StudyTag, ReachRecording]] = []
    problems: list[str] = []
    paths = sorted(folder.glob("*.jsonl")) if folder.is_dir() else []
    for path in paths:
        if is_reach_recording(path):
            if (reach := _read_reach(study, participant, path, problems)) is not None:
                reaches.append(reach)
            continue
        try:
            recording = read_recording(path)
        except EmptyRecording:
            problems.append(f"{path}: the file is empty (no session header); left out")
            continue
        except RecordingError as exc:
            problems.append(f"{exc}; left out")
            continue
        problem = _foreign(study, participant, recording)
        if problem:
            problems.append(f"{path}: {problem}; left out")
            continue
        problems.extend(f"{warning}; the rest of the file is counted" for warning in recording.warnings)
        tag = recording.header.study
        assert tag is not None, "_foreign refuses a recording without a study tag"
        found.append((tag, recording))
    found, copies = _one_per_session(found)
    problems.extend(copies)
    return ParticipantRecordings(participant, folder, tuple(found), tuple(problems),
                                 left_out=len(paths) - len(found) - len(reaches), reaches=tuple(reaches))


def _read_reach(study: LoadedStudy, participant: str, path: Path,
                problems: list[str]) -> tuple[StudyTag, ReachRecording] | None:
    """A reach recording of the participant's folder with its study tag, or None (and a line in `problems`)."""
    try:
        recording = read_reach_recording(path)
    except RecordingError as exc:
        problems.append(f"{exc}; left out")
        return None
    tag = recording.header.study
    problem = _foreign_tag(study, participant, tag)
    if problem is None and tag is not None:
        world = study.worlds[tag.world_index]
        if not isinstance(world, ReachWorld) or recording.world not in (world, calibration_world(world)):
            problem = f"recorded in another world than the study's worlds[{tag.world_index}] (was the study file changed?)"
    if problem is not None or tag is None:
        problems.append(f"{path}: {problem}; left out")
        return None
    problems.extend(f"{warning}; the rest of the file is counted" for warning in recording.warnings)
    return tag, recording


def _one_per_session(found: list[tuple[StudyTag, Recording]]) -> tuple[list[tuple[StudyTag, Recording]], list[str]]:
    """Each session once: a file whose header equals another's and whose lines all begin that
    other file (a backup copy, taken then or later, which has its own inode) is a copy; the file
    that holds the most is kept and each copy is named. Files of equal headers whose lines differ
    are different sessions, and both count."""
    sessions: dict[str, list[tuple[StudyTag, Recording]]] = {}
    for entry in found:
        sessions.setdefault(entry[1].header.model_dump_json(), []).append(entry)
    kept, problems = [], []
    for entries in sessions.values():
        mine: list[tuple[StudyTag, Recording]] = []
        for entry in sorted(entries, key=lambda entry: -_lines(entry[1])):  # stable: name order among equals
            original = next((k for _, k in mine if _prefix(entry[1], k)), None)
            if original is None:
                mine.append(entry)
                continue
            problems.append(f"{entry[1].path}: a copy of the session in {original.path.name} (the same header, and "
                            f"all its lines are in {original.path.name}); left out, so the session counts once")
        kept.extend(mine)
    position = {id(recording): i for i, (_, recording) in enumerate(found)}
    kept.sort(key=lambda entry: position[id(entry[1])])
    return kept, problems


def _lines(recording: Recording) -> int:
    return len(recording.steps) + len(recording.episode_ends)


def _prefix(short: Recording, long: Recording) -> bool:
    """Whether every step and episode end of `short` is the start of `long`'s."""
    n = len(short.steps)
    if n > len(long.steps) or len(short.episode_ends) > len(long.episode_ends):
        return False
    same_steps = all(np.array_equal(short.steps.column(name), long.steps.column(name)[:n], equal_nan=True)
                     for name in ("episode", "t", "row", "col", "direction", "level", "timed", "hold_ms"))
    return same_steps and short.episode_ends == long.episode_ends[: len(short.episode_ends)]


def _foreign(study: LoadedStudy, participant: str, recording: Recording) -> str | None:
    """Why a recording is not one of this participant's in this study, or None."""
    tag = recording.header.study
    if (problem := _foreign_tag(study, participant, tag)) is not None:
        return problem
    assert tag is not None
    if recording.world != study.worlds[tag.world_index]:
        return f"recorded in another world than the study's worlds[{tag.world_index}] (was the study file changed?)"
    return None


def _foreign_tag(study: LoadedStudy, participant: str, tag: StudyTag | None) -> str | None:
    """Why a recording's study tag is not one of this participant's in this study, or None."""
    if tag is None:
        return "not a study recording (its header has no study field)"
    if tag.name != study.study.name:
        return f"recorded for study {printable(tag.name, limit=VALUE_LIMIT)!r}, not {study.study.name!r}"
    if tag.participant != participant:
        return f"recorded for participant {printable(tag.participant, limit=VALUE_LIMIT)!r}, not {participant!r}"
    if tag.world_index >= len(study.worlds):
        return f"study.world_index {tag.world_index} is beyond the study's {plural(len(study.worlds), 'world')}"
    return None


def finished_episodes(recording: Recording) -> set[int]:
    """Episodes whose ``episode_end`` says they ended in a terminal cell or at the step limit."""
    return {end.episode for end in recording.episode_ends if end.outcome in FINISHED_OUTCOMES}


def interrupted_episodes(recording: Recording) -> set[int]:
    """Episodes with steps that did not finish: quit mid-way, or cut off without an ``episode_end``."""
    stepped = set(recording.steps.column("episode").tolist())
    return stepped - finished_episodes(recording)


# ---------------------------------------------------------------------------- the protocol


@dataclass(frozen=True)
class Block:
    """One world's practice or main episodes in a participant's sequence, and how far they got.

    Attributes:
        position: the block's world's place in the participant's order (0 first).
        world_index: the world's index in the study file's ``worlds``.
        phase: ``practice`` or ``main``.
        target: the episodes the study asks for.
        done: the finished episodes recorded.
        interrupted: the episodes recorded but not finished (each is played again).
        next_episode: the episode number the next one gets (numbers continue across files).
        files: the recordings of this block, in name order.
    """

    position: int
    world_index: int
    phase: Phase
    target: int
    done: int
    interrupted: int
    next_episode: int
    files: tuple[Path, ...]

    @property
    def remaining(self) -> int:
        return max(0, self.target - self.done)


@dataclass(frozen=True)
class Protocol:
    """Where a participant stands in a study: every block, and what comes next."""

    study: LoadedStudy
    participant: str
    folder: Path
    order: tuple[int, ...]
    blocks: tuple[Block, ...]
    problems: tuple[str, ...]
    calibration_trials: int = 0
    # Per reach world with "own" noise (by world index): the calibration reaches its folder holds.
    reach_calibration_trials: dict[int, int] = field(default_factory=dict)

    @property
    def calibration_left(self) -> int:
        """Targets of the study's calibration block still to ask (0 once done, or for a finished participant)."""
        return 0 if self.finished else max(0, self.study.study.calibration_block - self.calibration_trials)

    @property
    def reach_calibration_left(self) -> int:
        """Reaches of the calibration block still to make before the next block: its world is a reach world with
        "own" noise whose block the folder does not hold whole (0 otherwise; docs/reach.md)."""
        block = self.next_block
        if block is None:
            return 0
        world = self.study_world(block)
        if not (isinstance(world, ReachWorld) and world.noise == "own"):
            return 0
        wanted = len(calibration_schedule(world, self.study.study.calibration_reaches))
        return max(0, wanted - self.reach_calibration_trials.get(block.world_index, 0))

    @property
    def next_block(self) -> Block | None:
        """The first block with episodes still to play, or None when the participant has finished."""
        return next((block for block in self.blocks if block.remaining), None)

    @property
    def finished(self) -> bool:
        return self.next_block is None

    @property
    def progress(self) -> tuple[int, int]:
        """(finished episodes that count, episodes the protocol asks for), practice included."""
        return (sum(min(block.done, block.target) for block in self.blocks),
                sum(block.target for block in self.blocks))

    @property
    def started(self) -> bool:
        return any(block.done or block.interrupted for block in self.blocks)

    def world(self, block: Block) -> World:
        """The block's world, which a grid session plays (`StudyError` for a reach world: `study_world`)."""
        return grid_world(self.study_world(block), f"{self.study.path}: worlds[{block.world_index}]: a grid session")

    def study_world(self, block: Block) -> StudyWorld:
        """The block's world, grid or reach."""
        return self.study.worlds[block.world_index]

    def tag(self, block: Block) -> StudyTag:
        """The ``study`` header field of a new recording of `block`."""
        return StudyTag(name=self.study.study.name, participant=self.participant, phase=block.phase,
                        world_index=block.world_index)


def read_protocol(study: LoadedStudy, participant: str) -> Protocol:
    """What `participant` has done so far (from their folder) and the blocks of their sequence.

    Raises:
        StudyError: the participant id cannot name a folder.
    """
    check_participant(participant)
    found = read_participant(study, participant)
    order = world_order(study.study, participant)
    by_block: dict[tuple[int, str], list[Recording]] = {}
    for tag, recording in found.recordings:
        by_block.setdefault((tag.world_index, tag.phase), []).append(recording)
    reach_blocks: dict[tuple[int, str], list[ReachRecording]] = {}
    reach_calibration: dict[int, int] = {}
    for tag, reach in found.reaches:
        if reach.world == study.worlds[tag.world_index]:
            reach_blocks.setdefault((tag.world_index, tag.phase), []).append(reach)
        else:  # the calibration block's lone target (`_read_reach` lets no other world by)
            reach_calibration[tag.world_index] = reach_calibration.get(tag.world_index, 0) + len(reach.steps)
    problems = list(found.problems)
    blocks = []
    phases: list[tuple[Phase, int]] = [("practice", study.study.practice_episodes), ("main", study.study.episodes)]
    for position, world_index in enumerate(order):
        for phase, target in phases:
            if isinstance(study.worlds[world_index], ReachWorld):
                # A reach trial is an episode, whole once written (a reach being made is no line at all).
                reached = reach_blocks.pop((world_index, phase), []) if target else []
                steps = [step for reach in reached for step in reach.steps]
                if target:
                    blocks.append(Block(position=position, world_index=world_index, phase=phase, target=target,
                                        done=len(steps), interrupted=0,
                                        next_episode=max((step.episode for step in steps), default=-1) + 1,
                                        files=tuple(reach.path for reach in reached)))
                continue
            recordings = by_block.pop((world_index, phase), [])
            if target == 0:
                if recordings:
                    problems.append(f"{len(recordings)} practice recording(s) of worlds[{world_index}] are not "
                                    "counted: the study has no practice episodes now")
                continue
            numbers = [n for r in recordings for n in r.episodes]
            blocks.append(Block(
                position=position, world_index=world_index, phase=phase, target=target,
                done=sum(len(finished_episodes(r)) for r in recordings),
                interrupted=sum(len(interrupted_episodes(r)) for r in recordings),
                next_episode=max(numbers, default=-1) + 1,
                files=tuple(r.path for r in recordings),
            ))
    trials = sum(len(recording.calibration_trials) for _, recording in found.recordings)
    return Protocol(study=study, participant=participant, folder=found.folder, order=tuple(order),
                    blocks=tuple(blocks), problems=tuple(problems), calibration_trials=trials,
                    reach_calibration_trials=reach_calibration)
