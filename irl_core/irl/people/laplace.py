"""Laplace intervals for a model of people: the likelihood's curvature at the fit instead of 200 refits.

A bootstrap interval (`bootstrap`) refits every resample: 200 fits per fit. A planner that simulates
hundreds of studies cannot pay that. The Laplace approximation reads the interval off the curvature
of the log likelihood at its maximum: the observed information I = -d^2 LL / dz^2 over the fit's
variables z (the rewards, log beta, and log sigma and logit lapse where the model has them), by
central differences of the exact gradient (`likelihood.log_likelihood`: 2p fixed points for
p variables). The covariance is I^-1; a reward's interval is its estimate +- z_(1+c)/2 sqrt of its
variance, on one of two scales (`SCALES`):

- ``reward``: the interval is symmetric about the estimate (the textbook Wald interval);
- ``log``: for a reward away from zero, on log|reward| (delta method), so that the interval
  stretches toward the bound: a cliff's likelihood falls steeply toward zero and slowly toward
  -infinity, and the log scale follows that shape where the symmetric one cuts it off.

Variables at the end of their range (beta at its cap, the hand's sigma at 0.05, the lapse at its
floor) are held where they are: the curvature there is not the likelihood's shape. A reward the data
bound on one side only (`flat.flat_toward_bound`) reaches the bound on that side, as the
bootstrap's does. For a pool of people, `groups` gives the cluster-robust (sandwich) covariance, which
counts each person's episodes as one draw, as the pool's bootstrap resamples people. docs/people.md
("Laplace intervals") compares both scales with the bootstrap on the same fits.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import norm

from irl_core.irl.choices import Player
from irl_core.irl.maxent import one_blas_thread
from irl_core.irl.people.fit import PlayerFit
from irl_core.irl.people.flat import flat_toward_bound
from irl_core.irl.people.held import BOUND_STEPS, FLAT_DROP
from irl_core.irl.people.likelihood import LAPSE_BOUNDS, SIGMA_BOUNDS, beta_bounds, log_likelihood
from irl_core.irl.qmap import Unknowns
from irl_core.worlds.mdp import MDP

SCALES = ("log", "reward")
# Relative step of the central differences (of the exact gradient, so the error is the step squared).
STEP = 1e-4
# A variable this close (in its own units: log or logit) to an end of its range is held there.
AT_END = 1e-3
# Eigenvalues of the standardised information below this are directions the data do not pin.
FLAT_EIGENVALUE = 1e-9


def laplace_intervals(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *, rmax: float,
                      confidence: float = 0.95, scale: str = "log", groups: np.ndarray | None = None) -> np.ndarray:
    """(k, 2) [low, high] per unknown of `fit` (a model of people fitted to counts N (S, A)), from the
    curvature of the log likelihood there, clipped to [-rmax, rmax]; see the module's docstring.

    `groups` (n, S, A): the counts of each of n people whose sum is `counts` (a pool): the covariance is
    then the cluster-robust sandwich I^-1 (sum_i g_i g_i^T) I^-1 n / (n - 1), g_i person i's score at the
    fit, which covers the differences between people as the pool's bootstrap over people does (no variance
    below the model's).

    Raises ValueError for a `scale` not in `SCALES`."""
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {SCALES}, not {scale!r}")
    counts = np.asarray(counts, dtype=float)
    k = unknowns.k
    variance = np.diag(covariance(mdp, unknowns, counts, fit, groups=groups))[:k]
    # A pool's too takes the normal quantile, not Student's t on n - 1: the planner predicts the study report,
    # whose pooled bootstrap over people is a percentile interval without that correction.
    z = float(norm.ppf(0.5 + confidence / 2))
    se = np.sqrt(np.maximum(variance, 0.0))
    theta = fit.theta
    low, high = theta - z * se, theta + z * se
    if scale == "log":
        # Delta method on log|theta|: sd of log|theta| is se / |theta|; only where zero lies outside the
        # symmetric interval does the sign, and so the log, stay defined.
        away = (np.abs(theta) > z * se) & np.isfinite(se)
        ratio = np.exp(z * se[away] / np.abs(theta[away]))
        ends = np.sort(np.stack([theta[away] / ratio, theta[away] * ratio], axis=1), axis=1)
        low[away], high[away] = ends[:, 0], ends[:, 1]
    flat = flat_toward_bound(mdp, unknowns, counts, fit, rmax=rmax)
    low[flat < 0] = -rmax
    high[flat > 0] = rmax
    low[~np.isfinite(low)], high[~np.isfinite(high)] = -rmax, rmax
    return np.clip(np.stack([low, high], axis=1), -rmax, rmax)


def covariance(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *,
               groups: np.ndarray | None = None) -> np.ndarray:
    """(p, p) the inverse observed information over `fit`'s variables (`variables`), or with `groups` the
    cluster-robust sandwich (`laplace_intervals`); inf on the diagonal of a direction the data do not pin,
    0 in the rows of a variable held at the end of its range."""
    z, free = variables(fit)
    info = -hessian(mdp, unknowns, counts, fit, free=free)
    info = (info + info.T) / 2
    p = z.size
    cov = np.zeros((p, p))
    sub = info[np.ix_(free, free)]
    d = np.sqrt(np.maximum(np.diag(sub), 0.0))
    pinned = d > 0
    d_safe = np.where(pinned, d, 1.0)
    standard = sub / np.outer(d_safe, d_safe)
    values, vectors = np.linalg.eigh(standard)
    flat = values <= FLAT_EIGENVALUE * max(1.0, float(values.max(initial=0.0)))
    inverse = (vectors[:, ~flat] / values[~flat]) @ vectors[:, ~flat].T
    inner = inverse / np.outer(d_safe, d_safe)
    if groups is not None and len(groups) > 1:
        scores = np.stack([gradient(mdp, unknowns, np.asarray(g, dtype=float), fit, z)[free] for g in groups])
        scores -= scores.mean(axis=0)  # at the pooled optimum they sum to zero, up to the optimiser's tolerance
        n = len(groups)
        sandwich = inner @ (scores.T @ scores) @ inner * n / (n - 1)
        # With few people the sandwich is itself noisy and tends low (four alike people's gave a cliff interval
        # a tenth of one person's): the differences between people add to the noise within them, never take
        # from it, so no variance falls below the model's.
        np.fill_diagonal(sandwich, np.maximum(np.diag(sandwich), np.diag(inner)))
        inner = sandwich
    # A variable with any weight on a flat direction (or no curvature at all) is not pinned.
    loose = ~pinned | (np.abs(vectors[:, flat]) > 1e-6).any(axis=1)
    np.fill_diagonal(inner, np.where(loose, np.inf, np.diag(inner)))
    idx = np.flatnonzero(free)
    cov[np.ix_(idx, idx)] = inner
    return cov


# A reward direction whose standardised curvature is below this share of the largest is tried along its
# whole length (`pinned_together`); the likelihood itself then decides.
NEARLY_FLAT = 1e-4
# Beyond this many free rewards the curvature (2 fixed points each) is not worked out for `pinned_together`.
MAX_COMBINED = 80
# A reward with at least this share of a flat direction's largest component moves along it.
ON_DIRECTION = 0.05


def pinned_together(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *, rmax: float,
                    settled: np.ndarray) -> np.ndarray | None:
    """(k, 2) for each reward the data pin only loosely, in a combination with others, the range it covers along
    that combination at a cost to the log likelihood under `FLAT_DROP` (NaN rows elsewhere), or None when there
    are over `MAX_COMBINED` free rewards to look at.

    Among the rewards not `settled` (k,) (held or one-sided, read by their own notes) nor at ±rmax, the
    curvature of the log likelihood over the rewards (the player held; standardised, so that each reward's own
    curvature is 1) can have directions far flatter than the others, under `NEARLY_FLAT` of the largest: two
    mud cells of which the data fix little more than the sum. Along such a direction the search stops wherever
    its patience ends (issue 32's walled 24x24 world: two mud cells at -146 and -150 in one run, -117 and -180
    in another, their likelihoods within 1e-6 nats), so each is followed both ways, by bisection, to where the
    likelihood has fallen by `FLAT_DROP` (or ±rmax), and the rewards that move along it get that range."""
    counts = np.asarray(counts, dtype=float)
    k = unknowns.k
    out = np.full((k, 2), np.nan)
    z, _ = variables(fit)
    free = np.zeros(z.size, dtype=bool)
    free[:k] = ~np.asarray(settled, dtype=bool) & (np.abs(fit.theta) < rmax * (1 - 1e-9))
    rewards = np.flatnonzero(free)
    if rewards.size < 2:
        return out
    if rewards.size > MAX_COMBINED:
        return None
    info = -hessian(mdp, unknowns, counts, fit, free=free)[np.ix_(rewards, rewards)]
    info = (info + info.T) / 2
    d = np.sqrt(np.maximum(np.diag(info), 0.0))
    d_safe = np.where(d > 0, d, 1.0)
    values, vectors = np.linalg.eigh(info / np.outer(d_safe, d_safe))
    best = None
    for e in np.flatnonzero(values <= NEARLY_FLAT * max(1.0, float(values.max(initial=0.0)))):
        direction = vectors[:, e] / d_safe
        direction /= np.abs(direction).max()
        theta = fit.theta[rewards]
        moving = np.abs(direction) >= ON_DIRECTION
        v, at = direction[moving], theta[moving]
        # How far each way until the first reward that moves reaches ±rmax.
        up = np.where(v > 0, (rmax - at) / v, (-rmax - at) / v)
        down = np.where(v > 0, (-rmax - at) / v, (rmax - at) / v)
        reach = [float(down.max()), float(up.min())]
        if best is None:
            best = log_likelihood(mdp, counts, unknowns.state_rewards(fit.theta), model=fit.model, player=fit.player,
                                  V0=fit.V1, gradient=False).value
        flat_ends = [_reach_along(mdp, unknowns, counts, fit, rewards, direction, edge, best=best, rmax=rmax)
                     for edge in reach]
        if min(flat_ends) == 0 and max(flat_ends) == 0:
            continue
        for j in np.flatnonzero(moving):
            ends = np.clip(theta[j] + np.array(flat_ends) * direction[j], -rmax, rmax)
            row = out[rewards[j]]
            out[rewards[j]] = [np.fmin(row[0], ends.min()), np.fmax(row[1], ends.max())]
    return out


def _reach_along(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, rewards: np.ndarray,
                 direction: np.ndarray, edge: float, *, best: float, rmax: float) -> float:
    """How far along `direction` (over the `rewards`) toward `edge` the log likelihood stays within `FLAT_DROP` of
    `best`, by bisection (`BOUND_STEPS` steps), each step's soft values from the last one's."""
    near, far, V = 0.0, edge, fit.V1
    for _ in range(BOUND_STEPS):
        middle = (near + far) / 2
        moved = fit.theta.copy()
        moved[rewards] = np.clip(fit.theta[rewards] + middle * direction, -rmax, rmax)
        got = log_likelihood(mdp, counts, unknowns.state_rewards(moved), model=fit.model, player=fit.player, V0=V,
                             gradient=False)
        V = got.plan.V
        near, far = (middle, far) if best - got.value < FLAT_DROP else (near, middle)
    return near


def variables(fit: PlayerFit) -> tuple[np.ndarray, np.ndarray]:
    """z (p,) = theta, log beta, then log sigma and logit lapse where the model has them, and which of
    them are free (p,) (the others at the end of their range)."""
    player = fit.player
    z = [*fit.theta, np.log(player.beta)]
    free = [True] * fit.theta.size + [_inside(np.log(player.beta), beta_bounds(fit.model))]
    if fit.model.searches_hand:
        z.append(np.log(player.sigma))
        free.append(_inside(z[-1], np.log(SIGMA_BOUNDS)))
    if fit.model.lapses:
        z.append(np.log(player.lapse) - np.log1p(-player.lapse))
        free.append(_inside(z[-1], np.log(LAPSE_BOUNDS) - np.log1p(-np.asarray(LAPSE_BOUNDS))))
    return np.asarray(z, dtype=float), np.asarray(free)


def _inside(value: float, ends) -> bool:
    return bool(min(abs(value - end) for end in ends) > AT_END)


def hessian(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *, free: np.ndarray) -> np.ndarray:
    """(p, p) d^2 LL / dz^2 at the fit over `variables`, by central differences of the exact gradient in
    the `free` columns (zero elsewhere)."""
    z, _ = variables(fit)
    out = np.zeros((z.size, z.size))
    with one_blas_thread():
        for j in np.flatnonzero(free):
            h = STEP * max(1.0, abs(z[j]))
            up, down = z.copy(), z.copy()
            up[j] += h
            down[j] -= h
            out[:, j] = (gradient(mdp, unknowns, counts, fit, up) - gradient(mdp, unknowns, counts, fit, down)) / (2 * h)
    return out


def gradient(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, z: np.ndarray) -> np.ndarray:
    """(p,) dLL/dz at variables z (`variables`) of `fit`'s model (the exact gradient, by the chain rule)."""
    k = unknowns.k
    i = k + 1
    sigma, lapse, bias = fit.player.sigma, 0.0, fit.player.bias
    if fit.model.searches_hand:
        sigma, i = float(np.exp(z[i])), i + 1
    if fit.model.lapses:
        lapse = float(1 / (1 + np.exp(-z[i])))
    player = Player(float(np.exp(z[k])), sigma, lapse, bias)
    got = log_likelihood(mdp, counts, unknowns.state_rewards(z[:k]), model=fit.model, player=player, V0=fit.V1)
    parts = [unknowns.basis.T @ got.R_S, [got.log_beta]]
    if fit.model.searches_hand:
        parts.append([got.log_sigma])
    if fit.model.lapses:
        parts.append([got.lapse * lapse * (1 - lapse)])
    return np.concatenate(parts)
