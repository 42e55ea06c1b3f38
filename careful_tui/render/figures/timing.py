"""A time world's fit as pictures (docs/timing.md): the slip curve over the recorded slips, and the holds
against distance to danger, recorded and fitted.

- `draw_slip_curve`: the fitted p(d) with a band (the curves whose three parameters all lie within their
  intervals: the band is their pointwise envelope, wider than a joint band would be), over the recorded
  holds' slip rates in log-spaced groups (each a point at the group's median hold, ±1.96 standard errors)
  and a rug of the holds themselves.
- `draw_holds`: per distance to the nearest terminal cell, the recorded holds' geometric mean with a 95%
  interval, and the fitted player's intended hold h*(s, d) averaged (geometrically) over the same steps: those
  whose direction is the fitted player's best (a lapse's hold, which the model leaves free, would pull the
  recorded mean away from any intended hold).
"""

from __future__ import annotations

import itertools

import numpy as np
from matplotlib.axes import Axes
from matplotlib.ticker import MaxNLocator

from careful_tui.render.figures.carefulness import Z_95, state_distances
from careful_tui.render.figures.style import OKABE_ITO, QUIET
from irl_core.irl import FitResult
from irl_core.irl.timing.fit import timing_plan
from irl_core.worlds.world import SHORTEST_HOLD_MS

# Recorded holds are grouped into this many log-spaced groups for their slip rates.
SLIP_GROUPS = 12


def draw_slip_curve(ax: Axes, result: FitResult) -> None:
    """The slip curve the fit planned with, its band, and the recorded slips."""
    curve, world = result.slip_curve, result.world
    assert curve is not None, "a time world's fit has a slip curve"
    steps = result.demos.hold_steps
    hold, slipped = steps[:, 2], steps[:, 3]
    d = np.geomspace(SHORTEST_HOLD_MS, world.max_hold_ms, 300)

    def p(p0: float, p_inf: float, tau: float) -> np.ndarray:
        return p_inf + (p0 - p_inf) * np.exp(-d / tau)

    if curve.interval is not None:
        corners = [p(a, min(b, a), c) for a, b, c in itertools.product(*(curve.interval[n] for n in
                                                                          ("p0", "p_inf", "tau_ms")))]
        ax.fill_between(d, np.min(corners, axis=0), np.max(corners, axis=0), color=OKABE_ITO[1], alpha=0.2,
                        linewidth=0, label="every parameter within its interval")
    ax.plot(d, p(curve.p0, curve.p_inf, curve.tau_ms), color=OKABE_ITO[1], linewidth=1.2,
            label="the world's curve" if curve.known else "fitted curve")
    if hold.size:
        edges = np.geomspace(max(hold.min(), 1.0), hold.max() * 1.0001, SLIP_GROUPS + 1)
        group = np.clip(np.searchsorted(edges, hold, side="right") - 1, 0, SLIP_GROUPS - 1)
        for g in range(SLIP_GROUPS):
            inside = group == g
            n = int(inside.sum())
            if n < 5:
                continue
            rate = float(slipped[inside].mean())
            half = Z_95 * np.sqrt(max(rate * (1 - rate), 0.25 / n) / n)
            ax.errorbar(np.median(hold[inside]), rate, yerr=half, fmt="o", color=OKABE_ITO[0], markersize=3,
                        capsize=2, elinewidth=0.8, label="recorded slip rate ± 95%" if g == group.min() else None)
        ax.plot(hold, np.full(hold.size, -0.03), "|", color=QUIET, markersize=3, alpha=0.3)
    ax.set_xscale("log")
    ax.set_ylim(-0.06, max(0.6, curve.p0 + 0.05))
    _finish(ax, x="hold (ms)", y="chance of slipping", title="slip curve")


def draw_holds(ax: Axes, result: FitResult) -> None:
    """Recorded and fitted holds against distance to danger (geometric means over the same steps)."""
    mdp, curve = result.mdp, result.slip_curve
    assert curve is not None, "a time world's fit has a slip curve"
    steps = result.demos.hold_steps
    plan = timing_plan(mdp, result.R_S, p0=curve.p0, p_inf=curve.p_inf, tau_ms=curve.tau_ms,
                       cost_per_second=mdp.world.cost_per_second)
    steps = steps[steps[:, 1].astype(int) == plan.Q.argmax(axis=1)[steps[:, 0].astype(int)]]
    state, direction, hold = steps[:, 0].astype(int), steps[:, 1].astype(int), steps[:, 2]
    distance = state_distances(mdp)[state]
    fitted = np.maximum(plan.hold[state, direction], SHORTEST_HOLD_MS)
    rows = []
    for dist in np.unique(distance[distance >= 0]):
        at = distance == dist
        logs = np.log(np.maximum(hold[at], 1.0))
        half = Z_95 * logs.std(ddof=1) / np.sqrt(logs.size) if logs.size > 1 else np.nan
        rows.append((dist, np.exp(logs.mean()), np.exp(logs.mean() - half), np.exp(logs.mean() + half),
                     np.exp(np.log(fitted[at]).mean())))
    if rows:
        dist_, mean_, low_, high_, fit_ = (np.array(c) for c in zip(*rows))
        ax.errorbar(dist_, mean_, yerr=[mean_ - low_, high_ - mean_], fmt="o-", color=OKABE_ITO[0], markersize=3,
                    capsize=2, elinewidth=0.8, linewidth=1.0,
                    label="recorded, in the best direction\n(geometric mean ± 95%)")
        ax.plot(dist_, fit_, "s--", color=OKABE_ITO[1], markersize=3, linewidth=1.0,
                label="fitted player's intended hold")
    ax.set_yscale("log")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    _finish(ax, x="steps to the nearest terminal cell", y="hold (ms)", title="holds by distance to danger")


def _finish(ax: Axes, *, x: str, y: str, title: str) -> None:
    """A panel's labels and title, its open frame and its legend at the top right."""
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(title, pad=3)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    ax.legend(loc="upper right", fontsize=5)
