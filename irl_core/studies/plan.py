"""Planning a study (``careful study plan``): simulate whole studies before recruiting anyone.

For each world of the study, with the hypothesised rewards (`planned_worlds`), and each grid point
(participants n, main episodes e), `plan_study` simulates `PlanGrid.repeats` studies: n person-like
participants (`irl_core.players.person_like`, the kinds `PlanGrid.players` in turn, each of their
parameters scaled by exp(N(0, `PlanGrid.spread`)): people differ), each playing e episodes (and, with
`PlanGrid.calibration`, first a motor calibration block whose hand the fit holds fixed, as the report does);
it fits each participant's episodes with a model of people (`PlanGrid.model`) and the cheap Laplace interval
(`irl_core.irl.people.laplace`), pooled as the study report pools (`POOL_MODELS`: by default the population of
participants, `irl_core.studies.population`, over each participant's fit; or one shared fit of
everyone's episodes with the cluster-robust interval over participants), and counts

- **separated**: the pooled hazard interval lies below the nuisance's (the report's finding
  "carefulness separates catastrophe from nuisance", `experiment.claims.order_words`);
- **covered**: every pooled interval holds its hypothesised reward;
- the median width of each pooled interval.

Grid points share their random numbers: a repeat simulates its largest study once, and the smaller
ones are its first n participants and their first e episodes (common random numbers: the
differences between grid points are not drowned by the noise between repeats, and a repeat costs
one simulation). One (world, repeat) is one job of the process pool.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pydantic import ValidationError

from irl_core.coverage.check import HOLD_TOLERANCE
from irl_core.errors import PlanError
from irl_core.experiment.claims import order_words
from irl_core.irl.choices import LEVEL_MODELS, PLAN_FITS, POOL_MODELS, PlanFitsName, player_model
from irl_core.irl.options import MIN_RESAMPLES
from irl_core.irl.people import fit_given_model, hand_from_trials, laplace_intervals
from irl_core.irl.qmap import Unknowns, build_unknowns
from irl_core.play.motor_block import calibration_targets
from irl_core.players.experts import Rollouts, demonstrations_of, rollouts
from irl_core.players.person_like import KINDS, LEVEL_KINDS, TIME_KINDS, PersonLike, motor_trials, person_like
from irl_core.studies.forecast import reported_intervals
from irl_core.studies.population import pool_participants
from irl_core.studies.study import Exclusions
from irl_core.support.pool import run_in_pool
from irl_core.worlds.mdp import MDP, build_mdp
from irl_core.worlds.world import World

# A grid's sizes: at least one, and few enough that a plan is a plan and not a month of CPU.
MAX_PARTICIPANTS = 500
MAX_EPISODES = 500
MAX_REPEATS = 10_000
# A study file's own bound on its calibration block.
MAX_CALIBRATION = 100
MAX_RESAMPLES = 10_000
# Why a study's time worlds (care = "time") are left out: their report fits the timing model, which learns the
# slip curve from the holds, and the plan's players and `person`-family fits are those of a world with levels.
TIME_WORLDS_NOT_PLANNED = "the plan's simulated players and fits are those of worlds with levels"


def without_time_worlds(worlds: tuple[World, ...]) -> tuple[tuple[World, ...], tuple[World, ...]]:
    """The worlds a plan simulates, and the study's time worlds it leaves out (`TIME_WORLDS_NOT_PLANNED`)."""
    return tuple(w for w in worlds if w.care != "time"), tuple(w for w in worlds if w.care == "time")


