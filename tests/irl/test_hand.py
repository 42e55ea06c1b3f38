"""The hand from calibration trials: a known bias and noise recovered, and the people fit holding them."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from irl_core.irl import FitOptions, fit
from irl_core.irl.people.hand import hand_from_trials, trials_log_likelihood
from irl_core.irl.people.likelihood import level_kernel
from irl_core.players.experts import demonstrations_of, rollouts
from irl_core.players.person_like import motor_trials, person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def test_the_kernel_with_a_bias_is_centred_on_the_shifted_level():
    K, _ = level_kernel(14, 0.6, -2.0)
    assert np.allclose(K.sum(axis=1), 1.0)
    assert K[7].argmax() == 5  # intended 8, produced 6
    assert K[0].argmax() == 0  # nothing below level 1: the row renormalises on 1..L


def test_trials_recover_a_known_bias_and_noise():
    rng = np.random.default_rng(0)
    levels, bias, sigma = 14, -2.0, 1.0
    target = rng.integers(4, 13, 400)
    K, _ = level_kernel(levels, sigma, bias)
    produced = np.array([rng.choice(levels, p=K[c - 1]) + 1 for c in target])
    hand = hand_from_trials(np.column_stack([target, produced]), levels)
    assert hand.bias == pytest.approx(bias, abs=0.15)
    assert hand.sigma == pytest.approx(sigma, abs=0.15)
    trials = np.column_stack([target, produced])
    best = trials_log_likelihood(trials, levels, bias=hand.bias, sigma=hand.sigma)
    assert best >= trials_log_likelihood(trials, levels, bias=0.0, sigma=hand.sigma)


def test_no_trials_and_out_of_range_trials_are_refused():
    with pytest.raises(ValueError, match="at least one"):
        hand_from_trials(np.zeros((0, 2)), 5)
    with pytest.raises(ValueError, match="outside 1..5"):
        hand_from_trials(np.array([[6, 2]]), 5)


def test_the_people_fit_holds_the_hasty_players_bias_from_its_trials():
    """hasty under-holds by two levels; with ten calibration trials the fit's hand is theirs, said in a note."""
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    player = person_like(mdp, "hasty")
    rng = np.random.default_rng(4)
    demos = demonstrations_of(mdp, rollouts(mdp, player.choose, episodes=12, rng=rng))
    trials = motor_trials(player, np.arange(10) % 12 + 3, mdp.levels, rng)
    with_trials = dataclasses.replace(demos, calibration=trials)
    result = fit(with_trials, FitOptions(method="maxent", player_model="person", seed=1))
    assert result.player is not None and result.player.bias == pytest.approx(-2.0, abs=0.8)
    assert "hand_calibrated" in {note.code for note in result.notes}
    plain = fit(demos, FitOptions(method="maxent", player_model="person", seed=1))
    assert plain.player is not None and plain.player.bias == 0.0


def test_a_quick_slice_of_the_bench_hasty_on_mud_with_ten_calibration_trials():
    """bench_people's hasty run on mud (seed 0) with and without a calibration block of 10 (points only, no
    intervals): with the trials the rewards are in order and the cliff and the goal are nearer their truth
    (-1000, 100) than without, where the under-holding reads as a smaller cliff and a goal near zero."""
    from bench.bench_people import one_run

    options = FitOptions(method="auto", intervals=False, seed=0)
    plain, calibrated = (one_run("hasty", "mud", 0, options, calibration=n) for n in (0, 10))
    assert calibrated.error is None and calibrated.ordered, calibrated
    for symbol, truth in (("C", -1000.0), ("G", 100.0)):
        assert abs(np.log(calibrated.value[symbol] / truth)) < abs(np.log(abs(plain.value[symbol] / truth))), symbol


def hasty_on_mud_with_trials(episodes: int = 12, trials: int = 10):
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    player = person_like(mdp, "hasty")
    rng = np.random.default_rng(4)
    demos = demonstrations_of(mdp, rollouts(mdp, player.choose, episodes=episodes, rng=rng))
    return dataclasses.replace(demos, calibration=motor_trials(player, np.arange(trials) % 12 + 3, mdp.levels, rng))


