"""The player models a maxent fit knows (`irl_core.irl.people`), one entry each.

`FitOptions` checks a name here and ``careful fit --player-model`` offers these choices; the
model itself is `irl_core.irl.people_likelihood`. This module imports nothing heavy, so the command line
can read it before it needs numpy's solvers.
"""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class PlayerModel:
    """One entry of the player-model registry: which parts of the model are on."""

    name: str
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
AUTO = "auto"
# Candidates for `player_model="auto"`, simplest first (equally simple ones in order of preference).
CANDIDATES: tuple[str, ...] = ("boltzmann", "ends", "hand", "person", "naive")


def player_model(name: str) -> PlayerModel:
    """The registry entry called `name`; raises ValueError for any other name."""
    try:
        return PLAYER_MODELS[name]
    except KeyError:
        raise ValueError(f"player_model must be one of {(AUTO, *PLAYER_MODELS)}, not {name!r}") from None