@dataclass(frozen=True)
class PlanGrid:
    """What `plan_study` simulates: the grid (participants, episodes), the person-like `players` drawn
    in turn, the between-participant `spread` (sd of log of each player parameter's factor), the
    simulated studies per grid point, the motor `calibration` targets each participant holds before playing
    (a study's ``calibration_block``; 0: none, the hand estimated from play), and the fits' settings: `fits`
    (`PLAN_FITS`), with ``report`` the report's `resamples` and the study's `exclusions`."""

    participants: tuple[int, ...] = (5, 10, 20)
    episodes: tuple[int, ...] = (5, 10, 20)
    players: tuple[str, ...] = ("loose", "timed", "hasty")
    repeats: int = 20
    spread: float = 0.3
    seed: int = 0
    calibration: int = 0
    model: str = "person"
    pool: str = "population"
    confidence: float = 0.95
    rmax: float = 5000.0
    fits: PlanFitsName = "plan"
    resamples: int = 50
    exclusions: Exclusions = field(default_factory=Exclusions)

    def __post_init__(self) -> None:
        for name, sizes, top in (("participants", self.participants, MAX_PARTICIPANTS),
                                 ("episodes", self.episodes, MAX_EPISODES)):
            if not sizes:
                raise PlanError(name, "give at least one size")
            bad = [n for n in sizes if not 1 <= n <= top]
            if bad:
                raise PlanError(name, f"{bad[0]} is outside 1..{top}")
        if not 1 <= self.repeats <= MAX_REPEATS:
            raise PlanError("repeats", f"{self.repeats} is outside 1..{MAX_REPEATS}")
        # The plan simulates worlds with levels only (`without_time_worlds`), so a time world's player is
        # refused here, with the unknown names, before a simulation starts.
        unknown = [kind for kind in self.players if kind not in LEVEL_KINDS]
        if unknown or not self.players:
            raise PlanError("players", "give at least one player" if not unknown else (
                f"{unknown[0]!r} " + ("holds for a time and plays only time worlds, which the plan leaves out"
                                      if unknown[0] in TIME_KINDS else "is not a person-like player")
                + f"; the plan's players are {', '.join(LEVEL_KINDS)}"))
        if self.pool not in POOL_MODELS:
            raise PlanError("pool", f"{self.pool!r} is not one of {', '.join(POOL_MODELS)}")
        if not 0 <= self.calibration <= MAX_CALIBRATION:
            raise PlanError("calibration", f"{self.calibration} is outside 0..{MAX_CALIBRATION}")
        if not 0 <= self.spread < 5:
            raise PlanError("spread", f"{self.spread:g} is outside 0..5")
        if self.model not in LEVEL_MODELS:
            raise PlanError("model", f"{self.model!r} is not one of {', '.join(LEVEL_MODELS)}")
        if self.fits not in PLAN_FITS:
            raise PlanError("fits", f"{self.fits!r} is not one of {', '.join(PLAN_FITS)}")
        if not MIN_RESAMPLES <= self.resamples <= MAX_RESAMPLES:
            raise PlanError("resamples", f"{self.resamples} is outside {MIN_RESAMPLES}..{MAX_RESAMPLES} (a report's "
                                         "bootstrap needs as many for a usable interval)")


def planned_worlds(worlds: tuple[World, ...], truth: dict[str, float], *,
                   rmax: float = PlanGrid.rmax) -> tuple[World, ...]:
    """The study's worlds with the hypothesised rewards `truth` (symbol -> reward) in place of their own.

    Raises PlanError("truth", ...) for a symbol no world of the study has, a reward beyond the fits'
    bound `rmax` (no interval could hold it), or one a world refuses (a wall's)."""
    for symbol, reward in truth.items():
        if not abs(reward) < rmax:
            raise PlanError("truth", f"{symbol}={reward:g} is beyond the fits' bound of {rmax:g}")
        if not any(symbol in world.layout for world in worlds):
            names = ", ".join(world.name for world in worlds)
            raise PlanError("truth", f"no world of the study ({names}) has the symbol {symbol!r}")
    out = []
    for world in worlds:
        rewards = {**world.rewards, **{s: r for s, r in truth.items() if s in world.layout}}
        try:
            out.append(World.model_validate({**world.model_dump(), "rewards": rewards}))
        except ValidationError as exc:
            raise PlanError("truth", exc.errors()[0]["msg"].removeprefix("Value error, ")) from None
    return tuple(out)


@dataclass(frozen=True)
class PlanPoint:
    """One (world, participants, episodes) of the plan over `studies` simulated studies, each participant first
    holding `calibration` motor calibration targets.

    Attributes:
        separated: the share whose pooled hazard interval lies below the nuisance's (None: the world
            has no hazard and nuisance to separate).
        covered: the share whose every pooled interval holds its hypothesised reward.
        covered_each: per symbol, the share whose pooled interval holds it.
        width: per symbol, the median width of its pooled interval.
    """

    world: str
    participants: int
    episodes: int
    studies: int
    calibration: int
    symbols: tuple[str, ...]
    truth: tuple[float, ...]
    separated: float | None
    covered: float
    covered_each: dict[str, float] = field(default_factory=dict)
    width: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class _Study:
    """One simulated study's pooled answer: intervals (k, 2)."""

    intervals: np.ndarray


