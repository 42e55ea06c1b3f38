"""A fit's notes and errors: a stable code for programs, a sentence for people.

Readers filter notes by `Note.code`, never by their wording, so a sentence can be reworded
without changing what a table or a caption keeps. A sentence names the options it talks about
as ``{rmax}`` or ``{method=loss}``; `str()` says them as `fit`'s parameters (``rmax``,
``method="loss"``) and a front end says them in its own words with `worded` (the command line:
``--rmax``, ``--method loss``).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

# Every code a note can carry, and what it says (docs/fit-json.md lists them).
CODES: dict[str, str] = {
    "auto_chose": "the method auto chose, and why",
    "nothing_to_fit": "every cell is held at a known value",
    "at_bound": "unknowns at ±rmax: the bound, not the data, set them",
    "lp_interior": "the lp was solved by the interior point method, and its gap",
    "not_unique": "many rewards minimise the loss equally",
    "uniqueness_unchecked": "whether the loss's minimiser is unique could not be checked",
    "inaccurate": "the loss is pinned down only roughly",
    "not_converged": "maxent stopped before converging",
    "beta_fixed": "maxent's beta was given, not estimated",
    "beta_estimated": "maxent's beta as estimated",
    "not_identified": "beta (the reward's scale) is not identified",
    "intervals_not_computed": "no intervals, and why",
    "intervals_interior": "the intervals were solved by the interior point method",
    "resamples_failed": "bootstrap resamples whose refit failed",
    "refits_never_moved": "unknowns whose bootstrap intervals have no width",
    "beta_interval": "beta's confidence interval",
    "few_episodes": "too few episodes for a good bootstrap interval",
    "player_model": "maxent's model of the player, and why it was chosen",
    "player_estimated": "the player model's parameters as estimated",
    "hand_calibrated": "the hand's bias and noise, measured by a study's motor calibration trials",
    "hand_resampled": "the intervals' resamples drew the calibration trials again (the hand's sampling error)",
    "planning_not_identified": "whether the player plans for the hand's noise is not identified",
    "one_sided": "rewards the data bound on one side only",
    "interval_widened": "intervals widened to hold their point estimate (the refits sat to one side of it)",
    "models_joined": "the intervals join every player model held-out episodes do not tell apart (union)",
    "calibrated": "intervals widened by the scales careful check learned, so that they reached their level",
    "pinned_together": "rewards the data pin only in combination: each point is where the search stopped",
    "combinations_unchecked": "too many free rewards to check which the data pin only in combination",
    "unreached": "rewards no recorded action can lead into: held at -rmax, bounded above only",
    "fit_check_failed": "the fitted player does not reproduce the recordings",
    "fit_check_passed": "the fitted player reproduces the recordings",
    "fit_check_not_run": "the fit check could not run",
    "slip_curve_fitted": "a time world's slip curve as fitted to the recorded slips, with its intervals",
    "slip_curve_given": "a time world's slip curve taken from the world (no holds to learn it from)",
    "reward_in_seconds": "the cost of holding taken as unknown: rewards in seconds of holding",
    "intervals_scores": "the timing fit's intervals from the scores' spread alone (its curvature was not usable)",
    "scale_not_identified": "nothing fixes the rewards' units: each is read relative to a reference reward",
    "rewards_held": "rewards held at values the user gave (--known), not fitted",
    "units_from_beta": "nothing in the world fixes the rewards' units; the beta the user gave does",
    "cliff_not_separated": "the hazards' and nuisances' intervals overlap: the fit does not tell them apart",
    # `FitOptions.problem`: options a fit would not refuse, but the command line does.
    "beta_needs_maxent": "beta estimated for a method without one",
    "bad_confidence": "a confidence level outside (0, 1)",
    "too_few_resamples": "too few bootstrap resamples",
    "beta_needs_boltzmann": "a fixed beta for a player model that estimates it",
}

# An option named in a sentence: {name} or {name=value}.
OPTION = re.compile(r"\{(\w+)(?:=([^{}]*))?\}")


def python_option(name: str, value: str | None) -> str:
    """An option as `fit`'s keyword: rmax, method="loss", intervals=True, beta=2."""
    if value is None:
        return name
    try:
        float(value)
        literal = True
    except ValueError:
        literal = value in ("True", "False", "None")
    return f"{name}={value}" if literal else f'{name}="{value}"'


def worded(sentence: str, option: Callable[[str, str | None], str] = python_option) -> str:
    """`sentence` with every ``{name}`` and ``{name=value}`` said by `option(name, value)`."""
    return OPTION.sub(lambda match: option(match[1], match[2]), sentence)


@dataclass(frozen=True)
class Note:
    """A note on a fit: `code` (a key of `CODES`) and `sentence` (options as ``{name=value}``).

    `str()` is the sentence in `fit`'s words.
    """

    code: str
    sentence: str

    def __post_init__(self) -> None:
        if self.code not in CODES:
            raise ValueError(f"unknown note code {self.code!r}: add it to CODES")

    def __str__(self) -> str:
        return worded(self.sentence)
