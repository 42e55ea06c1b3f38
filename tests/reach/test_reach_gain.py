"""The expected gain of a reach against an independent route (Monte Carlo endpoints scored by the world's
own circles), the grid maximiser's behaviour across penalties, and the soft-optimal player's choices."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from irl_core.reach.gain import best_choice, choice_grid, expected_gain, hit_chances, soft_choice_log_probabilities
from irl_core.reach.players import HandReacher, OptimalReacher, SoftReacher
from irl_core.worlds.reach import REACH_WORLDS

WORLD = REACH_WORLDS["reach"]
GRID = choice_grid(WORLD)


def monte_carlo_gain(world, aim, duration, n, rng):
    """Score n simulated reaches circle by circle (points add where circles overlap), less the time cost."""
    aim = np.asarray(aim, dtype=float)
    ends = aim + rng.normal(0.0, float(world.sd(aim, duration)), (n, 2))
    scores = np.zeros(n)
    for region in world.regions:
        scores += region.points * (np.hypot(*(ends - region.centre).T) <= region.radius)
    return scores.mean() - world.cost_per_second * duration / 1000, scores.std() / np.sqrt(n)


@pytest.mark.parametrize(("aim", "duration"), [((200, 80), 300), ((215, 85), 900), ((184, 80), 150),
                                               ((150, 120), 1500), ((260, 40), 600)])
def test_expected_gain_agrees_with_monte_carlo(aim, duration):
    rng = np.random.default_rng(7)
    simulated, standard_error = monte_carlo_gain(WORLD, aim, duration, 200_000, rng)
    assert float(expected_gain(WORLD, aim, duration)) == pytest.approx(simulated, abs=4 * standard_error + 1e-9)


def test_a_reach_aimed_at_a_centre_hits_as_the_rayleigh_law_says():
    # Aimed at the circle's centre, the distance to it is Rayleigh: P(hit) = 1 - exp(-R^2 / (2 sd^2)).
    aim, duration = np.array([200.0, 80.0]), 500.0
    sd = float(WORLD.sd(aim, duration))
    assert hit_chances(WORLD, aim, duration)[0] == pytest.approx(1 - np.exp(-(32 / sd) ** 2 / 2))


@settings(max_examples=40, deadline=None)
@given(st.floats(0, 400), st.floats(0, 300), st.floats(150, 1500))
def test_hit_chances_are_chances(x, y, duration):
    hits = hit_chances(WORLD, (x, y), duration)
    assert np.all((hits >= 0) & (hits <= 1))


def test_the_maximiser_aims_away_from_a_worse_penalty_and_takes_longer():
    choices = {}
    for name in ("reach-mild", "reach", "reach-severe"):
        world = REACH_WORLDS[name]
        grid = choice_grid(world)
        choices[name] = best_choice(grid, list(world.points.values()))
    xs = [choices[name][0][0] for name in ("reach-mild", "reach", "reach-severe")]
    durations = [choices[name][1] for name in ("reach-mild", "reach", "reach-severe")]
    # The penalty is on the left: the worse it is, the further right the aim, and no hastier.
    assert 200 <= xs[0] < xs[1] < xs[2]
    assert durations[0] <= durations[1] <= durations[2]


def test_the_grid_best_beats_aiming_at_the_target_by_monte_carlo():
    world = REACH_WORLDS["reach-severe"]
    aim, duration = best_choice(choice_grid(world), list(world.points.values()))
    rng = np.random.default_rng(3)
    best, error_best = monte_carlo_gain(world, aim, duration, 100_000, rng)
    naive, error_naive = monte_carlo_gain(world, (200, 80), duration, 100_000, rng)
    assert best - naive > 4 * (error_best + error_naive)


def test_soft_choices_sum_to_one_and_concentrate_on_the_best_as_beta_grows():
    grid = choice_grid(WORLD)
    points = list(WORLD.points.values())
    for beta in (0.01, 1.0, 100.0):
        log_p = soft_choice_log_probabilities(grid, points, beta)
        assert np.exp(log_p).sum() == pytest.approx(1.0)
    assert np.exp(soft_choice_log_probabilities(grid, points, 1e4)).max() > 0.99


def test_the_reachers_choose_on_the_grid_and_scatter_by_the_spread_law():
    grid = choice_grid(WORLD)
    points = np.array(list(WORLD.points.values()))
    rng = np.random.default_rng(0)
    optimal = OptimalReacher(grid, points)
    assert all(np.array_equal(optimal.choose(rng)[0], best_choice(grid, points)[0]) for _ in range(3))
    soft = SoftReacher(grid, points, beta=1.0, aim_sd=0.0, extent=WORLD.field)
    chosen = [soft.choose(rng) for _ in range(200)]
    lattice = grid.aims.tolist()
    assert all(aim.tolist() in lattice for aim, _ in chosen[:20])  # without aim noise, the grid's own aims
    assert len({duration for _, duration in chosen}) > 1
    aim, duration = np.array([200.0, 80.0]), 400.0
    ends = np.array([WORLD.endpoint(aim, duration, rng) for _ in range(4000)])
    assert ends.std(axis=0) == pytest.approx([float(WORLD.sd(aim, duration))] * 2, rel=0.06)


@settings(max_examples=40, deadline=None)
@given(lapse=st.floats(0, 1), aim_sd=st.floats(0, 80), weber=st.floats(0, 3), seed=st.integers(0, 2**32 - 1))
def test_the_hand_always_reaches_inside_the_field_and_the_limits(lapse, aim_sd, weber, seed):
    hand = HandReacher(GRID, np.array(list(WORLD.points.values())), limits=(WORLD.min_ms, WORLD.max_ms),
                       extent=WORLD.field, lapse=lapse, aim_sd=aim_sd, weber=weber)
    rng = np.random.default_rng(seed)
    for _ in range(30):
        aim, duration = hand.choose(rng)
        assert np.all((aim >= 0) & (aim <= WORLD.field)) and WORLD.min_ms <= duration <= WORLD.max_ms
