"""Person-like players: simulated people who choose a direction sharply and a level loosely.

People do not play as a Boltzmann expert over (direction, level) does: a hold is timed by a
hand, not picked from a menu, and now and then a person lapses. These players act over the
world's true optimal plan (`experts.optimal_plan`): a*(s) = (d*(s), c*(s)), Q*(s, a). Each
differs in how its level and its direction go wrong. They are the test bench of a fit meant
for people (docs/people.md, "Person-like players"): a fit that recovers the rewards of these,
one of which lies outside every player model the fit contains (``timed``), is one that can
be trusted on people.

============  ==============================================  ===============================================
player        direction                                       level
============  ==============================================  ===============================================
``loose``     d*(s); with probability `lapse` (0.1) a         c*(s) + round(N(0, `spread`)), `spread` 1.75,
              uniformly random one (a lapse)                  clipped to 1..L: the spread has nothing to do
                                                              with what is at stake
``timed``     d*(s); with probability `lapse` (0.1) the       the level of a hold time: c*(s)'s hold (the
              previous step's direction (a random one at      middle of its window under the game's timing,
              an episode's first step)                        500 ms delay, 150 ms per level) times
                                                              exp(N(0, `weber`)), `weber` 0.25: the spread
                                                              grows with the level (Weber's law)
``hasty``     softmax over directions of max_c Q*(s, d, c)    the chosen direction's best level minus
              / `temperature` (1.25): errors cost-sensitive   `bias` (2) + round(N(0, `spread`)), `spread` 1,
                                                              clipped: people under-hold
``inverted``  as ``loose``                                    c*(s) mapped backwards onto 1..L (most careful
                                                              where the plan is least, careless beside the
                                                              cliff), then ``loose``'s noise: care no reward
                                                              explains
``reckless``  d*(s); with probability `lapse` (0.25) a        1 everywhere
              uniformly random one
``streaky``   d*(s), but lapses come in streaks: a two-state  as ``loose``
              chain (attentive, lapsing) whose streaks last
              `streak` (4) steps on average and hold a share
              `lapse` (0.1) of the steps; a lapsing step's
              direction is uniformly random
``growing``   as ``loose``                                    c*(s) + round(N(0, `spread` + `growth` c*(s))),
                                                              `spread` 0.5, `growth` 0.25, clipped: the
                                                              hand's sd grows linearly with the level aimed at
``learning``  as ``loose``, over the plan of the hazard it    as ``loose``, over that plan
              believes in: in episode e (from 0) of a
              recording it plans with each hazard's reward
              times 1 + (`fear` - 1) 0.5^(e / `half_life`),
              `fear` 0.1, `half_life` 5 episodes
============  ==============================================  ===============================================

The ``learning`` player learns the hazard's reward, not its precision: the hazard's reward is what the fit is
there to read, a newcomer does not yet know how bad a fall is, and no model of the fit lets a reward drift
over episodes. Its truth is the world's reward, the one it learns towards. A hazard is a terminal cell whose
reward is below zero; the belief is rounded to 0.01, so that a recording's episodes share a few plans.

On a time world (docs/timing.md) two more hold the key for a length of time, not a level:

============  ==============================================  ===============================================
player        direction                                       hold
============  ==============================================  ===============================================
``timing``    d*(s); with probability `lapse` (0.1) a         h*(s), the best hold over continuous time for
              uniformly random one                            d*(s) given the plan's values, times
                                                              exp(N(0, `weber`)), `weber` 0.25 (noise grows
                                                              with the hold), released on the next `poll_ms`
                                                              (8 ms, a USB keyboard's polling)
``steady``    as ``timing``                                   `hold_ms` (600) everywhere, whatever is at stake
============  ==============================================  ===============================================

Neither is any player model of the fit: the fit sees bins, these slip with their exact holds.

Every player is a `experts.Chooser`, so `experts.rollouts` and `experts.simulate_to_file` roll
them out and write them exactly as they do computer experts, with the player named
``person:loose(lapse=0.1, spread=1.75)``.
"""

from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from irl_core.play.hold import HoldProfile

if TYPE_CHECKING:  # the command line reads KINDS; planning's scipy waits until a player is made
    from irl_core.players.experts import Chooser
    from irl_core.worlds.mdp import MDP

