"""Noisy experts (docs/answers.md): beta estimated with the rewards, method auto, and bootstrap intervals."""

import numpy as np
import pytest

from irl_core.irl import FitOptions, fit
from irl_core.irl.intervals.bootstrap import interval, resample_weights
from irl_core.irl.maxent import fit_maxent, log_likelihood
from irl_core.irl.qmap import build_unknowns
from irl_core.players.experts import boltzmann_policy, demonstrations_of, optimal_policy, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def boltzmann(name, beta, episodes, seed):
    mdp = build_mdp(BUILTIN_WORLDS[name])
    return demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=beta), episodes=episodes, seed=seed))


def test_beta_auto_recovers_beta_and_the_rewards_at_2000_episodes():
    demos = boltzmann("mud", 0.5, 2000, seed=3)
    mdp = demos.mdp
    unknowns = build_unknowns(mdp, tie=True)
    solution = fit_maxent(mdp, unknowns, demos.counts, beta="auto", rmax=5000.0)
    assert solution.beta == pytest.approx(0.5, rel=0.25)
    truth = unknowns.true_theta(mdp)
    np.testing.assert_allclose(solution.theta, truth, rtol=0.10)
    at_truth, _, _ = log_likelihood(mdp, demos.counts, mdp.R_S, beta=0.5)
    assert solution.mean_log_likelihood * demos.counts.sum() >= at_truth - 1e-9


def test_auto_picks_lp_for_an_optimal_expert_and_maxent_for_a_noisy_one():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    optimal = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=30, seed=0))
    chosen = fit(optimal, method="auto")
    assert chosen.method == "lp" and chosen.beta is None and "auto chose lp" in str(chosen.notes[0])
    noisy = boltzmann("mud", 0.5, 30, seed=0)
    chosen = fit(noisy, method="auto", tie=True)
    assert chosen.method == "maxent" and chosen.beta_auto and "auto chose maxent" in str(chosen.notes[0])
    assert chosen.to_json()["options"]["beta"] == chosen.beta and chosen.to_json()["options"]["beta_auto"] is True


def test_one_carefulness_level_says_the_scale_is_not_identified_and_reads_rewards_relative_to_the_goal():
    result = fit(boltzmann("mud-simple", 0.5, 50, seed=0), method="maxent", beta="auto", tie=True, rmax=5000.0)
    assert "scale_not_identified" in [note.code for note in result.notes]
    assert result.reward_unit == "relative to G" and result.to_json()["reward_unit"] == "relative to G"
    assert result.theta[np.array(result.unknowns.symbols) == "G"].size == 0  # held at 1, not fitted
    rows = result.mdp.world.layout.split("\n")
    (goal,) = [(r, c) for r, row in enumerate(rows) for c, symbol in enumerate(row) if symbol == "G"]
    assert result.reward_grid[goal] == 1.0
    assert set(result.to_json()["move"]) == {"reward", "interval"}  # a move's cost, relative to G


def test_bootstrap_intervals_are_reproducible_and_widen_with_confidence():
    demos = boltzmann("mud", 0.5, 40, seed=1)
    options = FitOptions(method="maxent", beta="auto", tie=True, rmax=5000.0, intervals=True, resamples=40)
    seen = []
    first = fit(demos, options, workers=2, progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert first.interval_kind == "confidence" and seen[-1] == ("resamples", 40, 40)
    again = fit(demos, options, workers=1)
    np.testing.assert_allclose(first.intervals, again.intervals, rtol=1e-4)  # the workers do not matter
    low, high = first.intervals.T
    assert (low <= first.theta + 1e-6).all() and (first.theta <= high + 1e-6).all()
    wider = fit(demos, options, confidence=0.99, workers=1)
    assert (wider.intervals[:, 0] <= low + 1e-9).all() and (wider.intervals[:, 1] >= high - 1e-9).all()
    other = fit(demos, options, seed=1, workers=1)
    assert not np.allclose(other.intervals, first.intervals)


def test_percentile_and_basic_intervals_by_hand():
    estimates = np.arange(1.0, 101.0)[:, None]  # 1..100
    percentile = interval(estimates, np.array([40.0]), confidence=0.9, variant="percentile")
    np.testing.assert_allclose(percentile, [[np.quantile(estimates, 0.05), np.quantile(estimates, 0.95)]])
    basic = interval(estimates, np.array([40.0]), confidence=0.9, variant="basic")
    np.testing.assert_allclose(basic, [[80 - percentile[0, 1], 80 - percentile[0, 0]]])
    weights = resample_weights(7, 5, seed=0)
    assert weights.shape == (5, 7) and (weights.sum(axis=1) == 7).all()


def test_one_episode_gives_no_interval_and_says_why():
    demos = boltzmann("mud", 0.5, 1, seed=0)
    result = fit(demos, method="maxent", intervals=True, tie=True)
    assert result.intervals is None and result.interval_kind is None
    assert any("one episode" in str(note) for note in result.notes)


def test_refits_that_never_move_give_no_confidence_interval():
    """maxent with beta estimated on an optimal expert: the likelihood keeps rising with beta and
    is flat around the estimate, so every resample's refit stays at the full fit (zero-width
    intervals that said "95% confidence"); a noisy expert's refits spread and keep their intervals."""
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    optimal = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=40, seed=0))
    flat = fit(optimal, method="maxent", beta="auto", intervals=True, resamples=20, workers=1)
    assert flat.intervals is None and flat.interval_kind is None
    assert any(str(note).startswith("intervals not computed: every resample's refit stayed") for note in flat.notes)
    noisy = fit(boltzmann("mud", 0.5, 40, seed=0), method="maxent", beta="auto", intervals=True, resamples=20,
                workers=1)
    assert noisy.interval_kind == "confidence" and (np.diff(noisy.intervals, axis=1) > 1.0).all()
    assert not any("stayed" in str(note) for note in noisy.notes)


def test_when_every_resample_fails_to_refit_the_fit_says_so_and_claims_no_interval(monkeypatch):
    """A refit that raises on every resample (a solver failing, a refitter built wrong) leaves nothing to take
    quantiles of: no intervals and a note saying why, not a crash or intervals from nothing."""
    from irl_core.irl.intervals.bootstrap import Refit

    def fails(self, counts, *, resample=0):
        raise RuntimeError("no refit")

    monkeypatch.setattr(Refit, "__call__", fails)
    options = FitOptions(method="maxent", player_model="boltzmann", intervals=True, resamples=20, seed=0)
    result = fit(boltzmann("mud", 1.0, 20, 0), options, workers=1)
    assert result.intervals is None
    (note,) = [note for note in result.notes if note.code == "intervals_not_computed"]
    assert "every one of the 20 resamples failed to refit" in note.sentence
