"""Worlds: the cliff gridworlds of the paper as validated data (docs/worlds.md).

A world is a layout string plus the numbers that turn it into an MDP. It is read from
TOML with the standard library and validated with pydantic; seven worlds are built in, six
defined below and `walls` read from ``irl_core/worlds/walls.toml``.

====================  =====================================================
field                 meaning
====================  =====================================================
``layout``            rows of symbols, row 0 at the top: ``.`` ground,
                      ``C`` cliff, ``G`` goal, ``U`` undesirable, ``#`` wall
``levels``            L, the number of carefulness levels (c = 1..L, L <= 53)
``cost_per_level``    action cost R_A(a) = -cost_per_level * c
``gamma``             discount for planning and IRL, in [0, 1)
``slip``              ``halving``: P(chosen direction) = 1 - 2^-c, ``none``,
                      or ``{intended = p, others = [a, b, c]}``: a fixed split
                      at every level, the others in the order left, up,
                      right, down without the chosen one (`SlipSplit`)
``bump``              ``stay``: a move into a wall or off the grid is a step
                      that stays; ``drop``: no step is made or recorded
``terminal``          symbols whose cell ends the episode when entered
``start``             ``random`` (uniform non-terminal cell) or ``[row, col]``
``initial_score``     the game's starting score (undiscounted)
``max_steps``         step limit that truncates an episode
``rewards``           R_S per symbol; unlisted symbols have R_S = 0
====================  =====================================================

A world with ``care = "time"`` has no levels: care is how long the key is held (docs/timing.md).
A hold of d ms slips with p(d) = p_inf + (p0 - p_inf) exp(-d / tau_ms) and costs
cost_per_second * d / 1000, d capped at ``max_hold_ms``. For planning, d falls into the
``duration_bins_ms`` (by default 16 log-spaced bins, `default_duration_bins`); a bin's action
has the slip chance and cost of its geometric mid-point, so a time world is, to every method,
a world whose levels are its bins (`World.levels` is their count).
"""

from __future__ import annotations

import math
import tomllib
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)

from irl_core.errors import WorldError
from irl_core.support.plural import plural
from irl_core.support.safe_files import read_toml, reference_problem
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.reach import REACH_WORLDS, REFUSED, is_reach_data
from irl_core.worlds.world_text import describe_validation_error, toml_escape, toml_str

# A cell of the grid, (row, column) from the top left; a move's direction as recordings spell it.
Cell = tuple[int, int]
Direction = Literal["up", "right", "down", "left"]
# Directions in action order (d = 0..3), and the order a fixed slip lists the other directions in
# (the chosen one left out): left, up, right, down, as the labs whose tasks these are write them.
DIRECTIONS: tuple[Direction, ...] = ("up", "right", "down", "left")
SPLIT_ORDER: tuple[Direction, ...] = ("left", "up", "right", "down")
# A fixed slip's chances sum to 1 within this (a table copied from a paper: 0.76 + 0.09 + 0.05 + 0.10).
SPLIT_SUM_TOLERANCE = 1e-9

WALL = "#"
GROUND = "."
# With halving slip, 1 - 2^-c rounds to exactly 1 in double precision above c = 53, so more
# levels add nothing but cost; the bound also keeps a typo from building an MDP with 4e9 actions.
MAX_LEVELS = 53
# The largest world careful builds: its arrays grow with cells x actions, and a 2000x2000 layout
# in a 4 MB recording header would otherwise ask for tens of gigabytes. Checked on the layout,
# before anything is allocated. 128x128 with 14 levels fits (917,504 state-actions, a few
# hundred MB at most for a fit).
MAX_CELLS = 16_384
MAX_STATE_ACTIONS = 1_000_000
# Rewards, the cost of the most careful move and the initial score are at most this large, and an
# episode at most MAX_STEPS long, so every score, return and value stays a finite number JSON holds.
MAX_MAGNITUDE = 1e12
MAX_STEPS = 1_000_000