# Each kind's parameters and their defaults, in the order the player's name gives them.
KINDS: dict[str, dict[str, float]] = {
    "loose": {"lapse": 0.1, "spread": 1.75},
    "timed": {"lapse": 0.1, "weber": 0.25},
    "hasty": {"temperature": 1.25, "bias": 2.0, "spread": 1.0},
    "inverted": {"lapse": 0.1, "spread": 1.75},
    "reckless": {"lapse": 0.25},
    "timing": {"lapse": 0.1, "weber": 0.25, "poll_ms": 8.0},
    "steady": {"lapse": 0.1, "hold_ms": 600.0},
    "streaky": {"lapse": 0.1, "streak": 4.0, "spread": 1.75},
    "growing": {"lapse": 0.1, "spread": 0.5, "growth": 0.25},
    "learning": {"lapse": 0.1, "spread": 1.75, "fear": 0.1, "half_life": 5.0},
}
# The person-like players of a reach world (`irl_core.reach.players.HandReacher`, docs/reach.md), apart from the
# grid's: their parameters' defaults, in the order the player's name gives them.
REACH_KINDS: dict[str, dict[str, float]] = {
    "hand": {"lapse": 0.1, "aim_sd": 4.0, "weber": 0.15},
}
# The players that hold for a time and so need a time world; ``timed`` times the level world's windows.
TIME_KINDS = frozenset({"timing", "steady"})
LEVEL_KINDS = tuple(kind for kind in KINDS if kind not in TIME_KINDS)

# The game's hold timing with its defaults (`irl_core.play.hold.HoldProfile`, whose level_for is per hold,
# not per array): a hold shorter than its tap_ms is level 1, then one level per MS_PER_LEVEL.
DELAY_MS = HoldProfile().tap_ms
MS_PER_LEVEL = HoldProfile().ms_per_level


@dataclass(frozen=True)
class PersonLike:
    """A person-like player of one world.

    Attributes:
        kind: one of `KINDS`.
        parameters: the kind's parameters, every one of them (defaults filled in).
        choose: draws the player's actions (`experts.Chooser`).
    """

    kind: str
    parameters: dict[str, float] = field(compare=False)
    choose: Chooser = field(compare=False, repr=False)

    @property
    def player(self) -> str:
        """The recordings' `player`, e.g. ``person:loose(lapse=0.1, spread=1.75)``."""
        return f"person:{self.kind}(" + ", ".join(f"{k}={v:g}" for k, v in self.parameters.items()) + ")"


def person_like(mdp: MDP, kind: str, **parameters: float) -> PersonLike:
    """The person-like player `kind` of `mdp`'s world, with `parameters` in place of the defaults.

    Raises:
        ValueError: an unknown kind or parameter, or a parameter out of its range
            (a probability outside 0..1, a negative spread, a temperature that is not positive).
        NotConverged: the world's optimal plan did not converge.
    """
    if kind not in KINDS:
        raise ValueError(f"unknown person-like player {kind!r}; the players are {', '.join(KINDS)}")
    unknown = sorted(set(parameters) - set(KINDS[kind]))
    if unknown:
        raise ValueError(f"the {kind} player has no parameter {', '.join(unknown)}; its parameters are "
                         f"{', '.join(KINDS[kind])}")
    values = {name: float(parameters.get(name, default)) for name, default in KINDS[kind].items()}
    _check(values)
    timed_world = mdp.world.care == "time"
    if (kind in TIME_KINDS and not timed_world) or (kind == "timed" and timed_world):
        raise ValueError(f"the {kind} player " + ("holds for a time and needs a time world (care = \"time\")"
                         if kind in TIME_KINDS else "times the level windows of a world with levels; on a time "
                         "world the timing player holds for a time"))
    from irl_core.players.experts import optimal_plan

    plan = optimal_plan(mdp)
    L = mdp.levels
    best = plan.greedy
    d_star, c_star = mdp.direction[best], mdp.carefulness[best]
    if kind == "loose":
        choose = _loose(d_star, c_star, L, lapse=values["lapse"], spread=values["spread"])
    elif kind == "inverted":
        choose = _loose(d_star, _inverted(c_star, mdp.nonterminal, L), L, lapse=values["lapse"],
                        spread=values["spread"])
    elif kind == "reckless":
        choose = _loose(d_star, np.ones_like(c_star), L, lapse=values["lapse"], spread=0.0)
    elif kind == "streaky":
        choose = _streaky(d_star, c_star, L, lapse=values["lapse"], streak=values["streak"], spread=values["spread"])
    elif kind == "growing":
        choose = _loose(d_star, c_star, L, lapse=values["lapse"], spread=values["spread"], growth=values["growth"])
    elif kind == "learning":
        choose = _learning(mdp, lapse=values["lapse"], spread=values["spread"], fear=values["fear"],
                           half_life=values["half_life"])
    elif kind == "timed":
        choose = _timed(d_star, c_star, L, lapse=values["lapse"], weber=values["weber"])
    elif kind in TIME_KINDS:
        best_hold = (np.full(mdp.n_states, values["hold_ms"]) if kind == "steady"
                     else best_holds(mdp, plan.V, d_star))
        choose = _holding(mdp, d_star, best_hold, lapse=values["lapse"], weber=values.get("weber", 0.0),
                          poll_ms=values.get("poll_ms", 0.0))
    else:
        choose = _hasty(plan.Q, L, temperature=values["temperature"], bias=values["bias"], spread=values["spread"])
    return PersonLike(kind=kind, parameters=values, choose=choose)


