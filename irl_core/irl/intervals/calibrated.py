"""Calibrated intervals (docs/check.md, "Calibrated intervals"): a fit's intervals widened by the scales that
`careful check` learned from its own simulations, so that they reach their level for every player it checked.

After Syring & Martin (2019, "Calibrating general posterior credible regions", Biometrika), who choose one
scale of a posterior so that its regions reach their nominal coverage over datasets simulated from the
data's own fit: here the scale w >= 1 multiplies each interval's two half-widths around its point,

    [p - w (p - low), p + w (high - p)]   clipped to [-rmax, rmax],

one w per symbol (`Calibration.scales`), learned by `irl_core.coverage.calibrate`. The point stays inside
(w >= 1 never moves an end towards it), an end at ±rmax stays there (an interval open on one side stays
one-sided) and the asymmetry of the bootstrap is kept. A symbol no scale could bring to its level (a
dataset's truth beside a side of no width) gets the whole range.

A calibration holds for the design it was learned on: the same world and the same fit options (every one
but the seed). `Calibration.mismatch` names the first field that differs, and `fit` refuses it.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from irl_core.errors import CalibrationError
from irl_core.support.safe_files import open_regular, read_problem
from irl_core.support.safe_text import cut, one_line, printable
from irl_core.worlds.world import World


class FitOptions(Protocol):
    """What a calibration reads of `irl_core.irl.options.FitOptions` (which holds a calibration, so is not
    imported here)."""

    @property
    def method(self) -> str: ...

    def to_json(self) -> dict[str, Any]: ...


FORMAT = "careful calibration 1"
# The fit options a calibration must share with the fit it widens: all of `FitOptions.to_json` but these
# (the seed draws resamples, `intervals` is always on in a check, `calibration` is the calibration itself).
NOT_COMPARED = ("seed", "intervals", "calibration")
# A calibration file is a few kilobytes; more is not one.
LIMIT = 1 << 20


@dataclass(frozen=True)
class Calibration:
    """Scales learned by `careful check` and what they were learned from.

    Attributes:
        scales: (symbol, w) per symbol in the order of the fit's unknowns; w None where no scale reached the
            level (that symbol's interval becomes the whole range).
        confidence: the level the scales bring the intervals to.
        options: the fit options as `FitOptions.to_json` writes them, without `NOT_COMPARED`, as JSON with its
            keys sorted (a string, so that a calibration, like the `FitOptions` that hold it, can be hashed).
        world: the recordings' world's name; `world_digest` a SHA-256 of its definition.
        players: the players checked (the fit's own model first); datasets, episodes, seed: the design.
    """

    scales: tuple[tuple[str, float | None], ...]
    confidence: float
    options: str
    world: str
    world_digest: str
    players: tuple[str, ...]
    datasets: int
    episodes: int
    seed: int

    def scale_of(self, symbol: str) -> float | None:
        """w for `symbol`: 1 (unchanged) for a symbol the calibration does not name."""
        return dict(self.scales).get(symbol, 1.0)

    def to_json(self) -> dict[str, Any]:
        return {"format": FORMAT, "scales": dict(self.scales), "confidence": self.confidence,
                "world": self.world, "world_digest": self.world_digest, "options": json.loads(self.options),
                "players": list(self.players), "datasets": self.datasets, "episodes": self.episodes,
                "seed": self.seed}

    def mismatch(self, options: FitOptions, world: World) -> str | None:
        """Why this calibration does not fit a fit with `options` of the recordings' `world`: a sentence naming the
        first field that differs, or None."""
        if world.name != self.world or world_digest(world) != self.world_digest:
            return (f"world: learned on the world {self.world!r}" + (" as it was then (its file has changed)"
                                                                     if world.name == self.world else "")
                    + f", not {world.name!r}")
        mine = json.loads(self.options)
        theirs = json.loads(options_text(options))
        for name in dict.fromkeys([*mine, *theirs]):
            if mine.get(name) != theirs.get(name):
                return (f"options.{name}: learned with {_said(mine.get(name))}, this fit has "
                        f"{_said(theirs.get(name))}; learn one with these options (careful check)")
        return None


def _said(value: Any) -> str:
    return "none" if value is None else json.dumps(value)


def options_text(options: FitOptions | dict[str, Any]) -> str:
    """The fit options a calibration must share (`FitOptions`, or as a calibration file holds them: the method and
    `FitOptions.to_json`'s fields but `NOT_COMPARED`), as JSON with its keys sorted."""
    named = options if isinstance(options, dict) else {"method": options.method, **options.to_json()}
    return json.dumps({name: value for name, value in named.items() if name not in NOT_COMPARED}, sort_keys=True)


def world_digest(world: World) -> str:
    """A SHA-256 of a world's definition (its JSON, keys sorted): two worlds that play alike share it."""
    text = json.dumps(world.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def widen(theta: np.ndarray, bounds: np.ndarray, symbols: tuple[str, ...], calibration: Calibration, *,
          rmax: float) -> np.ndarray:
    """(k, 2) `bounds` with each unknown's half-widths around its point `theta` (k,) multiplied by its symbol's
    scale, clipped to [-rmax, rmax]; the whole range where the scale is None."""
    theta = np.asarray(theta, dtype=float)
    bounds = np.asarray(bounds, dtype=float)
    out = np.array(bounds, copy=True)
    for j, symbol in enumerate(symbols):
        scale = calibration.scale_of(symbol)
        if scale is None:
            out[j] = (-rmax, rmax)
            continue
        out[j, 0] = theta[j] - scale * (theta[j] - bounds[j, 0])
        out[j, 1] = theta[j] + scale * (bounds[j, 1] - theta[j])
    return np.clip(out, -rmax, rmax)


def read_calibration(path: str | Path) -> Calibration:
    """The calibration in `path` (written by `careful check`).

    Raises `CalibrationError`: one line naming the file, the line and the field where it is not one."""
    try:
        with open_regular(path) as file:
            raw = file.read(LIMIT + 1)
    except OSError as exc:
        raise CalibrationError(f"{path}: cannot read the calibration ({read_problem(exc)})") from None
    except ValueError as exc:
        raise CalibrationError(f"{path}: is {exc}; a calibration is the JSON careful check writes") from None
    if len(raw) > LIMIT:
        raise CalibrationError(f"{path}: over {LIMIT >> 20} MB, so not a calibration careful check wrote")
    try:
        text = raw.decode("utf-8")
        data = json.loads(text, parse_constant=_no_constant)
    except UnicodeDecodeError:
        raise CalibrationError(f"{path}: not UTF-8 text, so not a calibration careful check wrote") from None
    except ValueError as exc:
        where = f":{exc.lineno}" if isinstance(exc, json.JSONDecodeError) else ""
        raise CalibrationError(f"{path}{where}: not JSON ({cut(one_line(str(exc)), 120)})") from None

    def bad(field: str, problem: str) -> CalibrationError:
        return CalibrationError(f"{path}:{_line_of(text, field)}: {field}: {problem}")

    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise bad("format", f"not {FORMAT!r}: this is not a calibration careful check wrote")
    scales = data.get("scales")
    if not isinstance(scales, dict) or not scales:
        raise bad("scales", "must be an object of symbol: scale (a number of at least 1, or null)")
    for symbol, scale in scales.items():
        if scale is not None and (not _number(scale) or not scale >= 1):
            raise bad("scales", f"{printable(symbol, limit=20)!r} is {cut(json.dumps(scale), 30)}, "
                                "not a number of at least 1 (or null)")
    confidence = data.get("confidence")
    if not isinstance(confidence, (int, float)) or not _number(confidence) or not 0 < confidence < 1:
        raise bad("confidence", "must be a number between 0 and 1")
    if not isinstance(data.get("options"), dict):
        raise bad("options", "must be an object: the fit options the scales were learned with")
    for field in ("world", "world_digest"):
        if not isinstance(data.get(field), str):
            raise bad(field, "must be a string")
    players = data.get("players")
    if not isinstance(players, list) or not all(isinstance(p, str) for p in players):
        raise bad("players", "must be a list of player names")
    for field in ("datasets", "episodes", "seed"):
        value = data.get(field)
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise bad(field, "must be a whole number, 0 or more")
    return Calibration(scales=tuple((str(s), None if w is None else float(w)) for s, w in scales.items()),
                       confidence=float(confidence), options=options_text(data["options"]),
                       world=data["world"], world_digest=data["world_digest"], players=tuple(players),
                       datasets=data["datasets"], episodes=data["episodes"], seed=data["seed"])


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number")


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _line_of(text: str, field: str) -> int:
    """The line of `text` where `"field":` first appears (1 where it does not: the field is missing)."""
    at = text.find(json.dumps(field) + ":")
    return 1 if at < 0 else text.count("\n", 0, at) + 1
