"""Demonstrations as JSONL files (SPEC section 2): models, a crash-safe writer, a strict reader.

A file is one play session: a ``session`` header line, then ``step`` lines and
``episode_end`` lines as they happen. The writer never overwrites, flushes every line
and fsyncs at each episode end, so a crash loses at most the line in flight. The reader
validates every line and reports ``file:line: field: problem``; a truncated last line
(the crash case) is skipped with a warning.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import scipy.sparse as sp
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from irl_core.mdp import DIRECTIONS, MDP, action_index, build_mdp
from irl_core.world import World, field_path

SCHEMA_VERSION = 1
Direction = Literal["up", "right", "down", "left"]


class RecordingError(ValueError):
    """A recording that cannot be used. `str()` is `file:line: field: problem`."""

    def __init__(self, path: str | Path, line: int | None, field: str | None, problem: str):
        self.path, self.line, self.field, self.problem = str(path), line, field, problem
        where = self.path if line is None else f"{self.path}:{line}"
        super().__init__(f"{where}: {field}: {problem}" if field else f"{where}: {problem}")


class _Line(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, populate_by_name=True)


class SessionHeader(_Line):
    kind: Literal["session"] = "session"
    schema_version: int = Field(SCHEMA_VERSION, alias="schema")
    world: World
    player: str
    created: datetime
    seed: int | None = None
    input: dict[str, Any] = Field(default_factory=lambda: {"mode": "hold"})
    app_version: str = ""


class Step(_Line):
    kind: Literal["step"] = "step"
    episode: int = Field(ge=0)
    t: int = Field(ge=0)
    # JSON has no tuples: a cell arrives as a 2-element array.
    state: tuple[int, int] = Field(strict=False)
    direction: Direction
    carefulness: int = Field(ge=1)
    hold_ms: float | None = Field(default=None, ge=0)
    hold_exact: bool = False
    next_state: tuple[int, int] = Field(strict=False)
    slipped: bool
    reward: float
    score: float


class EpisodeEnd(_Line):
    kind: Literal["episode_end"] = "episode_end"
    episode: int = Field(ge=0)
    outcome: Literal["terminal", "quit", "step_limit"]
    terminal_symbol: str | None = None
    steps: int = Field(ge=0)
    return_: float = Field(alias="return")
    score: float


_BODY = TypeAdapter(Annotated[Step | EpisodeEnd, Field(discriminator="kind")])


def to_json_line(line: _Line) -> str:
    """One JSONL line (with its newline) in SPEC field names."""
    return json.dumps(line.model_dump(mode="json", by_alias=True), ensure_ascii=False) + "\n"


# ---------------------------------------------------------------------------- writing


class RecordingWriter:
    """Appends a session's lines to a new file as they happen.

    The file is created exclusively (an existing file is never overwritten); each line
    is flushed at once, and the file is fsynced at every episode end and on close.
    `sync_episodes=False` skips the per-episode fsync, for bulk output that can simply be
    written again (simulated experts).
    """

    def __init__(self, path: str | Path, header: SessionHeader, *, sync_episodes: bool = True):
        self.path = Path(path)
        self._sync_episodes = sync_episodes
        self._file = open(self.path, "x", encoding="utf-8")
        self._write(header)
        self._sync()

    @classmethod
    def create_in(cls, folder: str | Path, header: SessionHeader) -> RecordingWriter:
        """A writer for a new file in `folder`, named by the time and player.

        Two sessions started in the same second get distinct names (`-2`, `-3`, ...).
        """
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        stem = f"{header.created:%Y%m%d-%H%M%S}-{_slug(header.player)}"
        for n in range(1, 1000):
            path = folder / (f"{stem}.jsonl" if n == 1 else f"{stem}-{n}.jsonl")
            try:
                return cls(path, header)
            except FileExistsError:
                continue
        raise FileExistsError(f"{folder}: too many sessions named {stem}")

    def write_step(self, step: Step) -> None:
        self._write(step)

    def end_episode(self, end: EpisodeEnd) -> None:
        self._write(end)
        if self._sync_episodes:
            self._sync()

    def close(self) -> None:
        if not self._file.closed:
            self._sync()
            self._file.close()

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _write(self, line: _Line) -> None:
        self._file.write(to_json_line(line))
        self._file.flush()

    def _sync(self) -> None:
        self._file.flush()
        os.fsync(self._file.fileno())


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.=-]+", "_", text).strip("_") or "player"


# ---------------------------------------------------------------------------- reading


@dataclass
class Recording:
    """One session file as read: its header, steps, episode ends and any warnings."""

    path: Path
    header: SessionHeader
    steps: list[Step] = field(default_factory=list)
    episode_ends: list[EpisodeEnd] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def world(self) -> World:
        return self.header.world

    @property
    def episodes(self) -> list[int]:
        """Episode numbers that have a step or an end, in order of first appearance."""
        seen = dict.fromkeys(s.episode for s in self.steps)
        seen.update(dict.fromkeys(e.episode for e in self.episode_ends))
        return list(seen)


def read_recording(path: str | Path) -> Recording:
    """Read and validate one JSONL session file.

    Raises `RecordingError` naming the file, line and field of the first problem. A last
    line cut off without its newline (a crash mid-write) is skipped with a warning.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise RecordingError(path, None, None, f"cannot read the file ({exc.strerror or exc})") from None
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    lines = raw.split(b"\n")
    ends_cleanly = lines[-1] == b""
    if ends_cleanly:
        lines.pop()
    if not any(line.strip() for line in lines):
        raise RecordingError(path, None, None, "the file is empty: no session header")

    recording: Recording | None = None
    for number, data in enumerate(lines, start=1):
        is_last = number == len(lines)
        text = data.rstrip(b"\r")
        if not text.strip():
            continue
        try:
            obj = json.loads(text.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
            if is_last and not ends_cleanly and recording is not None:
                recording.warnings.append(f"{path}:{number}: the last line is truncated and was skipped")
                break
            raise RecordingError(path, number, None, _json_problem(exc)) from None
        if not isinstance(obj, dict):
            raise RecordingError(path, number, None, "a line must be a JSON object")
        if recording is None:
            recording = Recording(path=path, header=_read_header(obj, path, number))
            checker = _StepChecker(build_mdp(recording.world), path)
            continue
        try:
            line = _BODY.validate_python(obj)
        except ValidationError as exc:
            raise _line_error(path, number, exc, obj) from None
        if isinstance(line, Step):
            checker.check(line, number)
            recording.steps.append(line)
        else:
            recording.episode_ends.append(line)
    assert recording is not None
    return recording


def _json_problem(exc: Exception) -> str:
    if isinstance(exc, UnicodeDecodeError):
        return "not UTF-8 text"
    if isinstance(exc, RecursionError):
        return "not valid JSON (arrays or objects nested too deeply)"
    return f"not valid JSON ({exc.msg})"


def _brief(value: Any) -> str:
    """A value from the file, as JSON, short enough for a one-line message."""
    text = json.dumps(value, default=str)
    return text if len(text) <= 60 else text[:57] + "..."


def _read_header(obj: dict, path: Path, number: int) -> SessionHeader:
    if obj.get("kind") != "session":
        raise RecordingError(
            path, number, "kind", f"the first line must be the session header, not {_brief(obj.get('kind'))}"
        )
    if "schema" not in obj:
        raise RecordingError(path, number, "schema", "missing")
    schema = obj["schema"]
    if schema != SCHEMA_VERSION:
        raise RecordingError(
            path, number, "schema",
            f"schema version {_brief(schema)} is not supported (this careful reads version {SCHEMA_VERSION}); "
            "a newer careful may read it",
        )
    try:
        return SessionHeader.model_validate(obj, strict=False)
    except ValidationError as exc:
        raise _line_error(path, number, exc, obj) from None


def _line_error(path: Path, number: int, exc: ValidationError, obj: dict) -> RecordingError:
    first = exc.errors()[0]
    loc = list(first["loc"])
    # The discriminated union puts the kind first in the location: drop it.
    if loc and loc[0] == obj.get("kind"):
        loc = loc[1:]
    name = field_path(loc) or "kind"
    problem = first["msg"].removeprefix("Value error, ")
    if first["type"] == "missing":
        problem = "missing"
    elif "input" in first and first["type"] != "extra_forbidden":
        problem = f"{problem} (got {_brief(first['input'])})"
    return RecordingError(path, number, name, problem)


class _StepChecker:
    """Checks that a step is a move the header's world can make."""

    def __init__(self, mdp: MDP, path: Path):
        self.mdp, self.path = mdp, path
        self._neighbours = mdp.neighbour.tolist()

    def check(self, step: Step, number: int) -> None:
        world, mdp = self.mdp.world, self.mdp
        if step.carefulness > world.levels:
            raise RecordingError(
                self.path, number, "carefulness", f"{step.carefulness} is above the world's {world.levels} levels"
            )
        for name in ("state", "next_state"):
            cell = getattr(step, name)
            if cell not in mdp.state_of:
                what = "a wall" if 0 <= cell[0] < world.rows and 0 <= cell[1] < world.cols else "outside the grid"
                raise RecordingError(self.path, number, name, f"{list(cell)} is {what} ({world.rows}x{world.cols})")
        s = mdp.state_of[step.state]
        if not mdp.nonterminal[s]:
            raise RecordingError(self.path, number, "state", f"{list(step.state)} is a terminal cell: no move starts there")
        # A halving world may slip in any direction; a world without slip only goes the chosen way.
        reachable = self._neighbours[s]
        if world.slip == "none":
            reachable = [reachable[DIRECTIONS.index(step.direction)]]
        if mdp.state_of[step.next_state] not in reachable:
            raise RecordingError(
                self.path, number, "next_state",
                f"the world cannot move from {list(step.state)} to {list(step.next_state)} "
                f"going {step.direction} in one step",
            )


# ---------------------------------------------------------------------------- using


@dataclass(frozen=True)
class Demonstrations:
    """Every step of one or more recordings of the same world, as counts.

    Attributes:
        mdp: the world's MDP (from the recordings' headers).
        counts: (S, A) N(s, a), how often action a was demonstrated in state s.
        files, episodes, steps: how much was read.
        by_episode: (E, S * A) sparse, row e the counts of the e-th episode with steps (so that
            resampling episodes is a weighted sum of rows); None when only the counts are known.
    """

    mdp: MDP
    counts: np.ndarray
    files: int
    episodes: int
    steps: int
    by_episode: sp.csr_matrix | None = None

    @classmethod
    def from_recordings(cls, recordings: list[Recording]) -> Demonstrations:
        """Pool recordings; raises `RecordingError` if they come from different worlds."""
        if not recordings:
            raise RecordingError("(no files)", None, None, "no recordings were given")
        world = recordings[0].world
        for other in recordings[1:]:
            if other.world != world:
                differ = ", ".join(k for k in World.model_fields if getattr(other.world, k) != getattr(world, k))
                raise RecordingError(
                    other.path, None, "world",
                    f"recorded in world {other.world.name!r}, but {recordings[0].path} is from "
                    f"{world.name!r} (they differ in {differ}): fit recordings of one world at a time",
                )
        mdp = build_mdp(world)
        counts = np.zeros((mdp.n_states, mdp.n_actions))
        states = [mdp.state_of[s.state] for r in recordings for s in r.steps]
        actions = [action_index(s.direction, s.carefulness, world.levels) for r in recordings for s in r.steps]
        if states:
            np.add.at(counts, (states, actions), 1.0)
        episode_keys = [(i, s.episode) for i, r in enumerate(recordings) for s in r.steps]
        return cls(
            mdp=mdp,
            counts=counts,
            files=len(recordings),
            episodes=sum(len(r.episodes) for r in recordings),
            steps=sum(len(r.steps) for r in recordings),
            by_episode=episode_matrix(episode_keys, np.asarray(states, dtype=np.int64) * mdp.n_actions
                                      + np.asarray(actions, dtype=np.int64), mdp.n_states * mdp.n_actions),
        )

    @classmethod
    def read(cls, paths: list[str | Path]) -> Demonstrations:
        return cls.from_recordings([read_recording(p) for p in paths])

    @property
    def demonstrated(self) -> np.ndarray:
        """(S,) True where at least one action was demonstrated."""
        return self.counts.sum(axis=1) > 0

    @property
    def policy(self) -> np.ndarray:
        """(S, A) empirical action frequencies pi(s, a); rows of undemonstrated states are 0."""
        totals = self.counts.sum(axis=1, keepdims=True)
        return np.divide(self.counts, totals, out=np.zeros_like(self.counts), where=totals > 0)

    @property
    def most_frequent(self) -> np.ndarray:
        """(S,) the most frequent demonstrated action (lowest index among ties); -1 if none."""
        return np.where(self.demonstrated, self.counts.argmax(axis=1), -1)


def episode_matrix(episode_of_step: list, pair_of_step: np.ndarray, n_pairs: int) -> sp.csr_matrix:
    """(E, n_pairs) per-episode counts: row e counts the pairs (s * A + a) of the e-th distinct episode key.

    Args:
        episode_of_step: (steps,) a hashable episode key per step (e.g. (file, episode)).
        pair_of_step: (steps,) the state-action index s * A + a of each step.
    """
    rows = list(dict.fromkeys(episode_of_step))
    index = {key: e for e, key in enumerate(rows)}
    row_of_step = np.array([index[key] for key in episode_of_step], dtype=np.int64)
    matrix = sp.csr_matrix((np.ones(row_of_step.size), (row_of_step, np.asarray(pair_of_step, dtype=np.int64))),
                           shape=(len(rows), n_pairs))
    matrix.sum_duplicates()
    return matrix
