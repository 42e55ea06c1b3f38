"""The calibration block of a reach world with ``noise = "own"`` (docs/reach.md): reaches to a lone target at
four deadlines, and the spread law fitted from where they ended.

With a participant's own pointer the endpoint's scatter is theirs, not the world's ``spread``: the fit of the
points needs their law, and the decision trials alone mix it up with where they chose to aim. Dean, Wu &
Maloney (2007) measure it first: reaches to a target with nothing else on the field, each to be made in a
given time. Here the target is the world's circle of most points, alone, at its place (so the law is measured
at the distance it is used at), and the deadlines are four durations spread evenly on a log scale inside
``[min_ms, max_ms]``, at 1/8, 3/8, 5/8 and 7/8 of the way: the law's x = distance / seconds then takes four
values wide apart, which is what tells a (the scatter at any speed) from b (the scatter that grows with
speed), and each deadline keeps an eighth of the log range from the limits, so a reach a little off its
deadline is still inside them (a reach outside them is refused and repeated, as in the game).

The participant aims at the target's centre; a trial's miss is endpoint - centre, and the law is fitted from
the trials' misses and durations by `irl_core.reach.fit.fit_spread` (maximum likelihood, Laplace intervals).
It is stored beside the participant's recordings as ``spread-<world index>.json`` (`SPREAD_FILE`);
`read_spread_law` reads it back (or a hand-written a and b) for `careful fit --spread-law`, and
`calibration_beside` finds it beside own-noise recordings that were fitted without it.
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.stats import norm

from irl_core.errors import SpreadLawError
from irl_core.reach.fit import Note, SpreadFit, fit_spread
from irl_core.recordings.reach_reader import Reaches, read_reach_recording
from irl_core.support.safe_files import open_regular, read_problem
from irl_core.support.safe_text import printable
from irl_core.worlds.reach import MAX_SIZE, ReachWorld, Region, Spread

# The spread law a participant's calibration block gave, beside their recordings: spread-<world index>.json.
SPREAD_FILE = "spread-{index}.json"
# Builds the error of a law file's field: (field, problem) -> the error naming the file and the field's line.
Refuse = Callable[[str, str], SpreadLawError]
# The name of a calibration's file, its group the world index.
_SPREAD_NAME = re.compile(r"spread-(\d+)\.json")
# A spread law file is a few lines; anything larger is not one.
SPREAD_FILE_LIMIT = 1 << 16
# The confidence of a law file's interval when it does not say (the calibration block's).
DEFAULT_CONFIDENCE = 0.95

# Where the four deadlines sit on the log scale from min_ms (0) to max_ms (1).
DEADLINE_PLACES = (1 / 8, 3 / 8, 5 / 8, 7 / 8)
# Reaches a deadline asks for, unless the study says otherwise.
TRIALS_PER_DEADLINE = 10


def calibration_deadlines(world: ReachWorld) -> tuple[float, ...]:
    """The four deadlines (ms) of the world's calibration block, shortest first, rounded to whole ms (as the page
    words them) but never past the limits."""
    low, high = np.log(world.min_ms), np.log(world.max_ms)
    return tuple(float(np.clip(round(np.exp(low + place * (high - low))), world.min_ms, world.max_ms))
                 for place in DEADLINE_PLACES)


def calibration_world(world: ReachWorld) -> ReachWorld:
    """The world of the calibration block: the world's circle of most points alone, worth nothing (a
    calibration reach scores nothing), and the world's start, limits and time cost otherwise."""
    target = max(world.regions, key=lambda region: region.points)
    lone = Region(symbol=target.symbol, centre=target.centre, radius=target.radius, points=0.0)
    return world.model_copy(update={"regions": (lone,), "name": f"{world.name} calibration"})


def calibration_schedule(world: ReachWorld, per_deadline: int = TRIALS_PER_DEADLINE) -> list[float]:
    """The deadline of each trial of the block in order: `per_deadline` reaches at each deadline, the longest
    deadline first (the easiest, to learn the task on), as Dean et al. block them."""
    return [deadline for deadline in reversed(calibration_deadlines(world)) for _ in range(per_deadline)]


