"""The population of participants: a random-effects pool of per-participant fits (docs/studies-pooling.md).

Each participant has their own player (beta, hand, lapses) and their own fit; the population is what
those fits say about people in general. For one reward, participant i's fit gives an interval
[l_i, h_i]. On a scale where such intervals are near symmetric (``log(-r)`` for a reward every
participant puts below zero, ``log(r)`` above, else the reward itself: `pooling_scale`), participant
i's answer is y_i, the interval's middle, with a within-participant standard error
s_i = width / (2 z). An interval that runs to the bound (``rmax``) says only that the reward lies
beyond its other end: it enters censored. The model (Higgins, Thompson & Spiegelhalter 2009, with
censoring as in a Tobit likelihood)::

    y_i = mu + u_i + e_i,   u_i ~ N(0, tau^2) (between participants),   e_i ~ N(0, s_i^2) (within)

mu and tau are fitted by maximum likelihood. The centre's interval is mu +- t(n-1) se(mu), the
prediction interval for a new participant mu +- t(n-2) sqrt(tau^2 + se(mu)^2), each mapped back to
rewards. The middle of the interval, not the fit's point, is the answer pooled: a point follows one
planning model (the rival model's point lies elsewhere in the interval), and the middle weighs both.

Where planning is not identified (a world's pool names a rival planning model), the ambiguity is
shared by every participant and does not shrink with more of them: the population is pooled under
each planning model and the two intervals are joined (`join`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import minimize
from scipy.stats import norm
from scipy.stats import t as student

Scale = Literal["log_negative", "log_positive", "linear"]
# An interval end within this fraction of rmax counts as the bound (the fit put it there).
AT_BOUND = 1e-3
TAU_FLOOR = 1e-6


@dataclass(frozen=True)
class PopulationReward:
    """The population's answer for one reward, in reward units.

    Attributes:
        centre: the population's typical reward (its median on the pooling scale).
        interval: (2,) the centre's confidence interval.
        spread: the standard deviation of participants' rewards in the population (reward units).
        prediction: (2,) where a new participant's reward lies with the interval's confidence.
        tau: the between-participant standard deviation on the pooling scale.
        scale: the pooling scale (`pooling_scale`).
        mu, se: the centre on the pooling scale and its standard error.
        used: participants whose fit bounds the reward (on either side); censored: of those, bounded on one side only.
    """

    centre: float
    interval: np.ndarray
    spread: float
    prediction: np.ndarray
    tau: float
    scale: Scale
    used: int
    censored: int
    mu: float = float("nan")
    se: float = float("nan")


@dataclass(frozen=True)
class Answers:
    """Participants' answers for one reward on the pooling scale: (n,) arrays.

    ``kind`` is 0 for an interval (y, s), +1 for "at least y" (the interval ran to the bound above),
    -1 for "at most y", and 2 for no answer (both ends at the bound).
    """

    y: np.ndarray
    s: np.ndarray
    kind: np.ndarray
    scale: Scale


def pooling_scale(intervals: np.ndarray, *, rmax: float) -> Scale:
    """The scale to pool one reward on, from participants' intervals (n, 2): log of its size where every
    participant's interval lies on one side of zero, else the reward itself."""
    ends = np.asarray(intervals, dtype=float)
    if ends.size and (ends[:, 1] < 0).all():
        return "log_negative"
    if ends.size and (ends[:, 0] > 0).all():
        return "log_positive"
    return "linear"


def from_scale(values: np.ndarray, scale: Scale) -> np.ndarray:
    """Pooling-scale values back to rewards (order kept: the first of a low-high pair stays the lower reward)."""
    values = np.asarray(values, dtype=float)
    if scale == "log_negative":
        return -np.exp(values)[..., ::-1] if values.ndim else -np.exp(values)
    if scale == "log_positive":
        return np.exp(values)
    return values


