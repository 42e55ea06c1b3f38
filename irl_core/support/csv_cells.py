"""CSV files that a spreadsheet opens as data, never as formulas (docs/formats.md "CSV cells").

A text cell that starts with `=`, `+`, `-`, `@`, a tab or a carriage return runs as a formula
where a researcher opens the file (a player called `=HYPERLINK(...)`). `text_cell` puts a `'`
before such a value, which spreadsheets show as text and other readers can strip; numbers are
written as numbers and left alone. `csv_text` is the one writer of careful's CSV tables.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable
from typing import Any, TextIO

FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def text_cell(value: str) -> str:
    """`value` as a CSV text cell: with a leading `'` when it would start a formula."""
    return "'" + value if value.startswith(FORMULA_STARTS) else value


def csv_writer(handle: TextIO, *, lineterminator: str = "\n") -> Any:
    """A `csv.writer` for careful's tables; the caller makes each text cell a `text_cell`."""
    return csv.writer(handle, lineterminator=lineterminator)


def header(columns: Iterable[str]) -> list[str]:
    """Column names as cells (a name built from a world's symbol, `reward_=`, is text too)."""
    return [text_cell(column) for column in columns]


def csv_text(columns: Iterable[str], rows: Iterable[list[str]]) -> str:
    """A whole CSV table as a string, `\n`-terminated."""
    buffer = io.StringIO()
    writer = csv_writer(buffer)
    writer.writerow(header(columns))
    writer.writerows(rows)
    return buffer.getvalue()
