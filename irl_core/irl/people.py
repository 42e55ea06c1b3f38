"""People as they play: maxent's models of people, their public names in one place.

A person chooses a *direction* sharply and a *level* loosely (a hold is timed by a hand, not picked
from a menu) and now and then lapses. The paper's maxent expert (`maxent.py`) is soft-optimal over
(direction, level) with one temperature for both, and its soft backup runs on after the episode has
ended; on person-like play that puts the goal below zero (docs/people.md). The models of people add
an episode end, a hand's noise on the level and lapses, each a parameter estimated with the rewards,
nested so that maxent's expert is their special case. Each job has its module:

====================  ========================================================================
`people_likelihood`   the model, its soft fixed point and the log likelihood with its exact
                      gradient (the equations are there)
`people_fit`          the fit by maximum likelihood, the curvature that scales a refit, and the
                      bootstrap's refit (`PlayerRefit`)
`people_choice`       choosing a model on held-out episodes
`people_held`         the rewards no recorded action can lead into, held at -rmax, and their upper bounds
`people_flat`         the rewards the data bound on one side only
`people_checks`       what is read off the chosen fit (those bounds, the fit check), side by side
====================  ========================================================================

Code in the project imports from those modules; this one keeps every public name importable from
`irl_core.irl.people` for scripts written before the split.
"""

from __future__ import annotations

from irl_core.irl.people_choice import (
    FOLD_VALUE_TOLERANCE,
    FOLDS,
    MIN_EPISODES_TO_CHOOSE,
    SIGNIFICANT_Z,
    SIMPLER_MARGIN,
    ModelChoice,
    choose_player_model,
    fit_given_model,
    significantly_better,
)
from irl_core.irl.people_fit import (
    GRADIENT_TOLERANCE,
    MAX_ITER,
    REFIT_MAX_ITER,
    RESAMPLE_GRADIENT_TOLERANCE,
    RESAMPLE_VALUE_TOLERANCE,
    VALUE_TOLERANCE,
    PlayerFit,
    PlayerRefit,
    curvature_scale,
    fit_player,
)
from irl_core.irl.people_flat import flat_toward_bound
from irl_core.irl.people_held import BOUND_STEPS, FLAT_DROP, MAX_ONE_BY_ONE, held_upper_bounds, jointly, unreached
from irl_core.irl.people_likelihood import (
    IDENTITY,
    LAPSE_BOUNDS,
    MAX_LOG_RATIO,
    MAX_PERSON_BETA,
    SIGMA_BOUNDS,
    SOFT_MAX_ITER,
    SOFT_TOLERANCE,
    START_LAPSE,
    START_SIGMA,
    Likelihood,
    PlayerPlan,
    beta_bounds,
    level_kernel,
    log_likelihood,
)
from irl_core.irl.player_models import CANDIDATES, PLAYER_MODELS, Player, PlayerModel, player_model

__all__ = [
    "BOUND_STEPS", "CANDIDATES", "FLAT_DROP", "FOLDS", "FOLD_VALUE_TOLERANCE", "GRADIENT_TOLERANCE", "IDENTITY",
    "LAPSE_BOUNDS", "MAX_ITER", "MAX_LOG_RATIO", "MAX_ONE_BY_ONE", "MAX_PERSON_BETA", "MIN_EPISODES_TO_CHOOSE",
    "PLAYER_MODELS", "REFIT_MAX_ITER", "RESAMPLE_GRADIENT_TOLERANCE", "RESAMPLE_VALUE_TOLERANCE", "SIGMA_BOUNDS",
    "SIGNIFICANT_Z", "SIMPLER_MARGIN", "SOFT_MAX_ITER", "SOFT_TOLERANCE", "START_LAPSE", "START_SIGMA",
    "VALUE_TOLERANCE", "Likelihood", "ModelChoice", "Player", "PlayerFit", "PlayerModel", "PlayerPlan", "PlayerRefit",
    "beta_bounds", "choose_player_model", "curvature_scale", "fit_given_model", "fit_player", "flat_toward_bound",
    "held_upper_bounds", "jointly", "level_kernel", "log_likelihood", "player_model", "significantly_better",
    "unreached",
]
