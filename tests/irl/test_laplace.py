"""Laplace intervals for a model of people: the curvature against second differences of the likelihood
itself (an independent route), and intervals that hold what the curvature says."""

import numpy as np
import pytest

from irl_core.irl.choices import Player, player_model
from irl_core.irl.people.choice import fit_given_model
from irl_core.irl.people.laplace import covariance, hessian, laplace_intervals, variables
from irl_core.irl.people.likelihood import log_likelihood
from irl_core.irl.qmap import build_unknowns
from irl_core.players.experts import demonstrations_of, rollouts
from irl_core.players.person_like import person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

RMAX = 5000.0


@pytest.fixture(scope="module")
def fitted():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    unknowns = build_unknowns(mdp, tie=True)
    counts = demonstrations_of(mdp, rollouts(mdp, person_like(mdp, "loose").choose, episodes=10, seed=0)).counts
    fit = fit_given_model(mdp, unknowns, counts, model=player_model("person"), rmax=RMAX)
    return mdp, unknowns, counts, fit


def _ll(mdp, unknowns, counts, fit, z):
    k = unknowns.k
    player = Player(float(np.exp(z[k])), float(np.exp(z[k + 1])), float(1 / (1 + np.exp(-z[k + 2]))))
    return log_likelihood(mdp, counts, unknowns.state_rewards(z[:k]), model=fit.model, player=player, V0=fit.V1,
                          gradient=False).value


def test_the_hessian_of_the_exact_gradient_matches_second_differences_of_the_likelihood(fitted):
    mdp, unknowns, counts, fit = fitted
    z, free = variables(fit)
    H = hessian(mdp, unknowns, counts, fit, free=free)
    for j in np.flatnonzero(free):
        h = 1e-3 * max(1.0, abs(z[j]))
        up, down = z.copy(), z.copy()
        up[j] += h
        down[j] -= h
        second = (_ll(mdp, unknowns, counts, fit, up) - 2 * _ll(mdp, unknowns, counts, fit, z)
                  + _ll(mdp, unknowns, counts, fit, down)) / h**2
        assert H[j, j] == pytest.approx(second, rel=2e-3, abs=1e-6)


def test_the_hessian_is_symmetric_and_the_fit_a_maximum(fitted):
    mdp, unknowns, counts, fit = fitted
    _, free = variables(fit)
    H = hessian(mdp, unknowns, counts, fit, free=free)[np.ix_(free, free)]
    assert np.allclose(H, H.T, rtol=1e-3, atol=1e-6 * np.abs(H).max())
    assert np.linalg.eigvalsh((H + H.T) / 2).max() < 0


def test_the_reward_scale_interval_is_the_estimate_plus_or_minus_z_standard_errors(fitted):
    mdp, unknowns, counts, fit = fitted
    se = np.sqrt(np.diag(covariance(mdp, unknowns, counts, fit))[: unknowns.k])
    intervals = laplace_intervals(mdp, unknowns, counts, fit, rmax=RMAX, scale="reward")
    inside = np.isfinite(se) & (np.abs(fit.theta) + 2 * se < RMAX)
    assert inside.any()
    assert np.allclose(intervals[inside, 0], fit.theta[inside] - 1.959964 * se[inside], rtol=1e-5)
    assert np.allclose(intervals[inside, 1], fit.theta[inside] + 1.959964 * se[inside], rtol=1e-5)


def test_the_log_scale_interval_holds_the_estimate_and_keeps_its_sign(fitted):
    mdp, unknowns, counts, fit = fitted
    intervals = laplace_intervals(mdp, unknowns, counts, fit, rmax=RMAX)
    assert np.all(intervals[:, 0] <= fit.theta) and np.all(fit.theta <= intervals[:, 1])
    cliff = unknowns.symbols.index("C")
    assert intervals[cliff, 1] < 0  # the cliff is bad, and the interval says so
    # It stretches toward the bound: further below the estimate than above it.
    assert fit.theta[cliff] - intervals[cliff, 0] > intervals[cliff, 1] - fit.theta[cliff]


def test_an_unknown_scale_is_refused(fitted):
    mdp, unknowns, counts, fit = fitted
    with pytest.raises(ValueError, match="scale"):
        laplace_intervals(mdp, unknowns, counts, fit, rmax=RMAX, scale="logit")


