"""Fit check: does the fitted player reproduce the recordings?

A reward read from a player model means something only if the model explains how the recordings
were played. The check simulates replicates from the fitted player (its policy over recorded
actions, `people.PlayerPlan.observed`), each as many episodes as were recorded and from the same
starts, in the world's own dynamics, and compares with the recordings:

=================================  ===========================================================
statistic                          why
=================================  ===========================================================
mean carefulness at distance d     how care grows near danger: what the rewards are read from
(from the nearest terminal cell)   (one statistic per distance with enough recorded steps)
share in the likeliest direction   how sharp the choice of direction is
episodes ending in each symbol     where play leads (and the step limit)
mean episode length                how directly
=================================  ===========================================================

Each statistic's band is the replicates' central interval at 1 - 0.05 / m (m statistics, so that a
well-specified player fails any of them in about 5% of recordings); the check passes when every
recorded value lies in its band. Only finished episodes take part (a quit or a cut-short episode
says nothing about how episodes end).

Memory: the replicates are simulated a chunk at a time, as many as keep a chunk near
`CHUNK_STEPS` simulated steps (each replicate about as many steps as were recorded), from one
random stream; a small recording is one chunk, so its check is what one simulation of all
replicates gives. A 200 MB recording's fit had simulated all 200 replicates at once (14 GB).
"""

from __future__ import annotations

import weakref
from collections import deque
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from irl_core.players.experts import Chooser, rollouts
from irl_core.recordings.demonstrations import EpisodeFacts
from irl_core.worlds.mdp import MDP

REPLICATES = 200
FAMILY_LEVEL = 0.05
# A distance's mean carefulness is compared only with at least this many recorded steps there.
MIN_STEPS_AT_DISTANCE = 10
FARTHEST_DISTANCE = 4  # distances of 4 or more share one statistic
# Simulated steps per chunk of replicates: a few hundred bytes each while a chunk is simulated.
CHUNK_STEPS = 1_000_000


@dataclass(frozen=True)
class Statistic:
    """One compared statistic: the recorded value and the replicates' band [low, high]."""

    name: str
    observed: float
    low: float
    high: float

    @property
    def ok(self) -> bool:
        return bool(self.low - 1e-12 <= self.observed <= self.high + 1e-12)

    def to_json(self) -> dict:
        return {"name": self.name, "observed": _round(self.observed), "low": _round(self.low),
                "high": _round(self.high), "ok": self.ok}


@dataclass(frozen=True)
class FitCheck:
    """The check's verdict: `passed` is None when it could not run (`reason` says why)."""

    passed: bool | None
    statistics: tuple[Statistic, ...]
    replicates: int
    reason: str | None = None

    @property
    def failed(self) -> tuple[Statistic, ...]:
        return tuple(s for s in self.statistics if not s.ok)

    def summary(self) -> str:
        """One sentence: passed, failed on which statistics, or why it did not run."""
        if self.passed is None:
            return f"fit check not run: {self.reason}"
        if self.passed:
            return (f"fit check passed: the fitted player reproduces all {len(self.statistics)} statistics of the "
                    f"recordings ({self.replicates} replicates)")
        return "the fitted player does not reproduce: " + "; ".join(
            f"{s.name} {s.observed:.3g} (replicates {s.low:.3g} to {s.high:.3g})" for s in self.failed)

    def to_json(self) -> dict:
        return {"passed": self.passed, "replicates": self.replicates,
                "statistics": [s.to_json() for s in self.statistics],
                **({"reason": self.reason} if self.reason else {})}


def terminal_distance(mdp: MDP) -> np.ndarray:
    """(S,) moves from each state to the nearest terminal cell (0 there, -1 for the exit and where none can be reached);
    worked out once per MDP (each replicate of the check asks), read-only."""
    distance = _DISTANCE.get(mdp)
    if distance is None:
        distance = _DISTANCE[mdp] = _walk_back(mdp)
        distance.setflags(write=False)
    return distance


_DISTANCE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _walk_back(mdp: MDP) -> np.ndarray:
    distance = np.full(mdp.n_states, -1, dtype=np.int64)
    queue = deque(int(s) for s in np.flatnonzero(mdp.terminal))
    distance[list(queue)] = 0
    # neighbour[s, d] is one move away from s; walk it backwards from the terminal cells.
    sources: list[list[int]] = [[] for _ in range(mdp.n_states)]
    for s in np.flatnonzero(mdp.nonterminal).tolist():
        for t in set(mdp.neighbour[s].tolist()):
            if t != s:
                sources[t].append(s)
    while queue:
        t = queue.popleft()
        for s in sources[t]:
            if distance[s] < 0:
                distance[s] = distance[t] + 1
                queue.append(s)
    return distance