def answers(intervals: np.ndarray, *, rmax: float, confidence: float = 0.95, scale: Scale | None = None,
            shift: np.ndarray | None = None) -> Answers:
    """Participants' answers (see `Answers`) from their intervals (n, 2), each moved by `shift` (n,) first
    where given (a rival planning model's estimate minus the chosen one's)."""
    ends = np.asarray(intervals, dtype=float).copy()
    if shift is not None:
        ends = np.clip(ends + np.asarray(shift, dtype=float)[:, None], -rmax, rmax)
    scale = scale or pooling_scale(ends, rmax=rmax)
    if scale == "log_negative":
        ends = np.minimum(ends, -1e-9)
    elif scale == "log_positive":
        ends = np.maximum(ends, 1e-9)
    z = float(norm.ppf(0.5 + confidence / 2))
    low_bound = ends[:, 0] <= -rmax * (1 - AT_BOUND)
    high_bound = ends[:, 1] >= rmax * (1 - AT_BOUND)
    if scale == "log_negative":
        # -r runs the other way: the reward's lower end is the size's upper end.
        lo, hi = np.log(-ends[:, 1]), np.log(np.maximum(-ends[:, 0], 1e-300))
        at_lo, at_hi = high_bound, low_bound
    elif scale == "log_positive":
        lo, hi = np.log(ends[:, 0]), np.log(ends[:, 1])
        at_lo, at_hi = low_bound, high_bound
    else:
        lo, hi = ends[:, 0], ends[:, 1]
        at_lo, at_hi = low_bound, high_bound
    kind = np.zeros(len(ends), dtype=int)
    kind[at_hi & ~at_lo] = 1
    kind[at_lo & ~at_hi] = -1
    kind[at_lo & at_hi] = 2
    y = np.where(kind == 0, (lo + hi) / 2, np.where(kind == 1, lo, hi))
    s = np.where(kind == 0, np.maximum(hi - lo, 0.0) / (2 * z), 0.0)
    return Answers(y=y, s=s, kind=kind, scale=scale)


def _negative_log_likelihood(mu: float, tau: float, a: Answers, s_censored: float) -> float:
    exact, above, below = a.kind == 0, a.kind == 1, a.kind == -1
    sd = np.sqrt(tau**2 + a.s[exact] ** 2)
    total = -norm.logpdf(a.y[exact], mu, sd).sum()
    sd_c = np.sqrt(tau**2 + s_censored**2)
    total -= norm.logsf(a.y[above], mu, sd_c).sum()
    total -= norm.logcdf(a.y[below], mu, sd_c).sum()
    return float(total)


def fit_population(a: Answers) -> tuple[float, float, float, int]:
    """(mu, tau, se of mu, participants used) by maximum likelihood; NaNs without a participant who pins
    the reward on both sides."""
    used = a.kind != 2
    exact = a.kind == 0
    if exact.sum() == 0:
        return float("nan"), float("nan"), float("nan"), int(used.sum())
    # A censored answer's own noise is taken as the typical exact answer's.
    s_censored = float(np.median(a.s[exact]))
    spread = float(np.std(a.y[exact])) if exact.sum() > 1 else 0.0
    start = np.array([float(np.average(a.y[exact])), np.log(max(spread, s_censored, 1e-3))])

    def objective(x: np.ndarray) -> float:
        return _negative_log_likelihood(x[0], max(float(np.exp(x[1])), TAU_FLOOR), a, s_censored)

    best = minimize(objective, start, method="Nelder-Mead", options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 4000})
    mu, tau = float(best.x[0]), max(float(np.exp(best.x[1])), TAU_FLOOR)
    if tau < 1e-4:
        tau = 0.0
    # se(mu) from the curvature in mu at the fitted tau (a central difference).
    h = 1e-4 * max(1.0, abs(mu))
    f0 = _negative_log_likelihood(mu, max(tau, TAU_FLOOR), a, s_censored)
    curvature = (_negative_log_likelihood(mu + h, max(tau, TAU_FLOOR), a, s_censored) - 2 * f0
                 + _negative_log_likelihood(mu - h, max(tau, TAU_FLOOR), a, s_censored)) / h**2
    se = float(1 / np.sqrt(curvature)) if curvature > 0 else float("inf")
    return mu, tau, se, int(used.sum())


