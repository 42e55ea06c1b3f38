"""World files as text, for every kind of world (`world`'s grids and `reach`'s fields): pydantic's first
problem said as one line naming the field, and strings escaped for a TOML file a world is written back to."""

from __future__ import annotations

from pydantic import ValidationError

from irl_core.support.safe_text import VALUE_LIMIT, cut, is_unsafe


def toml_str(value: str) -> str:
    """`value` as a TOML basic string, quoted."""
    return '"' + toml_escape(value) + '"'


def toml_escape(value: str, *, keep_newlines: bool = False) -> str:
    """`value` for a TOML basic string: backslash, quote and control characters escaped."""
    out = []
    for ch in value:
        if ch in '\\"':
            out.append("\\" + ch)
        elif ch == "\n" and keep_newlines:
            out.append(ch)
        elif is_unsafe(ch):  # controls (C0, DEL, C1) and bidi or invisible marks: never raw in a file shown
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return "".join(out)


def describe_validation_error(exc: ValidationError) -> str:
    """The first problem in a pydantic error as `field: problem` (or `problem` for the whole), readable by a user."""
    first = exc.errors()[0]
    where = field_path(first["loc"])
    message = first["msg"].removeprefix("Value error, ")
    # A check of the whole world (a start in a wall, say) has no field: its message names one.
    return f"{where}: {message}" if where else message


def field_path(loc: tuple[str | int, ...] | list[str | int]) -> str:
    """A pydantic error location as `world.rewards.C`; a key that would break the line is quoted."""
    return ".".join(cut(str(part), VALUE_LIMIT) if str(part).isprintable() else cut(repr(part), VALUE_LIMIT)
                    for part in loc)
