"""A recording's steps as columns: a sequence of `Step` that costs about 60 bytes a step.

A recording of a billion bytes holds millions of steps; as pydantic objects they would take
several times the file's size. `StepTable` keeps each field in a numpy column that grows in
blocks, and builds a `Step` only when one is asked for (replay, summaries). Counting code reads
the columns directly (`cells`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any, overload

import numpy as np

from irl_core.mdp import DIRECTIONS
from irl_core.recording_lines import Step

_BLOCK = 4096
_COLUMNS = {
    "episode": np.int64, "t": np.int64, "row": np.int32, "col": np.int32, "direction": np.int8,
    "carefulness": np.int16, "hold_ms": np.float64, "hold_exact": np.bool_, "next_row": np.int32,
    "next_col": np.int32, "slipped": np.bool_, "reward": np.float64, "score": np.float64, "realised": np.int8,
}
_DIRECTION = {name: i for i, name in enumerate(DIRECTIONS)}


class StepTable(Sequence):
    """Steps in file order, stored column by column (`hold_ms` NaN and `realised` -1 mean absent).

    Appended steps wait as tuples until a block is full, then join the columns in one go.
    """

    def __init__(self) -> None:
        self._size = 0
        self._columns: dict[str, np.ndarray] = {name: np.empty(0, dtype) for name, dtype in _COLUMNS.items()}
        self._blocks: list[dict[str, np.ndarray]] = []
        self._pending: list[tuple] = []

    def append(self, step: Any) -> None:
        self._pending.append((
            step.episode, step.t, *step.state, _DIRECTION[step.direction], step.carefulness,
            np.nan if step.hold_ms is None else step.hold_ms, step.hold_exact, *step.next_state, step.slipped,
            step.reward, step.score, -1 if step.realised is None else _DIRECTION[step.realised],
        ))
        self._size += 1
        if len(self._pending) == _BLOCK:
            self._close_block()

    def _close_block(self) -> None:
        if self._pending:
            rows = list(zip(*self._pending))
            self._blocks.append({name: np.array(rows[i], dtype) for i, (name, dtype) in enumerate(_COLUMNS.items())})
            self._pending = []

    def _consolidated(self) -> dict[str, np.ndarray]:
        self._close_block()
        if self._blocks:
            self._columns = {name: np.concatenate([self._columns[name], *(b[name] for b in self._blocks)])
                             for name in _COLUMNS}
            self._blocks = []
        return self._columns

    def column(self, name: str) -> np.ndarray:
        """(n,) one field for every step (do not write to it)."""
        return self._consolidated()[name]

    def __len__(self) -> int:
        return self._size

    @overload
    def __getitem__(self, index: int) -> Any: ...
    @overload
    def __getitem__(self, index: slice) -> list[Any]: ...

    def __getitem__(self, index: int | slice) -> Any:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(self._size))]
        if index < 0:
            index += self._size
        if not 0 <= index < self._size:
            raise IndexError("step index out of range")
        c = {name: column[index].item() for name, column in self._consolidated().items()}
        return Step.model_construct(
            episode=c["episode"], t=c["t"], state=(c["row"], c["col"]), direction=DIRECTIONS[c["direction"]],
            carefulness=c["carefulness"], hold_ms=None if np.isnan(c["hold_ms"]) else c["hold_ms"],
            hold_exact=c["hold_exact"], next_state=(c["next_row"], c["next_col"]), slipped=c["slipped"],
            reward=c["reward"], score=c["score"], realised=None if c["realised"] < 0 else DIRECTIONS[c["realised"]],
        )

    def __iter__(self) -> Iterator[Any]:
        self._consolidated()
        for i in range(self._size):
            yield self[i]

    def window(self, start: int, stop: int) -> StepWindow:
        """Steps `start` to `stop` (not included) as a sequence that builds each `Step` when asked."""
        return StepWindow(self, start, stop)

    def __bool__(self) -> bool:
        return self._size > 0

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and len(self) == len(other) and list(self) == list(other)

    __hash__ = None  # type: ignore[assignment]


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
