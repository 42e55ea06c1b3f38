"""A fit's choices, one registry entry each: the IRL methods `fit` knows and the models of the player.

Every reader of a method's or a player model's name reads it here: `FitOptions` checks a name
(`method`, `player_model` raise naming the choices), `careful fit --method` and ``--player-model`` offer
these choices with this help, the fit view binds each method to its key and titles it with its label,
and `fit` asks which interval a method has. Which player model a fit runs is decided once, by
`player_model_for`. The fitters themselves are a table of functions keyed by these names
(`irl_core.irl.fitters.FITTERS`, the bootstrap's `REFITS`); this module imports nothing heavy, so the
command line can read it before it needs numpy's solvers.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

IntervalKind = Literal["identified", "confidence"]
MethodName = Literal["auto", "lp", "loss", "maxent"]
PlayerModelName = Literal["boltzmann", "ends", "hand", "person", "naive", "timing"]
AUTO = "auto"
# Which cells a fit estimates: every non-ground cell (ground at 0), or every cell (`qmap.build_unknowns`).
RewardCells = Literal["special", "all"]


@dataclass(frozen=True)
class Method:
    """One method.

    Attributes:
        name: what `FitOptions.method`, ``--method`` and the fit JSON call it.
        key: the fit view's key for it.
        label: what the paper calls it, for the fit view's title ("" for a chooser).
        summary: what it does, in a few words (the command line's help).
        interval_kind: its intervals: ``identified`` (every value the demonstrations allow) or
            ``confidence`` (a bootstrap over episodes; maxent's timing model on a time world gives its own);
            None for a chooser, whose choice decides.
        uses_beta: it reads `FitOptions.beta` (a temperature, given or estimated).
        uses_lambda: it reads `FitOptions.lam` (the L1 penalty).
        chooser: it picks one of the others for the demonstrations given.
        resampled: its intervals resample episodes, each resample refitted (`irl_core.irl.intervals.bootstrap`'s
            `REFITS` holds its refit).
    """

    name: MethodName
    key: str
    label: str
    summary: str
    interval_kind: IntervalKind | None
    uses_beta: bool
    uses_lambda: bool
    resampled: bool = False
    chooser: bool = False


# In the fit view's key order (tab cycles through them in this order).
METHODS: dict[str, Method] = {m.name: m for m in (
    Method("auto", "a", "", "lp for a deterministic expert whose lp is feasible, else maxent with beta "
           "estimated (a person's noisy play)", None, uses_beta=True, uses_lambda=True, chooser=True),
    Method("lp", "l", "the simple IRL agent", "the paper's simple IRL agent", "identified",
           uses_beta=False, uses_lambda=True),
    Method("loss", "o", "the loss IRL agent", "its loss IRL agent", "confidence", uses_beta=False, uses_lambda=True,
           resampled=True),
    Method("maxent", "m", "the MaxEnt baseline", "the maximum-entropy baseline", "confidence",
           uses_beta=True, uses_lambda=False, resampled=True),
)}
NAMES: tuple[str, ...] = tuple(METHODS)
# The methods that fit (every one but the chooser).
FITTED: tuple[str, ...] = tuple(name for name, m in METHODS.items() if not m.chooser)
# The methods whose intervals resample episodes (a refit each).
RESAMPLED: tuple[str, ...] = tuple(name for name, m in METHODS.items() if m.resampled)
DEFAULT: MethodName = "auto"


def method(name: str) -> Method:
    """The entry of `name`; raises ValueError naming the choices for any other."""
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise ValueError(f"method must be one of {', '.join(NAMES)}, not {name!r}") from None


# The models of the player (`irl_core.irl.people` fits them; the model itself is its `likelihood`).

@dataclass(frozen=True)
class PlayerModel:
    """One entry of the player-model registry: which parts of the model are on."""

    name: PlayerModelName
    ends: bool
    hand: bool
    lapses: bool
    summary: str
    plans: bool = True
    # (bias, sigma) in levels when the hand is known (a study's motor calibration trials): then the fit
    # searches neither; None: sigma is estimated with the rewards and the bias is 0.
    known_hand: tuple[float, float] | None = None

    @property
    def searches_hand(self) -> bool:
        """The hand's sigma is one of the fit's variables (the model has a hand and it is not known)."""
        return self.hand and self.known_hand is None

    @property
    def extra_parameters(self) -> int:
        """Parameters beyond the rewards and beta."""
        return int(self.searches_hand) + int(self.lapses)

    def with_hand(self, hand: tuple[float, float] | None) -> PlayerModel:
        """This model with the hand (bias, sigma) known, when it has a hand; else itself."""
        return replace(self, known_hand=hand) if self.hand and hand is not None else self


PLAYER_MODELS: dict[str, PlayerModel] = {
    model.name: model
    for model in (
        PlayerModel("boltzmann", ends=False, hand=False, lapses=False,
                    summary="the paper's maxent expert: soft-optimal over (direction, level), its soft backup "
                            "running on after the episode's end"),
        PlayerModel("ends", ends=True, hand=False, lapses=False,
                    summary="soft-optimal over (direction, level), with nothing after the episode's end"),
        PlayerModel("hand", ends=True, hand=True, lapses=False,
                    summary="soft-optimal over direction and intended level, the hand adding noise to the level"),
        PlayerModel("person", ends=True, hand=True, lapses=True,
                    summary="as hand, and now and then a lapse: a random direction"),
        PlayerModel("naive", ends=True, hand=True, lapses=True, plans=False,
                    summary="as person, but planning as if the intended level were the realised one"),
        PlayerModel("timing", ends=True, hand=True, lapses=True,
                    summary="a time world's player, holding for continuous times around the best hold, the slip "
                            "curve learnt with the rewards (the default there)"),
    )
}
@dataclass(frozen=True)
class Player:
    """A player's parameters besides the rewards: beta, the hand's sigma (levels), the lapse probability,
    and the hand's bias (produced minus intended level; known from calibration trials, else 0)."""

    beta: float
    sigma: float = 0.0
    lapse: float = 0.0
    bias: float = 0.0

    def to_json(self) -> dict[str, float]:
        return {"beta": self.beta, "sigma": self.sigma, "lapse": self.lapse, "bias": self.bias}


# The models of a levels world's player (the timing model reads time worlds' holds).
LEVEL_MODELS: tuple[str, ...] = tuple(name for name in PLAYER_MODELS if name != "timing")
# Candidates for `player_model="auto"`, simplest first (equally simple ones in order of preference).
CANDIDATES: tuple[str, ...] = ("boltzmann", "ends", "hand", "person", "naive")


def player_model(name: str) -> PlayerModel:
    """The registry entry called `name`; raises ValueError for any other name."""
    try:
        return PLAYER_MODELS[name]
    except KeyError:
        raise ValueError(f"player_model must be one of {(AUTO, *PLAYER_MODELS)}, not {name!r}") from None


def player_model_for(given: str | None, *, after_auto: bool, fixed_beta: bool, holds: bool) -> str:
    """The player model a maxent fit runs, decided here for every path: the one `given`
    (`FitOptions.player_model`); else on a time world's recorded holds (`holds`) the timing model; else
    ``auto`` (chosen by held-out episodes) when maxent runs for method auto (`after_auto`) with no fixed
    beta; else the paper's Boltzmann expert (so that ``method="maxent"`` is the paper's baseline)."""
    if given is not None:
        return given
    if holds:
        return "timing"
    return AUTO if after_auto and not fixed_beta else "boltzmann"


# How a study pools its participants (`study report --pool-model`, `study plan --pool-model`; section "A
# population of participants" of docs/studies-pooling.md). The report fits each; the plan simulates each.
PoolModelName = Literal["population", "shared"]
POOL_MODELS: dict[str, str] = {
    "population": "each participant with their own player, pooled as a population of people (random effects "
                  "over their fits)",
    "shared": "one fit of everyone's episodes, rewards and player shared (a fixed-effect pool)",
}
DEFAULT_POOL_MODEL: PoolModelName = "population"

# How `study plan --fits` fits each simulated study (irl_core/studies/forecast.py says why there are two).
PlanFitsName = Literal["plan", "report"]
PLAN_FITS: dict[str, str] = {
    "plan": "the plan's quick fit: one model of the player and its Laplace interval (a floor for a report's "
            "coverage)",
    "report": "as careful study report fits it: the model the pool chooses, bootstrap intervals, the exclusions",
}


def pool_model(name: str) -> PoolModelName:
    """`name` if it is a pool model (`POOL_MODELS`); raises ValueError naming the choices otherwise."""
    if name not in POOL_MODELS:
        raise ValueError(f"pool_model must be one of {', '.join(POOL_MODELS)}, not {name!r}")
    return name  # type: ignore[return-value]