def _check(values: dict[str, float]) -> None:
    for name, value in values.items():
        if name == "lapse" and not 0 <= value <= 1:
            raise ValueError(f"lapse is a probability, between 0 and 1, not {value:g}")
        if name in ("spread", "weber", "poll_ms", "growth", "fear") and not 0 <= value < np.inf:
            raise ValueError(f"{name} must be zero or more, not {value:g}")
        if name in ("temperature", "hold_ms", "half_life") and not 0 < value < np.inf:
            raise ValueError(f"{name} must be positive, not {value:g}")
        if name == "streak" and not 1 <= value < np.inf:
            raise ValueError(f"streak is a mean number of steps, at least 1, not {value:g}")
        if name == "bias" and not abs(value) < np.inf:
            raise ValueError(f"bias must be a finite number of levels, not {value:g}")
    if "streak" in values and _entering(values["lapse"], values["streak"]) > 1:
        raise ValueError(f"a lapse share of {values['lapse']:g} needs streaks of at least "
                         f"{values['lapse'] / (1 - values['lapse']):g} steps, not {values['streak']:g}"
                         if values["lapse"] < 1 else "a lapse share of 1 leaves no attentive step to end a streak")


def motor_trials(person: PersonLike, targets: np.ndarray, levels: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 2) (target, produced) of `person` asked for each of `targets` (n,) in a study's motor calibration
    block: their own hand, without the play's choices (``hasty`` under-holds by its `bias`, ``timed`` times
    the hold with its Weber noise, ``growing`` adds its sd at the target's level, the others add ``loose``'s
    `spread`; ``reckless`` holds as asked)."""
    targets = np.asarray(targets, dtype=np.int64)
    p = person.parameters
    if person.kind == "timed":
        held = intended_hold_ms(targets) * np.exp(rng.normal(0.0, p["weber"], targets.size))
        produced = level_of_hold(held, levels)
    elif person.kind == "growing":
        produced = _noisy_level(targets, p["spread"] + p["growth"] * targets, levels, rng)
    else:
        produced = _noisy_level(targets, p.get("spread", 0.0), levels, rng, bias=p.get("bias", 0.0))
    return np.column_stack([targets, produced]).astype(np.int64)


def intended_hold_ms(level: np.ndarray) -> np.ndarray:
    """(n,) the hold a player aims at for each level (n,): the middle of its window, half the delay for level 1."""
    level = np.asarray(level, dtype=float)
    return np.where(level <= 1, DELAY_MS / 2, DELAY_MS + (level - 1.5) * MS_PER_LEVEL)


def level_of_hold(hold_ms: np.ndarray, levels: int) -> np.ndarray:
    """(n,) the level each hold (n,) gives: 1 below the delay, then one more per MS_PER_LEVEL, up to `levels`."""
    hold_ms = np.asarray(hold_ms, dtype=float)
    # The epsilon keeps a hold of exactly a level's start at that level, as HoldProfile.level_for does.
    steps = np.floor((hold_ms - DELAY_MS) / MS_PER_LEVEL + 1e-9)
    return np.where(hold_ms < DELAY_MS, 1, np.minimum(levels, 2 + steps)).astype(np.int64)


def _inverted(c_star: np.ndarray, acting: np.ndarray, levels: int) -> np.ndarray:
    """(S,) c* mapped backwards onto 1..L over the states where the player acts: the plan's most careful
    cells get level 1, its least careful ones level L."""
    low, high = c_star[acting].min(), c_star[acting].max()
    if high == low:
        return np.full_like(c_star, levels)
    return np.rint(levels - (levels - 1) * (c_star - low) / (high - low)).astype(np.int64)


def _lapsed(d_star: np.ndarray, lapse: float, rng: np.random.Generator) -> np.ndarray:
    """(n,) d* (n,) with each entry replaced, with probability `lapse`, by a uniformly random direction."""
    lapses = rng.random(d_star.size) < lapse
    return np.where(lapses, rng.integers(4, size=d_star.size), d_star)


def _noisy_level(level: np.ndarray, spread: float | np.ndarray, levels: int, rng: np.random.Generator, *,
                 bias: float = 0.0) -> np.ndarray:
    """(n,) level (n,) minus `bias` plus N(0, spread), spread one sd or one (n,) per level, rounded and clipped
    to 1..levels."""
    noise = rng.normal(0.0, spread, level.size) if np.any(np.asarray(spread) > 0) else 0.0
    return np.clip(np.rint(level - bias + noise), 1, levels).astype(np.int64)


def _loose(d_star: np.ndarray, c: np.ndarray, levels: int, *, lapse: float, spread: float,
           growth: float = 0.0) -> Chooser:
    """The chooser of ``loose`` over the plan (d_star, c) (S,): its level's sd `spread` + `growth` times the
    level aimed at (``growing``; 0: the same sd everywhere)."""
    def choose(s: np.ndarray, previous: np.ndarray, rng: np.random.Generator, episode: np.ndarray) -> np.ndarray:
        d = _lapsed(d_star[s], lapse, rng)
        return d * levels + _noisy_level(c[s], spread + growth * c[s] if growth else spread, levels, rng) - 1

    return choose


def _entering(lapse: float, streak: float) -> float:
    """The chance of an attentive step's successor lapsing, so that streaks of mean length `streak` (leaving with
    chance 1 / streak) hold a share `lapse` of the steps: the stationary share enter / (enter + leave)."""
    return np.inf if lapse >= 1 else lapse / (streak * (1 - lapse))


def _streaky(d_star: np.ndarray, c_star: np.ndarray, levels: int, *, lapse: float, streak: float,
             spread: float) -> Chooser:
    """``streaky``'s chooser: each episode starts attentive or lapsing at the chain's stationary share, then
    steps through the chain; a lapsing step's direction is uniformly random, its level ``loose``'s."""
    leave, enter = 1.0 / streak, _entering(lapse, streak)
    # Whether each episode lapses lives between calls; per thread, so two rollouts on two threads of one
    # process (a Dask worker's) keep apart. Indexed by the episode's number, reset at its first step.
    memory = threading.local()

    def choose(s: np.ndarray, previous: np.ndarray, rng: np.random.Generator, episode: np.ndarray) -> np.ndarray:
        lapsing = getattr(memory, "lapsing", np.zeros(0, dtype=bool))
        if lapsing.size <= episode.max(initial=-1):
            lapsing = memory.lapsing = np.concatenate([lapsing, np.zeros(episode.max() + 1 - lapsing.size, bool)])
        u = rng.random(s.size)
        now = np.where(previous < 0, u < lapse, np.where(lapsing[episode], u >= leave, u < enter))
        lapsing[episode] = now
        d = np.where(now, rng.integers(4, size=s.size), d_star[s])
        return d * levels + _noisy_level(c_star[s], spread, levels, rng) - 1

    return choose


def _learning(mdp: MDP, *, lapse: float, spread: float, fear: float, half_life: float) -> Chooser:
    """``learning``'s chooser: ``loose`` over the optimal plan of the world whose hazards' rewards are scaled
    by the episode's belief (rounded to 0.01), each belief's plan made when first needed."""
    from irl_core.players.experts import optimal_plan

    hazard = ~mdp.nonterminal & (mdp.R_S < 0)
    plans: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def plan_of(belief: float) -> tuple[np.ndarray, np.ndarray]:
        if belief not in plans:
            greedy = optimal_plan(dataclasses.replace(mdp, R_S=np.where(hazard, belief * mdp.R_S, mdp.R_S))).greedy
            plans[belief] = mdp.direction[greedy], mdp.carefulness[greedy]
        return plans[belief]

    def choose(s: np.ndarray, previous: np.ndarray, rng: np.random.Generator, episode: np.ndarray) -> np.ndarray:
        belief = np.round(1 + (fear - 1) * 0.5 ** (episode / half_life), 2)
        d, c = np.empty_like(s), np.empty_like(s)
        for value in np.unique(belief).tolist():
            mine = belief == value
            d[mine], c[mine] = (chosen[s[mine]] for chosen in plan_of(value))
        return _lapsed(d, lapse, rng) * mdp.levels + _noisy_level(c, spread, mdp.levels, rng) - 1

    return choose


def _timed(d_star: np.ndarray, c_star: np.ndarray, levels: int, *, lapse: float, weber: float) -> Chooser:
    hold = intended_hold_ms(c_star)

    def choose(s: np.ndarray, previous: np.ndarray, rng: np.random.Generator, episode: np.ndarray) -> np.ndarray:
        lapses = rng.random(s.size) < lapse
        again = np.where(previous >= 0, previous // levels, rng.integers(4, size=s.size))
        d = np.where(lapses, again, d_star[s])
        held = hold[s] * np.exp(rng.normal(0.0, weber, s.size))
        return d * levels + level_of_hold(held, levels) - 1

    return choose


def _hasty(Q: np.ndarray, levels: int, *, temperature: float, bias: float, spread: float) -> Chooser:
    by_direction = Q.reshape(Q.shape[0], 4, levels)
    q = by_direction.max(axis=2)  # (S, 4)
    weights = np.exp((q - q.max(axis=1, keepdims=True)) / temperature)
    cdf = np.cumsum(weights / weights.sum(axis=1, keepdims=True), axis=1)
    best_level = by_direction.argmax(axis=2) + 1  # (S, 4)

    def choose(s: np.ndarray, previous: np.ndarray, rng: np.random.Generator, episode: np.ndarray) -> np.ndarray:
        d = np.minimum((cdf[s] < rng.random((s.size, 1))).sum(axis=1), 3)
        return d * levels + _noisy_level(best_level[s, d], spread, levels, rng, bias=bias) - 1

    return choose


# Holds the best-hold search looks at: log-spaced, fine enough that neighbours differ by under 1%.
_HOLD_GRID = 600


def best_holds(mdp: MDP, V: np.ndarray, d_star: np.ndarray) -> np.ndarray:
    """(S,) a time world's best hold h*(s) in ms for the direction d*(s) (S,), over continuous time:
    the h maximising -cost(h) + gamma [(1 - p(h)) V(n_d*) + p(h) / 3 sum of V over the other three
    neighbours], with the values V (S,) of the plan over bins (0 where the player does not act)."""
    world = mdp.world
    grid = np.geomspace(20.0, world.max_hold_ms, _HOLD_GRID)  # (H,)
    p, cost = world.hold_slip_chance(grid), world.hold_cost(grid)
    k = np.arange(4)
    ahead = V[mdp.neighbour[np.arange(mdp.n_states)[:, None], (d_star[:, None] + k[None, :]) % 4]]  # (S, 4)
    value = -cost[None, :] + mdp.gamma * ((1 - p)[None, :] * ahead[:, :1] + (p / 3)[None, :] * ahead[:, 1:].sum(1, keepdims=True))
    return np.where(mdp.nonterminal, grid[value.argmax(axis=1)], 0.0)


def _holding(mdp: MDP, d_star: np.ndarray, hold: np.ndarray, *, lapse: float, weber: float, poll_ms: float) -> Chooser:
    """The chooser of a player holding `hold` (S,) ms for d*(s), with log-normal timing noise and key-ups
    on the keyboard's polling grid; returns (actions, exact holds)."""
    world, levels = mdp.world, mdp.levels

    def choose(s: np.ndarray, previous: np.ndarray, rng: np.random.Generator,
               episode: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = _lapsed(d_star[s], lapse, rng)
        held = hold[s] * np.exp(rng.normal(0.0, weber, s.size)) if weber > 0 else hold[s].astype(float)
        if poll_ms > 0:
            held = np.ceil(held / poll_ms) * poll_ms
        held = np.minimum(held, world.max_hold_ms)
        return d * levels + world.bin_of(held), held

    return choose