def test_a_pool_of_people_who_differ_gets_a_wider_interval_than_one_who_plays_it_all():
    # Cluster-robust: three careful people and a reckless one differ more than their episodes do.
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    unknowns = build_unknowns(mdp, tie=True)
    groups = np.stack([demonstrations_of(mdp, rollouts(mdp, person_like(mdp, kind).choose, episodes=8, seed=i)).counts
                       for i, kind in enumerate(["loose", "loose", "timed", "reckless"])])
    counts = groups.sum(axis=0)
    fit = fit_given_model(mdp, unknowns, counts, model=player_model("person"), rmax=RMAX)
    alone = laplace_intervals(mdp, unknowns, counts, fit, rmax=RMAX, scale="reward")
    pooled = laplace_intervals(mdp, unknowns, counts, fit, rmax=RMAX, scale="reward", groups=groups)
    cliff = unknowns.symbols.index("C")
    assert np.diff(pooled[cliff]) > 1.5 * np.diff(alone[cliff])
    assert np.all(np.diff(pooled, axis=1) >= np.diff(alone, axis=1))


def test_two_unknowns_of_one_cell_are_pinned_only_together_and_reach_the_bound_along_their_difference():
    # Two unknowns that are the reward of the same cell: the data fix their sum, never each one. A third
    # pinned reward (the goal) must not be named.
    import dataclasses

    import scipy.sparse as sp

    from irl_core.irl.people.fit import fit_player
    from irl_core.irl.people.laplace import pinned_together

    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    tied = build_unknowns(mdp, tie=True)
    mud = tied.labels.index("U")
    basis = sp.hstack([tied.basis, tied.basis[:, mud]], format="csr")
    unknowns = dataclasses.replace(tied, labels=(*tied.labels, "U again"), basis=basis,
                                   weight=np.append(tied.weight, tied.weight[mud]), symbols=(*tied.symbols, "U"))
    counts = demonstrations_of(mdp, rollouts(mdp, person_like(mdp, "loose").choose, episodes=20, seed=1)).counts
    rmax = 100.0
    fit = fit_player(mdp, unknowns, counts, model=player_model("boltzmann"), rmax=rmax)
    assert np.abs(fit.theta).max() < rmax  # inside the box, where the check looks
    ranges = pinned_together(mdp, unknowns, counts, fit, rmax=rmax, settled=np.zeros(unknowns.k, dtype=bool))
    named = [label for label, (low, _) in zip(unknowns.labels, ranges) if not np.isnan(low)]
    assert named == ["U", "U again"]
    # Along the difference the likelihood does not change at all: they move until one of them meets -rmax, the
    # other then at their sum + rmax (the sum is negative: mud).
    total = fit.theta[mud] + fit.theta[-1]
    for j in (mud, unknowns.k - 1):
        assert ranges[j, 0] <= fit.theta[j] <= ranges[j, 1]
        np.testing.assert_allclose(ranges[j], [-rmax, total + rmax], atol=0.1)


def test_a_reward_pinned_only_in_combination_is_named_and_its_interval_holds_its_range(monkeypatch):
    # The fit's wiring: whatever `pinned_together` finds is named in the note and held by the bootstrap's interval,
    # whose refits, started where the fit stopped, would not move along the flat combination.
    from irl_core.irl import FitOptions, fit
    from irl_core.irl.people import checks as people_checks

    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, person_like(mdp, "loose").choose, episodes=12, seed=0))
    options = FitOptions(method="maxent", player_model="ends", intervals=True, resamples=20, seed=0, tie=True)
    plain = fit(demos, options, workers=1)
    mud = plain.unknowns.labels.index("U")
    assert "pinned_together" not in {note.code for note in plain.notes}
    assert plain.intervals[mud, 0] > -300 or plain.intervals[mud, 1] < 300  # the check below can fail

    def pinned(mdp, unknowns, counts, fit, *, rmax, settled):
        out = np.full((unknowns.k, 2), np.nan)
        out[mud] = [-300.0, 300.0]
        return out

    monkeypatch.setattr(people_checks, "pinned_together", pinned)
    flagged = fit(demos, options, workers=1)
    note = next(note for note in flagged.notes if note.code == "pinned_together")
    assert "U " in str(note) and "(-300 to 300)" in str(note)
    assert flagged.intervals[mud, 0] <= -300 and flagged.intervals[mud, 1] >= 300
    others = [j for j in range(len(plain.unknowns.labels)) if j != mud]
    assert flagged.intervals[others].tolist() == plain.intervals[others].tolist()