def pool_reward(intervals: np.ndarray, *, rmax: float, confidence: float = 0.95, scale: Scale | None = None,
                shift: np.ndarray | None = None) -> PopulationReward:
    """The population's answer for one reward from participants' intervals (n, 2) (see the module)."""
    a = answers(intervals, rmax=rmax, confidence=confidence, scale=scale, shift=shift)
    mu, tau, se, used = fit_population(a)
    n = int((a.kind != 2).sum())
    if not np.isfinite(mu):
        bound = _one_sided_bound(a, rmax=rmax)
        return PopulationReward(float("nan"), bound, float("nan"), bound, float("nan"), a.scale, used,
                                int((np.abs(a.kind) == 1).sum()))
    q = 0.5 + confidence / 2
    half = (float(student.ppf(q, n - 1)) if n > 1 else float("inf")) * se
    new_half = (float(student.ppf(q, n - 2)) if n > 2 else float("inf")) * float(np.sqrt(tau**2 + se**2))
    with np.errstate(over="ignore", invalid="ignore"):
        interval = np.clip(from_scale(np.array([mu - half, mu + half]), a.scale), -rmax, rmax)
        prediction = np.clip(from_scale(np.array([mu - new_half, mu + new_half]), a.scale), -rmax, rmax)
    centre = float(from_scale(np.array(mu), a.scale))
    if a.scale == "linear":
        spread = tau
    else:  # the standard deviation of a log-normal reward
        spread = abs(centre) * float(np.sqrt(np.expm1(tau**2) * np.exp(tau**2)))
    return PopulationReward(centre, interval, float(spread), prediction, tau, a.scale, used,
                            int((np.abs(a.kind) == 1).sum()), mu=mu, se=se)


def _one_sided_bound(a: Answers, *, rmax: float) -> np.ndarray:
    """(2,) what participants who all bound a reward on one side say of the population: up to the mildest
    bound among them ("every fit puts the cliff at most -300, one at most -120": at most -120); the whole
    range when they bound it on different sides or not at all."""
    sides = set(a.kind[a.kind != 2].tolist())
    if len(sides) != 1:
        return np.array([-rmax, rmax])
    y = a.y[a.kind != 2]
    # On the pooling scale, "at least" (kind 1) is bounded below by the smallest; "at most" above by the largest.
    end = float(y.min()) if sides == {1} else float(y.max())
    ends = np.array([end, np.inf]) if sides == {1} else np.array([-np.inf, end])
    with np.errstate(over="ignore"):
        return np.clip(from_scale(ends, a.scale), -rmax, rmax)


def join(first: PopulationReward, second: PopulationReward) -> PopulationReward:
    """One reward pooled under two planning models: the first's centre, both intervals joined."""
    interval = np.array([min(first.interval[0], second.interval[0]), max(first.interval[1], second.interval[1])])
    prediction = np.array([min(first.prediction[0], second.prediction[0]),
                           max(first.prediction[1], second.prediction[1])])
    return PopulationReward(first.centre, interval, max(first.spread, second.spread), prediction,
                            max(first.tau, second.tau), first.scale, first.used, first.censored, mu=first.mu,
                            se=first.se)


@dataclass(frozen=True)
class Population:
    """A pool of participants' fits: per reward (k,) its `PopulationReward`, and per participant (n,) whether
    they are an outlier or influential, and on which rewards."""

    rewards: tuple[PopulationReward, ...]
    outlier: np.ndarray
    influential: np.ndarray
    outlier_on: tuple[tuple[int, ...], ...]
    influential_on: tuple[tuple[int, ...], ...]

    @property
    def centre(self) -> np.ndarray:
        return np.array([r.centre for r in self.rewards])

    @property
    def intervals(self) -> np.ndarray:
        """(k, 2) the centre's intervals."""
        return np.array([r.interval for r in self.rewards]).reshape(-1, 2)

    @property
    def predictions(self) -> np.ndarray:
        """(k, 2) the prediction intervals."""
        return np.array([r.prediction for r in self.rewards]).reshape(-1, 2)

    @property
    def spread(self) -> np.ndarray:
        return np.array([r.spread for r in self.rewards])


