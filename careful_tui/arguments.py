"""The command line's arguments: their types (a bad value is one line, exit 2), and `careful fit`'s
options, each `FitOptions` field declared once here with its flag (`FIT_FLAGS`): the parser, the
options built from parsed arguments and the notes' words (`careful_tui.option_words`) all read it."""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import irl_core.irl.choices as choices
from irl_core.irl import FitOptions
from irl_core.irl.intervals.calibrated import read_calibration


def finite_float(text: str) -> float:
    """A number JSON can hold: "inf" and "nan" are refused (exit 2), as is anything beyond 1e300."""
    value = float(text)
    if not (math.isfinite(value) and abs(value) <= 1e300):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
    return value


def positive_float(text: str) -> float:
    value = finite_float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return value


def non_negative_float(text: str) -> float:
    value = finite_float(text)
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be zero or more, got {text}")
    return value


def probability(text: str) -> float:
    value = finite_float(text)
    if not 0 <= value <= 1:
        raise argparse.ArgumentTypeError(f"must be a probability from 0 to 1, got {text}")
    return value


def beta_value(text: str) -> float | str:
    """A positive number, or "auto" (estimate beta with the rewards)."""
    if text == "auto":
        return text
    try:
        return positive_float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive number or auto, got {text}") from None


def known_reward(text: str) -> tuple[str, float]:
    """``SYMBOL=VALUE``: a reward the user knows (one layout symbol, a finite number)."""
    symbol, equals, value = text.partition("=")
    if not equals or len(symbol.strip()) != 1:
        raise argparse.ArgumentTypeError(f"must be SYMBOL=VALUE with one layout symbol, as G=100, got {text}")
    try:
        return symbol.strip(), finite_float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be SYMBOL=VALUE with a number, as G=100, got {text}") from None


class Accumulate(argparse.Action):
    """A repeatable flag whose values gather in a tuple (argparse's append cannot start from an immutable default)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 _option_string: str | None = None) -> None:
        setattr(namespace, self.dest, (*getattr(namespace, self.dest, ()), values))


def seed_int(text: str) -> int:
    """A seed numpy takes: a whole number from 0 to 2**64 - 1."""
    value = int(text)
    if not 0 <= value < 2**64:
        raise argparse.ArgumentTypeError(f"must be a whole number from 0 to 2**64 - 1, got {text}")
    return value


def text_argument(text: str) -> str:
    """Text from the command line that a recording can hold: undecodable bytes are refused."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise argparse.ArgumentTypeError("is not valid UTF-8 text") from None
    return text


def player_names(text: str) -> tuple[str, ...]:
    """``loose,timed``: person-like players (`careful check --players`); an empty text names none."""
    from irl_core.coverage.rivals import parse_rivals
    from irl_core.errors import UsageError

    try:
        return parse_rivals(text)
    except UsageError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--players: ")) from None


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text}")
    return value


def non_negative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, got {text}")
    return value


@dataclass(frozen=True)
class Flag:
    """A `FitOptions` field's flag on `careful fit`: its name and argparse's keyword arguments."""

    field: str
    flag: str
    kwargs: dict[str, Any] = dataclasses.field(default_factory=dict)
    # What the parsed value becomes in `FitOptions` (a file named by the flag, read), where it is not the value.
    read: Callable[[Any], Any] | None = None


