"""The paper's experiments end to end, as data (the terminal and files are `careful_tui`'s job).

1. The optimal policy of `paper` with 14 levels (figure 3) and its true reward (figure 4).
2. The MaxEnt baseline: Boltzmann episodes on `paper-maxent`, fitted with `maxent` (figure 5).
3. The careful LP: optimal episodes on `paper`, fitted with `lp` (figure 6).
4. The loss method on a handful of noisy demonstrations (figures 7 and 8): people's sessions
   of `paper` only from a folder named explicitly (`careful experiment --recordings DIR`),
   otherwise Boltzmann episodes, labelled as such.
5. Beyond the paper: reward intervals on `mud` against `mud-simple` from optimal experts
   (the identified set), asking whether only carefulness separates the catastrophic cliff
   from the merely undesirable mud.
6. The same question for noisy (Boltzmann) experts: maxent with beta estimated and 95%
   bootstrap confidence intervals (`NOISY_RESAMPLES` resamples, to keep the run quick).

Every caption and note is written from the run's own numbers (`severity`, `interval_caption`):
a stage that does not recover the cliff says so. The paper's three claims are judged from the
same numbers (`irl_core.experiment.claims`): supported, not supported or mixed, with the stages that undercut
them discussed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from irl_core.errors import RecordingError
from irl_core.experiment.claims import RECOVERED, SYMBOL_WORDS, Claim, paper_claims
from irl_core.experiment.stage_results import Estimate, Separation
from irl_core.irl.fitting import fit
from irl_core.irl.options import FitOptions
from irl_core.irl.result import FitResult, at_bound
from irl_core.players.experts import (
    boltzmann_policy,
    demonstrations_of,
    optimal_policy,
    rollouts,
)
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.worlds.mdp import MDP, action_parts, build_mdp
from irl_core.worlds.planning import value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS, Cell, World


@dataclass(frozen=True)
class Sizes:
    """How much data each stage uses; `QUICK` is for tests."""

    maxent_episodes: int = 10_000
    lp_episodes: int = 100
    noisy_episodes: int = 10
    interval_episodes: int = 100
    boltzmann_episodes: int = 40
    resamples: int = 100


FULL, QUICK = Sizes(), Sizes(maxent_episodes=2_000, lp_episodes=100, noisy_episodes=10, interval_episodes=60,
                             boltzmann_episodes=40, resamples=40)
# Stage 6: the noisy experts' inverse temperature, and the confidence of the intervals.
NOISY_BETA = 0.5
NOISY_CONFIDENCE = 0.95


@dataclass(frozen=True)
class Figure:
    """One picture: a world with values per cell and/or an action per cell."""

    key: str
    title: str
    world: World
    values: np.ndarray | None = None
    policy: dict[Cell, tuple[str, int]] = field(default_factory=dict)  # (direction, carefulness level)
    caption: str = ""


@dataclass
class ExperimentResult:
    figures: list[Figure] = field(default_factory=list)
    estimates: list[Estimate] = field(default_factory=list)
    separations: list[Separation] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0
    claims: list[Claim] = field(default_factory=list)

    def summary(self) -> dict:
        """What `summary.json` holds."""
        return {
            "estimates": [
                {
                    "stage": e.stage, "method": e.method, "data": e.data,
                    "cliff": e.cliff, "true_cliff": e.true_cliff, "cliff_error": e.cliff_error,
                    "goal": e.goal, "true_goal": e.true_goal, "goal_error": e.goal_error,
                    "cliff_cells": e.cliff_cells, "cliff_at_bound": e.cliff_at_bound, "cliff_inside": e.cliff_inside,
                    "seconds": e.seconds,
                }
                for e in self.estimates
            ],
            "intervals": [
                {
                    "world": s.world, "cliff": list(s.cliff), "mud": list(s.mud),
                    "cliff_width": s.cliff_width, "mud_width": s.mud_width,
                    "separated": s.separated, "seconds": s.seconds, "kind": s.kind, "data": s.data,
                    "careful": s.careful,
                }
                for s in self.separations
            ],
            "claims": [
                {"claim": c.key, "statement": c.statement, "verdict": c.verdict, "evidence": c.evidence,
                 "discussion": list(c.discussion)}
                for c in self.claims
            ],
            "notes": self.notes,
            "seconds": self.seconds,
        }


Progress = Callable[[str], None]


def policy_cells(mdp: MDP, actions: Iterable[int], where: np.ndarray | None = None) -> dict[Cell, tuple[str, int]]:
    """Each acting cell's action as (direction, carefulness level); the render layer draws it.

    Args:
        actions: (S,) an action per state.
        where: (S,) bool, the states to label (default: every state where the agent acts).
    """
    where = mdp.nonterminal if where is None else where
    return {mdp.cells[s]: action_parts(int(a), mdp.levels)
            for s, a in enumerate(actions) if s < len(mdp.cells) and where[s]}


def symbol_mean(result: FitResult, symbol: str) -> float:
    """Mean fitted R_S over the cells showing `symbol`."""
    values = [result.R_S[s] for s, sym in enumerate(result.mdp.symbols) if sym == symbol]
    return float(np.mean(values))


def symbol_interval(result: FitResult, symbol: str) -> tuple[float, float]:
    """The hull of the intervals of every cell showing `symbol`: (lowest low, highest high)."""
    grid = result.interval_grid
    cells = [cell for cell, sym in zip(result.mdp.cells, result.mdp.symbols) if sym == symbol]
    return float(min(grid[c][0] for c in cells)), float(max(grid[c][1] for c in cells))


def human_sessions(folder: Path, world: World) -> tuple[list[Path], list[str]]:
    """Readable sessions in `folder` played by a person (not `expert:...`) in `world`, and a line
    per file that could not be read ("file:line: field: problem; left out")."""
    found, left_out = [], []
    for path in sorted(folder.glob("*.jsonl")) if folder.is_dir() else []:
        try:
            recording = read_recording(path)
        except RecordingError as exc:
            left_out.append(f"{exc}; left out")
            continue
        if recording.world == world and not recording.header.player.startswith("expert:") and recording.steps:
            found.append(path)
    return found, left_out


def _people_caption(result: FitResult) -> str:
    """What the people fit of people's episodes shows, from its own numbers: the cliff and the goal, whether
    the data bound the cliff from one side only, and the fit check's verdict."""
    cliff, goal = symbol_mean(result, "C"), symbol_mean(result, "G")
    one_sided = any(note.code == "one_sided" for note in result.notes)
    words = (f"Cliff {cliff:.3g}{' (the data bound it from above only: at most that)' if one_sided else ''} "
             f"against {result.world.reward_of('C'):g}; goal {goal:.3g} against {result.world.reward_of('G'):g}"
             f"{', above zero' if goal > 0 else ', not above zero'}.")
    if result.fit_check is not None:
        words += f" {result.fit_check.summary()[0].upper()}{result.fit_check.summary()[1:]}."
    return words


