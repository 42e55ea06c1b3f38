"""The kinds of line in a recording (recordings/README.md), as pydantic models: the ``session``
header, a ``step``, an ``episode_end`` and a study's ``calibration_trial``. `irl_core.recordings.writer` writes them,
`irl_core.recordings.demonstrations` reads them; `irl_core.recordings.step_table` builds `Step`s from its columns.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from irl_core.worlds.world import Direction, World

SCHEMA_VERSION = 1
# Episode numbers and counts are at most 2^53: every JSON reader holds them exactly, and the
# 64-bit columns they are stored in (`irl_core.recordings.step_table`) hold them and the next number too.
MAX_COUNT = 2**53


class _Line(BaseModel):
    # Every number must be one JSON can hold: NaN and Infinity are refused when read and never written.
    model_config = ConfigDict(extra="forbid", strict=True, populate_by_name=True, allow_inf_nan=False)


class StudyTag(_Line):
    """A study session's place in its study (docs/studies.md): the header's optional ``study`` field.

    `world_index` is the world's index in the study file's ``worlds`` list (not its place in a
    participant's shuffled order), so that a world is the same index for every participant.
    """

    name: str
    participant: str
    phase: Literal["practice", "main"]
    world_index: int = Field(ge=0, le=MAX_COUNT)


class ProlificTag(_Line):
    """Prolific's ids of a browser participant who came from a Prolific link (`careful serve`):
    the header's optional ``prolific`` field (the participant id is ``PROLIFIC_PID``)."""

    study_id: str
    session_id: str


class SessionHeader(_Line):
    kind: Literal["session"] = "session"
    schema_version: int = Field(SCHEMA_VERSION, alias="schema")
    world: World
    player: str
    created: datetime = Field(strict=False)
    seed: int | None = None
    input: dict[str, Any] = Field(default_factory=lambda: {"mode": "hold"})
    app_version: str = ""
    # Only in a study's recordings; a header without it reads (and is written) as before.
    study: StudyTag | None = None
    # Only for a participant who came from a Prolific link to `careful serve`.
    prolific: ProlificTag | None = None


class Step(_Line):
    kind: Literal["step"] = "step"
    episode: int = Field(ge=0, le=MAX_COUNT)
    t: int = Field(ge=0, le=MAX_COUNT)
    # JSON has no tuples: a cell arrives as a 2-element array.
    state: tuple[int, int] = Field(strict=False)
    direction: Direction
    # null on a time world, where the hold is the care and `bin` its duration bin (docs/timing.md).
    carefulness: int | None = Field(ge=1)
    hold_ms: float | None = Field(default=None, ge=0)
    hold_exact: bool = False
    # Only on a time world: the index of the duration bin holding hold_ms.
    bin: int | None = Field(default=None, ge=0)
    next_state: tuple[int, int] = Field(strict=False)
    slipped: bool
    reward: float
    score: float
    # The direction the move really went (differs from `direction` on a slip); optional, newer files have it.
    realised: Direction | None = None

    @property
    def level(self) -> int:
        """The action's level 1..L: the carefulness, or on a time world the duration bin + 1."""
        if self.carefulness is not None:
            return self.carefulness
        return 1 if self.bin is None else self.bin + 1


class EpisodeEnd(_Line):
    kind: Literal["episode_end"] = "episode_end"
    episode: int = Field(ge=0, le=MAX_COUNT)
    outcome: Literal["terminal", "quit", "step_limit"]
    terminal_symbol: str | None = None
    steps: int = Field(ge=0, le=MAX_COUNT)
    return_: float = Field(alias="return")
    score: float


class CalibrationTrial(_Line):
    """One target of a study's motor calibration block ("hold until the gauge shows 8, then let go"):
    the level asked for and the level the hold produced, with the hold's length (exact when the
    front end timed the release). Written before practice, in the participant's first file of the study."""

    kind: Literal["calibration_trial"] = "calibration_trial"
    target: int = Field(ge=1)
    produced: int = Field(ge=1)
    hold_ms: float | None = Field(default=None, ge=0)
    hold_exact: bool = False
