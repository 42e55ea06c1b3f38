"""Rewards no recorded action can lead into: held at -rmax by the people fit, released where the likelihood
rises upward, and reported with the upper bound the data give (checked by evaluating the likelihood)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.worlds import cliff_world
from irl_core.irl.choices import PLAYER_MODELS, Player, PlayerModel
from irl_core.irl.people.fit import fit_player
from irl_core.irl.people.held import BOUND_STEPS, FLAT_DROP, bound_groups, bounds_of, unreached, upper_bound
from irl_core.irl.people.likelihood import log_likelihood
from irl_core.irl.qmap import Unknowns, build_unknowns
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.support.executor import map_calls
from irl_core.worlds.mdp import MDP, build_mdp

RMAX = 1000.0


def held_upper_bounds(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, *, theta: np.ndarray, model: PlayerModel,
                      player: Player, held: np.ndarray, rmax: float, V0: np.ndarray | None = None,
                      workers: int = 1) -> np.ndarray:
    """(k,) for each held unknown (`held`, at -rmax in `theta`), the highest value to which it can be raised, the
    others kept, before the log likelihood falls by `FLAT_DROP` (NaN elsewhere): its interval is [-rmax, that].

    One by one up to `MAX_ONE_BY_ONE` held unknowns (on up to `workers` processes); beyond, all together (a common
    bound, at most as high as each's own: the interval is then narrower than one by one would give, said by
    `jointly`)."""
    counts = np.asarray(counts, dtype=float)
    groups = bound_groups(held)
    fitted = log_likelihood(mdp, counts, unknowns.state_rewards(theta), model=model, player=player, V0=V0,
                            gradient=False)
    shared = (mdp, unknowns, counts, theta, model, player, rmax, fitted.value, fitted.plan.V)
    bounds = map_calls(upper_bound, [(group,) for group in groups], shared=shared, workers=workers)
    return bounds_of(unknowns.k, groups, bounds)



@pytest.fixture(scope="module")
def top_rows():
    """A 5x6 cliff world whose recordings keep to its top two rows: no recorded action can reach the cliff."""
    mdp = build_mdp(cliff_world(5, 6))
    demos = demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=1.0), episodes=40, seed=0))
    rows = np.array([mdp.cells[s][0] if s < len(mdp.cells) else -1 for s in range(mdp.n_states)])
    counts = demos.counts * ((rows >= 0) & (rows <= 1))[:, None]
    return mdp, build_unknowns(mdp), counts


def test_the_unreached_rewards_are_exactly_those_no_recorded_action_can_step_into(top_rows):
    mdp, unknowns, counts = top_rows
    held = unreached(mdp, unknowns, counts)
    # Independently: a cell one step from a recorded state is in row 2 at most; every special cell is in row 4.
    assert held.all() and unknowns.k == 5
    full = unreached(mdp, unknowns, counts + 1.0)  # every action recorded somewhere: every cell can be reached
    assert not full.any()


def test_a_held_reward_stays_at_minus_rmax_and_the_fit_converges(top_rows):
    mdp, unknowns, counts = top_rows
    solution = fit_player(mdp, unknowns, counts, model=PLAYER_MODELS["ends"], rmax=RMAX)
    assert solution.converged
    held = solution.held
    assert held.any()
    np.testing.assert_array_equal(solution.theta[held], -RMAX)


def test_a_held_rewards_upper_bound_is_where_the_likelihood_has_fallen_by_the_drop(top_rows):
    mdp, unknowns, counts = top_rows
    model = PLAYER_MODELS["ends"]
    solution = fit_player(mdp, unknowns, counts, model=model, rmax=RMAX)
    upper = held_upper_bounds(mdp, unknowns, counts, theta=solution.theta, model=model, player=solution.player,
                              held=solution.held, rmax=RMAX)

    def ll(theta):
        return log_likelihood(mdp, counts, unknowns.state_rewards(theta), model=model, player=solution.player,
                              gradient=False).value

    best = ll(solution.theta)
    step = 2 * RMAX / 2**BOUND_STEPS
    for j in np.flatnonzero(solution.held):
        at, past = solution.theta.copy(), solution.theta.copy()
        at[j], past[j] = upper[j], upper[j] + step
        assert best - ll(at) < FLAT_DROP
        assert upper[j] >= RMAX - step or best - ll(past) >= FLAT_DROP


def test_holding_finds_a_likelihood_at_least_as_high_as_the_free_search(top_rows):
    # The held value is the box's maximum for those rewards, not a shortcut that costs likelihood.
    mdp, unknowns, counts = top_rows
    free = fit_player(mdp, unknowns, counts, model=PLAYER_MODELS["ends"], rmax=RMAX, hold=False)
    held = fit_player(mdp, unknowns, counts, model=PLAYER_MODELS["ends"], rmax=RMAX)
    assert held.mean_log_likelihood >= free.mean_log_likelihood - 1e-9


def test_the_checks_side_by_side_are_each_functions_own_answer(top_rows):
    # people_checks runs the held bounds, the one-sided and combination checks and the fit check as one batch on
    # the fit's processes: each answer must be what its own function gives, on one process or two.
    from irl_core.irl.fit_check import fit_check
    from irl_core.irl.people.checks import people_checks
    from irl_core.irl.people.flat import flat_toward_bound
    from irl_core.irl.people.laplace import pinned_together

    mdp, unknowns, counts = top_rows
    solution = fit_player(mdp, unknowns, counts, model=PLAYER_MODELS["ends"], rmax=RMAX)
    demos = demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=1.0), episodes=12, seed=3))
    episodes = (demos.by_episode, demos.episode_facts)
    flat = flat_toward_bound(mdp, unknowns, counts, solution, rmax=RMAX)
    own = {
        "held": held_upper_bounds(mdp, unknowns, counts, theta=solution.theta, model=solution.model,
                                  player=solution.player, held=solution.held, rmax=RMAX, V0=solution.V1),
        "flat": flat,
        "together": pinned_together(mdp, unknowns, counts, solution, rmax=RMAX, settled=solution.held | (flat != 0)),
        "check": fit_check(mdp, solution.plan.observed, *episodes, seed=7),
    }
    assert solution.held.any() and own["check"].statistics
    for workers in (1, 2):
        checks = people_checks(mdp, unknowns, counts, solution, rmax=RMAX, episodes=episodes, seed=7, workers=workers)
        np.testing.assert_array_equal(checks.held_upper, own["held"])
        np.testing.assert_array_equal(checks.flat, own["flat"])
        np.testing.assert_array_equal(checks.together, own["together"])
        assert checks.fit_check == own["check"]
    assert people_checks(mdp, unknowns, counts, solution, rmax=RMAX, episodes=None, seed=7).fit_check is None
