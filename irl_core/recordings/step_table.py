"""A recording's steps as columns: a sequence of `Step` that costs about 60 bytes a step.

A recording of a billion bytes holds millions of steps; as pydantic objects they would take
several times the file's size. `StepTable` keeps each field in a numpy column that grows in
blocks, and builds a `Step` only when one is asked for (replay, summaries): an
`irl_core.recordings.column_table.ColumnTable`. Counting code reads the columns directly (`cells`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from irl_core.recordings.column_table import ColumnTable
from irl_core.recordings.lines import Step
from irl_core.worlds.mdp import DIRECTIONS

_COLUMNS = {
    "episode": np.int64, "t": np.int64, "row": np.int32, "col": np.int32, "direction": np.int8,
    "level": np.int16, "timed": np.bool_, "hold_ms": np.float64, "hold_exact": np.bool_, "next_row": np.int32,
    "next_col": np.int32, "slipped": np.bool_, "reward": np.float64, "score": np.float64, "realised": np.int8,
}
_DIRECTION = {name: i for i, name in enumerate(DIRECTIONS)}


class StepTable(ColumnTable):
    """Steps in file order, stored column by column (`hold_ms` NaN and `realised` -1 mean absent).

    `level` is the action's level 1..L (`Step.level`): the carefulness, or on a time world (`timed`)
    the duration bin + 1.
    """

    COLUMNS = _COLUMNS

    def append(self, step: Any) -> None:
        self._append_row((
            step.episode, step.t, *step.state, _DIRECTION[step.direction], step.level, step.carefulness is None,
            np.nan if step.hold_ms is None else step.hold_ms, step.hold_exact, *step.next_state, step.slipped,
            step.reward, step.score, -1 if step.realised is None else _DIRECTION[step.realised],
        ))

    def _record(self, c: dict[str, Any]) -> Step:
        return Step.model_construct(
            episode=c["episode"], t=c["t"], state=(c["row"], c["col"]), direction=DIRECTIONS[c["direction"]],
            carefulness=None if c["timed"] else c["level"], bin=c["level"] - 1 if c["timed"] else None,
            hold_ms=None if np.isnan(c["hold_ms"]) else c["hold_ms"],
            hold_exact=c["hold_exact"], next_state=(c["next_row"], c["next_col"]), slipped=c["slipped"],
            reward=c["reward"], score=c["score"], realised=None if c["realised"] < 0 else DIRECTIONS[c["realised"]],
        )

    def window(self, start: int, stop: int) -> StepWindow:
        """Steps `start` to `stop` (not included) as a sequence that builds each `Step` when asked."""
        return StepWindow(self, start, stop)


class StepWindow(Sequence):
    """A run of a `StepTable`'s steps (one episode's), without copying them."""

    def __init__(self, table: StepTable, start: int, stop: int) -> None:
        self._table, self._start, self._stop = table, start, stop

    def __len__(self) -> int:
        return self._stop - self._start

    def __getitem__(self, index: int | slice) -> Any:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        if index < 0:
            index += len(self)
        if not 0 <= index < len(self):
            raise IndexError("step index out of range")
        return self._table[self._start + index]

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and len(self) == len(other) and list(self) == list(other)

    __hash__ = None  # type: ignore[assignment]