def _estimate(stage: str, data: str, result: FitResult, seconds: float) -> Estimate:
    world = result.world
    rmax = result.options.rmax
    cliff = np.array([result.R_S[s] for s, sym in enumerate(result.mdp.symbols) if sym == "C"])
    bounded = at_bound(cliff, rmax)
    return Estimate(
        stage=stage, method=result.method, data=data,
        cliff=symbol_mean(result, "C"), goal=symbol_mean(result, "G"),
        true_cliff=world.reward_of("C"), true_goal=world.reward_of("G"), seconds=seconds,
        cliff_cells=len(cliff), cliff_at_bound=int(bounded.sum()),
        cliff_inside=float(cliff[~bounded].mean()) if (~bounded).any() else None, rmax=rmax,
    )


def _fitted(result: FitResult, title: str, key: str, caption: str) -> Figure:
    return Figure(key=key, title=title, world=result.world, values=result.reward_grid, caption=caption)


def run_experiment(
    *,
    sizes: Sizes = FULL,
    recordings: Path | None = None,
    seed: int = 0,
    progress: Progress = lambda stage: None,
) -> ExperimentResult:
    """Run the six stages; `progress(name)` is called as each stage starts.

    Args:
        recordings: a folder of people's sessions of `paper` for stage 4; None (the default)
            uses simulated noisy experts and says so. Never read from anywhere not named here.
        seed: seeds every simulated expert and the bootstrap.
    """
    out = ExperimentResult()
    started = time.perf_counter()
    paper = build_mdp(BUILTIN_WORLDS["paper"])
    _optimal_stage(out, paper, progress)
    _maxent_stage(out, sizes, seed, progress)
    _lp_stage(out, paper, sizes, seed, progress)
    humans = _loss_stage(out, paper, sizes, recordings, seed, progress)
    _identified_stage(out, sizes, seed, progress)
    _noisy_stage(out, sizes, seed, progress)
    out.claims = paper_claims(out.estimates, out.separations, people=humans)
    out.seconds = time.perf_counter() - started
    return out


