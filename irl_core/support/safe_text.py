"""Text from a file or a flag, made safe to show in a terminal (docs/safety.md).

A player name, a world name or a path can hold anything: `ESC ] 2 ; ... BEL` retitles a
terminal, `ESC [ 2 J` clears it, a right-to-left override turns the rest of a line around.
`printable` shows every such character as an escape (`\\x1b`, `\\u202e`) instead, and cuts a
long value so that a message stays one readable line. It returns a plain string; the terminal
code shows it as `rich.text.Text` (never as Rich markup), so `[bold]` in a name is just text.
Where a string must go into markup (a Rich table's title, a Textual label), `for_markup`
escapes it too, so `[/]` in a world's symbols or an output folder stays text. Files that
are read back (a world's TOML, a CSV) escape their cells with `is_unsafe` and
`irl_core.support.csv_cells`.
"""

from __future__ import annotations

import re

# C0 and C1 controls, DEL, and the invisible format characters that move or hide text
# (zero-width, bidirectional marks, overrides and isolates, line and paragraph separators, BOM).
_UNSAFE = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200b-\u200f\u2028-\u202e\u2060-\u206f\ufeff\ufff9-\ufffb]")
_UNSAFE_KEEPING_NEWLINES = re.compile(
    "[\x00-\x09\x0b-\x1f\x7f-\x9f\u061c\u200b-\u200f\u2028-\u202e\u2060-\u206f\ufeff\ufff9-\ufffb]")

# A value longer than this is cut in messages: a 5,000-character name must not make a 5,000-character line.
VALUE_LIMIT = 80
# A whole one-line message (which may name a path, a field and a value) is cut at this length.
MESSAGE_LIMIT = 400


# Rich's and Textual's markup tag: `[` then a tag name (or `/`, `#`, `@`) up to `]`.
_MARKUP_TAG = re.compile(r"(\\*)(\[[a-zA-Z#/@][^[]*?])")


def is_unsafe(character: str) -> bool:
    """Whether `character` is a control or invisible format character (`printable` escapes it)."""
    return _UNSAFE.fullmatch(character) is not None or "\ud800" <= character <= "\udfff"


def for_markup(text: str, *, limit: int | None = None) -> str:
    """`printable(text)` made literal in Rich or Textual markup: every tag-like `[...]` escaped."""
    safe = printable(text, limit=limit)
    return _MARKUP_TAG.sub(lambda m: f"{m.group(1)}{m.group(1)}\\{m.group(2)}", safe)


def _escape(match: re.Match[str]) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def printable(text: str, *, limit: int | None = None, keep_newlines: bool = False) -> str:
    """`text` with every control and invisible format character shown as an escape, cut to `limit`.

    Lone surrogates (undecodable bytes in a command-line argument) are shown as `\\udcxx` too.
    `keep_newlines` keeps line breaks (for a layout or a TOML file shown whole).
    """
    pattern = _UNSAFE_KEEPING_NEWLINES if keep_newlines else _UNSAFE
    safe = pattern.sub(_escape, text)
    if any("\ud800" <= ch <= "\udfff" for ch in safe):
        safe = "".join(f"\\u{ord(ch):04x}" if "\ud800" <= ch <= "\udfff" else ch for ch in safe)
    return safe if limit is None else cut(safe, limit)


def cut(text: str, limit: int, *, say_length: bool = True) -> str:
    """`text` cut to about `limit` characters, saying how long it was: "abc… (5,000 characters)".

    Without `say_length` it is cut to exactly `limit` characters, the last an ellipsis ("abcdefgh…"),
    for a title where a count would take the room the name needs.
    """
    if len(text) <= limit:
        return text
    if not say_length:
        return f"{text[: max(0, limit - 1)]}…"
    return f"{text[: max(1, limit - 24)]}… ({len(text):,} characters)"


def one_line(message: str) -> str:
    """A message for stderr: printable, on one line, at most about `MESSAGE_LIMIT` characters.

    A long message loses its middle, not its end: the end says what went wrong.
    """
    safe = printable(message)
    if len(safe) <= MESSAGE_LIMIT:
        return safe
    tail = MESSAGE_LIMIT // 3
    return f"{safe[: MESSAGE_LIMIT - tail - 30]} …({len(safe) - MESSAGE_LIMIT + 30:,} characters cut)… {safe[-tail:]}"
