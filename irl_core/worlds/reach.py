"""Reach worlds: care in one continuous movement, not a grid (docs/reach.md).

A trial is one quick reach from ``start`` to a point the player aims at, taking a duration they
choose. The endpoint scatters around the aim, less the slower the reach; it scores the points of
every circle holding it (circles that overlap add), less the time the reach took. Moving slower
and aiming away from a penalty circle are how a player shows how bad they think the penalty is.

====================  =====================================================
field                 meaning
====================  =====================================================
``care``              ``"reach"`` (what tells this world from a grid)
``field``             [width, height] in field units; x runs right, y down
``start``             [x, y] where every reach starts, inside the field
``regions``           circles ``{symbol, centre, radius, points}``; a symbol
                      given twice has the same points in each circle
``noise``             ``simulated`` (endpoint = aim + N(0, sd^2) per axis) or
                      ``own`` (a browser pointer's real endpoint)
``spread``            ``{a, b}``: sd = a + b * distance / (duration_ms / 1000)
``cost_per_second``   a reach of d ms costs cost_per_second * d / 1000
``min_ms``, ``max_ms``  the durations a reach may take
====================  =====================================================
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from irl_core.errors import WorldError
from irl_core.support.safe_files import read_toml, reference_problem
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.world_text import describe_validation_error, toml_str

# Field sizes, points, costs and durations are at most this large, so every reward and score stays a
# finite number JSON holds (as a grid world's MAX_MAGNITUDE).
MAX_SIZE = 1e6
MAX_POINTS = 1e9
MAX_REGIONS = 64
MAX_DURATION_MS = 3_600_000.0
_MAX_WORLD_FILE_BYTES = 1 << 20

Point = tuple[float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Region(_Strict):
    """One circle of the field: the endpoints within `radius` of `centre` score `points`."""

    symbol: str = Field(strict=True)
    centre: Point
    radius: float = Field(gt=0, le=MAX_SIZE)
    points: float = Field(ge=-MAX_POINTS, le=MAX_POINTS)

    @field_validator("symbol")
    @classmethod
    def _symbol_is_one_character(cls, symbol: str) -> str:
        if len(symbol) != 1 or not symbol.isprintable() or symbol.isspace():
            raise ValueError(f"{printable(symbol, limit=VALUE_LIMIT)!r} is not one printable character")
        return symbol


class Spread(_Strict):
    """The endpoint's sd per axis: a + b * distance / (duration_ms / 1000), in field units."""

    a: float = Field(gt=0, le=MAX_SIZE)
    b: float = Field(ge=0, le=MAX_SIZE)


class ReachWorld(_Strict):
    """One reach world, exactly as docs/reach.md and a reach recording's header describe it."""

    name: str = Field("custom", strict=True)
    care: Literal["reach"]
    field: Point
    start: Point
    regions: tuple[Region, ...] = Field(min_length=1, max_length=MAX_REGIONS)
    noise: Literal["simulated", "own"] = "simulated"
    spread: Spread = Spread(a=2.0, b=0.05)
    cost_per_second: float = Field(20.0, ge=0, le=MAX_POINTS)
    min_ms: float = Field(150.0, gt=0, le=MAX_DURATION_MS)
    max_ms: float = Field(1500.0, gt=0, le=MAX_DURATION_MS)

    @field_validator("field")
    @classmethod
    def _field_is_sized(cls, field: Point) -> Point:
        if not all(0 < side <= MAX_SIZE for side in field):
            raise ValueError(f"width and height must be above 0 and at most {MAX_SIZE:g}")
        return field

    @model_validator(mode="after")
    def _consistent(self) -> ReachWorld:
        width, height = self.field
        if not (0 <= self.start[0] <= width and 0 <= self.start[1] <= height):
            raise ValueError(f"start: {list(self.start)} is outside the field {width:g}x{height:g}")
        points: dict[str, float] = {}
        for index, region in enumerate(self.regions):
            x, y = region.centre
            if not (region.radius <= x <= width - region.radius and region.radius <= y <= height - region.radius):
                raise ValueError(f"regions.{index}: the circle at {list(region.centre)} of radius {region.radius:g} "
                                 f"reaches outside the field {width:g}x{height:g}")
            if points.setdefault(region.symbol, region.points) != region.points:
                raise ValueError(f"regions.{index}.points: {region.symbol!r} scores {points[region.symbol]:g} in an "
                                 f"earlier circle; a symbol has one value of points")
        if self.min_ms >= self.max_ms:
            raise ValueError(f"min_ms: {self.min_ms:g} is not below max_ms {self.max_ms:g}")
        return self

    @property
    def symbols(self) -> tuple[str, ...]:
        """The regions' symbols, each once, in the order the file first gives them."""
        return tuple(dict.fromkeys(region.symbol for region in self.regions))

    @property
    def points(self) -> dict[str, float]:
        """Each symbol's points."""
        return {region.symbol: region.points for region in self.regions}

    def distance(self, aim: ArrayLike) -> np.ndarray:
        """(...) the distance from the start to aims (..., 2)."""
        return np.hypot(*np.moveaxis(np.asarray(aim, dtype=float) - np.asarray(self.start), -1, 0))

    def sd(self, aim: ArrayLike, duration_ms: ArrayLike, spread: Spread | None = None) -> np.ndarray:
        """(...) the endpoint's sd per axis for aims (..., 2) reached in durations (...) by the spread law
        (the world's own, or `spread`)."""
        law = spread or self.spread
        return law.a + law.b * self.distance(aim) / (np.asarray(duration_ms, dtype=float) / 1000.0)

    def cost(self, duration_ms: ArrayLike) -> np.ndarray:
        """(...) the time cost (positive) of reaches of durations (...) in ms."""
        return self.cost_per_second * np.asarray(duration_ms, dtype=float) / 1000.0

    def endpoint(self, aim: ArrayLike, duration_ms: float, rng: np.random.Generator) -> np.ndarray:
        """(2,) where a simulated reach aimed at `aim` (2,) taking `duration_ms` lands: aim + N(0, sd^2) per axis
        by the world's spread law (the simulators and careful/Reach-v0 draw it here)."""
        aim = np.asarray(aim, dtype=float)
        return aim + rng.normal(0.0, float(self.sd(aim, duration_ms)), 2)

    def regions_holding(self, endpoint: Point) -> list[str]:
        """The symbols of the circles holding `endpoint` (on the rim counts), each once, in the file's order."""
        return list(dict.fromkeys(region.symbol for region in self.regions
                                  if math.dist(endpoint, region.centre) <= region.radius))

    def score_of(self, endpoint: Point, duration_ms: float) -> float:
        """A reach's reward: the points of every circle holding the endpoint (once per circle), less its time cost."""
        held = sum(region.points for region in self.regions if math.dist(endpoint, region.centre) <= region.radius)
        return float(held - self.cost(duration_ms))

    def to_toml(self) -> str:
        """The world as a TOML file that `load_reach_world` reads back to an equal world."""
        regions = ",\n".join(f"  {{symbol = {toml_str(r.symbol)}, centre = [{r.centre[0]!r}, {r.centre[1]!r}], "
                             f"radius = {r.radius!r}, points = {r.points!r}}}" for r in self.regions)
        lines = [
            f"name = {toml_str(self.name)}",
            'care = "reach"',
            f"field = [{self.field[0]!r}, {self.field[1]!r}]",
            f"start = [{self.start[0]!r}, {self.start[1]!r}]",
            f"regions = [\n{regions},\n]",
            f"noise = {toml_str(self.noise)}",
            f"spread = {{a = {self.spread.a!r}, b = {self.spread.b!r}}}",
            f"cost_per_second = {self.cost_per_second!r}",
            f"min_ms = {self.min_ms!r}",
            f"max_ms = {self.max_ms!r}",
        ]
        return "\n".join(lines) + "\n"


