"""The population of participants (`irl_core.studies.population`): the random-effects pool against closed
forms and a brute-force likelihood, censored answers, outliers and influence that a wide fit cannot hide."""

import numpy as np
import pytest
from scipy.stats import norm

from irl_core.studies.population import answers, fit_population, pool_participants, pool_reward

Z = norm.ppf(0.975)


def intervals_on_log_scale(y, s):
    """Cliff intervals whose log(-r) middles are `y` with standard errors `s`."""
    y, s = np.asarray(y, float), np.asarray(s, float)
    return np.stack([-np.exp(y + Z * s), -np.exp(y - Z * s)], axis=1)


def test_equal_errors_give_the_closed_form():
    """With one within-participant error s for all and no censoring, the likelihood's maximum is the mean of
    the answers and tau^2 = max(0, their variance (1/n) - s^2)."""
    y = np.log([400.0, 650.0, 900.0, 1300.0, 2000.0, 700.0])
    s = np.full(6, 0.1)
    a = answers(intervals_on_log_scale(y, s), rmax=5000)
    assert a.scale == "log_negative" and (a.kind == 0).all()
    np.testing.assert_allclose(a.y, y, atol=1e-12)
    mu, tau, se, used = fit_population(a)
    assert mu == pytest.approx(y.mean(), abs=1e-4)
    assert tau == pytest.approx(np.sqrt(max(0.0, y.var() - 0.01)), rel=1e-3)
    assert se == pytest.approx(np.sqrt((tau**2 + 0.01) / 6), rel=1e-3) and used == 6


def brute_force(y, s, kinds, s_censored):
    """The (mu, tau) of largest likelihood on a fine grid, the likelihood written out again."""
    mu, tau = np.meshgrid(np.linspace(5.0, 8.5, 351), np.linspace(0.0, 1.5, 151), indexing="ij")
    ll = np.zeros_like(mu)
    for yi, si, k in zip(y, s, kinds):
        if k == 0:
            ll += norm.logpdf(yi, mu, np.hypot(tau, si))
        elif k == 1:
            ll += norm.logsf(yi, mu, np.hypot(tau, s_censored))
    i, j = np.unravel_index(np.argmax(ll), ll.shape)
    return mu[i, j], tau[i, j]


def test_a_one_sided_answer_enters_censored_and_matches_a_brute_force_likelihood():
    """Two participants whose cliff interval runs to the bound ("at most -2500", "at most -1800") say only
    that it is at least that bad: the population's centre moves toward them, as the brute-force maximum does."""
    exact = intervals_on_log_scale(np.log([600.0, 800.0, 1000.0, 700.0]), [0.2, 0.3, 0.25, 0.2])
    one_sided = np.array([[-5000.0, -2500.0], [-5000.0, -1800.0]])
    a = answers(np.vstack([exact, one_sided]), rmax=5000)
    assert list(a.kind) == [0, 0, 0, 0, 1, 1]
    mu, tau, _, _ = fit_population(a)
    grid_mu, grid_tau = brute_force(a.y, a.s, a.kind, float(np.median(a.s[a.kind == 0])))
    assert mu == pytest.approx(grid_mu, abs=0.011) and tau == pytest.approx(grid_tau, abs=0.011)
    without = fit_population(answers(exact, rmax=5000))[0]
    assert mu > without  # pulled toward the more severe one-sided answers
    nothing = answers(np.array([[-5000.0, 5000.0]]), rmax=5000)
    assert nothing.kind[0] == 2


def test_a_reckless_participant_is_an_outlier_however_wide_their_fit():
    """Eleven careful participants around -1000 and one whose fit says -20 to -120: an outlier, and nobody
    else is. Widening the reckless fit to [-400, -5] (a fit with little data) does not hide it."""
    rng = np.random.default_rng(4)
    y = np.log(1000) + rng.normal(0, 0.3, 11)
    careful = intervals_on_log_scale(y, np.full(11, 0.3))
    for reckless in ([-120.0, -20.0], [-400.0, -5.0]):
        population = pool_participants(np.vstack([careful, [reckless]])[:, None, :], rmax=5000)
        assert list(np.flatnonzero(population.outlier)) == [11]
        low, high = population.intervals[0]
        assert low <= -1000 <= high
        pred_low, pred_high = population.predictions[0]
        assert pred_low <= low and high <= pred_high