# The fields only a time world has, and the ones only a level world has: each kind's header and
# TOML hold its own (a level world's file reads and writes exactly as before time worlds existed).
TIME_FIELDS = ("care", "p0", "p_inf", "tau_ms", "cost_per_second", "max_hold_ms", "duration_bins_ms", "show_hold")
LEVEL_FIELDS = ("levels", "cost_per_level", "slip")
# Fields a world's header leaves out at their default, so that a world without them writes and reads
# exactly as before they existed.
QUIET_DEFAULTS = {"bump": "stay"}
# A bin starting at 0 ms has its geometric mid-point computed as if it started here: no key is
# held for less than the time a press takes to register.
SHORTEST_HOLD_MS = 20.0
DEFAULT_DURATION_BINS = 16


def default_duration_bins(max_hold_ms: float, *, bins: int = DEFAULT_DURATION_BINS) -> tuple[float, ...]:
    """(bins + 1,) edges: 0, then SHORTEST_HOLD_MS * r^k for k = 1..bins with r^bins = max_hold_ms / SHORTEST_HOLD_MS,
    rounded to the millisecond (the last is max_hold_ms itself)."""
    ratio = max_hold_ms / SHORTEST_HOLD_MS
    inner = [float(round(SHORTEST_HOLD_MS * ratio ** (k / bins))) for k in range(1, bins)]
    return (0.0, *inner, float(max_hold_ms))


class SlipSplit(BaseModel):
    """A fixed slip (another lab's task): the chosen direction with `intended`, the other three with `others`,
    listed in the order left, up, right, down with the chosen one left out; the same at every level."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    intended: float = Field(ge=0, le=1)
    others: tuple[float, float, float]

    @model_validator(mode="after")
    def _split_is_a_distribution(self) -> SlipSplit:
        # A world file's split is checked (with its field named) before it gets here; this keeps one made in code honest.
        if problem := slip_split_problem({"intended": self.intended, "others": list(self.others)}):
            raise ValueError(problem)
        return self

    def chances(self, chosen: int) -> tuple[float, float, float, float]:
        """The chance of each realised direction (in action order, `DIRECTIONS`) when `chosen` (0..3) is."""
        others = iter(self.others)
        by_name = {name: self.intended if name == DIRECTIONS[chosen] else next(others) for name in SPLIT_ORDER}
        up, right, down, left = (by_name[name] for name in DIRECTIONS)
        return up, right, down, left

    def to_toml(self) -> str:
        return f"{{intended = {self.intended!r}, others = [{', '.join(repr(p) for p in self.others)}]}}"


def slip_split_problem(slip: object) -> str | None:
    """What is wrong with a world file's `slip` (None: nothing), as `slip...: problem`, the field named."""
    if isinstance(slip, str):
        return None if slip in ("halving", "none") else (
            f'slip: {printable(slip, limit=VALUE_LIMIT)!r} is not "halving", "none" or a table '
            "{intended = ..., others = [left, up, right, down without the intended one]}")
    if isinstance(slip, SlipSplit):
        return None
    if not isinstance(slip, dict):
        return 'slip: must be "halving", "none" or a table {intended = ..., others = [...]}'
    unknown = sorted(set(slip) - {"intended", "others"})
    if unknown:
        return f"slip.{printable(str(unknown[0]), limit=VALUE_LIMIT)}: not a field of a slip (intended, others)"
    for name in ("intended", "others"):
        if name not in slip:
            return f"slip.{name}: missing (a fixed slip gives intended and others)"
    intended, others = slip["intended"], slip["others"]
    if not _is_number(intended):
        return "slip.intended: must be a number"
    if not isinstance(others, list | tuple) or not all(_is_number(p) for p in others):
        return "slip.others: must be a list of three numbers (left, up, right, down without the intended one)"
    if len(others) != 3:
        return (f"slip.others: {plural(len(others), 'chance')}; a move has three other directions (left, up, right, "
                "down without the intended one)")
    for name, value in (("intended", intended), *((f"others[{i}]", p) for i, p in enumerate(others))):
        if not math.isfinite(value) or value < 0:
            return f"slip.{name}: {value!r} is not a chance (at least 0)"
    total = math.fsum([intended, *others])
    if abs(total - 1.0) > SPLIT_SUM_TOLERANCE:
        return f"slip.others: {list(others)} with intended {intended!r} sum to {total:.12g}, not 1"
    return None


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


