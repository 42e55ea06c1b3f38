"""A recording's episode ends as columns: a sequence of `EpisodeEnd` that costs about 40 bytes an end.

A recording of a million one-step episodes holds a million ends; as pydantic objects they took
about 600 bytes each, so reading such a file peaked at 3.7 times its size. `EndTable` is an
`irl_core.recordings.column_table.ColumnTable`, like `irl_core.recordings.step_table.StepTable` for steps: the
terminal symbol is kept as an index into the few symbols seen.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, get_args

import numpy as np

from irl_core.recordings.column_table import ColumnTable
from irl_core.recordings.lines import EpisodeEnd

_OUTCOMES = get_args(EpisodeEnd.model_fields["outcome"].annotation)


class EndTable(ColumnTable):
    """Episode ends in file order, stored column by column (`symbol` -1 means no terminal symbol;
    `outcome` is an index into the outcomes)."""

    COLUMNS = {"episode": np.int64, "outcome": np.int8, "symbol": np.int32, "steps": np.int64,
               "return_": np.float64, "score": np.float64}

    def __init__(self, ends: Iterable[EpisodeEnd] = ()) -> None:
        super().__init__()
        self._symbols: list[str] = []
        for end in ends:
            self.append(end)

    def append(self, end: EpisodeEnd) -> None:
        symbol = -1
        if end.terminal_symbol is not None:
            if end.terminal_symbol not in self._symbols:
                self._symbols.append(end.terminal_symbol)
            symbol = self._symbols.index(end.terminal_symbol)
        self._append_row((end.episode, _OUTCOMES.index(end.outcome), symbol, end.steps, end.return_, end.score))

    def _record(self, c: dict[str, Any]) -> EpisodeEnd:
        return EpisodeEnd.model_construct(
            episode=c["episode"], outcome=_OUTCOMES[c["outcome"]],
            terminal_symbol=None if c["symbol"] < 0 else self._symbols[c["symbol"]], steps=c["steps"],
            return_=c["return_"], score=c["score"])
