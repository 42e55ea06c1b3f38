"""The core's notes and errors in the command line's words: ``{rmax}`` says ``--rmax``, ``{method=loss}``
``--method loss``, ``{intervals=True}`` ``--intervals``.

`FLAGS` is the one table from `FitOptions`' fields to `careful fit`'s flags; every field has one (checked
at import), so a new option cannot reach a user under its Python name.
"""

from __future__ import annotations

import dataclasses

from irl_core.irl import FitError, FitOptions, Note
from irl_core.irl.notes import worded

FLAGS: dict[str, str] = {
    "method": "--method",
    "rmax": "--rmax",
    "lam": "--lambda",
    "beta": "--beta",
    "player_model": "--player-model",
    "reward_cells": "--reward-cells",
    "tie": "--tie",
    "intervals": "--intervals",
    "confidence": "--confidence",
    "resamples": "--resamples",
    "seed": "--seed",
}
if set(FLAGS) != {field.name for field in dataclasses.fields(FitOptions)}:
    raise RuntimeError("careful_tui.option_words.FLAGS must name a flag for every FitOptions field")


def flag(name: str, value: str | None) -> str:
    """An option as a flag: --rmax, --method loss, --intervals (a switch turned on)."""
    return FLAGS[name] if value in (None, "True") else f"{FLAGS[name]} {value}"


def said(message: Note | FitError) -> str:
    """A note's or a fit error's sentence with its options as flags."""
    return worded(message.sentence, flag)