class World(BaseModel):
    """One gridworld, exactly as docs/worlds.md and the recordings' headers describe it."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    # Numbers are strict: `levels = true` or `gamma = "0.9"` is a mistake to report, not to guess.
    name: str = Field("custom", strict=True)
    layout: str = Field(strict=True)
    levels: int = Field(14, ge=1, le=MAX_LEVELS, strict=True)
    cost_per_level: float = Field(1.0, ge=0, strict=True)
    gamma: float = Field(0.95, ge=0, lt=1, strict=True)
    slip: Literal["halving", "none"] | SlipSplit = Field("halving", union_mode="left_to_right")
    bump: Literal["stay", "drop"] = "stay"
    terminal: tuple[str, ...] = ("C", "G")
    start: Literal["random"] | tuple[int, int] = "random"
    initial_score: float = Field(200.0, strict=True, ge=-MAX_MAGNITUDE, le=MAX_MAGNITUDE)
    max_steps: int = Field(200, ge=1, le=MAX_STEPS, strict=True)
    rewards: dict[str, float] = Field(default_factory=dict)
    # A time world's fields (docs/timing.md); a level world has their defaults and never shows them.
    care: Literal["levels", "time"] = "levels"
    p0: float = Field(0.5, ge=0, le=1, strict=True)
    p_inf: float = Field(0.0, ge=0, le=1, strict=True)
    tau_ms: float = Field(400.0, gt=0, le=MAX_MAGNITUDE, strict=True)
    cost_per_second: float = Field(5.0, ge=0, le=MAX_MAGNITUDE, strict=True)
    max_hold_ms: float = Field(4000.0, ge=50, le=3_600_000, strict=True)
    duration_bins_ms: tuple[float, ...] | None = None
    show_hold: bool = Field(False, strict=True)

    @model_validator(mode="before")
    @classmethod
    def _fields_of_its_kind(cls, data: Any) -> Any:
        """A time world gives no levels (its bins are its levels); a level world gives no time field."""
        if not isinstance(data, dict):
            return data
        if "slip" in data and (problem := slip_split_problem(data["slip"])):
            raise ValueError(problem)
        if "bump" in data and data["bump"] not in ("stay", "drop"):
            bump = data["bump"]
            shown = printable(bump, limit=VALUE_LIMIT) if isinstance(bump, str) else type(bump).__name__
            raise ValueError(f'bump: {shown!r} is neither "stay" (a move into a wall is a step that stays) nor '
                             '"drop" (no step is made)')
        if data.get("care", "levels") == "time" and data.get("bump", "stay") != "stay":
            raise ValueError('bump: a time world (care = "time") has bump = "stay" only')
        if data.get("care", "levels") != "time":
            for name in TIME_FIELDS[1:]:
                if name in data:
                    raise ValueError(f'{name}: only a time world (care = "time") has this field')
            return data
        for name in LEVEL_FIELDS:
            if name in data:
                raise ValueError(f'{name}: a time world (care = "time") has no {name}: care is how long the key '
                                 "is held (remove the field)")
        data = dict(data)
        max_hold = data.get("max_hold_ms", 4000.0)
        if data.get("duration_bins_ms") is None and isinstance(max_hold, int | float) and max_hold >= 50:
            data["duration_bins_ms"] = default_duration_bins(float(max_hold))
        bins = data.get("duration_bins_ms")
        data["levels"] = min(max(len(bins) - 1, 1), MAX_LEVELS) if isinstance(bins, list | tuple) else 1
        data["cost_per_level"] = 0.0
        return data

    @model_serializer(mode="wrap")
    def _dump_its_kind(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        data = handler(self)
        drop = LEVEL_FIELDS if self.care == "time" else TIME_FIELDS
        return {key: value for key, value in data.items()
                if key not in drop and not (key in QUIET_DEFAULTS and value == QUIET_DEFAULTS[key])}

    @field_validator("layout")
    @classmethod
    def _layout_is_rectangular(cls, layout: str) -> str:
        rows = _layout_rows(layout)
        if not rows:
            raise ValueError("the layout has no rows")
        if len(rows) * len(rows[0]) > MAX_CELLS:
            raise ValueError(
                f"the layout has {len(rows)}x{len(rows[0])} = {len(rows) * len(rows[0]):,} cells; careful handles "
                f"at most {MAX_CELLS:,} (128x128)"
            )
        widths = {len(row) for row in rows}
        if len(widths) != 1:
            ragged = next(i for i, row in enumerate(rows) if len(row) != len(rows[0]))
            raise ValueError(
                f"the layout is ragged: row 0 has {plural(len(rows[0]), 'cell')} but row {ragged} has {len(rows[ragged])}"
            )
        if any(ch.isspace() for row in rows for ch in row):
            raise ValueError("the layout contains a space inside a row; use '.' for ground")
        if not all(row.isprintable() for row in rows):
            raise ValueError("the layout contains a control or invisible character; cells are printable symbols")
        return "\n".join(rows) + "\n"

    @field_validator("start", mode="before")
    @classmethod
    def _start_is_random_or_a_cell(cls, start: object) -> object:
        # Without this the union reports its first branch: "start.literal['random']: Input should be 'random'".
        if (isinstance(start, str) and start == "random") or (
            isinstance(start, list | tuple)
            and len(start) == 2
            and all(isinstance(x, int) and not isinstance(x, bool) for x in start)
        ):
            return start
        raise ValueError('must be "random" or a cell [row, col] of two integers')

    @field_validator("terminal")
    @classmethod
    def _terminal_symbols_are_single(cls, terminal: tuple[str, ...]) -> tuple[str, ...]:
        for symbol in terminal:
            if len(symbol) != 1:
                raise ValueError(f"terminal symbol {symbol!r} is not one character")
        return terminal

    @field_validator("rewards")
    @classmethod
    def _rewards_are_bounded(cls, rewards: dict[str, float]) -> dict[str, float]:
        for symbol, reward in rewards.items():
            if not abs(reward) <= MAX_MAGNITUDE:
                raise ValueError(f"the reward of {symbol!r} is {reward:g}; rewards are at most {MAX_MAGNITUDE:g} in size")
        return rewards

    @model_validator(mode="after")
    def _consistent(self) -> World:
        if self.care == "time":
            self._check_time_fields()
        state_actions = (self.rows * self.cols + 1) * 4 * self.levels
        if state_actions > MAX_STATE_ACTIONS:
            raise ValueError(
                f"{self.rows}x{self.cols} cells with {self.levels} levels make {state_actions:,} state-actions; "
                f"careful handles at most {MAX_STATE_ACTIONS:,} (fewer cells or fewer levels)"
            )
        if self.care == "levels" and not self.cost_per_level * self.levels <= MAX_MAGNITUDE:
            raise ValueError(
                f"cost_per_level {self.cost_per_level:g} x {plural(self.levels, 'level')} is "
                f"{self.cost_per_level * self.levels:g}; "
                f"the most careful move may cost at most {MAX_MAGNITUDE:g}"
            )
        symbols = {ch for row in self.grid for ch in row}
        for symbol in self.rewards:
            if len(symbol) != 1:
                raise ValueError(f"reward symbol {symbol!r} is not one character")
            if symbol not in symbols:
                raise ValueError(f"a reward is given for {printable(symbol)!r}, which the layout does not use")
            if symbol == WALL:
                raise ValueError("a wall '#' is not a state and cannot have a reward")
        if self.start == "random" and not any(ch != WALL and ch not in self.terminal for row in self.grid for ch in row):
            raise ValueError("there is no cell to start from: every cell is a wall or terminal")
        if self.start != "random":
            r, c = self.start
            if not (0 <= r < self.rows and 0 <= c < self.cols):
                raise ValueError(f"start {list(self.start)} is outside the {self.rows}x{self.cols} grid")
            symbol = self.grid[r][c]
            if symbol == WALL:
                raise ValueError(f"start {list(self.start)} is a wall")
            if symbol in self.terminal:
                raise ValueError(f"start {list(self.start)} is a terminal cell {symbol!r}")
        return self

    def _check_time_fields(self) -> None:
        if self.p_inf > self.p0:
            raise ValueError(f"p_inf: {self.p_inf:g} is above p0 {self.p0:g}: a longer hold may not slip more often")
        bins = self.duration_bins_ms or ()
        if len(bins) < 2 or len(bins) - 1 > MAX_LEVELS:
            raise ValueError(f"duration_bins_ms: {plural(max(len(bins) - 1, 0), 'bin')}; a time world has 1 to "
                             f"{MAX_LEVELS} bins (2 to {MAX_LEVELS + 1} edges)")
        if bins[0] != 0 or bins[-1] != self.max_hold_ms or any(b <= a for a, b in zip(bins, bins[1:])):
            raise ValueError(f"duration_bins_ms: the edges must rise from 0 to max_hold_ms ({self.max_hold_ms:g})")

    # A property, not cached: `model_copy(update=...)` would carry a cached value over unchanged.
    @property
    def bin_mids_ms(self) -> tuple[float, ...]:
        """(L,) a time world's bins' geometric mid-points in ms (a bin from 0 counts from SHORTEST_HOLD_MS)."""
        edges = self.duration_bins_ms or ()
        return tuple(math.sqrt(max(lo, SHORTEST_HOLD_MS) * hi) for lo, hi in zip(edges, edges[1:]))

    def hold_slip_chance(self, hold_ms: ArrayLike) -> np.ndarray:
        """p(d) for holds (...) in ms, capped at max_hold_ms: a time world's chance that the move goes another way."""
        d = np.minimum(np.asarray(hold_ms, dtype=float), self.max_hold_ms)
        return self.p_inf + (self.p0 - self.p_inf) * np.exp(-d / self.tau_ms)

    def hold_cost(self, hold_ms: ArrayLike) -> np.ndarray:
        """(...) a time world's cost (positive) of holds (...) in ms, capped at max_hold_ms."""
        return self.cost_per_second * np.minimum(np.asarray(hold_ms, dtype=float), self.max_hold_ms) / 1000.0

    def bin_of(self, hold_ms: ArrayLike) -> np.ndarray:
        """(...) the index of the duration bin holding each hold (...) in ms; max_hold_ms and beyond: the last."""
        inner = np.asarray(self.duration_bins_ms or (0.0, self.max_hold_ms), dtype=float)[1:-1]
        return np.searchsorted(inner, np.asarray(hold_ms, dtype=float), side="right")

    @property
    def level_costs(self) -> tuple[float, ...]:
        """(L,) the cost (positive) of each carefulness level 1..L, or of each duration bin's mid-point."""
        if self.care == "time":
            return tuple(float(cost) for cost in self.hold_cost(self.bin_mids_ms))
        return tuple(self.cost_per_level * c for c in range(1, self.levels + 1))

    @property
    def slip_chances(self) -> tuple[float, ...]:
        """(L,) the chance that a move of each level 1..L (or duration bin) goes another way than chosen:
        2^-c with halving slip, 0 without, p(mid-point) on a time world."""
        if self.care == "time":
            return tuple(float(p) for p in self.hold_slip_chance(self.bin_mids_ms))
        if isinstance(self.slip, SlipSplit):
            return (1.0 - self.slip.intended,) * self.levels
        if self.slip == "none":
            return (0.0,) * self.levels
        return tuple(2.0**-c for c in range(1, self.levels + 1))

    @property
    def slip_is_fixed(self) -> bool:
        """Whether every level slips alike by the world file's own split (another lab's task): care then only costs."""
        return isinstance(self.slip, SlipSplit)

    def direction_split(self) -> np.ndarray:
        """(L, 4, 4) the chance [c - 1, d, k] that a level-c move chosen in direction d goes in direction k
        (action order, `DIRECTIONS`), before a wall or the grid's edge has its say (`bump`). A fixed slip gives
        its own split; every other slip shares a level's slip chance evenly over the other three directions."""
        if isinstance(self.slip, SlipSplit):
            one = np.array([self.slip.chances(d) for d in range(4)])
            return np.broadcast_to(one, (self.levels, 4, 4)).copy()
        other = np.asarray(self.slip_chances, dtype=float)[:, None, None] / 3.0
        eye = np.eye(4)[None, :, :]
        return eye * (1.0 - 3.0 * other) + (1.0 - eye) * other

    @property
    def slip_label(self) -> str:
        """The slip in a table's cell or a title: ``halving``, ``none`` or ``0.76/0.09/0.05/0.1`` (a fixed
        split: the chosen way, then the others), with ``, bump drop`` when moves into a wall are dropped."""
        slip = (f"{self.slip.intended:g}/" + "/".join(f"{p:g}" for p in self.slip.others)
                if isinstance(self.slip, SlipSplit) else self.slip)
        return slip + (", bump drop" if self.bump == "drop" else "")

    def describe_slip(self) -> str:
        """The world's slip in words, for a status line or a figure's caption."""
        if self.care == "time":
            return f"a hold of d ms slips with p0 {self.p0:g}, p_inf {self.p_inf:g}, tau {self.tau_ms:g} ms"
        if isinstance(self.slip, SlipSplit):
            others = " / ".join(f"{p:g}" for p in self.slip.others)
            return (f"fixed at every level: the chosen way {self.slip.intended:g}, the others {others} "
                    "(in the order left, up, right, down, the chosen one left out)")
        return ("halving: a level-c move goes another way with chance 2^-c, a third of it to each other direction"
                if self.slip == "halving" else "none: every move goes where it is aimed")

    def describe_bump(self) -> str:
        """What a move into a wall or off the grid does, in words."""
        if self.bump == "drop":
            return "drop: a move into a wall or off the grid is not made and not recorded"
        return "stay: a move into a wall or off the grid is a step that stays"

    @cached_property
    def grid(self) -> list[str]:
        """The layout's rows, top to bottom."""
        return _layout_rows(self.layout)

    @property
    def rows(self) -> int:
        return len(self.grid)

    @property
    def cols(self) -> int:
        return len(self.grid[0])

    def symbol(self, cell: tuple[int, int]) -> str:
        return self.grid[cell[0]][cell[1]]

    def reward_of(self, symbol: str) -> float:
        """R_S for a symbol (0 when the world lists none)."""
        return float(self.rewards.get(symbol, 0.0))

    @cached_property
    def cells(self) -> list[tuple[int, int]]:
        """Every cell that is a state (not a wall), in row-major order."""
        return [(r, c) for r, row in enumerate(self.grid) for c, ch in enumerate(row) if ch != WALL]

    @property
    def start_cells(self) -> list[tuple[int, int]]:
        """Cells an episode may start from: a fixed start, or every non-terminal state."""
        if self.start != "random":
            row, col = self.start
            return [(row, col)]
        return [cell for cell in self.cells if self.symbol(cell) not in self.terminal]

    def to_toml(self) -> str:
        """The world as a TOML file that `load_world` reads back to an equal world."""
        start = '"random"' if self.start == "random" else f"[{self.start[0]}, {self.start[1]}]"
        if self.care == "time":
            care = [
                'care = "time"', f"p0 = {self.p0!r}", f"p_inf = {self.p_inf!r}", f"tau_ms = {self.tau_ms!r}",
                f"cost_per_second = {self.cost_per_second!r}", f"max_hold_ms = {self.max_hold_ms!r}",
                "duration_bins_ms = [" + ", ".join(repr(b) for b in self.duration_bins_ms or ()) + "]",
                f"show_hold = {str(self.show_hold).lower()}",
            ]
        else:
            care = [f"levels = {self.levels}", f"cost_per_level = {self.cost_per_level!r}"]
        slip = [] if self.care == "time" else [
            f"slip = {self.slip.to_toml() if isinstance(self.slip, SlipSplit) else toml_str(self.slip)}"]
        bump = [] if self.bump == "stay" else [f"bump = {toml_str(self.bump)}"]
        lines = [
            f"name = {toml_str(self.name)}",
            f'layout = """\n{toml_escape(self.layout, keep_newlines=True)}"""',
            *care,
            f"gamma = {self.gamma!r}",
            *slip,
            *bump,
            "terminal = [" + ", ".join(toml_str(t) for t in self.terminal) + "]",
            f"start = {start}",
            f"initial_score = {self.initial_score!r}",
            f"max_steps = {self.max_steps}",
            "[rewards]",
            *(f"{toml_str(k)} = {v!r}" for k, v in self.rewards.items()),
        ]
        return "\n".join(lines) + "\n"


