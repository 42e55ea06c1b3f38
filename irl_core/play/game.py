"""The cliff game's rules, without a screen: what `careful play` runs (docs/worlds.md and recordings/README.md).

A `Game` takes move intents (direction, carefulness, how long the key was held) and plays
them in the world's MDP with one seeded numpy Generator. It keeps the score and writes every
step and every episode end to a `RecordingSink` the moment it happens.

==============  ==============================================================
episode         numbered 0, 1, 2, ... for the whole game (or on from
                ``first_episode``); starts at a start cell drawn from the world
                (a fixed cell, or uniform over non-terminal cells)
score           undiscounted, reset to ``initial_score`` at each episode start;
                a step adds R(s, a) = R_S(s) + R_A(a); entering a terminal cell
                adds its R_S once, at the episode end
slip            the realised direction differs from the chosen one (a move into
                a wall or off the grid that slips still counts as a slip)
bump            ``stay``: a move into a wall or off the grid is a step that
                stays; ``drop``: it is no step (`Game.move` returns None,
                nothing is recorded, the step count and score do not move)
episode end     ``terminal`` (entered a terminal cell), ``step_limit`` (after
                ``max_steps`` moves), ``quit`` (`Game.quit` during an episode
                that has at least one step; an episode without steps is not
                recorded)
==============  ==============================================================

The sink `careful play` uses is `irl_core.recordings.writer.SessionRecorder` (all file IO lives
with the recordings: the writer there, the reader in `irl_core.recordings.demonstrations`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np

from irl_core.errors import GameOver
from irl_core.recordings.lines import EpisodeEnd, Step
from irl_core.worlds.mdp import DIRECTIONS, MDP, action_index, build_mdp, sample_direction
from irl_core.worlds.world import Cell, World


class RecordingSink(Protocol):
    """Where a game's lines go (a `RecordingWriter`, a `SessionRecorder`, a list in tests).

    A sink may raise `OSError` (the file cannot be written); the move is then not played.
    """

    def write_step(self, step: Step) -> None: ...

    def end_episode(self, end: EpisodeEnd) -> None: ...


@dataclass(frozen=True)
class MoveResult:
    """One resolved move.

    Attributes:
        step: the step line as recorded.
        realised: the direction actually taken ("up", ...); differs from `step.direction` on a slip.
        end: the episode end this move caused (a terminal cell or the step limit), else None.
    """

    step: Step
    realised: str
    end: EpisodeEnd | None

    @property
    def slipped(self) -> bool:
        return self.step.slipped


def level_costs(world: World) -> list[float]:
    """The action cost of each carefulness level 1..L, as a positive number."""
    return list(world.level_costs)


def level_slip_chances(world: World) -> list[float]:
    """The chance that a move of each carefulness level 1..L goes another way than chosen.

    With ``slip = "halving"`` it is 2^-c (level 1: 0.5, level 2: 0.25, ...); with ``"none"``, 0; with a fixed
    split, 1 - intended at every level.
    """
    return list(world.slip_chances)


class Game:
    """Episodes of one world, played move by move and recorded as they happen.

    Args:
        world: the world to play.
        seed: seeds the one Generator behind start cells and slips.
        sink: receives every step and episode end.
        first_episode: the number of the first episode (a resumed study block continues its
            numbering, so no number is used twice).
    """

    def __init__(self, world: World, *, seed: int, sink: RecordingSink, first_episode: int = 0) -> None:
        self.world = world
        self.mdp, self._reward, self._starts = _built_arrays(world)
        self.seed = seed
        self.sink = sink
        self._rng = np.random.default_rng(seed)
        self.first_episode = first_episode
        self.episode = first_episode - 1
        self.t = 0
        self.cell: Cell | None = None
        self.score = world.initial_score
        self.live = False
        self.last_end: EpisodeEnd | None = None
        # Where the last move that was dropped went (``bump = "drop"``), for the player's message.
        self.last_dropped: str | None = None

    def __getstate__(self) -> dict[str, object]:
        # The world's arrays are built again where a pickled game is taken up (a web server's other worker).
        return {name: value for name, value in self.__dict__.items() if name not in ("mdp", "_reward", "_starts")}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self.mdp, self._reward, self._starts = _world_arrays(self.world)

    def costs(self) -> list[float]:
        """The action cost of each carefulness level 1..L, as a positive number."""
        return level_costs(self.world)

    def begin_episode(self) -> Cell:
        """Start the next episode at a start cell; returns that cell."""
        if self.live:
            raise GameOver("an episode is already running")
        self.episode += 1
        self.t = 0
        self.score = self.world.initial_score
        self.cell = self.mdp.cells[self._starts[int(self._rng.integers(len(self._starts)))]]
        self.live = True
        return self.cell

    def move(self, direction: str, carefulness: int | None, *, hold_ms: float | None = None,
             exact: bool = False) -> MoveResult | None:
        """Play one move, record it, and end the episode if it ends here; None when the world drops the move
        (``bump = "drop"``: it went into a wall or off the grid, and nothing happens or is recorded).

        On a time world `carefulness` is None and `hold_ms` the held time: the move slips with
        p(hold_ms) and costs the exact hold (capped at max_hold_ms); the step records its bin.

        Raises:
            GameOver: no episode is running.
            ValueError: an unknown direction, a carefulness outside 1..L, or (a time world) no hold.
        """
        if not self.live or self.cell is None:
            raise GameOver("no episode is running: call begin_episode first")
        if direction not in DIRECTIONS:
            raise ValueError(f"unknown direction {direction!r}")
        s = self.mdp.state_of[self.cell]
        if self.world.care == "time":
            if carefulness is not None or hold_ms is None or not 0 <= hold_ms < float("inf"):
                raise ValueError(f"a move on a time world is a hold in ms, got carefulness {carefulness}, hold {hold_ms}")
            held = min(round(float(hold_ms), 1), self.world.max_hold_ms)
            bin_: int | None = int(self.world.bin_of(held))
            slip = float(self.world.hold_slip_chance(held))
            k = int(self._rng.choice(4, p=[1.0 - slip, slip / 3, slip / 3, slip / 3]))
            realised = (DIRECTIONS.index(direction) + k) % 4
            s_next = int(self.mdp.neighbour[s, realised])
            reward = float(self.mdp.R_S[s] - self.world.hold_cost(held))
            hold: float | None = held
        else:
            if carefulness is None or not 1 <= carefulness <= self.world.levels:
                raise ValueError(f"carefulness must be in 1..{self.world.levels}, got {carefulness}")
            bin_ = None
            a = action_index(direction, carefulness, self.world.levels)
            realised = sample_direction(self.mdp.split[a], DIRECTIONS.index(direction), self._rng)
            if self.world.bump == "drop" and not self.mdp.leads[s, realised]:
                # Into a wall or off the grid: no step is made, as if the key had not been pressed.
                self.last_dropped = DIRECTIONS[realised]
                return None
            s_next = int(self.mdp.neighbour[s, realised])
            reward = float(self._reward[s, a])
            hold = None if hold_ms is None else round(float(hold_ms), 1)
        step = Step(
            episode=self.episode,
            t=self.t,
            state=self.cell,
            direction=direction,
            carefulness=carefulness,
            hold_ms=hold,
            hold_exact=exact,
            bin=bin_,
            next_state=self.mdp.cells[s_next],
            slipped=DIRECTIONS[realised] != direction,
            reward=reward,
            score=self.score + reward,
            realised=DIRECTIONS[realised],
        )
        self.sink.write_step(step)
        self.score = step.score
        self.t += 1
        self.cell = step.next_state
        end = None
        if self.mdp.terminal[s_next]:
            symbol = self.mdp.symbols[s_next]
            self.score += float(self.mdp.R_S[s_next])
            end = self._end("terminal", symbol)
        elif self.t >= self.world.max_steps:
            end = self._end("step_limit", None)
        return MoveResult(step=step, realised=DIRECTIONS[realised], end=end)

    def quit(self) -> EpisodeEnd | None:
        """End the running episode as ``quit``; None (and nothing recorded) when no step was played."""
        if not self.live:
            return None
        if self.t == 0:
            self.live = False
            self.episode -= 1
            return None
        return self._end("quit", None)

    def stop(self) -> None:
        """Play no further, recording nothing more (the recording cannot be written): the running
        episode, if any, stays as far as it was written."""
        self.live = False

    def _end(self, outcome: Literal["terminal", "quit", "step_limit"], symbol: str | None) -> EpisodeEnd:
        end = EpisodeEnd(
            episode=self.episode,
            outcome=outcome,
            terminal_symbol=symbol,
            steps=self.t,
            return_=self.score - self.world.initial_score,
            score=self.score,
        )
        self.sink.end_episode(end)
        self.live = False
        self.last_end = end
        return end


_BUILT: dict[int, tuple[World, MDP, np.ndarray, list[int]]] = {}
_BUILT_KEPT = 16


def _built_arrays(world: World) -> tuple[MDP, np.ndarray, list[int]]:
    """A game's MDP, reward matrix and start states for `world`."""
    mdp = build_mdp(world)
    return mdp, mdp.reward_matrix(), [mdp.state_of[cell] for cell in world.start_cells]


def _world_arrays(world: World) -> tuple[MDP, np.ndarray, list[int]]:
    """`_built_arrays`, once per world object (an unpickled game's world is its study's, the same object each
    time: `careful_tui.web.seat_files`)."""
    built = _BUILT.get(id(world))
    if built is None or built[0] is not world:
        built = (world, *_built_arrays(world))
        if len(_BUILT) >= _BUILT_KEPT:
            del _BUILT[next(iter(_BUILT))]
        _BUILT[id(world)] = built
    return built[1], built[2], built[3]