def test_each_resample_holds_the_hand_of_its_own_draw_of_the_trials():
    """The bootstrap's refits hold a hand measured again from each resample's draw of the trials: over many
    resamples its bias spreads as the trials' mean error does (sd / sqrt(n)), and a resample's draw is fixed by
    the seed and its number, so any worker refits it alike."""
    from irl_core.irl.choices import PLAYER_MODELS, Player
    from irl_core.irl.people.fit import PlayerRefit
    from irl_core.irl.qmap import build_unknowns

    demos = hasty_on_mud_with_trials(trials=30)
    mdp, trials = demos.mdp, demos.calibration
    hand = hand_from_trials(trials, mdp.levels)
    refit = PlayerRefit(mdp, build_unknowns(mdp, reward_cells="special", tie=True), PLAYER_MODELS["person"].with_hand(
        hand.known()), 1000.0, (np.zeros(3), Player(1.0)), trials=trials, seed=5)
    biases = np.array([refit.model_for(r).known_hand[0] for r in range(300)])
    error = trials[:, 1] - trials[:, 0]
    assert biases.mean() == pytest.approx(hand.bias, abs=0.1)
    assert biases.std() == pytest.approx(error.std() / np.sqrt(len(trials)), rel=0.3)
    assert refit.model_for(17) == refit.model_for(17) != refit.model_for(18)
    assert dataclasses.replace(refit, trials=None).model_for(17) == refit.model  # no trials: the hand as fitted


def test_intervals_with_calibration_trials_carry_the_hands_error_and_do_not_depend_on_the_workers(monkeypatch):
    """hasty fitted with the `naive` model (the one the bench's fits of hasty choose: a player who does not plan
    for the hand, so the hand's bias sets the rewards' scale): the goal's interval with the trials drawn again in
    each resample holds the one with the hand held as measured, and is wider by a third; one worker or two, the
    same intervals."""
    from irl_core.irl.people.fit import PlayerRefit

    demos = hasty_on_mud_with_trials()
    options = FitOptions(method="maxent", player_model="naive", intervals=True, resamples=40, seed=2, tie=True)
    drawn = fit(demos, options, workers=1)
    assert fit(demos, options, workers=2).intervals.tolist() == drawn.intervals.tolist()
    monkeypatch.setattr(PlayerRefit, "model_for", lambda self, resample: self.model)  # the hand held as measured
    held = fit(demos, options, workers=1)
    goal = drawn.unknowns.labels.index("G")
    (low, high), (held_low, held_high) = drawn.intervals[goal], held.intervals[goal]
    assert low <= held_low and held_high <= high and high - low > 4 / 3 * (held_high - held_low), (drawn.intervals, held.intervals)


def test_the_fit_says_the_trials_were_drawn_again_only_where_they_were():
    """The note `hand_resampled` is there for a model that holds the trials' hand and has intervals; not for a
    model without a hand (its resamples have no hand to measure), nor without intervals."""
    demos = hasty_on_mud_with_trials()

    def codes(**options) -> set[str]:
        result = fit(demos, FitOptions(method="maxent", resamples=20, seed=0, tie=True, **options), workers=1)
        return {note.code for note in result.notes}

    assert "hand_resampled" in codes(player_model="naive", intervals=True)
    assert "hand_resampled" not in codes(player_model="ends", intervals=True)
    assert "hand_resampled" not in codes(player_model="naive", intervals=False)



@pytest.mark.parametrize("model_name", ["hand", "person"])
def test_a_precise_biased_hand_gives_a_finite_likelihood(model_name):
    # A calibration block can measure a hand so precise and so biased that some levels are never produced (their
    # kernel column underflows to 0): the likelihood of the moves recorded was NaN there, and the fit's search
    # broke on it (bootstrap resamples of a study report with a block).
    from irl_core.irl.choices import PLAYER_MODELS, Player
    from irl_core.irl.people.likelihood import _times, log_likelihood
    from irl_core.irl.qmap import build_unknowns

    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    K, _ = level_kernel(mdp.levels, 0.05, -5.4)
    assert (K[:, -1] == 0).all(), "the top level is never produced by this hand"
    rng = np.random.default_rng(0)
    counts = demonstrations_of(mdp, rollouts(mdp, person_like(mdp, "reckless").choose, episodes=5, rng=rng)).counts
    model = PLAYER_MODELS[model_name].with_hand((-5.4, 0.05))
    player = Player(1.0, 0.05, 0.1 if model.lapses else 0.0, -5.4)
    unknowns = build_unknowns(mdp, tie=True)
    got = log_likelihood(mdp, counts, unknowns.state_rewards(unknowns.true_theta(mdp)), model=model, player=player)
    assert np.isfinite(got.value) and np.isfinite(got.R_S).all()
    if not model.lapses:  # the same sum by plain arithmetic: the realised policy is the intended one times K
        realised = _times(got.plan.intended, K)
        seen = mdp.nonterminal[:, None] & (counts > 0)
        assert got.value == pytest.approx(float((counts[seen] * np.log(realised[seen])).sum()), rel=1e-9)
