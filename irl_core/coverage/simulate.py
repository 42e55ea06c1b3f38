"""One simulated dataset of the recordings' size: from the fit's own model of play (its fitted rewards and
player, the policy the fit check replays) or from a rival person-like player of the world's own rewards.

Every dataset has its own random stream, `dataset_rng(seed, source, dataset)`, so that a dataset is the
same wherever and in whatever order it is simulated (one process, a pool, a Dask cluster).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from irl_core.errors import UsageError
from irl_core.irl.choices import player_model
from irl_core.irl.maxent import soft_bellman
from irl_core.irl.people import log_likelihood
from irl_core.irl.result import FitResult
from irl_core.players.experts import Chooser, demonstrations_of, optimal_policy, rollouts
from irl_core.players.person_like import person_like
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import MDP

# What the rows simulated from the fit's own model call the player, for lp and loss (no model of noise).
OPTIMAL = "optimal"


def own_player_name(fit: FitResult) -> str:
    """The fit's model of the player (``naive``, ``boltzmann``...), or ``optimal`` for lp and loss."""
    return fit.player_model or OPTIMAL


def fitted_policy(fit: FitResult) -> np.ndarray:
    """(S, A) the fit's player over the fit's own MDP: the recorded-action policy of its player model with the
    fitted rewards and player (what the fit check replays), or for lp and loss, which model no noise, the
    optimal policy for the fitted rewards.

    Raises `UsageError` for the timing model, whose holds over continuous time are not replayed here."""
    mdp = fit.mdp
    model = fit.player_model
    if model is None or fit.player is None:
        return optimal_policy(dataclasses.replace(mdp, R_S=np.asarray(fit.R_S, dtype=float)))
    if model == "timing":
        raise UsageError("careful check does not yet simulate from the timing model; fit with "
                         "--player-model person (bins of hold time) to check it")
    if model == "boltzmann":
        return soft_bellman(mdp, fit.R_S, beta=fit.player.beta).policy
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    return log_likelihood(mdp, counts, fit.R_S, model=player_model(model), player=fit.player,
                          gradient=False).plan.observed


def recorded_starts(demos: Demonstrations) -> np.ndarray:
    """(E,) the start state of each recorded episode with a step (the design the datasets repeat)."""
    if demos.episode_facts is not None and demos.episode_facts.start.size:
        return np.asarray(demos.episode_facts.start, dtype=np.int64)
    mdp = demos.mdp
    starts = np.array([mdp.state_of[cell] for cell in mdp.world.start_cells], dtype=np.int64)
    return np.resize(starts, max(1, demos.episodes))


def dataset_rng(seed: int, source: int, dataset: int) -> np.random.Generator:
    """The random stream of dataset `dataset` of source `source` (0 the fit's model, 1... the rivals)."""
    return np.random.default_rng(np.random.SeedSequence([seed, source, dataset]))


_RIVALS: dict[tuple[int, str], Chooser] = {}  # (id of the MDP, kind) -> chooser, within one process


def rival_chooser(mdp: MDP, kind: str) -> Chooser:
    """The person-like player `kind` of `mdp`'s world (planned once per process and world)."""
    key = (id(mdp), kind)
    if key not in _RIVALS:
        _RIVALS.clear()  # one world at a time: a new MDP's plans replace the last one's
        _RIVALS[key] = person_like(mdp, kind).choose
    return _RIVALS[key]


def simulate_dataset(play_mdp: MDP, player: np.ndarray | Chooser, starts: np.ndarray, rng: np.random.Generator,
                     *, recorded_mdp: MDP) -> Demonstrations:
    """Episodes from each of `starts` played by `player` (a policy (S, A) or a chooser) in `play_mdp`'s dynamics,
    as demonstrations of `recorded_mdp`'s world (the world a refit reads, as it read the recordings)."""
    played = rollouts(play_mdp, player, episodes=len(starts), starts=starts, rng=rng)
    return dataclasses.replace(demonstrations_of(play_mdp, played), mdp=recorded_mdp)
