"""Computer experts: optimal and Boltzmann policies, rolled out for many episodes at once.

Rollouts are vectorised across episodes: every live episode takes its step together,
so 10,000 episodes cost a few hundred array operations instead of 10,000 Python loops. A player
that is not a stationary policy (a person-like player, `irl_core.players.person_like`) is a `Chooser`,
which sees each episode's previous action, and rolls out and writes the same way.
The same seed gives the same episodes and, written out, the same bytes. `simulate_to_file`
rolls out and writes a block of episodes at a time, so memory stays flat however many
episodes are asked for. A plan that stopped at its iteration cap is not an expert:
`optimal_policy` and `boltzmann_policy` raise `NotConverged` rather than return it.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from irl_core.errors import NotConverged
from irl_core.recordings.demonstrations import Demonstrations, EpisodeFacts, episode_matrix, hold_steps
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import RecordingWriter
from irl_core.support.safe_files import built_beside
from irl_core.worlds.mdp import DIRECTIONS, MDP, from_chosen
from irl_core.worlds.planning import Plan, soft_value_iteration, value_iteration

# Simulated sessions are a function of (world, policy, seed): their header carries this
# fixed time so that the same seed writes the same bytes.
SIMULATED_AT = datetime(2000, 1, 1, tzinfo=UTC)


def _converged(plan: Plan, what: str, gamma: float) -> np.ndarray:
    if not plan.converged:
        raise NotConverged(
            f"value iteration for the {what} policy did not converge in {plan.iterations:,} sweeps "
            f"(last change {plan.residual:.3g}); with gamma = {gamma} it needs more, so no {what} expert "
            "can be recorded (a smaller gamma converges faster)"
        )
    return plan.policy


def optimal_plan(mdp: MDP) -> Plan:
    """The optimal plan (values, Q and the deterministic policy, ties to the lowest action index).

    Raises:
        NotConverged: value iteration stopped at its cap.
    """
    plan = value_iteration(mdp)
    _converged(plan, "optimal", mdp.gamma)
    return plan


def optimal_policy(mdp: MDP) -> np.ndarray:
    """(S, A) the deterministic optimal policy (ties to the lowest action index).

    Raises:
        NotConverged: value iteration stopped at its cap.
    """
    return optimal_plan(mdp).policy


def boltzmann_policy(mdp: MDP, *, beta: float) -> np.ndarray:
    """(S, A) the soft-optimal policy pi(a | s) = exp(beta (Q(s, a) - V(s))).

    Raises:
        NotConverged: soft value iteration stopped at its cap.
    """
    return _converged(soft_value_iteration(mdp, beta=beta), "Boltzmann", mdp.gamma)


def expert_name(policy: str, beta: float | None = None) -> str:
    """The `player` of a simulated session, e.g. ``expert:boltzmann(beta=0.1)``."""
    return f"expert:{policy}" if policy == "optimal" else f"expert:{policy}(beta={beta:g})"


@dataclass(frozen=True)
class Rollouts:
    """Steps of many episodes, in the order they happened (time-major).

    Step arrays (n_steps,): episode, t, state, action, direction (realised direction
    index), next_state, reward, and on a time world hold_ms (the exact hold; None elsewhere).
    Episode arrays (n_episodes,): length (steps taken), final_state, truncated (hit the step limit).
    """

    episode: np.ndarray
    t: np.ndarray
    state: np.ndarray
    action: np.ndarray
    direction: np.ndarray
    next_state: np.ndarray
    reward: np.ndarray
    length: np.ndarray
    final_state: np.ndarray
    truncated: np.ndarray
    hold_ms: np.ndarray | None = None


Chooser = Callable[[np.ndarray, np.ndarray, np.random.Generator, np.ndarray],
                   "np.ndarray | tuple[np.ndarray, np.ndarray]"]
"""A player's choice for many episodes at once: ``choose(states, previous, rng, episode)`` -> actions (n,),
where `previous` (n,) is each episode's previous action (-1 at its first step) and `episode` (n,) each
episode's number in the recording (a player who learns across episodes, or remembers within one, reads it).
On a time world a chooser may return (actions, hold_ms), each (n,), the action's level being the hold's
duration bin + 1; a chooser of actions alone holds each bin's geometric mid-point."""


def policy_chooser(policy: np.ndarray) -> Chooser:
    """The chooser that samples actions from a stationary policy (S, A)."""
    policy_cdf = np.cumsum(policy, axis=1)
    last = policy.shape[1] - 1

    def choose(s: np.ndarray, previous: np.ndarray, rng: np.random.Generator, episode: np.ndarray) -> np.ndarray:
        return np.minimum((policy_cdf[s] < rng.random((s.size, 1))).sum(axis=1), last)

    return choose