def _layout_rows(layout: str) -> list[str]:
    return [row.strip() for row in layout.strip("\n").splitlines() if row.strip()]


_PAPER_LAYOUT = "......\n......\n......\n.CCCCG\n"
_MUD_LAYOUT = "......\n.UU...\n......\n.CCCCG\n"
_PAPER_REWARDS = {"C": -1000.0, "G": 100.0}
_MUD_REWARDS = {"C": -1000.0, "G": 100.0, "U": -30.0}
# Gymnasium's CliffWalking-v1 (gymnasium/envs/toy_text/cliffwalking.py): 4x12, start bottom-left, the
# cliff along the bottom between it and the goal. Its -1 a step is carefulness 1's cost and its cliff's
# -100 the cliff's reward; the differences (the cliff ends the episode, moves slip, levels) are in
# docs/environment.md.
_CLIFFWALKING_LAYOUT = "............\n............\n............\n.CCCCCCCCCCG\n"

BUILTIN_WORLDS: dict[str, World] = {
    "paper": World(name="paper", layout=_PAPER_LAYOUT, levels=14, rewards=_PAPER_REWARDS),
    "paper-simple": World(name="paper-simple", layout=_PAPER_LAYOUT, levels=1, rewards=_PAPER_REWARDS),
    "paper-maxent": World(
        name="paper-maxent", layout=_PAPER_LAYOUT, levels=1, slip="none", rewards=_PAPER_REWARDS
    ),
    "mud": World(name="mud", layout=_MUD_LAYOUT, levels=14, rewards=_MUD_REWARDS),
    "mud-simple": World(name="mud-simple", layout=_MUD_LAYOUT, levels=1, rewards=_MUD_REWARDS),
    "cliffwalking": World(
        name="cliffwalking", layout=_CLIFFWALKING_LAYOUT, levels=14, start=(3, 0), rewards={"C": -100.0, "G": 0.0}
    ),
    "paper-time": World(name="paper-time", layout=_PAPER_LAYOUT, care="time", rewards=_PAPER_REWARDS),
    "mud-time": World(name="mud-time", layout=_MUD_LAYOUT, care="time", rewards=_MUD_REWARDS),
    "walls": World.model_validate(tomllib.loads((Path(__file__).parent / "walls.toml").read_text("utf-8"))),
}

