"""The column map of `careful import` (docs/import.md): which column of a trial table holds what.

==============  ===========================================================================
key             meaning
==============  ===========================================================================
``participant`` the column naming the participant (one recording each)
``episode``     the column numbering (or naming) the participant's episodes
``t``           optional: the column ordering an episode's moves (else the rows' order)
``state``       one column holding ``row,col``, ``[row, col]`` or a cell index, or two
                columns, ``["x", "y"]`` (in the order ``axes`` says)
``axes``        ``rowcol`` (default: the row first) or ``xy`` (x the column, y the row)
``origin``      ``top-left`` (default: row 0 at the top) or ``bottom-left``
``next_state``  optional, as ``state``: where the move went (else the next row's state)
``action``      the column of action codes, read through ``[actions]``
``[actions]``   a code per direction: ``up = "^"``, ``right = ">"``, ``down = "v"``, ...
``rt_ms``       optional: response times in milliseconds (into ``hold_ms``), or
``rt_s``        ... in seconds
``level``       optional: the carefulness level 1..L of each move (else 1)
==============  ===========================================================================
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from irl_core.errors import TableError
from irl_core.support.safe_files import read_toml
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.world import Direction
from irl_core.worlds.world_text import field_path

_MAX_MAP_FILE_BYTES = 1 << 20
Column = str
Cell = Column | tuple[Column, Column]


def code_text(value: object) -> str:
    """An action code as text, whatever the file held: `"^"`, `" ^ "` and JSON's `0` or `0.0` read as `^`, `0`."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    return str(value).strip()


class ColumnMap(BaseModel):
    """A trial table's columns, as `MAP.toml` names them (the module's table says what each key means)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    participant: Column = Field(min_length=1)
    episode: Column = Field(min_length=1)
    t: Column | None = Field(None, min_length=1)
    state: Cell
    next_state: Cell | None = None
    axes: Literal["rowcol", "xy"] = "rowcol"
    origin: Literal["top-left", "bottom-left"] = "top-left"
    action: Column = Field(min_length=1)
    actions: dict[Direction, str | int]
    rt_ms: Column | None = Field(None, min_length=1)
    rt_s: Column | None = Field(None, min_length=1)
    level: Column | None = Field(None, min_length=1)

    @field_validator("state", "next_state", mode="before")
    @classmethod
    def _cell_is_one_or_two_columns(cls, value: object) -> object:
        if isinstance(value, list):
            if len(value) != 2 or not all(isinstance(name, str) and name for name in value):
                raise ValueError('two columns are a list of two names, ["x", "y"]')
            return tuple(value)
        return value

    @field_validator("actions")
    @classmethod
    def _each_code_is_its_own(cls, actions: dict[str, str | int]) -> dict[str, str | int]:
        if not actions:
            raise ValueError('give a code per direction the table uses, as up = "^"')
        texts = [code_text(code) for code in actions.values()]
        if "" in texts:
            raise ValueError("an action code is empty")
        for text in texts:
            if texts.count(text) > 1:
                raise ValueError(f"the code {printable(text, limit=VALUE_LIMIT)!r} is given to two directions")
        return actions

    @model_validator(mode="after")
    def _time_column_is_named_once(self) -> ColumnMap:
        if self.rt_ms is not None and self.rt_s is not None:
            raise ValueError("rt_ms and rt_s: give the response time's column once, in ms or in seconds")
        return self

    @property
    def rt(self) -> Column | None:
        """The response time's column, whichever unit."""
        return self.rt_ms or self.rt_s

    @property
    def rt_scale(self) -> float:
        """Milliseconds per unit of the response time's column."""
        return 1.0 if self.rt_ms is not None else 1000.0

    @property
    def direction_of(self) -> dict[str, Direction]:
        """Each action code (as `code_text`) to its direction."""
        return {code_text(code): direction for direction, code in self.actions.items()}

    def columns(self) -> list[tuple[str, Column]]:
        """Every (key, column) the map names, in the order of its keys."""
        named: list[tuple[str, Column]] = []
        for key in ("participant", "episode", "t", "state", "next_state", "action", "rt_ms", "rt_s", "level"):
            value = getattr(self, key)
            if isinstance(value, tuple):
                named.extend((key, name) for name in value)
            elif value is not None:
                named.append((key, value))
        return named


def load_map(path: str | Path) -> ColumnMap:
    """The column map in the TOML file at `path`.

    Raises:
        TableError: one line naming the file and the key: unreadable, not TOML, an unknown or missing key,
            a bad value.
    """
    path = Path(path)
    try:
        data = read_toml(path, what="column map", limit=_MAX_MAP_FILE_BYTES, too_big="")
    except ValueError as exc:
        raise TableError([str(exc)]) from None
    try:
        return ColumnMap.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = field_path(first["loc"][:2] if first["loc"][:1] == ("actions",) else first["loc"][:1])
        problem = "missing" if first["type"] == "missing" else first["msg"].removeprefix("Value error, ")
        if first["type"] == "extra_forbidden":
            problem = "not a key of a column map (docs/import.md lists them)"
        shown = printable(str(path), limit=200)
        raise TableError([f"{shown}: {where}: {problem}" if where else f"{shown}: {problem}"]) from None