@dataclass(frozen=True)
class CalibrationFit:
    """The spread law fitted from a calibration block, and the notes of its fit."""

    spread: SpreadFit
    trials: int
    notes: tuple[Note, ...]
    world: str = ""
    confidence: float = DEFAULT_CONFIDENCE

    def to_json(self) -> dict[str, object]:
        """The law as a participant's recording stores it: the world's name, a, b, their intervals (at
        `confidence`) and covariance, and how many reaches."""
        law, interval, covariance = self.spread.spread, self.spread.interval, self.spread.covariance
        return {"world": self.world, "a": law.a, "b": law.b, "trials": self.trials,
                "interval": None if interval is None else {name: list(bounds) for name, bounds in interval.items()},
                "confidence": self.confidence,
                "covariance": None if covariance is None else covariance.tolist(),
                "notes": [note.code for note in self.notes]}


def fit_calibration(world: ReachWorld, durations_ms: ArrayLike, endpoints: ArrayLike, *,
                    confidence: float = 0.95) -> CalibrationFit:
    """The spread law from calibration reaches of `world` (its own world, not `calibration_world`): durations
    (n,) in ms and endpoints (n, 2), each aimed at the lone target's centre."""
    lone = calibration_world(world)
    durations = np.asarray(durations_ms, dtype=float)
    endpoints = np.asarray(endpoints, dtype=float).reshape(-1, 2)
    aims = np.broadcast_to(np.asarray(lone.regions[0].centre, dtype=float), endpoints.shape)
    notes: list[Note] = []
    law = fit_spread(Reaches(lone, aims, durations, endpoints, files=1), known=False, confidence=confidence,
                     notes=notes)
    return CalibrationFit(law, len(durations), tuple(notes), world=world.name, confidence=confidence)


def read_spread_law(path: str | Path, world: ReachWorld, *, world_indices: Iterable[int] = ()) -> SpreadFit:
    """The spread law in `path` for fitting recordings of `world` (of a study's worlds `world_indices`, as
    `study_worlds` gives them, if a study wrote them): a calibration's ``spread-<i>.json`` or a JSON or TOML (by the
    suffix ``.toml``) giving ``a`` and ``b``, and optionally ``world`` (the world's name),
    ``covariance`` ([[var a, cov], [cov, var b]]) or ``interval`` ({"a": [low, high], "b": [...]}, at
    ``confidence``, default 0.95). The law's uncertainty is its covariance, else a diagonal one from the
    interval (each half-width from the value up, the lower ends being clipped at 0), else none.

    Raises `SpreadLawError` naming the file, the line and the field of the first problem: unreadable, not a
    law, another world's law (by its ``world``, or for a ``spread-<i>.json`` without one by i), a or b missing,
    negative or not a number, a covariance or interval malformed."""
    path = Path(path)
    shown = printable(str(path), limit=200)
    try:
        with open_regular(path) as file:
            raw = file.read(SPREAD_FILE_LIMIT + 1)
    except OSError as exc:
        raise SpreadLawError(shown, None, None, f"cannot read the spread law ({read_problem(exc)})") from None
    except ValueError as exc:
        raise SpreadLawError(shown, None, None, f"is {exc}; a spread law is a JSON or TOML file") from None
    if len(raw) > SPREAD_FILE_LIMIT:
        raise SpreadLawError(shown, None, None, f"over {SPREAD_FILE_LIMIT >> 10} KB: not a spread law")
    toml = path.suffix.lower() == ".toml"
    try:
        text = raw.decode("utf-8-sig")
        found = tomllib.loads(text) if toml else json.loads(text)
    except UnicodeDecodeError:
        raise SpreadLawError(shown, None, None, "not UTF-8 text: not a spread law") from None
    except (ValueError, RecursionError) as exc:
        line = getattr(exc, "lineno", None)
        raise SpreadLawError(shown, line, None, f"not valid {'TOML' if toml else 'JSON'}: not a spread law") from None
    if not isinstance(found, dict):
        raise SpreadLawError(shown, 1, None, "not a table with a and b: not a spread law")

    def refuse(field: str, problem: str) -> SpreadLawError:
        return SpreadLawError(shown, _line_of(text, field.split(".")[0], toml=toml), field, problem)

    if "world" in found and found["world"] != world.name:
        raise refuse("world", f"the law of world {printable(str(found['world']), limit=60)!r}, not of the "
                     f"recordings' world {printable(world.name, limit=60)!r}")
    indices = set(world_indices)
    if "world" not in found and indices and (named := _SPREAD_NAME.fullmatch(path.name)) is not None \
            and int(named[1]) not in indices:
        raise SpreadLawError(shown, None, "world", f"the calibration of the study's world {named[1]}, not of the "
                             f"recordings' (world {', '.join(map(str, sorted(indices)))})")
    law = {name: _law_number(found, name, refuse) for name in ("a", "b")}
    if law["a"] <= 0:
        raise refuse("a", f"must be above 0 (the scatter at any speed), got {law['a']:g}")
    confidence = _law_number(found, "confidence", refuse) if "confidence" in found else DEFAULT_CONFIDENCE
    if not 0 < confidence < 1:
        raise refuse("confidence", f"must be between 0 and 1, got {confidence:g}")
    interval = None
    if found.get("interval") is not None:
        given = found["interval"]
        if not isinstance(given, dict) or set(given) != {"a", "b"}:
            raise refuse("interval", "must give a and b each a [low, high]")
        interval = {name: _law_pair(given[name], f"interval.{name}", refuse) for name in ("a", "b")}
    covariance = None
    if found.get("covariance") is not None:
        covariance = _law_covariance(found["covariance"], refuse)
    elif interval is not None:
        z = float(norm.ppf(0.5 + confidence / 2))
        covariance = np.diag([((interval[name][1] - law[name]) / z) ** 2 for name in ("a", "b")])
    return SpreadFit(Spread(a=law["a"], b=law["b"]), interval, True, covariance, source=shown)


