"""Which player models `--union` joins: those the chosen model does not beat beyond their noise in the paired
per-episode test of held-out log likelihoods (`significantly_better`, as for the planning rival), checked
against the test's own arithmetic on hand-made per-episode scores."""

import numpy as np

from irl_core.irl.people.choice import SIGNIFICANT_Z, ModelChoice, close_models, planning_rival


def choice_of(per_episode, chosen):
    fits = {name: name for name in per_episode}  # stand-ins: close_models hands back the fits it picks
    return ModelChoice(chosen, {n: float(v.sum()) for n, v in per_episode.items()}, 5, fits, "hand-made",
                       {n: np.asarray(v, dtype=float) for n, v in per_episode.items()})


def paired_z(first, second):
    difference = np.asarray(first) - np.asarray(second)
    return difference.mean() / (difference.std(ddof=1) / np.sqrt(difference.size))


def test_close_models_are_those_within_the_paired_tests_noise_of_the_chosen_one():
    rng = np.random.default_rng(3)
    chosen = rng.normal(-10, 1, size=30)
    per_episode = {
        "naive": chosen,
        "person": chosen - rng.normal(0.05, 0.5, size=30),  # a hair worse, within the noise
        "hand": chosen - rng.normal(2.0, 0.5, size=30),  # worse on every episode: told apart
        "ends": chosen - np.r_[np.full(29, 0.01), 300.0],  # 300 nats worse, all in one episode: not told apart
    }
    expected = [n for n in per_episode if n != "naive" and paired_z(chosen, per_episode[n]) <= SIGNIFICANT_Z]
    assert expected == ["person", "ends"]
    assert list(close_models(choice_of(per_episode, "naive"))) == expected
    assert planning_rival(choice_of(per_episode, "naive")) == "person"


def test_no_held_out_choice_joins_nothing():
    choice = ModelChoice("ends", None, 0, {"ends": "ends"}, "too few episodes")
    assert close_models(choice) == ()