def rollouts(
    mdp: MDP,
    policy: np.ndarray | Chooser,
    *,
    episodes: int,
    seed: int | None = None,
    rng: np.random.Generator | None = None,
    max_steps: int | None = None,
    starts: np.ndarray | None = None,
    first_episode: int = 0,
) -> Rollouts:
    """Roll out `policy` (S, A), or a `Chooser`, from the world's start cells for `episodes` episodes,
    or from the states `starts` (episodes,) when given. A chooser is told each episode's number in the
    recording: `first_episode` (a later block's first) and on.

    Randomness comes from `rng` when given (to continue a stream block by block), else from `seed`.
    """
    world = mdp.world
    max_steps = world.max_steps if max_steps is None else max_steps
    rng = np.random.default_rng(seed) if rng is None else rng
    given_starts = starts
    starts = np.array([mdp.state_of[cell] for cell in world.start_cells])
    choose = policy if callable(policy) else policy_chooser(policy)
    R = mdp.reward_matrix()
    timed = world.care == "time"
    mids = np.asarray(world.bin_mids_ms)

    state = (np.asarray(given_starts, dtype=np.int64).copy() if given_starts is not None
             else starts[rng.integers(len(starts), size=episodes)])
    previous = np.full(episodes, -1, dtype=np.int64)
    length = np.zeros(episodes, dtype=np.int64)
    live = np.arange(episodes)
    trace: list[tuple[np.ndarray, ...]] = []
    holds: list[np.ndarray] = []
    for t in range(max_steps):
        if live.size == 0:
            break
        s = state[live]
        chosen = choose(s, previous[live], rng, first_episode + live)
        a = np.asarray(chosen[0] if isinstance(chosen, tuple) else chosen)
        previous[live] = a
        if timed:
            # The slip and the cost of the exact hold, not of its bin's mid-point.
            hold = np.asarray(chosen[1], dtype=float) if isinstance(chosen, tuple) else mids[a % mdp.levels]
            slipped = rng.random(live.size) < world.hold_slip_chance(hold)
            k = np.where(slipped, 1 + rng.integers(3, size=live.size), 0)
            d = (mdp.direction[a] + k) % 4
            reward = np.where(mdp.nonterminal[s], mdp.R_S[s] - world.hold_cost(hold), mdp.R_S[s])
            holds.append(hold)
        else:
            # The step as P has it (`MDP.step_chances`): in a world that drops moves into a wall, a player
            # who presses the same key again until a step is made.
            cdf = np.cumsum(from_chosen(mdp.step_chances(s, a), mdp.direction[a]), axis=1)
            k = np.minimum((cdf < rng.random((live.size, 1))).sum(axis=1), 3)
            d = (mdp.direction[a] + k) % 4
            reward = R[s, a]
        s_next = mdp.neighbour[s, d]
        trace.append((live, np.full(live.size, t), s, a, d, s_next, reward))
        state[live] = s_next
        length[live] += 1
        live = live[mdp.nonterminal[s_next]]

    columns = [np.concatenate(parts) for parts in zip(*trace)] if trace else [np.zeros(0, int)] * 7
    episode, step_t, step_state, action, direction, next_state, reward = columns
    return Rollouts(
        episode, step_t, step_state, action, direction, next_state, reward,
        length=length,
        final_state=state,
        truncated=mdp.nonterminal[state],
        hold_ms=(np.concatenate(holds) if holds else np.zeros(0)) if timed else None,
    )


def demonstrations_of(mdp: MDP, result: Rollouts) -> Demonstrations:
    """Rollouts as demonstrations (counts N(s, a)), without a file in between."""
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    np.add.at(counts, (result.state, result.action), 1.0)
    # Rollouts number their episodes 0, 1, ... and every one has a first step at t = 0, in order: they are the rows.
    by_episode = episode_matrix(result.episode, result.state * mdp.n_actions + result.action,
                                mdp.n_states * mdp.n_actions)
    first = np.unique(result.episode, return_index=True)[1]
    symbols = mdp.symbols + ("",)
    ends = tuple("step_limit" if cut else symbols[s] for s, cut in zip(result.final_state, result.truncated))
    facts = EpisodeFacts(start=result.state[first], length=result.length[result.length > 0],
                         end=tuple(end for end, n in zip(ends, result.length) if n > 0))
    chosen = mdp.direction[result.action]
    holds = (np.zeros((0, 5)) if result.hold_ms is None else
             hold_steps(result.state, chosen, result.hold_ms, result.direction != chosen, result.episode))
    return Demonstrations(mdp=mdp, counts=counts, files=0, episodes=int(result.length.size),
                          steps=int(result.state.size), by_episode=by_episode, episode_facts=facts,
                          hold_steps=holds)


# The most steps one block of `simulate_to_file` may hold (about 60 bytes each while rolled out).
STEPS_PER_BLOCK = 2_000_000


def session_header(mdp: MDP, *, player: str, seed: int) -> SessionHeader:
    """The header of a simulated session: fixed time, digits input (an expert states its level), or on a time
    world hold input (its holds are exact by construction)."""
    mode = "hold" if mdp.world.care == "time" else "digits"
    return SessionHeader(
        world=mdp.world,
        player=player,
        created=SIMULATED_AT,
        seed=seed,
        input={"mode": mode, "expert": player},
        app_version=app_version(),
    )


