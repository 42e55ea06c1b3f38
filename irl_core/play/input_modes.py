"""The input modes, one registry: every place that offers, describes or builds a mode reads it.

An entry carries what each front end needs to know about its mode: how it is built (`make`),
how the command line describes it (`cli_help`), how a study's instructions explain it
(`study_words`), the two lines under the gauge before the first move (`gauge_help`), the key
bar's entries (`key_hints`) and whether it times how long a key is held (`times_holds`:
calibration applies to it, its gauge fills with time and its hold's milliseconds are shown). The session header's `"input"` object
is the built input's `header()` (`InputMode.header`).

Adding a mode: its `MoveInput` class (as `irl_core.play.modes`), its entry here, its tests; the
study file's `input` field lists the names too (`irl_core.studies.study.Study`, which a test holds to
this registry). An unknown name raises `ValueError` where it enters (`input_mode`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

from irl_core.play.hold import Clock, HoldDetector, HoldProfile, MoveInput
from irl_core.play.modes import DigitsInput, TapCounter


@dataclass(frozen=True)
class KeyHint:
    """One entry of a front end's key bar: the `keys` it names (comma-separated key names), how
    they are shown (`display`) and what they do (`words`)."""

    keys: str
    display: str
    words: str


ARROWS = KeyHint("up,right,down,left", "←↑→↓", "move")


@dataclass(frozen=True)
class InputMode:
    """One way to enter a move's carefulness.

    Attributes:
        name: the mode's name, as `--input` and a study file's `input` take it.
        make: builds the mode's input on a timing profile and a clock.
        cli_help: what `careful play --help` says the mode does (lower case, no full stop).
        study_words: how a study's instructions tell a participant to choose a level.
        gauge_help: given k = min(3, levels), the lines shown under the gauge before the first
            move in a world of several levels (each at most 17 characters, the first alone
            making sense).
        times_holds: the level comes from how long a key is held.
        key_hints: the key bar's entries while a move can be made (a world of several levels).
    """

    name: str
    make: Callable[[HoldProfile, Clock], MoveInput]
    cli_help: str
    study_words: str
    gauge_help: Callable[[int], str]
    times_holds: bool
    key_hints: tuple[KeyHint, ...]

    def header(self, profile: HoldProfile) -> dict[str, object]:
        """The session header's `"input"` object for this mode on `profile`."""
        return self.make(profile, time.monotonic).header()


INPUT_MODES: dict[str, InputMode] = {
    mode.name: mode
    for mode in (
        InputMode(
            name="hold",
            make=lambda profile, clock: HoldDetector(profile, clock=clock),
            cli_help="hold an arrow longer to be more careful",
            study_words="Hold an arrow key down: the longer you hold it, the more careful the move. The move is "
                        "made when you let go.",
            gauge_help=lambda k: "hold = careful\nlet go: move",
            times_holds=True,
            key_hints=(replace(ARROWS, words="move · hold longer: more careful"),),
        ),
        InputMode(
            name="tap",
            make=lambda profile, clock: TapCounter(profile, clock=clock),
            cli_help="tap an arrow k times for level k",
            study_words="Tap an arrow key k times quickly for a move at level k (one tap: level 1).",
            gauge_help=lambda k: f"tap k× = level k\n{'→' * k}: right at {k}",
            times_holds=False,
            key_hints=(replace(ARROWS, words="move · tap ×k: level k"),),
        ),
        InputMode(
            name="digits",
            make=lambda profile, clock: DigitsInput(profile, clock=clock),
            cli_help="type the level, then the arrow",
            study_words="Type the level (a number), then press the arrow key. An arrow alone is a level 1 move; "
                        "backspace takes back a digit.",
            gauge_help=lambda k: f"level, then arrow\n{k} →: right at {k}",
            times_holds=False,
            key_hints=(KeyHint("1,2,3,4,5,6,7,8,9", "1-9", "level"), ARROWS, KeyHint("backspace", "⌫", "fix")),
        ),
    )
}

INPUT_MODE_NAMES: tuple[str, ...] = tuple(INPUT_MODES)
DEFAULT_INPUT_MODE = "hold"


def input_mode(name: str) -> InputMode:
    """The registered mode called `name`.

    Raises:
        ValueError: no mode has that name (the message lists the names).
    """
    try:
        return INPUT_MODES[name]
    except KeyError:
        raise ValueError(f"unknown input mode {name!r}: use one of {', '.join(INPUT_MODE_NAMES)}") from None
