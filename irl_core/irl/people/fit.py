"""Fitting a model of people: the rewards and the player by maximum likelihood (L-BFGS-B over the exact
gradient of `likelihood`), the curvature that scales a refit, and the bootstrap's refit."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from irl_core.irl.choices import Player, PlayerModel
from irl_core.irl.maxent import one_blas_thread
from irl_core.irl.people.hand import hand_from_trials
from irl_core.irl.people.held import unreached
from irl_core.irl.people.likelihood import (
    LAPSE_BOUNDS,
    SIGMA_BOUNDS,
    START_LAPSE,
    START_SIGMA,
    PlayerPlan,
    WarmStart,
    beta_bounds,
    log_likelihood,
)
from irl_core.irl.qmap import Unknowns
from irl_core.worlds.mdp import MDP

# L-BFGS-B stops when an iteration improves the mean log likelihood by less than this, relative.
# A reward the data do not pin (a cliff nobody steps into) only walks on along a flat direction past
# this point, so its value is the optimiser's patience, not the data's: the fit reads such rewards as
# one-sided ("at most X", `flat_toward_bound`), bench/bench_people.py measures both speed and answers.
VALUE_TOLERANCE = 1e-10
GRADIENT_TOLERANCE = 1e-7
MAX_ITER = 1000
# L-BFGS-B keeps this many steps to model the curvature (scipy's default is 10). On issue 32's walled 24x24 world
# (45 variables) 10 took 792 iterations for the ends model and ran out of 1000 for hand; 60 took 161 and 196,
# 6x faster, to a likelihood as high or higher (bench/bench_people_big.py).
MEMORY = 60
# A resample's refit runs over variables scaled to unit curvature (`curvature_scale`) and stops at this
# projected gradient, as maxent's does (`bootstrap.RESAMPLE_GRADIENT_TOLERANCE`).
RESAMPLE_GRADIENT_TOLERANCE = 1e-5
RESAMPLE_VALUE_TOLERANCE = 1e-12
REFIT_MAX_ITER = 200
# How many times a fit frees held rewards whose gradient points up and searches again.
RELEASES = 3


@dataclass(frozen=True)
class PlayerFit:
    """The rewards theta (k,) and the player that maximise the likelihood, V (S,) at beta 1 there,
    the mean log likelihood per recorded step, L-BFGS-B's report, and `held` (k,): the unknowns held at
    -rmax because no recorded action can lead into them (`flat.unreached`)."""

    model: PlayerModel
    theta: np.ndarray
    player: Player
    V1: np.ndarray
    mean_log_likelihood: float
    converged: bool
    iterations: int
    message: str
    plan: PlayerPlan = field(repr=False)
    held: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    @property
    def beta_at_bound(self) -> bool:
        return min(abs(np.log(self.player.beta) - end) for end in beta_bounds(self.model)) < 1e-6

    def parameters(self) -> np.ndarray:
        """(p,) theta, then beta, then sigma and the lapse where the model has them (the bootstrap's vector)."""
        extra = [self.player.beta]
        if self.model.searches_hand:
            extra.append(self.player.sigma)
        if self.model.lapses:
            extra.append(self.player.lapse)
        return np.append(self.theta, extra)


def _logit(p: float) -> float:
    return float(np.log(p) - np.log1p(-p))


def fit_player(
    mdp: MDP,
    unknowns: Unknowns,
    counts: np.ndarray,
    *,
    model: PlayerModel,
    rmax: float,
    start: tuple[np.ndarray, Player] | None = None,
    start_V: np.ndarray | None = None,
    scale: np.ndarray | None = None,
    value_tolerance: float = VALUE_TOLERANCE,
    gradient_tolerance: float = GRADIENT_TOLERANCE,
    max_iter: int = MAX_ITER,
    hold: bool = True,
) -> PlayerFit:
    """Maximise the mean log likelihood of counts N (S, A) over the unknowns (|theta| <= rmax), log beta,
    and, where `model` has them, log sigma and logit lapse, from `start` = (theta, player) (else theta 0,
    beta 1, sigma 1, lapse 0.02) and the soft values from `start_V` (S,, at beta 1).

    `scale` (p,): the variables' natural sizes (`curvature_scale`), over which the search runs (a warm
    start then converges in a few steps); without it the rewards move in units of rmax / 100.

    With `hold`, the unknowns no recorded action can lead into (`flat.unreached`) are held at -rmax,
    where the likelihood's maximum in the box lies for them, and released (up to `RELEASES` times) where the
    gradient there says the likelihood rises upward; `PlayerFit.held` says which stayed held.

    Raises ValueError without a recorded step, `Stopped` once the fit's stop check says so."""
    counts = np.asarray(counts, dtype=float)
    if counts.sum() <= 0:
        raise ValueError("the player model needs at least one recorded step")
    theta0, player0 = start if start is not None else (np.zeros(unknowns.k), Player(1.0, START_SIGMA, START_LAPSE))
    z0, bounds = _variables(model, theta0, player0, rmax=rmax)
    held = unreached(mdp, unknowns, counts) if hold else np.zeros(unknowns.k, dtype=bool)
    negative = _Objective(mdp, unknowns, counts, model, start_V)
    if scale is None:
        # Rewards run in hundreds, the other variables near 1: rewards in units of rmax / 100, so that
        # L-BFGS-B's first steps are of a sensible size in every direction.
        scale = np.ones(z0.size)
        scale[: unknowns.k] = max(rmax / 100.0, 1.0)
    options = {"maxiter": max_iter, "ftol": value_tolerance, "gtol": gradient_tolerance, "maxcor": MEMORY}
    with one_blas_thread():
        for _ in range(RELEASES + 1):
            z0[: unknowns.k][held] = -rmax
            searched = [(-rmax, -rmax) if j < unknowns.k and held[j] else bound for j, bound in enumerate(bounds)]
            result = minimize(lambda z: _scaled(negative, z, scale), z0 / scale, jac=True, method="L-BFGS-B",
                              bounds=[(low / u, high / u) for (low, high), u in zip(searched, scale)], options=options)
            z0 = result.x * scale
            # A held reward whose likelihood rises upward after all (its cell's neighbours' values matter more
            # than its risky actions) is searched over like the others.
            rising = held & (negative(z0)[1][: unknowns.k] < -gradient_tolerance)
            if not rising.any():
                break
            held = held & ~rising
        theta, player = _unpack(model, unknowns.k, z0)
        final = log_likelihood(mdp, counts, unknowns.state_rewards(theta), model=model, player=player,
                               V0=negative.V, gradient=False)
    return PlayerFit(model=model, theta=np.asarray(theta, dtype=float), player=player, V1=final.plan.V,
                     mean_log_likelihood=final.value / counts.sum(), converged=bool(result.success),
                     iterations=int(result.nit), message=str(result.message), plan=final.plan, held=held)


def _variables(model: PlayerModel, theta: np.ndarray, player: Player, *,
               rmax: float) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """The search's variables z (p,) = theta, log beta, then log sigma and logit lapse where the model has
    them, and their bounds."""
    z = list(np.asarray(theta, dtype=float)) + [float(np.clip(np.log(player.beta), *beta_bounds(model)))]
    bounds = [(-rmax, rmax)] * len(theta) + [beta_bounds(model)]
    if model.searches_hand:
        z.append(float(np.log(np.clip(player.sigma or START_SIGMA, *SIGMA_BOUNDS))))
        bounds.append((float(np.log(SIGMA_BOUNDS[0])), float(np.log(SIGMA_BOUNDS[1]))))
    if model.lapses:
        z.append(_logit(float(np.clip(player.lapse or START_LAPSE, *LAPSE_BOUNDS))))
        bounds.append((_logit(LAPSE_BOUNDS[0]), _logit(LAPSE_BOUNDS[1])))
    return np.asarray(z), bounds


def _unpack(model: PlayerModel, k: int, z: np.ndarray) -> tuple[np.ndarray, Player]:
    """(theta, player) from the search's variables (`_variables`)."""
    i = k + 1
    sigma = lapse = bias = 0.0
    if model.known_hand is not None and model.hand:
        bias, sigma = model.known_hand
    elif model.hand:
        sigma, i = float(np.exp(z[i])), i + 1
    if model.lapses:
        lapse = float(1 / (1 + np.exp(-z[i])))
    return z[:k], Player(float(np.exp(z[k])), sigma, lapse, bias)


class _Objective:
    """The mean negative log likelihood and its gradient over the search's variables, warm-starting each
    soft Bellman fixed point from the last (`warm`; the first from `V`)."""

    def __init__(self, mdp: MDP, unknowns: Unknowns, counts: np.ndarray, model: PlayerModel,
                 V: np.ndarray | None) -> None:
        self.mdp, self.unknowns, self.counts, self.model, self.V = mdp, unknowns, counts, model, V
        self.warm: WarmStart | None = None
        self.total = counts.sum()
        self.basis_T = unknowns.basis.T.tocsr()

    def __call__(self, z: np.ndarray) -> tuple[float, np.ndarray]:
        theta, player = _unpack(self.model, self.unknowns.k, z)
        got = log_likelihood(self.mdp, self.counts, self.unknowns.state_rewards(theta), model=self.model,
                             player=player, V0=self.V, warm=self.warm)
        self.V, self.warm = got.plan.V, got.warm
        grad = [self.basis_T @ got.R_S, [got.log_beta]]
        if self.model.searches_hand:
            grad.append([got.log_sigma])
        if self.model.lapses:
            grad.append([got.lapse * player.lapse * (1 - player.lapse)])
        return -got.value / self.total, -np.concatenate(grad) / self.total


def _scaled(negative, z: np.ndarray, unit: np.ndarray) -> tuple[float, np.ndarray]:
    value, gradient = negative(z * unit)
    return value, gradient * unit


def curvature_scale(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *, rmax: float) -> np.ndarray:
    """(p,) 1 / sqrt of the mean negative log likelihood's curvature along each search variable at `fit`,
    from central differences of the exact gradient; capped at rmax where it is (nearly) flat (a cliff
    nobody steps into), as `maxent.curvature_scale`."""
    z, bounds = _variables(fit.model, fit.theta, fit.player, rmax=rmax)
    negative = _Objective(mdp, unknowns, np.asarray(counts, dtype=float), fit.model, fit.V1)
    curvature = np.empty(z.size)
    with one_blas_thread():
        for j in range(z.size):
            h = 1e-4 * max(1.0, abs(z[j]))
            up, down = z.copy(), z.copy()
            up[j], down[j] = min(z[j] + h, bounds[j][1]), max(z[j] - h, bounds[j][0])
            curvature[j] = (negative(up)[1][j] - negative(down)[1][j]) / (up[j] - down[j])
    return np.minimum(1.0 / np.sqrt(np.maximum(curvature, 1.0 / rmax**2)), rmax)



# Mixed into the seed of a resample's draw of the calibration trials, so that it is not the episodes' stream.
TRIALS_STREAM = 7


@dataclass(frozen=True, eq=False)
class PlayerRefit:
    """How the bootstrap refits one resample's counts (S, A) with a player model: from the full fit's answer,
    over the variables' `scale` there (`curvature_scale`). Returns `PlayerFit.parameters()` (p,).

    `trials` (n, 2): the calibration trials whose hand the model holds fixed (`model.known_hand`). Each resample
    then draws n of them with replacement as well, by its number and `seed` (the same draw on any worker), and
    holds the hand those measure: the interval carries the hand's sampling error too, which a hand held at
    the full data's estimate leaves out (bench_people, hasty on mud with 10 trials: the goal covered in 70% of
    runs, 20% with the hand held; docs/people.md)."""

    mdp: MDP
    unknowns: Unknowns
    model: PlayerModel
    rmax: float
    start: tuple[np.ndarray, Player]
    start_V: np.ndarray | None = None
    scale: np.ndarray | None = None
    trials: np.ndarray | None = None
    seed: int = 0

    @property
    def size(self) -> int:
        """p: the unknowns, beta, and sigma and the lapse where the model has them."""
        return self.unknowns.k + 1 + self.model.extra_parameters

    @property
    def draws_trials(self) -> bool:
        """Whether each resample draws the trials again: there are trials, and the model holds their hand."""
        return self.trials is not None and self.model.known_hand is not None

    def model_for(self, resample: int) -> PlayerModel:
        """The model that resample `resample` is refitted with: the hand of its draw of the trials, if any."""
        if not self.draws_trials:
            return self.model
        trials = np.asarray(self.trials).reshape(-1, 2)
        draw = np.random.default_rng((self.seed, TRIALS_STREAM, resample)).integers(0, len(trials), len(trials))
        return self.model.with_hand(hand_from_trials(trials[draw], self.mdp.levels).known())

    def __call__(self, counts: np.ndarray, *, resample: int = 0) -> np.ndarray:
        return fit_player(self.mdp, self.unknowns, counts, model=self.model_for(resample), rmax=self.rmax,
                          start=self.start, start_V=self.start_V, scale=self.scale,
                          value_tolerance=RESAMPLE_VALUE_TOLERANCE, gradient_tolerance=RESAMPLE_GRADIENT_TOLERANCE,
                          max_iter=REFIT_MAX_ITER).parameters()