def plan_study(worlds: tuple[World, ...], grid: PlanGrid, *, workers: int = 1,
               progress: Callable[[int, int], None] | None = None) -> list[PlanPoint]:
    """Every (world, participants, episodes) of the plan, world by world, participants then episodes
    ascending; `workers` processes; progress(jobs done, jobs) after each (world, repeat)."""
    jobs = [(world, grid, repeat) for world in worlds for repeat in range(grid.repeats)]
    results: list[dict[tuple[int, int], _Study] | None] = [None] * len(jobs)
    done = 0

    def returned(i: int, got: dict[tuple[int, int], _Study]) -> None:
        nonlocal done
        results[i], done = got, done + 1
        if progress:
            progress(done, len(jobs))

    if workers <= 1:
        for i, job in enumerate(jobs):
            returned(i, simulate_repeat(*job))
    else:
        run_in_pool(simulate_repeat, jobs, workers=workers, on_result=returned)
    points = []
    for w, world in enumerate(worlds):
        mine = [r for r in results[w * grid.repeats:(w + 1) * grid.repeats] if r is not None]
        for n in sorted(set(grid.participants)):
            for e in sorted(set(grid.episodes)):
                points.append(_point(world, n, e, [r[(n, e)] for r in mine], grid))
    return points


def _point(world: World, n: int, e: int, studies: list[_Study], grid: PlanGrid) -> PlanPoint:
    mdp = build_mdp(world)
    unknowns = build_unknowns(mdp, tie=True)
    symbols, truth = unknowns.symbols, unknowns.true_theta(mdp)
    intervals = np.stack([s.intervals for s in studies])  # (studies, k, 2); NaN: the study had no interval
    # As `careful check` counts a hold (its tolerance at an end); a NaN interval holds nothing.
    slack = HOLD_TOLERANCE * grid.rmax
    holds = (intervals[:, :, 0] - slack <= truth) & (truth <= intervals[:, :, 1] + slack)
    pair = hazard_and_nuisance(world, symbols, truth)
    separated = None
    if pair is not None:
        h, u = pair
        separated = float(np.mean([np.isfinite(i[[h, u]]).all() and order_words(tuple(i[h]), tuple(i[u])) == "below"
                                   for i in intervals]))
    spans = intervals[:, :, 1] - intervals[:, :, 0]
    widths = np.array([np.median(column[np.isfinite(column)]) if np.isfinite(column).any() else np.nan
                       for column in spans.T])
    return PlanPoint(world=world.name, participants=n, episodes=e, studies=len(studies),
                     calibration=block_targets(world, grid), symbols=symbols,
                     truth=tuple(float(t) for t in truth), separated=separated, covered=float(holds.all(axis=1).mean()),
                     covered_each={s: float(c) for s, c in zip(symbols, holds.mean(axis=0))},
                     width={s: float(w) for s, w in zip(symbols, widths)})


def hazard_and_nuisance(world: World, symbols: tuple[str, ...], truth: np.ndarray) -> tuple[int, int] | None:
    """The indices of the worst hazard (a terminal symbol with the most negative reward) and the worst
    nuisance (a non-terminal one with a negative reward), as the report's finding picks them; None
    without both."""
    hazards = sorted((truth[j], j) for j, s in enumerate(symbols) if s in world.terminal and truth[j] < 0)
    nuisances = sorted((truth[j], j) for j, s in enumerate(symbols) if s not in world.terminal and truth[j] < 0)
    if not hazards or not nuisances:
        return None
    return int(hazards[0][1]), int(nuisances[0][1])


def simulate_repeat(world: World, grid: PlanGrid, repeat: int) -> dict[tuple[int, int], _Study]:
    """One repeat of every grid point of `world`: the largest study simulated once, each grid point's
    participants its first n and their first e episodes, pooled as `grid.pool` says (see `POOL_MODELS`)."""
    mdp = build_mdp(world)
    unknowns = build_unknowns(mdp, tie=True)
    n_most, episodes = max(grid.participants), sorted(set(grid.episodes))
    seeds = np.random.SeedSequence([grid.seed, repeat, sum(map(ord, world.name))]).spawn(n_most)
    played, trials, names = [], [], []
    for i, seed in enumerate(seeds):
        rng = np.random.default_rng(seed)
        person = drawn_player(mdp, grid.players[i % len(grid.players)], grid.spread, rng)
        played.append(rollouts(mdp, person.choose, episodes=max(episodes), rng=rng))
        names.append(person.player)
        # Drawn after the episodes, so that a plan without a block simulates the same play.
        trials.append(calibration_block(person, world, block_targets(world, grid), rng))
    sizes = sorted(set(grid.participants))
    out = {}
    if grid.fits == "report":
        for n in sizes:
            for e in episodes:
                first = [(name, _first_episodes(r, e)) for name, r in zip(names[:n], played[:n])]
                out[(n, e)] = _Study(reported_intervals(
                    world, unknowns, first, trials[:n], calibration=block_targets(world, grid), pool=grid.pool,
                    resamples=grid.resamples, rmax=grid.rmax, exclusions=grid.exclusions,
                    seed=grid.seed * MAX_REPEATS + repeat))
        return out
    counts = {e: [demonstrations_of(mdp, _first_episodes(r, e)).counts for r in played] for e in episodes}
    if grid.pool == "shared":
        for n in sizes:
            # One shared player, so one hand: every participant's trials, as the report's shared pool.
            hand = _hand(np.concatenate(trials[:n]), world)
            for e in episodes:
                out[(n, e)] = _Study(pooled_interval(mdp, unknowns, np.stack(counts[e][:n]), grid, hand=hand))
        return out
    hands = [_hand(t, world) for t in trials]
    fits = {e: [fit_participant(mdp, unknowns, c, grid, hand=h) for c, h in zip(counts[e], hands)] for e in episodes}
    for n in sizes:
        for e in episodes:
            intervals = np.stack([f[1] for f in fits[e][:n]])
            pooled = pool_participants(intervals, confidence=grid.confidence, rmax=grid.rmax, marks=False)
            out[(n, e)] = _Study(pooled.intervals)
    return out