FIT_FLAGS: tuple[Flag, ...] = (
    Flag("method", "--method", dict(choices=choices.NAMES, default=choices.DEFAULT, help="; ".join(
        f"{m.name}{' (default)' if m.name == choices.DEFAULT else ''}: {m.summary}"
        for m in choices.METHODS.values()))),
    Flag("rmax", "--rmax", dict(type=positive_float, default=1000.0, help="bound |R_S| <= rmax (default 1000)")),
    Flag("lam", "--lambda", dict(type=non_negative_float, default=0.0, help="L1 penalty on R_S (default 0)")),
    Flag("beta", "--beta", dict(type=beta_value, default=None, metavar="X|auto", help=(
        "maxent inverse temperature, or auto to estimate it with the rewards (default: 1.0 with --method "
        "maxent, auto when --method auto picks maxent)"))),
    Flag("player_model", "--player-model", dict(choices=(choices.AUTO, *choices.PLAYER_MODELS), default=None,
         help="maxent's model of the player: auto chooses by held-out episodes (the default when --method auto "
         "picks maxent); " + "; ".join(f"{m.name}: {m.summary}" for m in choices.PLAYER_MODELS.values())
         + " (boltzmann is the default with --method maxent)")),
    Flag("reward_cells", "--reward-cells", dict(choices=["special", "all"], default="special",
         help="special: fit non-ground cells, ground is 0 (default); all: fit every cell")),
    Flag("tie", "--tie", dict(action="store_true", help="one unknown per symbol instead of per cell")),
    Flag("intervals", "--intervals", dict(action="store_true", help=(
        "an interval per unknown: for lp every value the demonstrations allow (identified set); for maxent and "
        "loss a confidence interval from resampling whole episodes"))),
    Flag("confidence", "--confidence", dict(type=finite_float, default=0.95, metavar="P",
         help="confidence level of maxent's and loss's intervals, between 0 and 1 (default 0.95)")),
    Flag("resamples", "--resamples", dict(type=int, default=200, metavar="N",
         help="bootstrap resamples for those intervals, at least 20 (default 200)")),
    Flag("seed", "--seed", dict(type=seed_int, default=0, help="seed of the resampling (default 0)")),
    Flag("slip_known", "--slip-known", dict(action="store_true", help=(
        "a time world: plan with the world's own slip curve instead of learning it from the recorded slips"))),
    Flag("cost", "--cost", dict(choices=["known", "unknown"], default="known", help=(
        "a time world: known (default) reports rewards in points; unknown treats the cost of holding as unknown "
        "and reports each reward in seconds of holding (the scale the data identify without it)"))),
    Flag("known", "--known", dict(type=known_reward, action=Accumulate, default=(), metavar="SYMBOL=VALUE", help=(
        "a reward you know, held at that value instead of fitted (repeatable): it fixes the rewards' units where "
        "nothing in the world does (one level or moves that cost nothing, which else read rewards relative to "
        "the goal)"))),
    Flag("union", "--union", dict(action="store_true", help=(
        "with the player model chosen by held-out episodes (maxent's default), join the intervals of every "
        "candidate model those episodes do not tell from the chosen one beyond their noise, not only the other "
        "planning assumption's: wider intervals that stay honest when the player is none of the models"))),
    Flag("calibration", "--calibration", dict(type=Path, default=None, metavar="FILE", help=(
        "widen the intervals by the scales careful check learned (the calibration.json it writes), so that they "
        "held the truth at their level for every player it checked; refused if learned on another world or "
        "other fit options (the seed aside)")), read=read_calibration),
)
if {f.field for f in FIT_FLAGS} != {f.name for f in dataclasses.fields(FitOptions)}:
    raise RuntimeError("careful_tui.arguments.FIT_FLAGS must declare a flag for every FitOptions field")


def add_fit_options(parser: argparse.ArgumentParser) -> None:
    """`careful fit`'s option flags, one per `FitOptions` field (`FIT_FLAGS`)."""
    for option in FIT_FLAGS:
        parser.add_argument(option.flag, dest=option.field, **option.kwargs)


def options_from_args(args: argparse.Namespace) -> FitOptions:
    """The fit's settings from `careful fit`'s parsed arguments (built once; the view refits with replace)."""
    return FitOptions(**{option.field: _value(option, getattr(args, option.field)) for option in FIT_FLAGS})


def _value(option: Flag, parsed: Any) -> Any:
    return option.read(parsed) if option.read is not None and parsed is not None else parsed


def fit_inputs(args: argparse.Namespace) -> list[Path]:
    """Every file `careful fit` reads (the recordings, and a reach fit's --spread-law), which none of its outputs
    may be written over."""
    return [*args.files, *([] if getattr(args, "spread_law", None) is None else [args.spread_law])]
