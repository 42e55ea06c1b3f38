"""`FitOptions`: the settings of one fit, in one shape from the command line to the JSON.

The command line builds it once from its arguments, the fit view changes it with
`dataclasses.replace` to refit, `fit` reads it, and `FitResult.options` keeps it, written
to the JSON under the fit JSON's names (docs/fit-json.md; ``lambda`` for `lam`).

``beta`` is a number or ``"auto"`` (estimated with R_S); ``None`` means the method's
default: 1.0 for ``maxent``, ``"auto"`` when ``auto`` falls back to maxent.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import irl_core.irl.choices as choices
from irl_core.irl.choices import AUTO as PLAYER_AUTO
from irl_core.irl.choices import MethodName, PlayerModelName, RewardCells, player_model
from irl_core.irl.intervals.calibrated import Calibration
from irl_core.irl.notes import Note

MIN_RESAMPLES = 20
DEFAULT_BETA = 1.0


@dataclass(frozen=True)
class FitOptions:
    """One fit's settings, as `careful fit` names them (`lam` is ``--lambda``).

    Attributes:
        method: a name in `irl_core.irl.choices` (``auto``, ``lp``, ``loss``, ``maxent``);
            ``auto`` by default, as for `careful fit`.
        rmax: the bound |R_S| <= rmax.
        lam: the L1 penalty lambda on R_S (lp and loss).
        beta: maxent's inverse temperature, ``"auto"`` to estimate it, or None for the default.
        player_model: maxent's model of the player (`irl_core.irl.choices`: ``boltzmann``, the paper's
            expert; ``ends``, ``hand``, ``person``, ``naive``, models of people), ``"auto"`` to choose one by
            held-out episodes, or None for the default: ``auto`` after method auto, ``boltzmann`` for maxent.
        reward_cells: ``special`` or ``all``.
        tie: one unknown per symbol.
        intervals: compute an interval per unknown.
        confidence: the confidence level of maxent's and loss's intervals, in (0, 1).
        resamples: bootstrap resamples for those intervals (at least 20).
        seed: the bootstrap's seed.
        slip_known: on a time world, plan with the world's slip curve instead of fitting it (docs/timing.md).
        cost: on a time world, ``known`` (rewards in points) or ``unknown`` (rewards in seconds of holding).
        known: (symbol, value) pairs: rewards the user knows, held at that value instead of fitted, which fixes
            the units where nothing in the world does (`irl_core.irl.identification`).
        union: with a player model chosen by held-out episodes, join the intervals of every candidate model they
            do not tell from the chosen one (`people.choice.close_models`), not only the other planning assumption.
        calibration: scales learned by `careful check` that widen the intervals until they reach their level
            for the players it checked (`irl_core.irl.intervals.calibrated`), or None.
    """

    method: MethodName = choices.DEFAULT
    rmax: float = 1000.0
    lam: float = 0.0
    beta: float | Literal["auto"] | None = None
    player_model: PlayerModelName | Literal["auto"] | None = None
    reward_cells: RewardCells = "special"
    tie: bool = False
    intervals: bool = False
    confidence: float = 0.95
    resamples: int = 200
    seed: int = 0
    slip_known: bool = False
    cost: Literal["known", "unknown"] = "known"
    known: tuple[tuple[str, float], ...] = ()
    union: bool = False
    calibration: Calibration | None = None

    def __post_init__(self) -> None:
        choices.method(self.method)
        if not self.rmax > 0:
            raise ValueError("rmax must be positive")
        if not self.lam >= 0:
            raise ValueError("lambda must be zero or more")
        if self.beta is not None and self.beta != "auto" and not float(self.beta) > 0:
            raise ValueError(f"beta must be positive or 'auto', not {self.beta!r}")
        if self.player_model is not None and self.player_model != PLAYER_AUTO:
            player_model(self.player_model)
        if self.cost not in ("known", "unknown"):
            raise ValueError(f"cost must be 'known' or 'unknown', not {self.cost!r}")

    def problem(self) -> Note | None:
        """Why these options are bad input (a `Note` whose sentence is for the user), or None.

        `fit` does not refuse them (the fit view switches methods freely); the command line does.
        """
        if self.beta == "auto" and not choices.method(self.method).uses_beta:
            return Note("beta_needs_maxent", f"{{beta=auto}} needs {{method=maxent}} or auto: {self.method} has no "
                                             "temperature to estimate")
        if isinstance(self.beta, (int, float)) and self.player_model not in (None, "boltzmann"):
            return Note("beta_needs_boltzmann", f"a fixed {{beta}} needs {{player_model=boltzmann}}: the player model "
                                                f"{self.player_model} estimates beta with the rewards")
        if not 0 < self.confidence < 1:
            return Note("bad_confidence", f"{{confidence}} must lie strictly between 0 and 1, not {self.confidence:g}")
        if self.resamples < MIN_RESAMPLES:
            return Note("too_few_resamples", f"{{resamples}} must be at least {MIN_RESAMPLES} for a usable interval, "
                                             f"not {self.resamples}")
        return None

    def maxent_beta(self, *, chosen_by_auto: bool) -> float | Literal["auto"]:
        """The beta maxent runs with: the given one, else auto after `auto`, else 1.0."""
        if self.beta is not None:
            return self.beta
        return "auto" if chosen_by_auto else DEFAULT_BETA

    def describe(self) -> str:
        """The method and whether intervals are on, for messages: "loss, with intervals"."""
        return f"{self.method}{', with intervals' if self.intervals else ''}"

    def to_json(self) -> dict[str, Any]:
        """The fit JSON's option names (docs/fit-json.md) and values (beta as given; the fit replaces it by what it used)."""
        return {
            "rmax": self.rmax,
            "lambda": self.lam,
            "beta": self.beta,
            "player_model": self.player_model,
            "reward_cells": self.reward_cells,
            "tie": self.tie,
            "intervals": self.intervals,
            "confidence": self.confidence,
            "resamples": self.resamples,
            "seed": self.seed,
            # A time world's two (a fit on levels refuses them, and its JSON does not show them).
            **({"slip_known": self.slip_known, "cost": self.cost} if self.slip_known or self.cost != "known" else {}),
            **({"known": dict(self.known)} if self.known else {}),
            **({"union": True} if self.union else {}),
            **({"calibration": dict(self.calibration.scales)} if self.calibration is not None else {}),
        }
