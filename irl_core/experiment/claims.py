"""What a run's numbers say about the paper's claims (docs/studies-pooling.md).

The paper (Hanslope & Aitchison) makes three claims that `careful experiment` tests:

===  ============================================================================
(a)  the MaxEnt baseline, without carefulness, underestimates the cliff's severity
(b)  carefulness separates a catastrophe (the cliff) from a nuisance (the mud)
(c)  the loss agent recovers the cliff's severity from a few noisy episodes
===  ============================================================================

Each is judged from the stages' numbers into a `Claim`: a verdict (``supported``, ``not
supported`` or ``mixed``), the numbers behind it, and a sentence on every stage whose result
undercuts it. `order_words` says how two intervals lie for the study report's pooled rows too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from irl_core.experiment.stage_results import Estimate, Separation
from irl_core.irl.result import at_bound

Verdict = Literal["supported", "not supported", "mixed"]
# A severity within this fraction of the truth is "recovered" (the experiment's captions use it too).
RECOVERED = 0.25
# A cliff within this factor of the truth (either way) is near it, though not recovered.
NEAR_FACTOR = 2.0

SYMBOL_WORDS = {"C": "cliff", "G": "goal", "U": "mud"}
STATEMENTS = {
    "a": "the MaxEnt baseline underestimates the cliff",
    "b": "carefulness separates catastrophe (cliff) from nuisance (mud)",
    "c": "the loss agent recovers the cliff's severity from a few noisy episodes",
}


@dataclass(frozen=True)
class Claim:
    """One claim of the paper against one run.

    Attributes:
        key: ``a``, ``b`` or ``c`` (`STATEMENTS`).
        verdict: ``supported``, ``not supported`` or ``mixed``.
        evidence: the run's numbers for and against, in a sentence or two.
        discussion: a sentence per stage whose result undercuts the claim, saying what it means.
    """

    key: str
    verdict: Verdict
    evidence: str
    discussion: tuple[str, ...] = ()

    @property
    def statement(self) -> str:
        return STATEMENTS[self.key]

    def text(self) -> str:
        """The claim, its verdict and its numbers, then the discussion, as one paragraph."""
        return " ".join([f"({self.key}) {self.statement}: {self.verdict}. {self.evidence}", *self.discussion])


def order_words(low: tuple[float, float], high: tuple[float, float]) -> str:
    """How the interval `low` (expected to be the worse) lies against `high`: ``below``, ``above``
    (the expected order reversed) or ``overlaps``."""
    if low[1] < high[0]:
        return "below"
    if high[1] < low[0]:
        return "above"
    return "overlaps"


def number_text(value: float) -> str:
    """A reward in a sentence: whole from 100 up, else three significant figures (-1069, -35.2, 12.8)."""
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:.3g}"


def interval_text(interval: tuple[float, float]) -> str:
    return f"[{number_text(interval[0])}, {number_text(interval[1])}]"


def paper_claims(estimates: list[Estimate], separations: list[Separation], *, people: bool) -> list[Claim]:
    """The three claims judged from a run's stages (by their stage names; a missing stage is left out).

    Args:
        people: stage 4 fitted a person's sessions (else simulated noisy experts).
    """
    by_stage = {e.stage: e for e in estimates}
    claims = []
    if "maxent baseline" in by_stage:
        claims.append(maxent_claim(by_stage["maxent baseline"], by_stage.get("careful lp")))
    if separations:
        claims.append(separation_claim(separations))
    if "loss, noisy" in by_stage:
        claims.append(loss_claim(by_stage["loss, noisy"], people=people))
    return claims


def _against(e: Estimate) -> str:
    return f"{e.cliff:.0f} against {e.true_cliff:.0f}"


def maxent_claim(baseline: Estimate, careful: Estimate | None) -> Claim:
    """(a) from the baseline's cliff, with the careful lp's beside it for the contrast the paper draws."""
    discussion = []
    if baseline.cliff_cells and baseline.cliff_at_bound == baseline.cliff_cells:
        verdict: Verdict = "not supported"
        evidence = (f"The baseline's cliff cells all sit at the fit's bound ({_against(baseline)}): as severe as "
                    "the bound allows, so it does not underestimate the cliff here, though the bound, not the "
                    "data, set it.")
    elif baseline.cliff >= 0:
        verdict = "supported"
        evidence = f"The baseline's cliff is {_against(baseline)}, not even negative."
        discussion.append("The paper found the baseline at least tells that the cliff is bad; this run's does not.")
    elif abs(baseline.cliff) < (1 - RECOVERED) * abs(baseline.true_cliff):
        verdict = "supported"
        evidence = (f"The baseline's cliff is {_against(baseline)}, {baseline.true_cliff / baseline.cliff:.1f}x "
                    f"too mild, from {baseline.data}.")
    else:
        verdict = "not supported"
        evidence = (f"The baseline's cliff is {_against(baseline)} ({baseline.cliff_error:.0%} off), from "
                    f"{baseline.data}: it does not underestimate the cliff.")
        discussion.append("The paper put the baseline's shortfall down to too few samples; with this many the "
                          "baseline recovers the cliff without carefulness.")
    if careful is not None:
        evidence += f" The careful lp, from {careful.data}, gets {_against(careful)} ({careful.cliff_error:.0%} off)."
        if careful.cliff_error > RECOVERED:
            discussion.append("The careful lp does not recover the cliff either, so the contrast the paper draws "
                              "(carefulness recovers what the baseline misses) is not shown by this run.")
        elif careful.cliff_at_bound:
            one = careful.cliff_at_bound == 1
            bound = "-rmax" if careful.rmax is None else f"{-careful.rmax:.0f}"
            discussion.append(f"{careful.cliff_at_bound} of the careful lp's {careful.cliff_cells} cliff cells "
                              f"{'sits' if one else 'sit'} at its bound ({bound}), which set {'it' if one else 'them'}, "
                              "not the data: the contrast holds for the cells the data set, and the bound decides "
                              f"{'that one' if one else 'those'}.")
    return Claim("a", verdict, evidence, tuple(discussion))


def separation_claim(separations: list[Separation]) -> Claim:
    """(b) from the cliff and mud intervals: with carefulness they should lie apart (cliff below), without
    it they should overlap. Each kind of interval (identified, confidence) is one test; the verdict is
    ``supported`` when every test agrees, ``not supported`` when none does, else ``mixed``."""
    evidence: list[str] = []
    discussion: list[str] = []
    tests: dict[str, list[bool]] = {}
    for s in separations:
        where = "with" if s.careful else "without"
        order = order_words(s.cliff, s.mud)
        evidence.append(f"{s.world} ({s.kind}, {where} carefulness): cliff {interval_text(s.cliff)} {order} "
                        f"mud {interval_text(s.mud)}")
        agrees = order == "below" if s.careful else order == "overlaps"
        tests.setdefault(s.kind, []).append(agrees)
        if not agrees:
            identified = next((o for o in separations if o.world == s.world and o.kind == "identified"), None)
            discussion.append(_undercut(s, order, identified))
    supporting = sum(all(results) for results in tests.values())
    verdict: Verdict = ("supported" if supporting == len(tests) else "not supported" if supporting == 0 else "mixed")
    return Claim("b", verdict, "; ".join(evidence) + ".", tuple(discussion))


def _undercut(s: Separation, order: str, identified: Separation | None) -> str:
    """What a separation stage against claim (b) means (`identified`: the same world's identified sets)."""
    if s.careful:
        if order == "above":
            return (f"On {s.world} the mud comes out worse than the cliff ({s.kind}), carefulness notwithstanding: "
                    "these demonstrations rank the two the wrong way round.")
        return (f"On {s.world} the cliff's and the mud's {s.kind} intervals overlap even with carefulness: these "
                "demonstrations do not tell them apart.")
    bounded = [f"the {name}'s {end:.0f}" for name, interval in (("cliff", s.cliff), ("mud", s.mud))
               for end in interval if s.rmax is not None and at_bound(end, s.rmax)]
    if s.kind == "confidence":
        there = ""
        if identified is not None:
            there = (", while the identified sets there overlap" if order_words(identified.cliff, identified.mud)
                     == "overlaps" else "")
        text = (f"Without carefulness ({s.world}) the confidence intervals lie apart too{there}. A confidence "
                "interval measures only how the maxent estimate moves between resamples of the episodes, assuming "
                "a Boltzmann player; it does not hold every reward the demonstrations allow, as an identified set "
                "does. The separation is the model's, not the data's: without carefulness it is the assumption of "
                "a Boltzmann-rational player that tells the cliff from the mud.")
    else:
        text = (f"Without carefulness ({s.world}) the identified sets lie apart too: these demonstrations tell "
                "the cliff from the mud without carefulness, so here carefulness is not what separates them.")
    if bounded:
        text += (f" At ±{s.rmax:.0f}, {' and '.join(bounded)} {'is' if len(bounded) == 1 else 'are'} the fit's "
                 "bound, not a value the data set.")
    return text


def loss_claim(e: Estimate, *, people: bool) -> Claim:
    """(c) from the loss stage's cliff (and goal)."""
    discussion = []
    bounded = e.cliff_at_bound
    if e.cliff_cells and bounded == e.cliff_cells:
        verdict: Verdict = "not supported"
        evidence = (f"Every cliff cell sits at the fit's bound ({_against(e)}): the bound, not the {e.data}, "
                    "set the severity.")
    elif bounded:
        verdict = "mixed"
        inside = "" if e.cliff_inside is None else f"; the others average {e.cliff_inside:.0f}"
        evidence = (f"The cliff comes out at {_against(e)} ({e.cliff_error:.0%} off) from {e.data}, but {bounded} "
                    f"of its {e.cliff_cells} cells sit at the fit's bound, which set them, not the data{inside}.")
    elif e.cliff < 0 and e.cliff_error <= RECOVERED:
        verdict = "supported"
        evidence = f"The cliff comes out at {_against(e)} ({e.cliff_error:.0%} off) from {e.data}."
    elif e.cliff < 0 and 1 / NEAR_FACTOR <= e.cliff / e.true_cliff <= NEAR_FACTOR:
        verdict = "mixed"
        evidence = (f"The cliff comes out at {_against(e)} ({e.cliff_error:.0%} off) from {e.data}: bad, and near "
                    "its severity, but not within 25%.")
    else:
        verdict = "not supported"
        evidence = f"The cliff comes out at {_against(e)} ({e.cliff_error:.0%} off) from {e.data}."
    if e.goal <= 0 < e.true_goal:
        verdict = "mixed" if verdict == "supported" else verdict
        discussion.append(f"The goal comes out at {e.goal:.0f} (truth {e.true_goal:.0f}), not positive: the fit "
                          "does not explain why the player plays at all.")
    if not people:
        discussion.append("The paper's claim is about a person's episodes, and these are simulated noisy experts "
                          "(careful experiment --recordings DIR fits a person's).")
    return Claim("c", verdict, evidence, tuple(discussion))
