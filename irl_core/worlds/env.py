"""Gymnasium environments over careful's worlds (docs/environment.md): a grid world's MDP, and a reach world.

``import irl_core.worlds.env`` registers ``careful/Careful-v0`` (grid worlds) and ``careful/Reach-v0``
(reach worlds, `ReachEnv`)::

    import gymnasium as gym
    import irl_core.worlds.env  # noqa: F401  (registers careful/Careful-v0)

    env = gym.make("careful/Careful-v0", world="paper")

``gym.make("irl_core.worlds.env:careful/Careful-v0", world=...)`` imports this module itself. The
dynamics are the MDP's own (`irl_core.worlds.mdp.MDP.move`, the sampler `careful play` uses), so an
agent here lives in exactly the world a player or a fitted reward sees.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from irl_core.worlds.mdp import DIRECTIONS, build_mdp
from irl_core.worlds.reach import ReachWorld, load_reach_world, reach_world_from_dict
from irl_core.worlds.world import Cell, World, load_world, world_from_dict

ENV_ID = "careful/Careful-v0"
REACH_ENV_ID = "careful/Reach-v0"



def resolve_world(world: str | Path | World | Mapping[str, Any]) -> World:
    """A built-in name, a world file, a `World`, or a world as a mapping (its TOML fields).

    Raises `irl_core.errors.WorldError` (a one-line message) for anything else that is not a world.
    """
    if isinstance(world, World):
        return world
    if isinstance(world, Mapping):
        return world_from_dict(dict(world))
    return load_world(world)


def cell_observation(cell: Cell, cols: int) -> int:
    """The observation of a cell: row * cols + col."""
    return int(cell[0]) * cols + int(cell[1])


class CarefulEnv(gym.Env):
    """
    The careful cliff gridworlds: move on a grid, choosing how careful each move is.

    ## Description
    A grid world from `careful` (a built-in world such as the paper's `paper`, or a world file).
    Each move has a direction and a carefulness c = 1..L: a careful move costs more and slips
    less. With `slip = "halving"` the move goes the chosen way with probability 1 - 2^-c and
    slips to each other direction with 2^-c / 3; a world file's fixed slip
    (`slip = {intended = 0.76, others = [...]}`) has its own split. Moving off the grid or into a
    wall `#` stays (`bump = "stay"`); with `bump = "drop"` such a move is not made and a step is one
    of the moves that lead somewhere, as if the agent pressed again (the world's MDP, `P`).
    Entering a terminal cell (`C` cliff, `G` goal by default) ends the episode.

    ## Action Space
    `Discrete(4 * L)`: action a = d * L + (c - 1), direction d in 0 up, 1 right, 2 down,
    3 left, carefulness c in 1..L. With `action_space="multidiscrete"`: `MultiDiscrete([4, L])`,
    an action [d, c - 1].

    ## Observation Space
    `Discrete(rows * cols)`: the agent's cell as row * cols + col (an `int`). Walls are never
    observed; terminal cells are observed only as the last observation of an episode.

    ## Rewards
    Leaving cell s with carefulness c gives R_S(s) - cost_per_level * c. The step that enters
    a terminal cell also gives that cell's R_S (`paper`: cliff -1000, goal +100). An episode's
    return is the game's score change, and equals the `return` that `careful play` records.

    ## Starting State
    The world's start: a uniformly random non-terminal cell (`start = "random"`, the default),
    or its fixed cell. `reset(options={"start": [row, col]})` starts at a given cell.

    ## Episode End
    - Termination: the agent enters a terminal cell.
    - Truncation: the world's step limit (`max_steps`, 200 in the built-in worlds).
    Calling `step` after either raises `gymnasium.error.ResetNeeded`.

    ## Information
    `reset` and `step` return `cell` (np.array([row, col])), `carefulness` (the move's c, 0 at
    reset) and `slipped` (the move went another way than chosen, also when that way was blocked;
    False at reset). Reset and step infos share keys so Minari's DataCollector can record them.

    ## Arguments
    ```python
    gym.make("careful/Careful-v0", world="paper", action_space="discrete", render_mode=None)
    ```
    `world`: a built-in name, a world TOML file, a `World`, or a world's fields as a dict.
    `render_mode="ansi"`: `render()` returns the board as text, `@` for the agent.
    `env.unwrapped.mdp` is the world's MDP: its sparse transitions `P` and rewards.

    ## Version History
    - v0: Initial version.
    """

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(
        self,
        world: str | Path | World | Mapping[str, Any] = "paper",
        *,
        action_space: str = "discrete",
        render_mode: str | None = None,
    ) -> None:
        if action_space not in ("discrete", "multidiscrete"):
            raise ValueError(f'action_space must be "discrete" or "multidiscrete", got {action_space!r}')
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or 'ansi', got {render_mode!r}")
        self.world = resolve_world(world)
        self.mdp = build_mdp(self.world)
        self.render_mode = render_mode
        levels = self.world.levels
        self.observation_space = spaces.Discrete(self.world.rows * self.world.cols)
        self.action_space = (
            spaces.Discrete(4 * levels) if action_space == "discrete" else spaces.MultiDiscrete([4, levels])
        )
        self._reward = self.mdp.reward_matrix()
        self._starts = [self.mdp.state_of[cell] for cell in self.world.start_cells]
        self._state: int | None = None
        self._t = 0
        self._done = False
        self._return = 0.0
        self._last_move: tuple[int, int, int] | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[int, dict[str, Any]]:
        super().reset(seed=seed)
        start = None if options is None else options.get("start")
        if start is None:
            self._state = self._starts[int(self.np_random.integers(len(self._starts)))]
        else:
            self._state = self._start_state(start)
        self._t, self._done, self._return, self._last_move = 0, False, 0.0, None
        return self._observation(), self._info(carefulness=0, slipped=False)

    def step(self, action: Any) -> tuple[int, float, bool, bool, dict[str, Any]]:
        if self._state is None or self._done:
            raise ResetNeeded("the episode has ended (or never began): call reset() first")
        a = self._action_index(action)
        s = self._state
        s_next, realised = self.mdp.move(s, a, self.np_random)
        d, c = divmod(a, self.world.levels)
        reward = float(self._reward[s, a])
        terminated = bool(self.mdp.terminal[s_next])
        if terminated:
            reward += float(self.mdp.R_S[s_next])
        self._state = s_next
        self._t += 1
        self._return += reward
        self._done = terminated or self._t >= self.world.max_steps
        self._last_move = (d, c + 1, realised)
        truncated = self._done and not terminated
        return self._observation(), reward, terminated, truncated, self._info(carefulness=c + 1, slipped=realised != d)

    def render(self) -> str | None:
        if self.render_mode != "ansi":
            return None
        agent = None if self._state is None else self.mdp.cells[self._state]
        lines = [
            "".join(
                "@" if (r, c) == agent else (ch if ch.isprintable() else "?")
                for c, ch in enumerate(row)
            )
            for r, row in enumerate(self.world.grid)
        ]
        status = f"step {self._t} of {self.world.max_steps}, return {self._return:g}"
        if self._last_move is not None:
            chosen, carefulness, realised = self._last_move
            status += f"; last move {DIRECTIONS[chosen]} at carefulness {carefulness}"
            if realised != chosen:
                status += f", slipped {DIRECTIONS[realised]}"
        return "\n".join([*lines, status]) + "\n"

    def _action_index(self, action: Any) -> int:
        if not self.action_space.contains(action):
            raise ValueError(f"{action!r} is not an action of {self.action_space}")
        if isinstance(self.action_space, spaces.MultiDiscrete):
            d, c0 = (int(x) for x in np.asarray(action))
            return d * self.world.levels + c0
        return int(action)

    def _start_state(self, start: Any) -> int:
        try:
            cell = (int(start[0]), int(start[1]))
            if len(start) != 2:
                raise ValueError
        except (TypeError, ValueError, IndexError, KeyError):
            raise ValueError(f"options['start'] must be a cell [row, col], got {start!r}") from None
        state = self.mdp.state_of.get(cell)
        if state is None or not self.mdp.nonterminal[state]:
            raise ValueError(f"options['start'] {list(cell)} is not a non-terminal cell of world {self.world.name!r}")
        return state

    def _cell(self) -> Cell:
        # Only called after reset() has placed the agent.
        assert self._state is not None
        return self.mdp.cells[self._state]

    def _observation(self) -> int:
        return cell_observation(self._cell(), self.world.cols)

    def _info(self, *, carefulness: int, slipped: bool) -> dict[str, Any]:
        return {
            "cell": np.array(self._cell(), dtype=np.int64),
            "carefulness": carefulness,
            "slipped": bool(slipped),
        }


def resolve_reach_world(world: str | Path | ReachWorld | Mapping[str, Any]) -> ReachWorld:
    """A built-in reach world's name, a reach world file, a `ReachWorld`, or one as a mapping (its TOML fields).

    Raises `irl_core.errors.WorldError` (a one-line message) for anything else that is not a reach world."""
    if isinstance(world, ReachWorld):
        return world
    if isinstance(world, Mapping):
        return reach_world_from_dict(dict(world))
    return load_reach_world(world)


class ReachEnv(gym.Env):
    """
    careful's reach worlds: one quick reach to a target beside a penalty circle, its aim and duration chosen.

    ## Description
    A reach world from `careful` (`reach`, `reach-mild`, `reach-severe`, or a reach world file; docs/reach.md).
    An episode is one reach from the world's start: the agent chooses where to aim and how long to take. The
    endpoint is the aim plus a normal scatter per axis of sd a + b * distance / (duration_ms / 1000), the
    world's spread law: a slower reach lands closer to its aim, and costs more time.

    ## Action Space
    `Box([0, 0, min_ms], [width, height, max_ms], (3,), float64)`: aim x, aim y (field units, y down) and the
    duration in ms.

    ## Observation Space
    `Box([-inf, -inf], [inf, inf], (2,), float64)`: where the hand is. At reset, the world's start; after the
    step, the reach's endpoint (which may lie outside the field: the scatter is not clipped). The world itself
    never changes, so the hand's place is the whole state, as the cell is in careful/Careful-v0.

    ## Rewards
    The points of every circle holding the endpoint (circles that overlap add), less cost_per_second *
    duration_ms / 1000: the `reward` a reach recording holds.

    ## Starting State
    The world's start, always.

    ## Episode End
    - Termination: after the one step (a trial is one reach). Truncation: never.
    Calling `step` after it raises `gymnasium.error.ResetNeeded`.

    ## Information
    `reset` and `step` return `aim` (np.array([x, y]), the start at reset), `duration_ms` (0 at reset) and
    `hit` (np.array of 0 or 1 per symbol of the world, in its order: 1 where a circle of that symbol holds the
    endpoint; all 0 at reset). Numbers only, so Minari's datasets store them.

    ## Arguments
    ```python
    gym.make("careful/Reach-v0", world="reach", render_mode=None)
    ```
    `world`: a built-in reach world's name, a reach world file, a `ReachWorld` or its fields as a dict.
    `render_mode="ansi"`: `render()` returns the last reach in a line of text.

    ## Version History
    - v0: Initial version.
    """

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(self, world: str | Path | ReachWorld | Mapping[str, Any] = "reach", *,
                 render_mode: str | None = None) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or 'ansi', got {render_mode!r}")
        self.world = resolve_reach_world(world)
        self.render_mode = render_mode
        width, height = self.world.field
        self.action_space = spaces.Box(low=np.array([0.0, 0.0, self.world.min_ms]),
                                       high=np.array([width, height, self.world.max_ms]), dtype=np.float64)
        self.observation_space = spaces.Box(low=-np.inf, high=np.inf, shape=(2,), dtype=np.float64)
        self._hand: np.ndarray | None = None
        self._done = False
        self._last: dict[str, Any] | None = None

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self._hand, self._done, self._last = np.array(self.world.start, dtype=np.float64), False, None
        return self._hand.copy(), self._info(np.array(self.world.start, dtype=np.float64), 0.0, [])

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._hand is None or self._done:
            raise ResetNeeded("the reach has been made (or the episode never began): call reset() first")
        action = np.asarray(action, dtype=np.float64)
        if action.shape != (3,) or not self.action_space.contains(action):
            raise ValueError(f"{action!r} is not an action of {self.action_space}")
        aim, duration = action[:2], float(action[2])
        self._hand = self.world.endpoint(aim, duration, self.np_random)
        endpoint = (float(self._hand[0]), float(self._hand[1]))
        reward = self.world.score_of(endpoint, duration)
        regions = self.world.regions_holding(endpoint)
        self._done = True
        self._last = {"aim": aim, "duration_ms": duration, "endpoint": endpoint, "regions": regions, "reward": reward}
        return self._hand.copy(), reward, True, False, self._info(aim, duration, regions)

    def render(self) -> str | None:
        if self.render_mode != "ansi":
            return None
        if self._last is None:
            return f"{self.world.name}: at the start {list(self.world.start)}, no reach yet\n"
        last = self._last
        return (f"{self.world.name}: aimed at ({last['aim'][0]:.1f}, {last['aim'][1]:.1f}) in "
                f"{last['duration_ms']:.0f} ms, ended at ({last['endpoint'][0]:.1f}, {last['endpoint'][1]:.1f}) in "
                f"{', '.join(last['regions']) or 'no circle'}: reward {last['reward']:g}\n")

    def _info(self, aim: np.ndarray, duration: float, regions: list[str]) -> dict[str, Any]:
        return {"aim": np.array(aim, dtype=np.float64), "duration_ms": duration,
                "hit": symbol_hits(self.world, regions)}


def symbol_hits(world: ReachWorld, regions: list[str] | tuple[str, ...]) -> np.ndarray:
    """(S,) int8: 1 for each of the world's symbols (its order) that `regions` names, else 0."""
    return np.array([symbol in regions for symbol in world.symbols], dtype=np.int8)


if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="irl_core.worlds.env:CarefulEnv")
if REACH_ENV_ID not in gym.registry:
    gym.register(id=REACH_ENV_ID, entry_point="irl_core.worlds.env:ReachEnv")