WORLD_PURPOSES: dict[str, str] = {
    "paper": "the paper's careful setting",
    "paper-simple": "four actions, no carefulness choice",
    "paper-maxent": "the MaxEnt baseline's deterministic world",
    "mud": "catastrophic vs merely undesirable",
    "mud-simple": "the same without carefulness",
    "cliffwalking": "Gymnasium's CliffWalking layout, for code written for it",
    "paper-time": "the paper's layout; care is how long the key is held",
    "mud-time": "mud's layout; care is how long the key is held",
    "walls": "walls, mud, a corridor beside the cliff",
}


def world_from_dict(data: dict, *, source: str = "world") -> World:
    """Validate a world given as a mapping (a TOML table or a recording's header); a reach world is refused
    in one line (`irl_core.worlds.reach` reads those)."""
    if is_reach_data(data):
        raise WorldError(f"{source} {REFUSED}")
    try:
        return World.model_validate(data)
    except ValidationError as exc:
        raise WorldError(f"{source}: {describe_validation_error(exc)}") from None


def load_world(name_or_path: str | Path) -> World:
    """A built-in world by name, or a world read from a TOML file.

    Raises `WorldError` with a one-line message for an unknown name, an unreadable
    file, bad TOML, a world that fails validation or a reach world (`irl_core.worlds.reach`).
    """
    key = str(name_or_path)
    if key in BUILTIN_WORLDS:
        return BUILTIN_WORLDS[key]
    if key in REACH_WORLDS:
        raise WorldError(f"{key} {REFUSED}")
    path = Path(key)
    if problem := reference_problem(key):
        raise WorldError(f"no world named {printable(key, limit=VALUE_LIMIT)!r}, and it cannot be a file: {problem}")
    if not path.exists():
        known = ", ".join(BUILTIN_WORLDS)
        raise WorldError(f"no world named {printable(key, limit=VALUE_LIMIT)!r} and no such file (built-in worlds: {known})")
    try:
        # A world file bigger than this cannot hold a world within MAX_CELLS.
        data = read_toml(path, what="world", limit=_MAX_WORLD_FILE_BYTES, too_big=f"a world has at most {MAX_CELLS:,} cells")
    except ValueError as exc:
        raise WorldError(str(exc)) from None
    data.setdefault("name", path.stem)
    return world_from_dict(data, source=str(path))


_MAX_WORLD_FILE_BYTES = 16 << 20
