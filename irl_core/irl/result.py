"""The one result of every fit (the errors a fit can end with are in `irl_core.errors`, and importable here).

A `FitResult` holds what `careful fit` shows and writes: the fitted reward on the grid,
which cells were fitted, their intervals, the demonstrated policy, how much was read,
the solver's status and time, and notes a researcher should read (`Note`, e.g. ``not_unique``).
`to_json()` is the fit JSON (docs/fit-json.md), key for key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, overload

import numpy as np

# The errors a fit ends with, importable here as before (`irl_core.irl` exports them from here).
from irl_core.errors import BadInputError, FitError, InfeasibleError, SolverError  # noqa: F401
from irl_core.irl.choices import Player
from irl_core.irl.evaluation import Evaluation
from irl_core.irl.fit_check import FitCheck
from irl_core.irl.identification import Scale
from irl_core.irl.notes import Note
from irl_core.irl.options import DEFAULT_BETA, FitOptions
from irl_core.irl.qmap import Unknowns
from irl_core.irl.timing.slip_curve import SlipCurve
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import MDP, action_parts
from irl_core.worlds.world import WALL, World

# How near ±rmax a value must be, relative to rmax, to be "at the bound". A value the box decided
# is exactly ±rmax from the simplex and from maxent's L-BFGS-B (which projects onto the box), but the
# loss's cutting planes stop at a relative gap of up to 1e-6 (`loss.STALL_TOLERANCE`) and a bootstrap
# end interpolates between refits, so an end the bound set can sit a few millionths of rmax inside it
# (-999.99948 at rmax 1000, tests/irl/test_at_bound.py). 1e-5 of rmax is ten times that and well
# below the three or four figures a reading shows (0.01 at rmax 1000), yet it does not take in a
# value the data set 5e-5 of rmax inside the bound (that test's fit, which --rmax 2000 moves to -987).
AT_BOUND_TOLERANCE = 1e-5


@overload
def at_bound(value: float, rmax: float) -> bool: ...
@overload
def at_bound(value: np.ndarray, rmax: float) -> np.ndarray: ...
def at_bound(value: float | np.ndarray, rmax: float) -> bool | np.ndarray:
    """Whether `value` (elementwise for an array) lies at the ±rmax box: there the bound, not the
    demonstrations, set it. The one test of it: fits, readings, captions and figures all ask here."""
    return np.abs(value) >= rmax * (1 - AT_BOUND_TOLERANCE)


@dataclass(frozen=True)
class PolicyCell:
    """The most frequent demonstrated action at one cell, and how often it was taken."""

    direction: str
    carefulness: int
    count: int


@dataclass(frozen=True, eq=False)
class FitResult:
    """A fitted reward and everything needed to show or save it.

    Attributes:
        method: the method used, a fitting entry of `irl_core.irl.choices` (``auto`` chooses one).
        options: the fit's settings as asked (`FitOptions`; ``options.method`` may be ``auto``).
        beta: maxent's beta (estimated with ``beta_auto``); None for lp and loss.
        beta_auto: whether beta was estimated.
        R_S: (S,) fitted state rewards (known cells at their fixed value, 0 at the exit).
        V: (S,) the values that came with the fit (the LP's or loss's V, maxent's soft V).
        theta: (k,) the fitted unknowns.
        unknowns: which state rewards theta stands for (labels, basis).
        intervals: (k, 2) [low, high] per unknown, or None when not computed.
        interval_kind: ``identified`` (lp: every value the demonstrations allow) or ``confidence``
            (maxent, loss: a bootstrap confidence interval), None without intervals.
        interval_method: how they were made: ``identified``, ``bootstrap``, ``two-level bootstrap`` or
            ``sandwich``, with ``+union`` (joined with a rival planning model's) and ``+calibrated`` (widened by
            careful check's scales) where those apply; None without intervals.
        demos: the demonstrations fitted (their world, counts N(s, a) and sizes).
        evaluation: what an agent that plans for the fitted reward does in the true world.
        status: ``optimal`` or the solver's word for a usable but imperfect answer.
        elapsed_s: wall-clock seconds the fit took (intervals included).
        notes: what the reader should know (`Note`: a code and a sentence): the method auto chose,
            non-uniqueness, rewards at the bound, ...
        player_model: maxent's model of the player (`irl_core.irl.choices`), None for lp and loss.
        player: that model's parameters besides the rewards (beta, the hand's sigma, the lapse rate).
        fit_check: whether the fitted player reproduces the recordings (`irl_core.irl.fit_check`),
            None where no check was made (lp and loss, whose answers are not a model of play).
        rival_model: where held-out episodes cannot tell whether the player plans for the hand, the other
            planning model (``person`` or ``naive``), whose rewards the intervals also cover; else None.
        rival_theta: (k,) that model's fitted unknowns, or None.
        slip_curve: on a time world, the slip curve the fit planned with (fitted, or the world's with
            ``slip_known``); `demos` then sit on the world with that curve (and a cost per second of 1 when the
            cost is unknown: rewards in seconds of holding).
        recorded_world: the world the recordings name, when the fit planned in another (the JSON's ``world``).
    """

    method: str
    options: FitOptions
    beta: float | None
    beta_auto: bool
    R_S: np.ndarray
    V: np.ndarray
    theta: np.ndarray
    unknowns: Unknowns
    intervals: np.ndarray | None
    interval_kind: str | None
    demos: Demonstrations
    evaluation: Evaluation
    status: str
    elapsed_s: float
    notes: list[Note] = field(default_factory=list)
    player_model: str | None = None
    player: Player | None = None
    fit_check: FitCheck | None = None
    rival_model: str | None = None
    rival_theta: np.ndarray | None = None
    slip_curve: SlipCurve | None = None
    recorded_world: World | None = None
    scale: Scale = field(default_factory=Scale)
    interval_method: str | None = None

    @property
    def mdp(self) -> MDP:
        return self.demos.mdp

    @property
    def counts(self) -> np.ndarray:
        """(S, A) demonstrated action counts N(s, a)."""
        return self.demos.counts

    @property
    def demonstrations(self) -> dict[str, int]:
        """Files, episodes and steps read (the JSON's ``demonstrations``)."""
        return {"files": self.demos.files, "episodes": self.demos.episodes, "steps": self.demos.steps}

    @property
    def rmax(self) -> float:
        return self.options.rmax

    def options_json(self) -> dict[str, Any]:
        """The JSON's ``options``: the fit JSON's names, beta as used (maxent's estimate with ``beta_auto``)."""
        out = self.options.to_json()
        given = self.options.beta
        out["beta"] = self.beta if self.beta is not None else (given if isinstance(given, (int, float)) else DEFAULT_BETA)
        out["beta_auto"] = self.beta_auto
        out["player_model"] = self.player_model
        if self.slip_curve is not None:
            out.update(slip_known=self.options.slip_known, cost=self.options.cost)
        if self.player is not None and self.player_model is not None and self.player_model != "boltzmann":
            out["sigma"] = self.player.sigma
            out["lapse"] = self.player.lapse
            if self.player.bias:
                out["bias"] = self.player.bias
        return out

    @property
    def world(self) -> World:
        return self.mdp.world

    @property
    def labels(self) -> tuple[str, ...]:
        return self.unknowns.labels

    @property
    def unknown(self) -> np.ndarray:
        """(S,) True at states whose reward was fitted."""
        return self.unknowns.mask

    def grid(self, per_state: np.ndarray, fill: float = np.nan) -> np.ndarray:
        """(rows, cols) from a per-state array (S,), `fill` at walls."""
        out = np.full((self.world.rows, self.world.cols), fill, dtype=float)
        for s, (r, c) in enumerate(self.mdp.cells):
            out[r, c] = per_state[s]
        return out

    @property
    def reward_grid(self) -> np.ndarray:
        """(rows, cols) each cell's own fitted reward, NaN at walls (a move's cost, where it is an unknown, is
        not in it: `move`)."""
        move = self.unknowns.move
        if move is None:
            return self.grid(self.R_S)
        return self.grid(self.R_S - self.unknowns.basis[:, [move]] @ self.theta[[move]])

    @property
    def move(self) -> tuple[float, np.ndarray | None] | None:
        """A move's cost as a reward relative to the reference, and its interval (2,) or None, where nothing fixes
        the units and every move costs the same (`irl_core.irl.qmap.MOVE`); None elsewhere."""
        move = self.unknowns.move
        if move is None:
            return None
        return float(self.theta[move]), None if self.intervals is None else self.intervals[move]

    @property
    def true_reward_grid(self) -> np.ndarray:
        """(rows, cols) the world's own R_S, NaN at walls (in the fit's `reward_unit`: on a time world whose
        cost was taken as unknown, in seconds of holding at the recorded world's cost)."""
        return self.grid(self.mdp.R_S * self.truth_factor)

    @property
    def truth_factor(self) -> float:
        """What the world's own rewards are multiplied by to be in the fit's `reward_unit` (NaN where they cannot
        be: a reference whose own reward in the world is 0)."""
        if self.reward_unit == "seconds of holding":
            return 1.0 / (self.recorded_world or self.world).cost_per_second
        if self.scale.reference is not None:
            own = self.world.rewards.get(self.scale.reference, 0.0)
            return 1.0 / own if own else float("nan")
        return 1.0

    def true_theta(self) -> np.ndarray:
        """(k,) the world's own rewards as the unknowns, in the fit's `reward_unit`."""
        return self.unknowns.true_theta(self.mdp) * self.truth_factor

    @property
    def unknown_grid(self) -> np.ndarray:
        """(rows, cols) bool, True at fitted cells."""
        return self.grid(self.unknown.astype(float), fill=0.0) > 0

    @property
    def interval_grid(self) -> np.ndarray:
        """(rows, cols, 2) [low, high] per cell, NaN where not computed."""
        out = np.full((self.world.rows, self.world.cols, 2), np.nan)
        if self.intervals is None:
            return out
        basis = self.unknowns.cell_basis.tocoo()
        for s, j in zip(basis.row, basis.col):
            out[self.mdp.cells[s]] = self.intervals[j]
        return out

    def policy_cells(self) -> dict[tuple[int, int], PolicyCell]:
        """The most frequent demonstrated action (lowest index among ties) at each demonstrated cell."""
        levels = self.world.levels
        out = {}
        for s, cell in enumerate(self.mdp.cells):
            if self.counts[s].sum() == 0:
                continue
            a = int(self.counts[s].argmax())
            direction, carefulness = action_parts(a, levels)
            out[cell] = PolicyCell(direction, carefulness, int(self.counts[s, a]))
        return out

    def to_json(self) -> dict[str, Any]:
        """The fit JSON (docs/fit-json.md): rows x cols grids with null at walls (and where undefined).

        ``policy`` gives, per demonstrated cell, the most frequent action and its count
        (how often that action was taken there); null at cells never acted in.
        """
        world = self.world
        wall = [[ch == WALL for ch in row] for row in world.grid]
        reward = self.reward_grid
        unknown = self.unknown_grid
        interval = self.interval_grid
        policy = self.policy_cells()
        return {
            "method": self.method,
            "world": (self.recorded_world or world).model_dump(mode="json"),
            "options": self.options_json(),
            "reward": [
                [None if wall[r][c] else _number(reward[r, c]) for c in range(world.cols)] for r in range(world.rows)
            ],
            "unknown": [[bool(unknown[r, c]) for c in range(world.cols)] for r in range(world.rows)],
            "interval": [
                [
                    None if np.isnan(interval[r, c]).any() else [_number(interval[r, c, 0]), _number(interval[r, c, 1])]
                    for c in range(world.cols)
                ]
                for r in range(world.rows)
            ],
            "interval_kind": self.interval_kind,
            "policy": [
                [
                    None
                    if (r, c) not in policy
                    else {
                        "direction": policy[(r, c)].direction,
                        "carefulness": policy[(r, c)].carefulness,
                        "count": policy[(r, c)].count,
                    }
                    for c in range(world.cols)
                ]
                for r in range(world.rows)
            ],
            "demonstrations": self.demonstrations,
            "evaluation": self.evaluation.to_json(),
            "status": self.status,
            "elapsed_s": round(float(self.elapsed_s), 4),
            "fit_check": None if self.fit_check is None else self.fit_check.to_json(),
            "notes": [str(note) for note in self.notes],
            "note_codes": [note.code for note in self.notes],
            # After the keys every fit has, as a time world's are: how the intervals were made, where there are any.
            **({} if self.interval_method is None else {"interval_method": self.interval_method}),
            **self._time_json(),
        }

    @property
    def reward_unit(self) -> str:
        """``points``; ``seconds of holding`` when a time world's cost was taken as unknown; ``relative to G`` when
        nothing fixes the units and G is the reference (`identification`)."""
        if self.slip_curve is not None and self.options.cost == "unknown":
            return "seconds of holding"
        return self.scale.unit

    def _time_json(self) -> dict[str, Any]:
        """``reward_unit`` where it is not points or the world is a time world, and a time world's ``slip_curve``."""
        out: dict[str, Any] = {}
        if self.move is not None:
            value, interval = self.move
            out["move"] = {"reward": _number(value),
                           "interval": None if interval is None else [_number(v) for v in interval]}
        if self.slip_curve is not None:
            out["slip_curve"] = self.slip_curve.to_json()
        if self.slip_curve is not None or self.reward_unit != "points":
            out["reward_unit"] = self.reward_unit
        return out


def _number(value: float) -> float:
    """A JSON number without solver dust: -0.0 and |x| < 1e-9 become 0.0."""
    value = float(value)
    return 0.0 if abs(value) < 1e-9 else value
