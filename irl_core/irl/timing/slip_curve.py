"""A time world's slip curve p(d) = p_inf + (p0 - p_inf) exp(-d / tau_ms), fitted to the recorded slips.

Every step on a time world records how long the key was held (d, exact) and whether the move
slipped: a Bernoulli outcome with probability p(d). `fit_slip_curve` maximises that likelihood over
(p0, p_inf, tau_ms) and gives each a profile-likelihood interval: the values where twice the drop
in log likelihood, the other two re-optimised, reaches the chi-square(1) quantile. A fit on a time
world (`irl_core.irl.fitting`) then plans with the fitted curve (`SlipCurve.world`); the holds a
player chose tell of the rewards, the slips of the curve.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize
from scipy.stats import chi2

from irl_core.worlds.world import World

PARAMETERS = ("p0", "p_inf", "tau_ms")
# The time constant is searched between these multiples of the longest hold: a curve that changes
# faster than this or slower than this is flat over every hold a person makes, as far as slips say.
TAU_RANGE = (1e-3, 100.0)
_EDGE = 1e-9


@dataclass(frozen=True)
class SlipCurve:
    """p0, p_inf, tau_ms; `interval` maps each to its (low, high) (None when the curve was given), `known`
    whether it is the world's own (``--slip-known``), `observations` the recorded holds it was fitted to."""

    p0: float
    p_inf: float
    tau_ms: float
    known: bool
    observations: int = 0
    interval: dict[str, tuple[float, float]] | None = None

    @classmethod
    def of_world(cls, world: World, *, observations: int = 0) -> SlipCurve:
        return cls(world.p0, world.p_inf, world.tau_ms, known=True, observations=observations)

    def world(self, world: World, *, cost_per_second: float | None = None) -> World:
        """`world` with this curve (and the given cost per second), validated like any world."""
        data = world.model_dump()
        data.update(p0=self.p0, p_inf=self.p_inf, tau_ms=self.tau_ms)
        if cost_per_second is not None:
            data["cost_per_second"] = cost_per_second
        return World.model_validate(data)

    def sentence(self) -> str:
        """The fitted curve in one sentence, its intervals and how many holds it rests on."""
        def shown(name: str, value: float, digits: str, unit: str = "") -> str:
            if self.interval is None:
                return f"{name} {value:{digits}}{unit}"
            low, high = self.interval[name]
            return f"{name} {value:{digits}}{unit} ({low:{digits}} to {high:{digits}})"
        return (f"slip curve fitted to {self.observations:,} recorded holds: " + ", ".join([
            shown("p0", self.p0, ".3f"), shown("p_inf", self.p_inf, ".3f"), shown("tau_ms", self.tau_ms, ".0f", " ms")]))

    def to_json(self) -> dict[str, Any]:
        """The fit JSON's ``slip_curve`` (docs/fit-json.md)."""
        return {"p0": self.p0, "p_inf": self.p_inf, "tau_ms": self.tau_ms,
                "interval": None if self.interval is None else {k: list(v) for k, v in self.interval.items()},
                "known": self.known}


def fit_slip_curve(outcomes: np.ndarray, *, max_hold_ms: float, confidence: float = 0.95) -> SlipCurve:
    """The maximum-likelihood slip curve of `outcomes` (n, 2) = (hold_ms, slipped), with profile intervals.

    Raises:
        ValueError: no outcomes to fit.
    """
    outcomes = np.asarray(outcomes, dtype=float).reshape(-1, 2)
    if outcomes.shape[0] == 0:
        raise ValueError("no recorded holds: the slip curve cannot be fitted")
    d = np.minimum(outcomes[:, 0], max_hold_ms)
    y = outcomes[:, 1]
    tau_low, tau_high = TAU_RANGE[0] * max_hold_ms, TAU_RANGE[1] * max_hold_ms

    def log_likelihood(p0: float, p_inf: float, tau: float) -> float:
        p = np.clip(p_inf + (p0 - p_inf) * np.exp(-d / tau), _EDGE, 1 - _EDGE)
        return float(np.sum(y * np.log(p) + (1 - y) * np.log1p(-p)))

    log_tau = (np.log(tau_low), np.log(tau_high))
    tau_start = np.log(max_hold_ms / 8)

    # Free coordinates for each search: every one is a box, so L-BFGS-B keeps p_inf <= p0 by construction.
    def search(fixed: str | None, value: float) -> tuple[Callable[[np.ndarray], tuple[float, float, float]],
                                                         list[tuple[float, float]], list[float]]:
        """How the free coordinates z make (p0, p_inf, tau) with `fixed` held at `value`; their box and start."""
        def unpack(z: np.ndarray) -> tuple[float, float, float]:
            if fixed == "p0":
                return value, value * z[0], float(np.exp(z[1]))
            if fixed == "p_inf":
                return value + (1 - value) * z[0], value, float(np.exp(z[1]))
            if fixed == "tau_ms":
                return z[0], z[0] * z[1], value
            return z[0], z[0] * z[1], float(np.exp(z[2]))

        if fixed in ("p0", "p_inf"):
            return unpack, [(0.0, 1.0), log_tau], [0.1 if fixed == "p0" else 0.5, tau_start]
        if fixed == "tau_ms":
            return unpack, [(0.0, 1.0), (0.0, 1.0)], [0.5, 0.1]
        return unpack, [(0.0, 1.0), (0.0, 1.0), log_tau], [0.5, 0.1, tau_start]

    def best(fixed: str | None, value: float) -> tuple[float, tuple[float, float, float]]:
        unpack, bounds, start = search(fixed, value)
        tries = [minimize(lambda z: -log_likelihood(*unpack(z)), np.array(x0), method="L-BFGS-B", bounds=bounds)
                 for x0 in _starts(start, bounds)]
        top = min(tries, key=lambda r: r.fun)
        return -float(top.fun), unpack(top.x)

    top, (p0, p_inf, tau) = best(None, 0.0)
    drop = chi2.ppf(confidence, 1) / 2
    ranges = {"p0": (0.0, 1.0), "p_inf": (0.0, 1.0), "tau_ms": (tau_low, tau_high)}
    at = {"p0": p0, "p_inf": p_inf, "tau_ms": tau}
    interval = {}
    for name in PARAMETERS:
        def below(v: float, name: str = name) -> bool:
            return top - best(name, v)[0] <= drop

        low, high = ranges[name]
        ends = []
        for edge in (low, high):
            if below(edge):
                ends.append(edge)
                continue
            inside, outside = at[name], edge
            for _ in range(40 if name == "tau_ms" else 30):
                middle = np.sqrt(inside * outside) if name == "tau_ms" else (inside + outside) / 2
                inside, outside = (middle, outside) if below(middle) else (inside, middle)
            ends.append(inside)
        interval[name] = (float(ends[0]), float(ends[1]))
    return SlipCurve(p0, p_inf, tau, known=False, observations=int(d.size), interval=interval)


def _starts(start: list[float], bounds: list[tuple[float, float]]) -> list[list[float]]:
    """The given start, and one at the middle of every box: the likelihood need not be concave in these coordinates."""
    return [start, [(lo + hi) / 2 for lo, hi in bounds]]
