"""A participant's hand from a study's motor calibration trials: the bias and noise of the produced level.

Each trial asked for a level (the target) and recorded the level the hold produced. The hand is the
people model's (`likelihood.level_kernel`): produced c given target c* with probability
K(c | c*) ~ exp(-(c - c* - b)^2 / (2 sigma^2)) on 1..L. `hand_from_trials` maximises the trials'
likelihood over the bias b and sigma, on the same kernel the fit then holds fixed, so an under-holder
(b < 0) is told apart from a player who fears less.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from irl_core.irl.people.likelihood import SIGMA_BOUNDS, level_kernel


@dataclass(frozen=True)
class Hand:
    """The hand's `bias` (levels, produced minus intended) and `sigma` (levels), from `trials` trials."""

    bias: float
    sigma: float
    trials: int

    def known(self) -> tuple[float, float]:
        """(bias, sigma), as `PlayerModel.with_hand` takes it."""
        return (self.bias, self.sigma)


def trials_log_likelihood(trials: np.ndarray, levels: int, *, bias: float, sigma: float) -> float:
    """sum over trials (n, 2) of (target, produced) of log K(produced | target)."""
    K, _ = level_kernel(levels, sigma, bias)
    with np.errstate(divide="ignore"):
        return float(np.log(K[trials[:, 0] - 1, trials[:, 1] - 1]).sum())


def hand_from_trials(trials: np.ndarray, levels: int) -> Hand:
    """The maximum-likelihood hand of calibration trials (n, 2) (target, produced), on 1..`levels`.

    Raises:
        ValueError: no trials, or a level outside 1..levels.
    """
    trials = np.asarray(trials, dtype=np.int64).reshape(-1, 2)
    if trials.shape[0] == 0:
        raise ValueError("the hand needs at least one calibration trial")
    if trials.min() < 1 or trials.max() > levels:
        raise ValueError(f"a calibration trial's level is outside 1..{levels}")
    if levels == 1:
        return Hand(0.0, SIGMA_BOUNDS[0], int(trials.shape[0]))
    error = (trials[:, 1] - trials[:, 0]).astype(float)
    start = np.array([error.mean(), np.log(np.clip(error.std() or 0.5, *SIGMA_BOUNDS))])
    bounds = [(-(levels - 1.0), levels - 1.0), (float(np.log(SIGMA_BOUNDS[0])), float(np.log(SIGMA_BOUNDS[1])))]

    def negative(z: np.ndarray) -> float:
        value = trials_log_likelihood(trials, levels, bias=float(z[0]), sigma=float(np.exp(z[1])))
        return -value if np.isfinite(value) else 1e300

    result = minimize(negative, start, method="Nelder-Mead", bounds=bounds,
                      options={"xatol": 1e-4, "fatol": 1e-9, "maxiter": 2000})
    return Hand(float(result.x[0]), float(np.exp(result.x[1])), int(trials.shape[0]))
