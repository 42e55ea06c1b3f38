"""A recording's episode ends as columns: a sequence of `EpisodeEnd` that costs about 40 bytes an end.

A recording of a million one-step episodes holds a million ends; as pydantic objects they took
about 600 bytes each, so reading such a file peaked at 3.7 times its size. `EndTable` keeps each
field in a numpy column (the terminal symbol as an index into the few symbols seen) and builds an
`EpisodeEnd` only when one is asked for, like `irl_core.step_table.StepTable` does for steps.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from typing import Any, get_args

import numpy as np

from irl_core.recording_lines import EpisodeEnd

_OUTCOMES = get_args(EpisodeEnd.model_fields["outcome"].annotation)
_BLOCK = 4096
_DTYPES = {"episode": np.int64, "outcome": np.int8, "symbol": np.int32, "steps": np.int64,
           "return_": np.float64, "score": np.float64}


class EndTable(Sequence):
    """Episode ends in file order, stored column by column (`symbol` -1 means no terminal symbol)."""

    def __init__(self, ends: Iterable[EpisodeEnd] = ()) -> None:
        self._columns = {name: np.empty(0, dtype) for name, dtype in _DTYPES.items()}
        self._blocks: list[list[np.ndarray]] = []
        self._pending: list[tuple] = []
        self._symbols: list[str] = []
        self._size = 0
        for end in ends:
            self.append(end)

    def append(self, end: EpisodeEnd) -> None:
        symbol = -1
        if end.terminal_symbol is not None:
            if end.terminal_symbol not in self._symbols:
                self._symbols.append(end.terminal_symbol)
            symbol = self._symbols.index(end.terminal_symbol)
        self._pending.append((end.episode, _OUTCOMES.index(end.outcome), symbol, end.steps, end.return_, end.score))
        self._size += 1
        if len(self._pending) == _BLOCK:
            self._close_block()

    def _close_block(self) -> None:
        if self._pending:
            rows = list(zip(*self._pending))
            self._blocks.append([np.array(rows[i], dtype) for i, dtype in enumerate(_DTYPES.values())])
            self._pending = []

    def _consolidated(self) -> dict[str, np.ndarray]:
        self._close_block()
        if self._blocks:
            self._columns = {name: np.concatenate([self._columns[name], *(block[i] for block in self._blocks)])
                             for i, name in enumerate(_DTYPES)}
            self._blocks = []
        return self._columns

    def column(self, name: str) -> np.ndarray:
        """(n,) one field for every end: episode, outcome (an index into the outcomes), steps, return_, score."""
        return self._consolidated()[name]

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, index: int | slice) -> Any:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(self._size))]
        if index < 0:
            index += self._size
        if not 0 <= index < self._size:
            raise IndexError("episode end index out of range")
        c = {name: column[index].item() for name, column in self._consolidated().items()}
        return EpisodeEnd.model_construct(
            episode=c["episode"], outcome=_OUTCOMES[c["outcome"]],
            terminal_symbol=None if c["symbol"] < 0 else self._symbols[c["symbol"]], steps=c["steps"],
            return_=c["return_"], score=c["score"])

    def __iter__(self) -> Iterator[Any]:
        self._consolidated()
        for i in range(self._size):
            yield self[i]

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and len(self) == len(other) and list(self) == list(other)

    __hash__ = None  # type: ignore[assignment]