def fit_check(
    mdp: MDP,
    observed_policy: np.ndarray,
    by_episode: sp.csr_matrix,
    facts: EpisodeFacts,
    *,
    replicates: int = REPLICATES,
    seed: int = 0,
    player: Chooser | None = None,
) -> FitCheck:
    """Compare the recorded episodes (rows of `by_episode` (E, S * A), `facts` of each) with
    `replicates` simulations of the fitted player `observed_policy` (S, A) from the same starts, or of
    `player` when given (a time world's timing model, which holds for continuous times and slips with them)."""
    finished = facts.finished
    if not finished.any():
        return FitCheck(None, (), 0, "no recorded episode ran to its end (every one was quit or cut short)")
    rows = sp.csr_matrix(by_episode)[np.flatnonzero(finished)]
    starts = facts.start[finished]
    recorded = _statistics_of_counts(mdp, _likeliest_direction(mdp, observed_policy), np.asarray(rows.sum(axis=0)).ravel())
    recorded_ends = [facts.end[e] for e in np.flatnonzero(finished)]
    recorded.update(_ending_statistics(mdp, recorded_ends, facts.length[finished]))

    names = [name for name in recorded if name.startswith(("mean carefulness", "share"))]
    distance_steps = _steps_by_distance(mdp, np.asarray(rows.sum(axis=0)).ravel())
    names = [name for name in names if not name.startswith("mean carefulness") or
             distance_steps.get(name, 0) >= MIN_STEPS_AT_DISTANCE]
    names += [name for name in recorded if name.startswith(("episodes ending", "mean episode length"))]
    per_chunk = max(1, min(replicates, CHUNK_STEPS // max(1, int(facts.length[finished].sum()))))
    values = {name: np.empty(replicates) for name in names}
    rng = np.random.default_rng(seed)
    for first in range(0, replicates, per_chunk):
        count = min(per_chunk, replicates - first)
        chunk = _replicate_statistics(mdp, observed_policy, starts, count, names, rng, player=player)
        for name in names:
            values[name][first:first + count] = chunk[name]
    tail = FAMILY_LEVEL / (2 * len(names))
    statistics = []
    for name in names:
        sample = values[name][~np.isnan(values[name])]
        if sample.size == 0:
            continue
        low, high = np.quantile(sample, [tail, 1 - tail])
        statistics.append(Statistic(name, float(recorded[name]), float(low), float(high)))
    return FitCheck(all(s.ok for s in statistics), tuple(statistics), replicates)


def _replicate_statistics(mdp: MDP, policy: np.ndarray, starts: np.ndarray, count: int, names: list[str],
                          rng: np.random.Generator, *, player: Chooser | None = None) -> dict[str, np.ndarray]:
    """Each statistic in `names` for `count` replicates of the episodes from `starts` (n,): (count,) each,
    played by `player` when given, else by `policy`."""
    n = len(starts)
    simulated = rollouts(mdp, policy if player is None else player, starts=np.tile(starts, count),
                         episodes=n * count, rng=rng)
    pairs = simulated.state * mdp.n_actions + simulated.action
    # Row by row: the whole (count, S * A) array was a third of a 24x24 world's check.
    per_replicate = sp.csr_matrix((np.ones(pairs.size), (simulated.episode // n, pairs)),
                                  shape=(count, mdp.n_states * mdp.n_actions))
    symbols = mdp.symbols + ("",)
    ends = ["step_limit" if cut else symbols[s] for s, cut in zip(simulated.final_state.tolist(), simulated.truncated.tolist())]
    values = {name: np.empty(count) for name in names}
    likeliest = _likeliest_direction(mdp, policy)
    for r in range(count):
        these = _statistics_of_counts(mdp, likeliest, per_replicate[r].toarray().ravel())
        these.update(_ending_statistics(mdp, ends[r * n:(r + 1) * n], simulated.length[r * n:(r + 1) * n]))
        for name in names:
            values[name][r] = these.get(name, np.nan)
    return values


def _distance_label(d: int) -> str:
    return f"mean carefulness {d}+ moves from a terminal cell" if d >= FARTHEST_DISTANCE else \
        f"mean carefulness {d} move{'s' if d != 1 else ''} from a terminal cell"


def _steps_by_distance(mdp: MDP, pair_counts: np.ndarray) -> dict[str, float]:
    per_state = pair_counts.reshape(mdp.n_states, mdp.n_actions).sum(axis=1)
    distance = np.minimum(terminal_distance(mdp), FARTHEST_DISTANCE)
    return {_distance_label(d): float(per_state[distance == d].sum()) for d in range(1, FARTHEST_DISTANCE + 1)}


def _likeliest_direction(mdp: MDP, policy: np.ndarray) -> np.ndarray:
    """(S,) the index of each state's likeliest direction under `policy` (S, A), its levels added up."""
    return policy.reshape(mdp.n_states, 4, mdp.levels).sum(axis=2).argmax(axis=1)


def _statistics_of_counts(mdp: MDP, likeliest: np.ndarray, pair_counts: np.ndarray) -> dict[str, float]:
    """Carefulness by distance and the share of steps in the fitted policy's `likeliest` direction (S,), from counts
    (S * A,)."""
    counts = pair_counts.reshape(mdp.n_states, mdp.n_actions)
    out: dict[str, float] = {}
    distance = np.minimum(terminal_distance(mdp), FARTHEST_DISTANCE)
    care = counts @ mdp.carefulness
    steps = counts.sum(axis=1)
    for d in range(1, FARTHEST_DISTANCE + 1):
        here = distance == d
        if steps[here].sum() > 0:
            out[_distance_label(d)] = float(care[here].sum() / steps[here].sum())
    by_direction = counts.reshape(mdp.n_states, 4, mdp.levels).sum(axis=2)
    if steps.sum() > 0:
        out["share of steps in the fitted likeliest direction"] = float(
            by_direction[np.arange(mdp.n_states), likeliest].sum() / steps.sum())
    return out


def _ending_statistics(mdp: MDP, ends: list[str], lengths: np.ndarray) -> dict[str, float]:
    """Shares of episodes ending in each terminal symbol (and the step limit) and the mean length."""
    kinds = sorted(set(mdp.world.terminal) | {"step_limit"})
    out = {}
    for kind in kinds:
        label = f"episodes ending {'at the step limit' if kind == 'step_limit' else 'in ' + kind}"
        out[label] = float(np.mean([end == kind for end in ends])) if ends else np.nan
    out["mean episode length"] = float(np.mean(lengths)) if len(lengths) else np.nan
    return out


def _round(value: float) -> float:
    return float(f"{value:.6g}")
