"""The lines of a reach recording (docs/reach.md): its ``session`` header, whose world is a reach world,
and one ``step`` line a trial (a trial is an episode; no ``episode_end`` line follows it).
`irl_core.recordings.writer` writes them, `irl_core.recordings.reach_reader` reads them.
"""

from __future__ import annotations

import math
from datetime import datetime
from typing import Any, Literal

from pydantic import Field, field_validator

from irl_core.recordings.lines import MAX_COUNT, SCHEMA_VERSION, ProlificTag, StudyTag, _Line
from irl_core.worlds.reach import ReachWorld


class ReachHeader(_Line):
    """A reach recording's first line: the world, who played (``expert:optimal``, a participant) and when; in a
    study, its place (``study``), how it was played (``input``: the browser's) and Prolific's ids, as a grid
    recording's header holds them."""

    kind: Literal["session"] = "session"
    schema_version: int = Field(SCHEMA_VERSION, alias="schema")
    world: ReachWorld
    player: str
    created: datetime = Field(strict=False)
    seed: int | None = None
    app_version: str = ""
    input: dict[str, Any] | None = None
    study: StudyTag | None = None
    prolific: ProlificTag | None = None


class ReachStep(_Line):
    """One reach: where it was aimed, how long it took, where it ended, the circles holding the endpoint
    (by symbol, each once), its reward and the session's score after it. `hold_exact` says the duration was
    timed exactly (a simulated reach, or a front end that timed the release)."""

    kind: Literal["step"] = "step"
    episode: int = Field(ge=0, le=MAX_COUNT)
    t: int = Field(ge=0, le=MAX_COUNT)
    aim: tuple[float, float] = Field(strict=False)
    duration_ms: float = Field(ge=0)
    endpoint: tuple[float, float] = Field(strict=False)
    regions: tuple[str, ...] = Field(strict=False)
    reward: float
    score: float
    hold_exact: bool = False

    @field_validator("aim", "endpoint", mode="before")
    @classmethod
    def _point_is_a_pair(cls, value: Any) -> Any:
        if not (isinstance(value, list | tuple) and len(value) == 2
                and all(isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) for x in value)):
            raise ValueError("must be a pair of finite numbers [x, y]")
        return value
