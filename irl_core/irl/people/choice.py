"""Choosing a model of people: each candidate fitted, and the one held-out episodes explain best (the
fewest parameters among those that tie)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from irl_core.irl.choices import CANDIDATES, PLAYER_MODELS, Player, PlayerModel, player_model
from irl_core.irl.people.fit import REFIT_MAX_ITER, PlayerFit, fit_player
from irl_core.irl.people.likelihood import START_LAPSE, START_SIGMA
from irl_core.irl.qmap import Unknowns
from irl_core.support.executor import map_calls, run_calls
from irl_core.worlds.mdp import MDP

FOLDS = 5
# A fold's refit starts at the full fit and stops sooner: its error is far below the held-out noise.
FOLD_VALUE_TOLERANCE = 1e-6
# With fewer episodes than this there is no held-out choice.
MIN_EPISODES_TO_CHOOSE = 3


@dataclass(frozen=True)
class ModelChoice:
    """Which player model explains the recordings best on held-out episodes, and by how much.

    Attributes:
        name: the chosen model.
        held_out: per candidate, the log likelihood of each episode under the model fitted without
            its fold, summed over episodes (None where the choice was not made on held-out data).
        folds: how many folds the episodes were split into (0: no held-out choice).
        fits: per candidate, its fit to every episode.
        reason: one sentence for the reader.
        per_episode: per candidate, each episode's held-out log likelihood (E,) (None as held_out).
    """

    name: str
    held_out: dict[str, float] | None
    folds: int
    fits: dict[str, PlayerFit]
    reason: str
    per_episode: dict[str, np.ndarray] | None = None


def choose_player_model(
    mdp: MDP,
    unknowns: Unknowns,
    by_episode: sp.csr_matrix,
    *,
    rmax: float,
    candidates: tuple[str, ...] = CANDIDATES,
    folds: int = FOLDS,
    seed: int = 0,
    hand: tuple[float, float] | None = None,
    workers: int = 1,
) -> ModelChoice:
    """Fit each candidate model to the episodes (rows of `by_episode`, (E, S * A)) and choose by
    `folds`-fold held-out log likelihood of whole episodes: of the models within `SIMPLER_MARGIN` of
    the best, the one with the fewest parameters, the likeliest among those. With fewer than
    `MIN_EPISODES_TO_CHOOSE` episodes the choice is the ``ends`` model (the simplest with a person's
    episode end), said so. `hand` (bias, sigma): the hand measured by calibration trials, held fixed in
    every model with a hand. The candidates' fits from the default start, and the folds' refits, run on
    `workers` processes (the same answer on any number)."""
    by_episode = sp.csr_matrix(by_episode)
    counts = _counts_of(by_episode, mdp)
    E = by_episode.shape[0]
    models = [player_model(name).with_hand(hand) for name in candidates]
    if E < MIN_EPISODES_TO_CHOOSE:
        fit = fit_player(mdp, unknowns, counts, model=PLAYER_MODELS["ends"], rmax=rmax)
        return ModelChoice("ends", None, 0, {"ends": fit},
                           f"player model ends, without a held-out choice: {E} episode{'s' if E != 1 else ''} "
                           f"cannot be split into folds (a choice needs {MIN_EPISODES_TO_CHOOSE})")
    fits: dict[str, PlayerFit] = {}
    from_default: dict[int, PlayerFit] = {}

    def arrived(i: int, default: PlayerFit) -> None:
        # Each model's other starts come from the model before it: as soon as that one and this model's default
        # start are in, its fit is settled here while the workers go on with the later default starts.
        from_default[i] = default
        while len(fits) < len(models) and len(fits) in from_default:
            j = len(fits)
            fits[models[j].name] = _best_of_starts(mdp, unknowns, counts, models, j, from_default[j], fits, rmax=rmax)

    # The default starts depend on nothing else, so they run side by side (on walled-24 they were 6.45 s of a
    # 10.6 s fit).
    run_calls(_fit_from_default, [(model,) for model in models], shared=(mdp, unknowns, counts, rmax),
              workers=workers, on_result=arrived)
    k = min(folds, E)
    fold_of = np.random.default_rng(seed).permutation(np.arange(E) % k)
    per_episode: dict[str, np.ndarray] = {model.name: np.zeros(E) for model in models}
    refits = [(model, fits[model.name], by_episode[fold_of != f], by_episode[fold_of == f])
              for f in range(k) for model in models]
    tested = map_calls(_held_out_refit, refits, shared=(mdp, unknowns, rmax), workers=workers)
    for (model, _, _, _), f, values in zip(refits, np.repeat(np.arange(k), len(models)), tested):
        per_episode[model.name][fold_of == f] = values
    held_out: dict[str, float] = {name: float(values.sum()) for name, values in per_episode.items()}
    best = max(held_out, key=held_out.__getitem__)
    standing = [m for m in models if held_out[best] - held_out[m.name] <= SIMPLER_MARGIN]
    fewest = min(m.extra_parameters for m in standing)
    chosen = max((m.name for m in standing if m.extra_parameters == fewest), key=held_out.__getitem__)
    steps = int(counts.sum())
    scores = ", ".join(f"{name} {held_out[name] / steps:.4f}" for name in candidates)
    why = (f"player model {chosen} chosen by {k}-fold held-out log likelihood of whole episodes, per step: "
           f"{scores}")
    if chosen != best:
        why += f" ({best} is no better by more than {SIMPLER_MARGIN:g} nats in all, so the simpler model stands)"
    return ModelChoice(chosen, held_out, k, fits, why, per_episode)


def _best_of_starts(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, models: list[PlayerModel], j: int,
                    default: PlayerFit, fits: dict[str, PlayerFit], *, rmax: float) -> PlayerFit:
    """Model j's best fit: from the default start (`default`), and for a richer model also from where the one before
    it ended (in `fits`): the likelihood is not concave, and either start alone can stop in a poorer optimum."""
    model = models[j]
    tries = [default]
    previous = fits[models[j - 1].name] if j else None
    if previous is not None:
        start = (previous.theta, Player(previous.player.beta, previous.player.sigma or START_SIGMA,
                                        previous.player.lapse or START_LAPSE))
        tries.append(fit_player(mdp, unknowns, counts, model=model, rmax=rmax, start=start))
    # And, as `fit_given_model` does, from the ends model's answer with a fresh hand: a hand model's
    # sigma, started from the simpler hand's small one, can stay in the optimum where beta explains the
    # spread of levels (on a time world that optimum put the cliff at half its size).
    ends = fits.get("ends")
    if model.hand and ends is not None and previous is not ends:
        start = (ends.theta, Player(ends.player.beta, START_SIGMA, START_LAPSE))
        tries.append(fit_player(mdp, unknowns, counts, model=model, rmax=rmax, start=start))
    return max(tries, key=lambda fit: fit.mean_log_likelihood)


def _fit_from_default(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, rmax: float, model: PlayerModel) -> PlayerFit:
    return fit_player(mdp, unknowns, counts, model=model, rmax=rmax)


def _held_out_refit(mdp: MDP, unknowns: Unknowns, rmax: float, model: PlayerModel, full: PlayerFit,
                    train: sp.csr_matrix, test: sp.csr_matrix) -> np.ndarray:
    """Each test episode's log likelihood (rows of `test`, (n, S * A)) under `model` refitted to the `train` episodes,
    from its fit to all of them."""
    part = fit_player(mdp, unknowns, _counts_of(train, mdp), model=model, rmax=rmax, start=(full.theta, full.player),
                      start_V=full.V1, value_tolerance=FOLD_VALUE_TOLERANCE, max_iter=REFIT_MAX_ITER)
    return np.asarray(test @ part.plan.log_observed.ravel()).ravel()


# A model with more parameters is chosen only if its held-out log likelihood beats the simpler one's by
# more than this (nats over all held-out episodes; cross-validation already charges for overfitting).
SIMPLER_MARGIN = 2.0
# Two models of equal size are told apart on held-out episodes when the mean of their paired per-episode log likelihood
# differences is this many standard errors above zero.
SIGNIFICANT_Z = 2.0


def significantly_better(first: np.ndarray, second: np.ndarray) -> bool:
    """Whether per-episode held-out log likelihoods `first` (E,) beat `second` (E,) beyond their noise."""
    difference = np.asarray(first) - np.asarray(second)
    spread = difference.std(ddof=1) if difference.size > 1 else 0.0
    if spread == 0:
        return bool(difference.sum() > 0)
    return bool(difference.mean() / (spread / np.sqrt(difference.size)) > SIGNIFICANT_Z)


def fit_given_model(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, *, model: PlayerModel, rmax: float) -> PlayerFit:
    """`fit_player` for one model named in advance, from the starts `choose_player_model` tries: the default,
    and for a model with a hand, where the simpler ``ends`` model ends (the likelier answer is kept), so that a
    model given by name finds the optimum the choice would have found."""
    tries = [fit_player(mdp, unknowns, counts, model=model, rmax=rmax)]
    if model.hand:
        simpler = fit_player(mdp, unknowns, counts, model=PLAYER_MODELS["ends"], rmax=rmax)
        tries.append(fit_player(mdp, unknowns, counts, model=model, rmax=rmax,
                                start=(simpler.theta, Player(simpler.player.beta, START_SIGMA, START_LAPSE))))
    return max(tries, key=lambda fit: fit.mean_log_likelihood)


def _counts_of(rows: sp.csr_matrix, mdp: MDP) -> np.ndarray:
    """(S, A) counts summed over episode rows (n, S * A)."""
    return np.asarray(rows.sum(axis=0)).reshape(mdp.n_states, mdp.n_actions)


def close_models(choice: ModelChoice) -> tuple[PlayerFit, ...]:
    """The fits of the other candidates that held-out episodes do not tell from the chosen model: those it does not
    beat beyond their noise (`significantly_better`, the paired per-episode test `planning_rival` asks of the other
    planning assumption), in the candidates' order; empty without a held-out choice."""
    if choice.held_out is None or choice.per_episode is None:
        return ()
    mine = choice.per_episode[choice.name]
    return tuple(choice.fits[name] for name in choice.fits
                 if name != choice.name and not significantly_better(mine, choice.per_episode[name]))


def planning_rival(choice: ModelChoice) -> PlayerFit | None:
    """The fit of the other planning assumption (``person`` or ``naive``) when held-out episodes cannot tell it
    from the chosen model, else None."""
    pair = {"person": "naive", "naive": "person"}
    other = pair.get(choice.name)
    if other is None or choice.held_out is None or other not in choice.held_out:
        return None
    assert choice.per_episode is not None
    if significantly_better(choice.per_episode[choice.name], choice.per_episode[other]):
        return None
    return choice.fits[other]
