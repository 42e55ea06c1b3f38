"""Reading another lab's trial table (docs/import.md): its rows, each with the line it starts on.

A table is CSV (``.csv``), TSV (``.tsv``, ``.tab``), JSON lines (``.jsonl``, ``.ndjson``) or a JSON array of
objects (``.json``), chosen by the file's suffix. `read_table` gives its column names and then its rows as
`TableRow`s (the cells by column name: text from CSV and TSV, JSON's own values from JSON); what the cells
mean is `irl_core.recordings.importing`'s business. A table over `MAX_TABLE_BYTES` is refused before a
byte is read, as is anything that is not a regular file; a problem of the file as a whole (not UTF-8,
not JSON, a row that is not an object) is a `TableError` naming the file and line.
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from irl_core.errors import TableError
from irl_core.support.safe_files import open_regular, read_problem
from irl_core.support.safe_text import VALUE_LIMIT, printable

# The largest table careful imports: each row is kept (about 200 bytes) until every row is checked, so that
# nothing is written from a table with a bad row; 256 MB is some five million rows of a typical trial table.
MAX_TABLE_BYTES = 256 << 20

FORMATS = {".csv": "csv", ".tsv": "tsv", ".tab": "tsv", ".jsonl": "jsonl", ".ndjson": "jsonl", ".json": "json"}


@dataclass(frozen=True)
class TableRow:
    """One row: the line it starts on (1 is the file's first) and its cells by column name."""

    line: int
    cells: dict[str, Any]


@dataclass
class Table:
    """A table being read: its path, its format, its columns (the header's, or the first object's keys)
    and its rows, read as they are iterated (`rows`)."""

    path: Path
    format: str
    columns: tuple[str, ...]
    header_line: int
    rows: Iterator[TableRow]


def table_format(path: Path) -> str:
    """The format of `path` by its suffix; `TableError` for a suffix careful does not read."""
    kind = FORMATS.get(path.suffix.lower())
    if kind is None:
        known = ", ".join(FORMATS)
        raise TableError([f"{_shown(path)}: a table's name ends in one of {known} (it says the format); "
                          f"{printable(path.suffix or 'no suffix', limit=VALUE_LIMIT)!r} is none of them"])
    return kind


def read_table(path: str | Path) -> Table:
    """Open `path` and read its header (or first object); the rows follow as `Table.rows` is iterated.

    Raises:
        TableError: the file cannot be read, is not a regular file, is over `MAX_TABLE_BYTES`, is not
            UTF-8, has no header or rows, or (JSON) is not JSON objects; the message names file and line.
    """
    path = Path(path)
    kind = table_format(path)
    try:
        file = open_regular(path)
    except OSError as exc:
        raise TableError([f"{_shown(path)}: cannot read the table ({exc.strerror or exc})"]) from None
    except ValueError as exc:
        raise TableError([f"{_shown(path)}: is {exc}; a table is a file"]) from None
    with file:
        size = _size(file)
        if size > MAX_TABLE_BYTES:
            raise TableError([f"{_shown(path)}: the table is {size / (1 << 20):,.0f} MB; careful imports tables of "
                              f"at most {MAX_TABLE_BYTES >> 20} MB (split it by participant and import each part)"])
        try:
            raw = file.read(MAX_TABLE_BYTES + 1)
        except OSError as exc:
            raise TableError([f"{_shown(path)}: cannot read the table ({read_problem(exc)})"]) from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise TableError([f"{_shown(path)}:{line}: not UTF-8 text"]) from None
    del raw
    if kind in ("csv", "tsv"):
        return _delimited(path, kind, text)
    objects = _json_lines(path, text) if kind == "jsonl" else _json_array(path, text)
    first = next(objects, None)
    if first is None:
        raise TableError([f"{_shown(path)}: the table has no rows"])

    def rows() -> Iterator[TableRow]:
        yield first
        yield from objects

    return Table(path, kind, tuple(first.cells), first.line, rows())


def _size(file: Any) -> int:
    return os.fstat(file.fileno()).st_size


def _shown(path: Path) -> str:
    return printable(str(path), limit=200)


# ---------------------------------------------------------------------------- CSV and TSV


def _delimited(path: Path, kind: str, text: str) -> Table:
    reader = csv.reader(io.StringIO(text, newline=""), delimiter="\t" if kind == "tsv" else ",", strict=True)
    header: list[str] | None = None
    header_line = 0
    try:
        while header is None:
            before = reader.line_num
            row = next(reader, None)
            if row is None:
                raise TableError([f"{_shown(path)}: the table is empty: no header line"])
            if any(cell.strip() for cell in row):
                header, header_line = [cell.strip() for cell in row], before + 1
    except csv.Error as exc:
        raise TableError([f"{_shown(path)}:{reader.line_num}: not a {kind.upper()} table ({exc})"]) from None
    repeated = sorted({name for name in header if header.count(name) > 1 and name})
    if repeated:
        raise TableError([f"{_shown(path)}:{header_line}: {printable(repeated[0], limit=VALUE_LIMIT)}: the header "
                          "names this column twice"])

    def rows() -> Iterator[TableRow]:
        while True:
            start = reader.line_num + 1
            try:
                row = next(reader, None)
            except csv.Error as exc:
                raise TableError([f"{_shown(path)}:{start}: not a {kind.upper()} row ({exc})"]) from None
            if row is None:
                return
            if not "".join(row).strip():
                continue
            if len(row) != len(header):
                raise TableError([f"{_shown(path)}:{start}: the row has {len(row)} cells, but the header "
                                  f"(line {header_line}) names {len(header)} columns"])
            yield TableRow(start, dict(zip(header, row)))

    return Table(path, kind, tuple(header), header_line, rows())


# ---------------------------------------------------------------------------- JSON


def _json_lines(path: Path, text: str) -> Iterator[TableRow]:
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            value = json.loads(line)
        except (ValueError, RecursionError) as exc:
            raise TableError([f"{_shown(path)}:{number}: not valid JSON ({_json_problem(exc)})"]) from None
        yield TableRow(number, _object(path, number, value))


def _json_array(path: Path, text: str) -> Iterator[TableRow]:
    """The objects of a JSON array, each with the line it starts on (read one by one, so each has its line)."""
    decoder = json.JSONDecoder()
    position, line = _skip_space(text, 0), 1
    if not text.startswith("[", position):
        where = text.count("\n", 0, position) + 1
        raise TableError([f"{_shown(path)}:{where}: a .json table is an array of objects, [{{...}}, {{...}}]"])
    position += 1
    counted = 0
    expect_value = True
    while True:
        position = _skip_space(text, position)
        line += text.count("\n", counted, position)
        counted = position
        if text.startswith("]", position):
            if _skip_space(text, position + 1) != len(text):
                raise TableError([f"{_shown(path)}:{line}: text after the array's closing ]"])
            return
        if not expect_value:
            if not text.startswith(",", position):
                raise TableError([f"{_shown(path)}:{line}: not valid JSON (a ',' or ']' was expected)"])
            position += 1
            expect_value = True
            continue
        try:
            value, end = decoder.raw_decode(text, position)
        except (ValueError, RecursionError) as exc:
            raise TableError([f"{_shown(path)}:{line}: not valid JSON ({_json_problem(exc)})"]) from None
        yield TableRow(line, _object(path, line, value))
        position, expect_value = end, False


def _skip_space(text: str, position: int) -> int:
    while position < len(text) and text[position] in " \t\r\n":
        position += 1
    return position


def _object(path: Path, line: int, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise TableError([f"{_shown(path)}:{line}: a row is a JSON object of column: value, not {type(value).__name__}"])
    return value


def _json_problem(exc: Exception) -> str:
    if isinstance(exc, json.JSONDecodeError):
        return exc.msg
    if isinstance(exc, RecursionError):
        return "arrays or objects nested too deeply"
    return "a number is over 4,300 digits long"
