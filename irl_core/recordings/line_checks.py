"""What makes a recording's lines agree with its world and with each other (recordings/README.md).

A step must be a move the header's world can make (a level it has, cells that are states, a
next cell the move can reach with a chance above 0, a `realised` direction the move can take that leads
there; in a world that drops moves into a wall, ``bump = "drop"``, no step stays where it started), and the lines must tell
one story: episodes in increasing order; within one, `t` counting 0, 1, 2, ...; each step
starting where the previous one ended; nothing of an episode after its `episode_end`; and each
`episode_end` agreeing with its steps: `steps` is how many there were, a `terminal` end's last step
entered a terminal cell whose symbol is `terminal_symbol`, a `quit` or `step_limit` end's did not
(and names no symbol). A ``calibration_trial`` comes before the file's first step, its target and
produced levels among the world's. The
reader (`irl_core.recordings.demonstrations`) feeds every line to a `LineChecker` and turns a `Mismatch`
into `file:line: field: problem`.
"""

from __future__ import annotations

from irl_core.errors import Mismatch
from irl_core.recordings.lines import CalibrationTrial, EpisodeEnd, Step
from irl_core.support.plural import plural
from irl_core.support.safe_text import printable
from irl_core.worlds.mdp import DIRECTIONS, MDP

_DIRECTION_INDEX = {name: d for d, name in enumerate(DIRECTIONS)}