def _optimal_stage(out: ExperimentResult, paper: MDP, progress: Progress) -> None:
    # 1. Figures 3 and 4: the optimal policy with 14 levels, and the true reward.
    progress("optimal policy of paper (figures 3, 4)")
    plan = value_iteration(paper)
    out.figures.append(Figure("fig3-optimal-policy", "Figure 3: optimal policy, 14 levels of carefulness",
                              paper.world, policy=policy_cells(paper, plan.greedy),
                              caption=_carefulness_caption(paper, plan.greedy)))
    out.figures.append(Figure("fig4-true-reward", "Figure 4: true reward", paper.world,
                              values=paper.grid_of(paper.R_S), caption=_reward_caption(paper.world)))


def _maxent_stage(out: ExperimentResult, sizes: Sizes, seed: int, progress: Progress) -> None:
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
                               severity(out.estimates[-1])))


def _lp_stage(out: ExperimentResult, paper: MDP, sizes: Sizes, seed: int, progress: Progress) -> None:
    # 3. Figure 6: the careful LP from optimal episodes.
    progress(f"careful LP: {sizes.lp_episodes} optimal episodes (figure 6)")
    t = time.perf_counter()
    demos = demonstrations_of(paper, rollouts(paper, optimal_policy(paper), episodes=sizes.lp_episodes, seed=seed))
    result = fit(demos, method="lp")
    data = f"{sizes.lp_episodes} optimal episodes"
    out.estimates.append(_estimate("careful lp", data, result, time.perf_counter() - t))
    out.figures.append(_fitted(result, "Figure 6: careful LP from optimal rollouts", "fig6-lp",
                               severity(out.estimates[-1])))


def _loss_stage(out: ExperimentResult, paper: MDP, sizes: Sizes, recordings: Path | None, seed: int,
                progress: Progress) -> bool:
    """Figures 7 and 8 (and the people fit of people's sessions); whether people's sessions were read."""
    # 4. Figures 7 and 8: the loss method on a handful of noisy demonstrations.
    humans, left_out = human_sessions(recordings, paper.world) if recordings is not None else ([], [])
    out.notes += left_out
    t = time.perf_counter()
    if humans:
        progress(f"loss method: {len(humans)} human session(s) from {recordings} (figures 7, 8)")
        demos = Demonstrations.read(humans)
        data = f"{demos.episodes} human episodes from {len(humans)} session(s)"
    else:
        progress(f"loss method: {sizes.noisy_episodes} Boltzmann episodes (figures 7, 8)")
        demos = demonstrations_of(paper, rollouts(paper, boltzmann_policy(paper, beta=1.0),
                                                  episodes=sizes.noisy_episodes, seed=seed))
        data = f"{sizes.noisy_episodes} simulated Boltzmann episodes (beta 1), not people"
        where = f"no person's sessions of paper in {recordings}" if recordings is not None else "no --recordings given"
        out.notes.append(f"{where}: stage 4 used simulated noisy experts")
    result = fit(demos, method="loss")
    out.estimates.append(_estimate("loss, noisy", data, result, time.perf_counter() - t))
    out.figures.append(Figure("fig7-demonstrated-policy", "Figure 7: the demonstrated policy (most frequent action)",
                              paper.world, policy=policy_cells(paper, demos.counts.argmax(axis=1), demos.demonstrated),
                              caption=data))
    out.figures.append(_fitted(result, "Figure 8: loss IRL from noisy demonstrations", "fig8-loss",
                               severity(out.estimates[-1])))
    out.notes += [f"loss: {note}" for note in result.notes]
    if humans:
        # People's own play, read as the default fit reads it: maxent with a model of the player.
        t = time.perf_counter()
        result = fit(demos, method="auto", tie=True)
        out.estimates.append(_estimate("people fit, human", data, result, time.perf_counter() - t))
        out.figures.append(_fitted(result, f"The people fit of the same episodes ({result.player_model} player)",
                                   "fig8b-people", _people_caption(result)))
        out.notes += [f"people fit: {note}" for note in result.notes
                      if note.code in ("player_model", "fit_check_failed", "fit_check_not_run", "one_sided")]
    return bool(humans)


