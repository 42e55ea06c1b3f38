"""`careful experiment` judges the paper's three claims from its run's numbers: the verdict and its
words follow the numbers, and a stage that undercuts a claim is discussed."""

from careful_tui.commands.experiment import report_markdown
from irl_core.experiment.claims import loss_claim, maxent_claim, paper_claims, separation_claim
from irl_core.experiment.run import Estimate, ExperimentResult, Separation, interval_caption


def estimate(stage, cliff, goal=100.0, *, cells=4, at_bound=0, inside=None, data="10 episodes"):
    return Estimate(stage=stage, method="m", data=data, cliff=cliff, goal=goal, true_cliff=-1000.0, true_goal=100.0,
                    seconds=0.0, cliff_cells=cells, cliff_at_bound=at_bound, cliff_inside=inside, rmax=1000.0)


LP = estimate("careful lp", -990.0, data="100 optimal episodes")


def test_a_the_baseline_underestimating_the_cliff_is_supported_and_recovering_it_is_not():
    mild = maxent_claim(estimate("maxent baseline", -160.0, data="2000 Boltzmann episodes"), LP)
    assert mild.verdict == "supported"
    assert "-160 against -1000, 6.2x too mild, from 2000 Boltzmann episodes" in mild.evidence
    assert "The careful lp, from 100 optimal episodes, gets -990 against -1000 (1% off)" in mild.evidence
    assert mild.discussion == ()
    recovered = maxent_claim(estimate("maxent baseline", -900.0, data="10000 Boltzmann episodes"), LP)
    assert recovered.verdict == "not supported" and "(10% off)" in recovered.evidence
    assert any("without carefulness" in sentence for sentence in recovered.discussion)
    # The contrast needs the careful lp to recover the cliff: when it does not, the run says so.
    weak_lp = maxent_claim(estimate("maxent baseline", -160.0), estimate("careful lp", -300.0))
    assert weak_lp.verdict == "supported"
    assert any("does not recover the cliff either" in sentence for sentence in weak_lp.discussion)
    assert maxent_claim(estimate("maxent baseline", -1000.0, at_bound=4), LP).verdict == "not supported"


def test_b_separation_with_carefulness_only_is_supported():
    supports = [Separation("mud", (-1000.0, -661.0), (-49.0, -15.0), 0.0),
                Separation("mud-simple", (-1000.0, 35.0), (-101.0, 46.0), 0.0, careful=False)]
    claim = separation_claim(supports)
    assert claim.verdict == "supported" and claim.discussion == ()
    assert "mud (identified, with carefulness): cliff [-1000, -661] below mud [-49, -15]" in claim.evidence
    assert "mud-simple (identified, without carefulness): cliff [-1000, 35] overlaps mud [-101, 46]" in claim.evidence


def test_b_confidence_intervals_that_separate_without_carefulness_make_it_mixed_and_are_discussed():
    """The run's own case: without carefulness the identified sets overlap, but maxent's confidence
    intervals lie apart (the cliff's at the fit's bound): a stage against the claim, not left bare."""
    separations = [Separation("mud", (-1000.0, -661.0), (-49.0, -15.0), 0.0),
                   Separation("mud-simple", (-1000.0, 35.0), (-101.0, 46.0), 0.0, careful=False),
                   Separation("mud", (-1452.0, -590.0), (-69.0, -30.0), 0.0, kind="confidence", rmax=5000.0),
                   Separation("mud-simple", (-5000.0, -4785.0), (-170.0, -81.0), 0.0, kind="confidence",
                              rmax=5000.0, careful=False)]
    claim = separation_claim(separations)
    assert claim.verdict == "mixed"
    [discussion] = claim.discussion
    assert discussion.startswith("Without carefulness (mud-simple) the confidence intervals lie apart too, while "
                                 "the identified sets there overlap.")
    assert "assumption of a Boltzmann-rational player" in discussion
    assert "the cliff's -5000 is the fit's bound" in discussion
    assert "not carefulness's doing" in interval_caption(separations[3])
    assert "not carefulness's doing" not in interval_caption(separations[2])
    # With carefulness and still overlapping, the claim finds no support at all.
    against = separation_claim([Separation("mud", (-1000.0, -10.0), (-49.0, -15.0), 0.0),
                                Separation("mud-simple", (-1000.0, 35.0), (-101.0, 46.0), 0.0, careful=False)])
    assert against.verdict == "not supported"
    assert "overlap even with carefulness" in against.discussion[0]


def test_c_the_loss_agent_follows_the_cliff_and_the_bound():
    assert loss_claim(estimate("loss, noisy", -950.0), people=True).verdict == "supported"
    near = loss_claim(estimate("loss, noisy", -600.0), people=True)
    assert near.verdict == "mixed" and "not within 25%" in near.evidence
    assert loss_claim(estimate("loss, noisy", -100.0), people=True).verdict == "not supported"
    bound = loss_claim(estimate("loss, noisy", -957.0, at_bound=3, inside=-827.0), people=True)
    assert bound.verdict == "mixed" and "3 of its 4 cells sit at the fit's bound" in bound.evidence
    assert "the others average -827" in bound.evidence
    assert loss_claim(estimate("loss, noisy", -1000.0, at_bound=4), people=True).verdict == "not supported"
    goal = loss_claim(estimate("loss, noisy", -950.0, goal=-20.0), people=True)
    assert goal.verdict == "mixed" and "The goal comes out at -20" in goal.discussion[0]
    simulated = loss_claim(estimate("loss, noisy", -950.0), people=False)
    assert simulated.verdict == "supported" and "simulated noisy experts" in simulated.discussion[-1]


def test_the_report_states_each_claim_with_its_verdict():
    estimates = [estimate("maxent baseline", -160.0), LP, estimate("loss, noisy", -950.0)]
    separations = [Separation("mud", (-1000.0, -661.0), (-49.0, -15.0), 0.0),
                   Separation("mud-simple", (-1000.0, 35.0), (-101.0, 46.0), 0.0, careful=False)]
    claims = paper_claims(estimates, separations, people=True)
    assert [(c.key, c.verdict) for c in claims] == [("a", "supported"), ("b", "supported"), ("c", "supported")]
    report = report_markdown(ExperimentResult(estimates=estimates, separations=separations, claims=claims))
    section = report[report.index("## The paper's claims, against this run"):]
    assert "- (a) the MaxEnt baseline underestimates the cliff: supported. The baseline's cliff is -160" in section
    assert "- (b) carefulness separates catastrophe (cliff) from nuisance (mud): supported." in section
    assert "- (c) the loss agent recovers the cliff's severity from a few noisy episodes: supported." in section