def _builtin(name: str, penalty: float) -> ReachWorld:
    # Dean, Wu & Maloney (2007)'s layout scaled to the field: a target with a penalty circle
    # overlapping it by half a radius on the left, reached from below.
    return ReachWorld(name=name, care="reach", field=(400.0, 300.0), start=(200.0, 280.0), regions=(
        Region(symbol="G", centre=(200.0, 80.0), radius=32.0, points=100.0),
        Region(symbol="C", centre=(168.0, 80.0), radius=32.0, points=penalty),
    ))


REACH_WORLDS: dict[str, ReachWorld] = {
    "reach": _builtin("reach", -500.0),
    "reach-mild": _builtin("reach-mild", -100.0),
    "reach-severe": _builtin("reach-severe", -5000.0),
}

REACH_PURPOSES: dict[str, str] = {
    "reach": "a quick reach to a target beside a penalty circle",
    "reach-mild": "the same with a mild penalty (-100)",
    "reach-severe": "the same with a severe penalty (-5000)",
}

REFUSED = ("is a reach world (care = \"reach\"); serve and studies do not take reach worlds yet "
           "(careful play in a terminal, worlds, simulate and fit do)")


def is_reach_data(data: object) -> bool:
    """Whether a world given as a mapping (a TOML table, a header's ``world``) says ``care = "reach"``."""
    return isinstance(data, dict) and data.get("care") == "reach"


def reach_world_from_dict(data: dict, *, source: str = "world") -> ReachWorld:
    """Validate a reach world given as a mapping; a problem is a `WorldError` naming `source` and the field."""
    try:
        return ReachWorld.model_validate(data)
    except ValidationError as exc:
        raise WorldError(f"{source}: {describe_validation_error(exc)}") from None


def read_world_table(key: str) -> dict[str, Any] | None:
    """The TOML table of the world file `key` names, or None when `key` is no file (a name, or missing).

    Raises `WorldError` for a file that cannot be read as TOML."""
    if reference_problem(key) or not Path(key).exists():
        return None
    try:
        data = read_toml(Path(key), what="world", limit=_MAX_WORLD_FILE_BYTES, too_big="a reach world file is a few kilobytes")
    except ValueError as exc:
        raise WorldError(str(exc)) from None
    data.setdefault("name", Path(key).stem)
    return data


def is_reach_world(name_or_path: str | Path) -> bool:
    """Whether a world name or file is a reach world (a file that cannot be read is not: its reader says why)."""
    key = str(name_or_path)
    if key in REACH_WORLDS:
        return True
    try:
        return is_reach_data(read_world_table(key))
    except WorldError:
        return False


def load_reach_world(name_or_path: str | Path) -> ReachWorld:
    """A built-in reach world by name, or one read from a TOML file; `WorldError` in one line otherwise."""
    key = str(name_or_path)
    if key in REACH_WORLDS:
        return REACH_WORLDS[key]
    data = read_world_table(key)
    if data is None:
        raise WorldError(f"no reach world named {printable(key, limit=VALUE_LIMIT)!r} and no such file "
                         f"(built-in reach worlds: {', '.join(REACH_WORLDS)})")
    return reach_world_from_dict(data, source=key)
