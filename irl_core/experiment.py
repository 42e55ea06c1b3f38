"""The paper's experiments end to end, as data (the terminal and files are `careful_tui`'s job).

1. The optimal policy of `paper` with 14 levels (figure 3) and its true reward (figure 4).
2. The MaxEnt baseline: Boltzmann episodes on `paper-maxent`, fitted with `maxent` (figure 5).
3. The careful LP: optimal episodes on `paper`, fitted with `lp` (figure 6).
4. The loss method on a handful of noisy demonstrations (figures 7 and 8): human sessions
   of `paper` when there are some, otherwise Boltzmann episodes, labelled as such.
5. Beyond the paper: reward intervals on `mud` against `mud-simple`, showing that only
   carefulness separates the catastrophic cliff from the merely undesirable mud.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from irl_core.demonstrations import Demonstrations, RecordingError, read_recording
from irl_core.experts import (
    boltzmann_policy,
    demonstrations_of,
    optimal_policy,
    rollouts,
)
from irl_core.irl.fit import fit
from irl_core.irl.result import FitResult
from irl_core.mdp import ARROWS, MDP, action_parts, build_mdp
from irl_core.planning import value_iteration
from irl_core.world import BUILTIN_WORLDS, World

Cell = tuple[int, int]


@dataclass(frozen=True)
class Sizes:
    """How much data each stage uses; `QUICK` is for tests."""

    maxent_episodes: int = 10_000
    lp_episodes: int = 100
    noisy_episodes: int = 10
    interval_episodes: int = 100


FULL, QUICK = Sizes(), Sizes(maxent_episodes=2_000, lp_episodes=100, noisy_episodes=10, interval_episodes=60)


@dataclass(frozen=True)
class Figure:
    """One picture: a world with values per cell and/or a label per cell."""

    key: str
    title: str
    world: World
    values: np.ndarray | None = None
    labels: dict[Cell, str] = field(default_factory=dict)
    caption: str = ""


@dataclass(frozen=True)
class Estimate:
    """A fit's cliff and goal against the truth (means over the cells of each symbol)."""

    stage: str
    method: str
    data: str
    cliff: float
    goal: float
    true_cliff: float
    true_goal: float
    seconds: float

    @property
    def cliff_error(self) -> float:
        """Relative error of the cliff estimate, |est - true| / |true|."""
        return abs(self.cliff - self.true_cliff) / abs(self.true_cliff)

    @property
    def goal_error(self) -> float:
        return abs(self.goal - self.true_goal) / abs(self.true_goal)


@dataclass(frozen=True)
class Separation:
    """Intervals of the cliff and mud cells in one world, and whether they are disjoint."""

    world: str
    cliff: tuple[float, float]
    mud: tuple[float, float]
    seconds: float

    @property
    def separated(self) -> bool:
        return self.cliff[1] < self.mud[0] or self.mud[1] < self.cliff[0]

    @property
    def cliff_width(self) -> float:
        return self.cliff[1] - self.cliff[0]

    @property
    def mud_width(self) -> float:
        return self.mud[1] - self.mud[0]


@dataclass
class ExperimentResult:
    figures: list[Figure] = field(default_factory=list)
    estimates: list[Estimate] = field(default_factory=list)
    separations: list[Separation] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def summary(self) -> dict:
        """What `summary.json` holds."""
        return {
            "estimates": [
                {
                    "stage": e.stage, "method": e.method, "data": e.data,
                    "cliff": e.cliff, "true_cliff": e.true_cliff, "cliff_error": e.cliff_error,
                    "goal": e.goal, "true_goal": e.true_goal, "goal_error": e.goal_error,
                    "seconds": e.seconds,
                }
                for e in self.estimates
            ],
            "intervals": [
                {
                    "world": s.world, "cliff": list(s.cliff), "mud": list(s.mud),
                    "cliff_width": s.cliff_width, "mud_width": s.mud_width,
                    "separated": s.separated, "seconds": s.seconds,
                }
                for s in self.separations
            ],
            "notes": self.notes,
            "seconds": self.seconds,
        }