def _identified_stage(out: ExperimentResult, sizes: Sizes, seed: int, progress: Progress) -> None:
    # 5. Beyond the paper: what carefulness buys, as intervals.
    for name in ("mud", "mud-simple"):
        progress(f"intervals on {name}: {sizes.interval_episodes} optimal episodes")
        mdp = build_mdp(BUILTIN_WORLDS[name])
        t = time.perf_counter()
        demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=sizes.interval_episodes, seed=seed))
        result = fit(demos, method="lp", intervals=True)
        out.separations.append(Separation(name, symbol_interval(result, "C"), symbol_interval(result, "U"),
                                          time.perf_counter() - t, data=f"{sizes.interval_episodes} optimal episodes",
                                          rmax=result.options.rmax, careful=mdp.levels > 1))
        out.figures.append(_fitted(result, f"Identified sets on {name}: every value the lp allows",
                                   f"intervals-{name}", interval_caption(out.separations[-1])))


def _noisy_stage(out: ExperimentResult, sizes: Sizes, seed: int, progress: Progress) -> None:
    # 6. The same with noisy experts: confidence intervals.
    for name in ("mud", "mud-simple"):
        progress(f"confidence intervals on {name}: {sizes.boltzmann_episodes} Boltzmann episodes, "
                 f"{sizes.resamples} resamples")
        mdp = build_mdp(BUILTIN_WORLDS[name])
        t = time.perf_counter()
        demos = demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=NOISY_BETA),
                                                episodes=sizes.boltzmann_episodes, seed=seed))
        options = FitOptions(method="maxent", beta="auto", tie=True, rmax=5000.0, intervals=True,
                             confidence=NOISY_CONFIDENCE, resamples=sizes.resamples, seed=seed)
        result = fit(demos, options)
        data = (f"{sizes.boltzmann_episodes} Boltzmann episodes (beta {NOISY_BETA:g}), maxent with beta "
                f"estimated ({result.beta:.2g}), {sizes.resamples} resamples")
        if any(note.code == "not_identified" for note in result.notes):
            data += "; beta is not identified here, so only the signs and ratios of the rewards mean anything"
        out.separations.append(Separation(name, symbol_interval(result, "C"), symbol_interval(result, "U"),
                                          time.perf_counter() - t, kind="confidence", data=data,
                                          rmax=options.rmax, careful=mdp.levels > 1))
        out.figures.append(_fitted(result, f"Confidence intervals on {name}: maxent from noisy experts",
                                   f"intervals-noisy-{name}", interval_caption(out.separations[-1])))
        out.notes += [f"noisy {name}: {note}" for note in result.notes if note.code == "not_identified"]


def severity(e: Estimate) -> str:
    """What a stage's fit says about the cliff and the goal, against the truth, in one or two sentences.

    Cliff cells at the fit's bound were set by the bound, not the data: with any of them the
    cliff is not called recovered (with rmax at the truth's size, the bound alone would look right).
    """
    if e.cliff_at_bound:
        cliff = _bound_set_cliff(e)
    elif e.cliff >= 0:
        cliff = f"The cliff is not recovered: fitted {e.cliff:.0f}, not even negative (truth {e.true_cliff:.0f})."
    elif e.cliff_error <= RECOVERED:
        cliff = (f"The cliff's severity is recovered: {e.cliff:.0f} against {e.true_cliff:.0f} "
                 f"({e.cliff_error:.0%} off).")
    elif abs(e.cliff) < abs(e.true_cliff):
        cliff = (f"The cliff is found to be bad but its severity is not recovered: {e.cliff:.0f} against "
                 f"{e.true_cliff:.0f}, {e.true_cliff / e.cliff:.1f}x too mild.")
    else:
        cliff = (f"The cliff comes out too severe: {e.cliff:.0f} against {e.true_cliff:.0f}, "
                 f"{e.cliff / e.true_cliff:.1f}x the truth.")
    if e.goal <= 0 < e.true_goal:
        goal = f" The goal is not recovered: {e.goal:.0f} (truth {e.true_goal:.0f})."
    else:
        goal = f" Goal {e.goal:.0f} against {e.true_goal:.0f} ({e.goal_error:.0%} off)."
    return cliff + goal


