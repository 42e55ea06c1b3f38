"""A sequence of records stored as numpy columns that grow in blocks: the base of
`irl_core.recordings.step_table.StepTable` and `irl_core.recordings.end_table.EndTable`.

A recording can hold millions of steps and episode ends; as pydantic objects they would take
several times the file's size. A `ColumnTable` keeps each field in a column, gathers appended
rows as tuples until a block is full, joins the blocks into the columns only when a column is
asked for, and builds a record only when one is asked for (`_record`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any, ClassVar

import numpy as np

_BLOCK = 4096


class ColumnTable(Sequence):
    """Records in the order appended; a subclass names its columns (`COLUMNS`, name -> dtype),
    turns a record into a row (`append`) and a row back into a record (`_record`)."""

    COLUMNS: ClassVar[dict[str, Any]]

    def __init__(self) -> None:
        self._size = 0
        self._columns = {name: np.empty(0, dtype) for name, dtype in self.COLUMNS.items()}
        self._blocks: list[dict[str, np.ndarray]] = []
        self._pending: list[tuple] = []

    def _append_row(self, row: tuple) -> None:
        """One record's values, in `COLUMNS` order."""
        self._pending.append(row)
        self._size += 1
        if len(self._pending) == _BLOCK:
            self._close_block()

    def _close_block(self) -> None:
        if self._pending:
            rows = list(zip(*self._pending))
            self._blocks.append({name: np.array(rows[i], dtype) for i, (name, dtype) in enumerate(self.COLUMNS.items())})
            self._pending = []

    def _consolidated(self) -> dict[str, np.ndarray]:
        self._close_block()
        if self._blocks:
            self._columns = {name: np.concatenate([self._columns[name], *(b[name] for b in self._blocks)])
                             for name in self.COLUMNS}
            self._blocks = []
        return self._columns

    def column(self, name: str) -> np.ndarray:
        """(n,) one field for every record (do not write to it)."""
        return self._consolidated()[name]

    def _record(self, values: dict[str, Any]) -> Any:
        """The record of one row (`values`: column name -> Python value)."""
        raise NotImplementedError

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, index: int | slice) -> Any:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(self._size))]
        if index < 0:
            index += self._size
        if not 0 <= index < self._size:
            raise IndexError(f"{type(self).__name__} index out of range")
        return self._record({name: column[index].item() for name, column in self._consolidated().items()})

    def __iter__(self) -> Iterator[Any]:
        self._consolidated()
        for i in range(self._size):
            yield self[i]

    def __bool__(self) -> bool:
        return self._size > 0

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and len(self) == len(other) and list(self) == list(other)

    __hash__ = None  # type: ignore[assignment]