def test_the_rival_planning_model_widens_the_interval_it_shares():
    """Every participant's cliff is 2.5 times more severe under the rival planning model: however many
    participants there are, the population's interval covers both answers."""
    y = np.log(400) + np.random.default_rng(0).normal(0, 0.2, 30)
    intervals = intervals_on_log_scale(y, np.full(30, 0.2))
    shift = (-np.exp(y) * 1.5)[:, None]  # rival estimate minus chosen: -1000 against -400
    alone = pool_participants(intervals[:, None, :], rmax=5000)
    both = pool_participants(intervals[:, None, :], rmax=5000, rival_shift=shift)
    assert alone.intervals[0, 0] > -600 and both.intervals[0, 0] < -900
    assert both.intervals[0, 1] == pytest.approx(alone.intervals[0, 1])


def test_a_reward_with_both_signs_pools_on_its_own_scale():
    reward = pool_reward(np.array([[-10.0, 30.0], [5.0, 40.0], [0.0, 20.0]]), rmax=5000)
    assert reward.scale == "linear" and reward.interval[0] < reward.centre < reward.interval[1]


def test_participants_who_all_bound_a_reward_on_one_side_bound_the_population_by_the_mildest():
    reward = pool_reward(np.array([[-5000.0, -325.0], [-5000.0, -119.0], [-5000.0, -741.0]]), rmax=5000)
    assert np.isnan(reward.centre) and list(reward.interval) == [-5000.0, pytest.approx(-119.0)]
    mixed = pool_reward(np.array([[-5000.0, -325.0], [40.0, 5000.0]]), rmax=5000)
    assert list(mixed.interval) == [-5000.0, 5000.0]


@pytest.mark.parametrize("n", [4, 5, 8, 12])
def test_the_outlier_tests_reach_is_the_width_at_which_an_answer_is_called_outside(n):
    """`outlier_reach` (what the finding quotes) is `_outside`'s own threshold over the normal's: an answer just
    inside reach x z standard deviations of the others' centre is in, just beyond it out."""
    from irl_core.studies.population import Answers, PopulationReward, _outside, outlier_reach

    confidence = 1 - 0.05 / 3
    edge = outlier_reach(n, rewards=3) * norm.ppf(0.5 + confidence / 2)
    others = PopulationReward(centre=1.0, interval=np.zeros(2), spread=0.0, prediction=np.zeros(2), tau=0.0,
                              scale="linear", used=n - 1, censored=0, mu=0.0, se=0.0)
    for y, outside in ((0.999 * edge, False), (1.001 * edge, True)):
        mine = Answers(y=np.array([y]), s=np.array([1.0]), kind=np.array([0]), scale="linear")
        assert _outside(mine, others, confidence=confidence) is outside


@pytest.mark.parametrize(("n", "said"), [
    (2, "with 2 participants nobody is tested as an outlier or for influence"),
    (3, "nobody moves the centre alone; with 3 participants nobody can be found an outlier (too few others to say "
        "where a fit would lie)"),
    (5, "no participant is an outlier or moves the centre alone; with 5 participants the outlier test finds only "
        "fits far outside the others (its interval is 3.2 times as wide as with many participants)"),
    (12, "no participant is an outlier or moves the centre alone"),
])
def test_a_populations_finding_says_how_far_its_outlier_test_could_see(n, said):
    # "No outlier" from five participants is not "no outlier" from fifty: the finding says which it is.
    from irl_core.studies.report import CellFit
    from irl_core.studies.report_table import _population_marks

    result = CellFit(symbols=("C", "U", "G"), estimate=np.zeros(3), pooled=n, pool_model="population",
                     confidence=0.95)
    assert _population_marks(None, None, result) == said