def _bound_set_cliff(e: Estimate) -> str:
    """The cliff sentence when some of its cells sit at the fit's bound."""
    n, bound = e.cliff_at_bound, f"{-e.rmax:.0f}" if e.rmax is not None else "-rmax"
    if n == e.cliff_cells:
        return (f"The cliff is not recovered: every cell is at the fit's bound ({bound}), which set them, not the "
                f"data (truth {e.true_cliff:.0f}).")
    sentence = (f"The cliff comes out at {e.cliff:.0f} against {e.true_cliff:.0f} ({e.cliff_error:.0%} off), but "
                f"{n} of its {e.cliff_cells} cells {'is' if n == 1 else 'are'} at the fit's bound ({bound}), "
                f"which set {'it' if n == 1 else 'them'}, not the data")
    inside = e.cliff_inside
    assert inside is not None, "some cliff cells are inside the bound"
    error = abs(inside - e.true_cliff) / abs(e.true_cliff)
    rest = e.cliff_cells - n
    what = f"the one the data set is {inside:.0f}" if rest == 1 else f"the {rest} the data set average {inside:.0f}"
    return f"{sentence}; {what} ({error:.0%} off)."


def _carefulness_caption(mdp: MDP, actions: np.ndarray) -> str:
    """How careful the policy is beside the cliff against elsewhere (mean levels)."""
    cliff = {cell for cell, symbol in zip(mdp.cells, mdp.symbols) if symbol == "C"}
    beside: list[int] = []
    elsewhere: list[int] = []
    for s, cell in enumerate(mdp.cells):
        if not mdp.nonterminal[s]:
            continue
        near = any((cell[0] + dr, cell[1] + dc) in cliff for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)))
        (beside if near else elsewhere).append(action_parts(int(actions[s]), mdp.levels)[1])
    if not beside or not elsewhere:
        return ""
    more = "more" if np.mean(beside) > np.mean(elsewhere) else "not more"
    return (f"Mean carefulness {np.mean(beside):.1f} beside the cliff against {np.mean(elsewhere):.1f} elsewhere: "
            f"{more} careful near it.")


def _reward_caption(world: World) -> str:
    parts = [f"{SYMBOL_WORDS.get(symbol, symbol)} {value:+g}" for symbol, value in world.rewards.items()]
    return ", ".join(parts) + ", ground 0."


def interval_caption(s: Separation) -> str:
    what = "95% confidence intervals" if s.kind == "confidence" else "identified by the demonstrations"
    if s.separated:
        worse = ("the maxent model puts the cliff below the mud" if s.kind == "confidence" and not s.careful
                 else "the cliff is shown to be worse than the mud")
        verdict = f"disjoint: {worse}" if s.cliff[1] < s.mud[0] else "disjoint, but the mud comes out worse than the cliff"
    else:
        verdict = "overlapping: these demonstrations cannot tell the cliff from the mud"
    caption = (f"{what}: cliff between {s.cliff[0]:.0f} and {s.cliff[1]:.0f}; mud between {s.mud[0]:.0f} "
               f"and {s.mud[1]:.0f}; {verdict}.")
    if s.separated and not s.careful:
        caption += (" This world has no carefulness, so the separation is not carefulness's doing"
                    + (": a confidence interval is the sampling noise of the maxent model's estimate, not every "
                       "reward the demonstrations allow." if s.kind == "confidence" else "."))
    if s.rmax is not None:
        bounded = [f"the {name}'s {end:.0f}" for name, interval in (("cliff", s.cliff), ("mud", s.mud))
                   for end in interval if at_bound(end, s.rmax)]
        if bounded:
            caption += (f" At ±{s.rmax:.0f}, {' and '.join(bounded)} {'is' if len(bounded) == 1 else 'are'} "
                        "the bound of the fit, not a value the data set.")
    return caption