def _law_number(found: dict[str, Any], name: str, refuse: Refuse) -> float:
    """`found[name]` as a finite number of 0 or more (at most the world's largest size)."""
    if name not in found:
        raise refuse(name, "missing: a spread law gives a and b (sd = a + b * distance / seconds)")
    value = found[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise refuse(name, f"must be a finite number, got {printable(repr(value), limit=40)}")
    if not 0 <= value <= MAX_SIZE:
        raise refuse(name, f"must be from 0 to {MAX_SIZE:g}, got {value:g}")
    return float(value)


def _law_pair(value: Any, field: str, refuse: Refuse) -> tuple[float, float]:
    """An interval [low, high] of finite numbers, low <= high."""
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
            or value[0] > value[1]):
        raise refuse(field, "must be [low, high], two finite numbers, low first")
    return float(value[0]), float(value[1])


def _law_covariance(value: Any, refuse: Refuse) -> np.ndarray:
    """A 2 x 2 covariance of (a, b): finite, symmetric, positive semi-definite."""
    try:
        matrix = np.array(value, dtype=float)
    except (TypeError, ValueError):
        matrix = np.empty(0)
    if (matrix.shape != (2, 2) or not np.all(np.isfinite(matrix)) or not np.allclose(matrix, matrix.T)
            or np.linalg.eigvalsh((matrix + matrix.T) / 2).min() < -1e-12 * max(1.0, float(np.abs(matrix).max()))):
        raise refuse("covariance", "must be [[var a, cov], [cov, var b]]: finite, symmetric, no negative variance")
    return matrix


def _line_of(text: str, key: str, *, toml: bool) -> int | None:
    """The line (1-based) where `key` is first given in a JSON or TOML text, None if it is not."""
    pattern = re.compile(rf"^\s*{re.escape(key)}\s*=" if toml else rf'"{re.escape(key)}"\s*:', re.MULTILINE)
    match = pattern.search(text)
    return None if match is None else text.count("\n", 0, match.start()) + 1


def study_worlds(paths: Iterable[str | Path]) -> dict[Path, int]:
    """Each reach recording of `paths` that a study wrote, and the index of its world in the study's worlds."""
    found = {}
    for path in paths:
        if (study := read_reach_recording(path).header.study) is not None:
            found[Path(path)] = study.world_index
    return found


def calibration_beside(indices: dict[Path, int], world: ReachWorld) -> Path | None:
    """The calibration of `world` beside its own-noise study recordings (`indices`, as `study_worlds` gives
    them): the ``spread-<world index>.json`` in a recording's folder; None when the world's noise is not "own"
    or no such file is there."""
    if world.noise != "own":
        return None
    for path, index in indices.items():
        if (found := path.parent / SPREAD_FILE.format(index=index)).is_file():
            return found
    return None