def write_rollouts(
    path: str | Path,
    mdp: MDP,
    result: Rollouts,
    *,
    player: str,
    seed: int,
    progress: Callable[[int], None] | None = None,
    header: SessionHeader | None = None,
) -> Path:
    """Write rollouts as a session file (recordings/README.md), never overwriting.

    Args:
        progress: called with the number of episodes written so far, now and then.
        header: the session header to write instead of `session_header(mdp, player, seed)`
            (a simulated study participant's, which carries a ``study`` field).
    """
    header = header or session_header(mdp, player=player, seed=seed)
    with RecordingWriter(path, header, sync_episodes=False) as writer:
        _write_block(writer, mdp, result, first_episode=0, progress=progress)
    return Path(path)


def simulate_to_file(
    path: str | Path,
    mdp: MDP,
    policy: np.ndarray | Chooser,
    *,
    episodes: int,
    seed: int,
    player: str,
    block: int = 10_000,
    progress: Callable[[int], None] | None = None,
) -> Counter[str]:
    """Roll out and write `episodes` episodes, `block` at a time (memory does not grow with `episodes`).

    The episodes are those of one `rollouts` call with `seed` when `episodes <= block`, and the
    same seed always writes the same bytes. The file is built beside `path` and renamed into place
    when whole (`safe_files.built_beside`): a file that cannot be finished, or a kill, leaves none
    under its name (an expert's session cut short would read as complete). Returns how the
    episodes ended ("G", "C", "step limit").

    Raises:
        OSError: the file cannot be written (nothing is left), or `path` exists (`FileExistsError`).
    """
    rng = np.random.default_rng(seed)
    # A block's steps are held in memory: at most STEPS_PER_BLOCK of them, however long episodes may be.
    block = max(1, min(block, STEPS_PER_BLOCK // mdp.world.max_steps))
    ended: Counter[str] = Counter()
    header = session_header(mdp, player=player, seed=seed)
    with built_beside(path) as temporary, RecordingWriter(temporary, header, sync_episodes=False) as writer:
        for first in range(0, episodes, block):
            result = rollouts(mdp, policy, episodes=min(block, episodes - first), rng=rng, first_episode=first)
            counted: Callable[[int], None] | None = (
                None if progress is None else lambda done, first=first: progress(first + done))
            _write_block(writer, mdp, result, first_episode=first, progress=counted)
            ended.update(mdp.symbols[s] if not t else "step limit"
                         for s, t in zip(result.final_state.tolist(), result.truncated.tolist()))
    return ended


def _write_block(
    writer: RecordingWriter,
    mdp: MDP,
    result: Rollouts,
    *,
    first_episode: int,
    progress: Callable[[int], None] | None,
) -> None:
    """Write the episodes of `result`, numbered from `first_episode`, a few thousand lines per write."""
    world = mdp.world
    order = np.lexsort((result.t, result.episode))
    cells = mdp.cells
    steps_of = np.bincount(result.episode, minlength=result.length.size)
    lines: list[Step | EpisodeEnd] = []
    i = 0
    for episode, n_steps in enumerate(steps_of.tolist()):
        score = world.initial_score
        for j in order[i : i + n_steps].tolist():
            if len(lines) >= 5000:
                writer.write_many(lines)
                lines = []
            s, a, s_next = int(result.state[j]), int(result.action[j]), int(result.next_state[j])
            score += float(result.reward[j])
            direction, realised = DIRECTIONS[int(mdp.direction[a])], DIRECTIONS[int(result.direction[j])]
            # On a time world: the exact hold (to the 0.1 ms a recording keeps) and its bin.
            hold = None if result.hold_ms is None else round(float(result.hold_ms[j]), 1)
            lines.append(
                Step.model_construct(
                    episode=first_episode + episode,
                    t=int(result.t[j]),
                    state=cells[s],
                    direction=direction,
                    carefulness=None if hold is not None else int(mdp.carefulness[a]),
                    hold_ms=0.0 if hold is None else hold,
                    hold_exact=hold is not None,
                    bin=None if hold is None else int(mdp.carefulness[a]) - 1,
                    next_state=cells[s_next],
                    slipped=realised != direction,
                    reward=float(result.reward[j]),
                    score=score,
                    realised=realised,
                )
            )
        i += n_steps
        final = int(result.final_state[episode])
        truncated = bool(result.truncated[episode])
        score += 0.0 if truncated else float(mdp.R_S[final])
        lines.append(
            EpisodeEnd(
                episode=first_episode + episode,
                outcome="step_limit" if truncated else "terminal",
                terminal_symbol=None if truncated else mdp.symbols[final],
                steps=int(n_steps),
                return_=score - world.initial_score,
                score=score,
            )
        )
        if progress is not None and (episode + 1) % 500 == 0:
            progress(episode + 1)
    writer.write_many(lines)
    if progress is not None:
        progress(result.length.size)


def app_version() -> str:
    """The installed careful's version, for a simulated session's header."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("careful")
    except PackageNotFoundError:
        return "0+unknown"