Progress = Callable[[str], None]


def policy_labels(mdp: MDP, actions: Iterable[int], where: np.ndarray | None = None) -> dict[Cell, str]:
    """"→8"-style labels: each acting cell's action as an arrow and a carefulness level.

    Args:
        actions: (S,) an action per state.
        where: (S,) bool, the states to label (default: every state where the agent acts).
    """
    where = mdp.nonterminal if where is None else where
    labels = {}
    for s, a in enumerate(actions):
        if s < len(mdp.cells) and where[s]:
            direction, c = action_parts(int(a), mdp.levels)
            labels[mdp.cells[s]] = f"{ARROWS[direction]}{c}" if mdp.levels > 1 else ARROWS[direction]
    return labels


def symbol_mean(result: FitResult, symbol: str) -> float:
    """Mean fitted R_S over the cells showing `symbol`."""
    values = [result.R_S[s] for s, sym in enumerate(result.mdp.symbols) if sym == symbol]
    return float(np.mean(values))


def symbol_interval(result: FitResult, symbol: str) -> tuple[float, float]:
    """The hull of the intervals of every cell showing `symbol`: (lowest low, highest high)."""
    grid = result.interval_grid
    cells = [cell for cell, sym in zip(result.mdp.cells, result.mdp.symbols) if sym == symbol]
    return float(min(grid[c][0] for c in cells)), float(max(grid[c][1] for c in cells))


def human_sessions(folder: Path, world: World) -> list[Path]:
    """Readable sessions in `folder` played by a person (not `expert:...`) in `world`."""
    found = []
    for path in sorted(folder.glob("*.jsonl")) if folder.is_dir() else []:
        try:
            recording = read_recording(path)
        except RecordingError:
            continue
        if recording.world == world and not recording.header.player.startswith("expert:") and recording.steps:
            found.append(path)
    return found


def _estimate(stage: str, data: str, result: FitResult, seconds: float) -> Estimate:
    world = result.world
    return Estimate(
        stage=stage, method=result.method, data=data,
        cliff=symbol_mean(result, "C"), goal=symbol_mean(result, "G"),
        true_cliff=world.reward_of("C"), true_goal=world.reward_of("G"), seconds=seconds,
    )


def _fitted(result: FitResult, title: str, key: str, caption: str) -> Figure:
    return Figure(key=key, title=title, world=result.world, values=result.reward_grid, caption=caption)