def pool_participants(intervals: np.ndarray, *, rmax: float, confidence: float = 0.95,
                      rival_shift: np.ndarray | None = None, marks: bool = True) -> Population:
    """The population from n participants' fits of k rewards, with outliers and influence.

    Args:
        intervals: (n, k, 2) each participant's interval per reward (their fit's confidence interval).
        rival_shift: (n, k) where planning is not identified: each participant's estimate under the rival
            planning model minus their estimate under the chosen one. The population is then pooled under
            both and the intervals joined.
        marks: whether to mark outliers and influence (n leave-one-out pools per reward; `careful study plan`
            needs only the pool).

    A participant is an `outlier` when, on some reward, their answer lies outside the prediction interval
    of the others (pooled without them), each reward's test at (1 - confidence) / k (Bonferroni: with three
    rewards at 95% each, one careful participant in seven would be an outlier somewhere by chance), and
    `influential` when the centre with them lies outside the centre's interval without them or the other
    way round.
    """
    intervals = np.asarray(intervals, dtype=float)
    n, k = intervals.shape[:2]
    rewards, scales = [], []
    for j in range(k):
        pooled = pool_reward(intervals[:, j], rmax=rmax, confidence=confidence)
        if rival_shift is not None:
            pooled = join(pooled, pool_reward(intervals[:, j], rmax=rmax, confidence=confidence, scale=pooled.scale,
                                              shift=rival_shift[:, j]))
        rewards.append(pooled)
        scales.append(pooled.scale)
    outlier_on: list[tuple[int, ...]] = []
    influential_on: list[tuple[int, ...]] = []
    for i in range(n if marks else 0):
        keep = np.arange(n) != i
        outside, moved = [], []
        for j in range(k):
            if n < 3:
                continue
            others = pool_reward(intervals[keep, j], rmax=rmax, confidence=confidence, scale=scales[j])
            mine = answers(intervals[i:i + 1, j], rmax=rmax, confidence=confidence, scale=scales[j])
            if _outside(mine, others, confidence=1 - (1 - confidence) / k):
                outside.append(j)
            if _moves(rewards[j], others):
                moved.append(j)
        outlier_on.append(tuple(outside))
        influential_on.append(tuple(moved))
    return Population(rewards=tuple(rewards), outlier=np.array([bool(o) for o in outlier_on] or [False] * n),
                      influential=np.array([bool(m) for m in influential_on] or [False] * n),
                      outlier_on=tuple(outlier_on), influential_on=tuple(influential_on))


def outlier_reach(n: int, *, rewards: int, confidence: float = 0.95) -> float:
    """How many times wider than with many participants the outlier test's interval is among `n` participants
    (`_outside`: the n - 1 others' t(n - 3) quantile at the Bonferroni level over `rewards`, against the normal's);
    inf when n < 4, where no answer can lie outside."""
    q = 0.5 + (1 - (1 - confidence) / max(rewards, 1)) / 2
    return float(student.ppf(q, n - 3)) / float(norm.ppf(q)) if n > 3 else float("inf")


def _outside(mine: Answers, others: PopulationReward, *, confidence: float) -> bool:
    """Whether one participant's answer lies outside where the others say an answer like it would lie: their
    centre +- t(n-2) sqrt(tau^2 + se^2 + s_i^2), the participant's own measurement noise included (the
    studentized deleted residual of Viechtbauer & Cheung 2010). A one-sided answer is outside only when all
    it allows is."""
    if not np.isfinite(others.mu) or mine.kind[0] == 2:
        return False
    q = 0.5 + confidence / 2
    n = others.used
    half = (float(student.ppf(q, n - 2)) if n > 2 else float("inf")) * float(
        np.sqrt(others.tau**2 + others.se**2 + float(mine.s[0]) ** 2))
    low, high = others.mu - half, others.mu + half
    y = float(mine.y[0])
    if mine.kind[0] == 0:
        return not low <= y <= high
    return y > high if mine.kind[0] == 1 else y < low


def _moves(with_them: PopulationReward, without: PopulationReward) -> bool:
    """Whether a participant moves the centre out of an interval, either way round."""
    if not (np.isfinite(with_them.centre) and np.isfinite(without.centre)):
        return False
    inside = lambda x, ends: ends[0] <= x <= ends[1]  # noqa: E731
    return not inside(with_them.centre, without.interval) or not inside(without.centre, with_them.interval)