def block_targets(world: World, grid: PlanGrid) -> int:
    """How many calibration targets each of `world`'s simulated participants holds (none where there are no
    levels to hold for: a time world, or one level)."""
    return grid.calibration if world.care == "levels" and world.levels >= 2 else 0


def calibration_block(person: PersonLike, world: World, targets: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 2) (target, produced) of `person`'s motor calibration block of `targets` targets on `world`'s levels,
    drawn as a study asks them (`calibration_targets`); none in a world without levels to hold for."""
    if not targets:
        return np.zeros((0, 2), dtype=np.int64)
    asked = np.array(calibration_targets(world.levels, targets, seed=int(rng.integers(2**32))))
    return motor_trials(person, asked, world.levels, rng)


def _hand(trials: np.ndarray, world: World) -> tuple[float, float] | None:
    """The (bias, sigma) the calibration `trials` (n, 2) measure, or None without trials."""
    return hand_from_trials(trials, world.levels).known() if trials.size else None


def pooled_interval(mdp: MDP, unknowns: Unknowns, groups: np.ndarray, grid: PlanGrid, *,
                    hand: tuple[float, float] | None = None) -> np.ndarray:
    """(k, 2) the shared pool's intervals: one fit of the summed counts of groups (n, S, A), and the
    cluster-robust Laplace interval over its n participants; `hand` (bias, sigma): the hand held fixed."""
    counts = groups.sum(axis=0)
    fitted = fit_given_model(mdp, unknowns, counts, model=player_model(grid.model).with_hand(hand), rmax=grid.rmax)
    return laplace_intervals(mdp, unknowns, counts, fitted, rmax=grid.rmax, confidence=grid.confidence,
                             groups=groups)


def drawn_player(mdp: MDP, kind: str, spread: float, rng: np.random.Generator) -> PersonLike:
    """A person-like player of `kind` whose parameters are the defaults each times exp(N(0, spread))
    (a probability kept below 0.9)."""
    values = {name: default * float(np.exp(rng.normal(0.0, spread))) for name, default in KINDS[kind].items()}
    if "lapse" in values:
        values["lapse"] = min(values["lapse"], 0.9)
    return person_like(mdp, kind, **values)


def _first_episodes(played: Rollouts, e: int) -> Rollouts:
    """The rollouts' steps of their first `e` episodes."""
    keep = played.episode < e
    return Rollouts(played.episode[keep], played.t[keep], played.state[keep], played.action[keep],
                    played.direction[keep], played.next_state[keep], played.reward[keep],
                    length=played.length[:e], final_state=played.final_state[:e], truncated=played.truncated[:e])


def fit_participant(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, grid: PlanGrid, *,
                    hand: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One simulated participant's rewards (k,) and Laplace intervals (k, 2) from their counts (S, A), fitted
    from the starts a model given by name is (`fit_given_model`; a warm start from the same participant's
    fit on fewer episodes is faster, but stopped in a poorer optimum in 2 of 12 trials on mud); `hand`
    (bias, sigma): their calibration block's hand, held fixed (the interval does not carry its noise)."""
    fitted = fit_given_model(mdp, unknowns, counts, model=player_model(grid.model).with_hand(hand), rmax=grid.rmax)
    return fitted.theta, laplace_intervals(mdp, unknowns, counts, fitted, rmax=grid.rmax, confidence=grid.confidence)