def run_experiment(
    *,
    sizes: Sizes = FULL,
    recordings: Path | None = Path("recordings"),
    seed: int = 0,
    progress: Progress = lambda stage: None,
) -> ExperimentResult:
    """Run the five stages; `progress(name)` is called as each stage starts."""
    out = ExperimentResult()
    started = time.perf_counter()

    # 1. Figures 3 and 4: the optimal policy with 14 levels, and the true reward.
    progress("optimal policy of paper (figures 3, 4)")
    paper = build_mdp(BUILTIN_WORLDS["paper"])
    plan = value_iteration(paper)
    out.figures.append(Figure("fig3-optimal-policy", "Figure 3: optimal policy, 14 levels of carefulness",
                              paper.world, labels=policy_labels(paper, plan.greedy),
                              caption="More careful near the cliff, and often moving away from it."))
    out.figures.append(Figure("fig4-true-reward", "Figure 4: true reward", paper.world,
                              values=paper.grid_of(paper.R_S), caption="Cliff -1000, goal +100, ground 0."))

    # 2. Figure 5: the MaxEnt baseline in the deterministic world.
    progress(f"MaxEnt baseline: {sizes.maxent_episodes} Boltzmann episodes (figure 5)")
    maxent_mdp = build_mdp(BUILTIN_WORLDS["paper-maxent"])
    t = time.perf_counter()
    demos = demonstrations_of(maxent_mdp, rollouts(maxent_mdp, boltzmann_policy(maxent_mdp, beta=0.1),
                                                   episodes=sizes.maxent_episodes, seed=seed))
    result = fit(demos, method="maxent", beta=0.1)
    data = f"{sizes.maxent_episodes} Boltzmann episodes (beta 0.1)"
    out.estimates.append(_estimate("maxent baseline", data, result, time.perf_counter() - t))
    out.figures.append(_fitted(result, "Figure 5: MaxEnt baseline (no carefulness)", "fig5-maxent",
                               "Finds the cliff and the goal but badly underestimates how bad the cliff is: "
                               "the expert almost never steps off, so the likelihood barely depends on it."))

    # 3. Figure 6: the careful LP from optimal episodes.
    progress(f"careful LP: {sizes.lp_episodes} optimal episodes (figure 6)")
    t = time.perf_counter()
    demos = demonstrations_of(paper, rollouts(paper, optimal_policy(paper), episodes=sizes.lp_episodes, seed=seed))
    result = fit(demos, method="lp")
    data = f"{sizes.lp_episodes} optimal episodes"
    out.estimates.append(_estimate("careful lp", data, result, time.perf_counter() - t))
    out.figures.append(_fitted(result, "Figure 6: careful LP from optimal rollouts", "fig6-lp",
                               "Carefulness reveals the severity of the cliff."))

    # 4. Figures 7 and 8: the loss method on a handful of noisy demonstrations.
    humans = human_sessions(recordings, paper.world) if recordings is not None else []
    t = time.perf_counter()
    if humans:
        progress(f"loss method: {len(humans)} human session(s) from {recordings} (figures 7, 8)")
        demos = Demonstrations.read(humans)
        data = f"{demos.episodes} human episodes"
    else:
        progress(f"loss method: {sizes.noisy_episodes} Boltzmann episodes (figures 7, 8)")
        demos = demonstrations_of(paper, rollouts(paper, boltzmann_policy(paper, beta=1.0),
                                                  episodes=sizes.noisy_episodes, seed=seed))
        data = f"{sizes.noisy_episodes} Boltzmann episodes (beta 1)"
        out.notes.append(f"no human sessions of paper in {recordings}: stage 4 used simulated noisy experts")
    result = fit(demos, method="loss")
    out.estimates.append(_estimate("loss, noisy", data, result, time.perf_counter() - t))
    out.figures.append(Figure("fig7-demonstrated-policy", "Figure 7: the demonstrated policy (most frequent action)",
                              paper.world, labels=policy_labels(paper, demos.counts.argmax(axis=1), demos.demonstrated),
                              caption=data))
    out.figures.append(_fitted(result, "Figure 8: loss IRL from noisy demonstrations", "fig8-loss",
                               "Variable with so few episodes, but the cliff's severity comes through."))
    out.notes += [f"loss: {note}" for note in result.notes]

    # 5. Beyond the paper: what carefulness buys, as intervals.
    for name in ("mud", "mud-simple"):
        progress(f"intervals on {name}: {sizes.interval_episodes} optimal episodes")
        mdp = build_mdp(BUILTIN_WORLDS[name])
        t = time.perf_counter()
        demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=sizes.interval_episodes, seed=seed))
        result = fit(demos, method="lp", intervals=True)
        out.separations.append(Separation(name, symbol_interval(result, "C"), symbol_interval(result, "U"),
                                          time.perf_counter() - t))
        out.figures.append(_fitted(result, f"Intervals on {name}: lp estimate", f"intervals-{name}",
                                   _interval_caption(out.separations[-1])))

    out.seconds = time.perf_counter() - started
    return out


def _interval_caption(s: Separation) -> str:
    verdict = "disjoint: the cliff is shown to be far worse than the mud" if s.separated else "overlapping: cannot tell them apart"
    return f"cliff between {s.cliff[0]:.0f} and {s.cliff[1]:.0f}; mud between {s.mud[0]:.0f} and {s.mud[1]:.0f}: {verdict}"