class LineChecker:
    """Checks that a step is a move the header's world can make, and that lines agree.

    Episodes come in increasing order; within one, `t` counts 0, 1, 2, ...; each step starts
    where the previous one ended; nothing of an episode follows its `episode_end`.
    """

    def __init__(self, mdp: MDP):
        self.mdp = mdp
        self._neighbours = mdp.neighbour.tolist()
        # (state, action): which directions a step can go with a chance above 0, worked out once per pair.
        self._can_go: dict[tuple[int, int], tuple[frozenset[int], tuple[bool, ...]]] = {}
        self._episode: int | None = None
        self._next_t = 0
        self._cell: tuple[int, int] | None = None
        self._ended_on: int | None = None

    def _possible(self, state: int, action: int) -> tuple[frozenset[int], tuple[bool, ...]]:
        """The states a step of `action` (-1: any, a time world's) from `state` reaches with a chance above 0, and
        whether it goes each way (`MDP.step_chances`), worked out once per pair: the reader asks for every step."""
        key = (state, action)
        found = self._can_go.get(key)
        if found is None:
            can_go = (True,) * 4 if action < 0 else tuple((self.mdp.step_chances(state, action) > 0).tolist())
            reach = frozenset(n for n, possible in zip(self._neighbours[state], can_go) if possible)
            found = self._can_go[key] = (reach, can_go)
        return found

    @staticmethod
    def _error(number: int, field: str, problem: str) -> Mismatch:
        return Mismatch(number, field, problem)

    def _enter(self, episode: int, number: int) -> None:
        """Move on to `episode` if it is a new one; refuse one that comes back or has ended."""
        if episode == self._episode:
            if self._ended_on is not None:
                raise self._error(number, "episode", f"episode {episode} already ended on line {self._ended_on}")
            return
        if self._episode is not None and episode < self._episode:
            raise self._error(number, "episode", f"episode {episode} comes after episode {self._episode}: "
                              "episodes must be in order")
        self._episode, self._next_t, self._cell, self._ended_on = episode, 0, None, None

    def step(self, step: Step, number: int) -> None:
        self._check_move(step, number)
        self._enter(step.episode, number)
        if step.t != self._next_t:
            what = "repeats" if step.t < self._next_t else "skips"
            raise self._error(number, "t", f"{step.t} {what} a step: episode {step.episode}'s next step is "
                              f"t = {self._next_t}")
        if self._cell is not None and step.state != self._cell:
            raise self._error(number, "state", f"{list(step.state)} is not where the previous step ended "
                              f"({list(self._cell)})")
        self._next_t += 1
        self._cell = step.next_state

    def trial(self, trial: CalibrationTrial, number: int) -> None:
        """A calibration trial: before any step (the block comes before practice), on the world's levels."""
        if self._episode is not None:
            raise self._error(number, "kind", "a calibration_trial after the file's first step: the calibration "
                              "block comes before play")
        levels = self.mdp.world.levels
        for name in ("target", "produced"):
            if getattr(trial, name) > levels:
                raise self._error(number, name, f"{getattr(trial, name)} is above the world's {plural(levels, 'level')}")

    def end(self, end: EpisodeEnd, number: int) -> None:
        self._enter(end.episode, number)
        self._ended_on = number
        if end.steps != self._next_t:
            raise self._error(number, "steps", f"{end.steps}, but episode {end.episode} has "
                              f"{plural(self._next_t, 'step')} in the file")
        self._check_outcome(end, number)

    def _check_outcome(self, end: EpisodeEnd, number: int) -> None:
        """A terminal end entered the terminal cell it names; any other entered none."""
        mdp, cell = self.mdp, self._cell
        s = None if cell is None else mdp.state_of[cell]
        symbol = None if s is None or not mdp.terminal[s] else str(mdp.symbols[s])
        where = "no step" if cell is None else f"the last step entered {list(cell)}"
        if end.outcome == "terminal":
            if symbol is None:
                ended = ("there was no step" if cell is None
                         else f"the last step ended on {list(cell)}, which is not a terminal cell")
                raise self._error(number, "outcome", f"terminal, but {ended}")
            if end.terminal_symbol != symbol:
                shown = printable(str(end.terminal_symbol), limit=20)
                raise self._error(number, "terminal_symbol", f"{shown!r}, but {where}, which is {symbol}")
            return
        if symbol is not None:
            raise self._error(number, "outcome", f"{end.outcome}, but {where}, which is {symbol}, a terminal cell")
        if end.terminal_symbol is not None:
            raise self._error(number, "terminal_symbol", f"{printable(end.terminal_symbol, limit=20)!r}, but the "
                              f"episode ended as {end.outcome}, in no terminal cell")

    def _check_hold(self, step: Step, number: int) -> None:
        """A time world's step: no carefulness, a hold within max_hold_ms, and the bin that holds it."""
        world = self.mdp.world
        if step.carefulness is not None:
            raise self._error(number, "carefulness", f"{step.carefulness}, but on a time world care is the hold: "
                              "carefulness is null")
        if step.hold_ms is None:
            raise self._error(number, "hold_ms", "missing: a time world's step records how long the key was held")
        if step.hold_ms > world.max_hold_ms:
            raise self._error(number, "hold_ms", f"{step.hold_ms:g} is beyond the world's max_hold_ms "
                              f"({world.max_hold_ms:g})")
        if step.bin is None:
            raise self._error(number, "bin", "missing: a time world's step records its duration bin")
        if step.bin != int(world.bin_of(step.hold_ms)):
            raise self._error(number, "bin", f"{step.bin}, but a hold of {step.hold_ms:g} ms is in bin "
                              f"{int(world.bin_of(step.hold_ms))}")

    def _check_move(self, step: Step, number: int) -> None:
        world, mdp = self.mdp.world, self.mdp
        if world.care == "time":
            self._check_hold(step, number)
        elif step.carefulness is None:
            raise self._error(number, "carefulness", "null, but this world has levels (only a time world's steps "
                              "have no carefulness)")
        elif step.carefulness > world.levels:
            raise self._error(number, "carefulness", f"{step.carefulness} is above the world's {plural(world.levels, 'level')}")
        elif step.bin is not None:
            raise self._error(number, "bin", "a step on a world with levels has no duration bin")
        for name in ("state", "next_state"):
            cell = getattr(step, name)
            if cell not in mdp.state_of:
                what = "a wall" if 0 <= cell[0] < world.rows and 0 <= cell[1] < world.cols else "outside the grid"
                raise self._error(number, name, f"{list(cell)} is {what} ({world.rows}x{world.cols})")
        s = mdp.state_of[step.state]
        if not mdp.nonterminal[s]:
            raise self._error(number, "state", f"{list(step.state)} is a terminal cell: no move starts there")
        # A time world may slip in any direction; a level world goes where its split (and its bump rule) lets the
        # chosen action go: a world without slip only the chosen way, a dropping world nowhere that stays.
        d = _DIRECTION_INDEX[step.direction]
        action = -1 if world.care == "time" else d * world.levels + (step.carefulness or 1) - 1
        reachable, can_go = self._possible(s, action)
        if mdp.state_of[step.next_state] not in reachable:
            if world.bump == "drop" and step.next_state == step.state:
                raise self._error(number, "next_state", f"{list(step.next_state)} is where the step started, but "
                                  'this world drops a move into a wall or off the grid (bump = "drop"): no step stays')
            raise self._error(number, "next_state", f"the world cannot move from {list(step.state)} to "
                              f"{list(step.next_state)} going {step.direction} in one step")
        if step.realised is not None:
            if world.slip == "none" and step.realised != step.direction:
                raise self._error(number, "realised", f"{step.realised}, but this world never slips "
                                  f"(the move was {step.direction})")
            if not can_go[_DIRECTION_INDEX[step.realised]]:
                raise self._error(number, "realised", f"{step.realised}: a step chosen {step.direction} from "
                                  f"{list(step.state)} never goes that way in this world")
            if mdp.state_of[step.next_state] != self._neighbours[s][DIRECTIONS.index(step.realised)]:
                raise self._error(number, "next_state", f"{list(step.next_state)} is not where going "
                                  f"{step.realised} from {list(step.state)} leads")
            if step.slipped != (step.realised != step.direction):
                raise self._error(number, "slipped", f"{str(step.slipped).lower()}, but the move went "
                                  f"{step.realised} for {step.direction}")
