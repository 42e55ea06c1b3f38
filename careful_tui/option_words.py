"""The core's notes and errors in the command line's words: ``{rmax}`` says ``--rmax``, ``{method=loss}``
``--method loss``, ``{intervals=True}`` ``--intervals``.

`FLAGS` maps `FitOptions`' fields to `careful fit`'s flags, read from `careful_tui.arguments.FIT_FLAGS`,
where each field's flag is declared once (checked at import), so a new option cannot reach a user under its
Python name.
"""

from __future__ import annotations

from careful_tui.arguments import FIT_FLAGS
from irl_core.irl import FitError, Note
from irl_core.irl.notes import worded

FLAGS: dict[str, str] = {option.field: option.flag for option in FIT_FLAGS}


def flag(name: str, value: str | None) -> str:
    """An option as a flag: --rmax, --method loss, --intervals (a switch turned on)."""
    return FLAGS[name] if value in (None, "True") else f"{FLAGS[name]} {value}"


def said(message: Note | FitError) -> str:
    """A note's or a fit error's sentence with its options as flags."""
    return worded(message.sentence, flag)
