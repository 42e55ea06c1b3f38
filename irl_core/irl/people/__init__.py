"""People as they play: maxent's models of people (docs/people.md), behind one face.

A person chooses a *direction* sharply and a *level* loosely (a hold is timed by a hand, not picked
from a menu) and now and then lapses. The paper's maxent expert (`irl_core.irl.maxent`) is soft-optimal
over (direction, level) with one temperature for both, and its soft backup runs on after the episode
has ended; on person-like play that puts the goal below zero. The models of people add an episode end,
a hand's noise on the level and lapses, each a parameter estimated with the rewards, nested so that
maxent's expert is their special case. Each job has its module:

==============  ==============================================================================
`likelihood`    the model, its soft fixed point and the log likelihood with its exact gradient
                (the equations are there)
`hand`          the hand's noise on the level, and a hand measured by calibration trials
`fit`           the fit by maximum likelihood, the curvature that scales a refit, and the
                bootstrap's refit (`PlayerRefit`)
`choice`        choosing a model on held-out episodes
`held`          the rewards no recorded action can lead into, held at -rmax, and their upper bounds
`flat`          the rewards the data bound on one side only
`laplace`       Laplace intervals, and rewards the data pin only in combination
`checks`        what is read off the chosen fit (those bounds, the fit check), side by side
==============  ==============================================================================

Code outside this package imports the names below from `irl_core.irl.people`, never its modules
(tests may reach in); each is imported on first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from irl_core.support.lazy import lazy_names

if TYPE_CHECKING:
    from irl_core.irl.people.checks import people_checks  # noqa: F401
    from irl_core.irl.people.choice import (  # noqa: F401
        ModelChoice,
        choose_player_model,
        close_models,
        fit_given_model,
        planning_rival,
    )
    from irl_core.irl.people.fit import PlayerFit, PlayerRefit, curvature_scale  # noqa: F401
    from irl_core.irl.people.hand import hand_from_trials  # noqa: F401
    from irl_core.irl.people.held import FLAT_DROP, note_of_bounds  # noqa: F401
    from irl_core.irl.people.laplace import MAX_COMBINED, NEARLY_FLAT, laplace_intervals  # noqa: F401
    from irl_core.irl.people.likelihood import log_likelihood  # noqa: F401

_HOMES = {
    "people_checks": "irl_core.irl.people.checks",
    "ModelChoice": "irl_core.irl.people.choice", "choose_player_model": "irl_core.irl.people.choice",
    "close_models": "irl_core.irl.people.choice",
    "fit_given_model": "irl_core.irl.people.choice", "planning_rival": "irl_core.irl.people.choice",
    "PlayerFit": "irl_core.irl.people.fit", "PlayerRefit": "irl_core.irl.people.fit",
    "curvature_scale": "irl_core.irl.people.fit",
    "hand_from_trials": "irl_core.irl.people.hand",
    "FLAT_DROP": "irl_core.irl.people.held", "note_of_bounds": "irl_core.irl.people.held",
    "MAX_COMBINED": "irl_core.irl.people.laplace", "NEARLY_FLAT": "irl_core.irl.people.laplace",
    "laplace_intervals": "irl_core.irl.people.laplace",
    "log_likelihood": "irl_core.irl.people.likelihood",
}

__all__ = sorted(_HOMES)

__getattr__, __dir__ = lazy_names(__name__, _HOMES, globals())
