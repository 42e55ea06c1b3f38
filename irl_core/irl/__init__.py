"""Inverse RL for careful experts (docs/fitting.md; the paper's "Simple IRL agent",
"Game and Loss IRL agent" and MaxEnt baseline).

Every method shares one affine Q map (`qmap`), returns one `FitResult` (`result`) and is
reached through `fit` (`fitting`), which runs the method's fitter (`fitters.FITTERS`):

==========  ====================================================================
``lp``      the simple IRL agent: rewards under which the most frequent actions are
            optimal, maximising the margin to the next best action (`lp/`)
``loss``    the loss IRL agent: a convex loss for noisy demonstrations (`loss/`)
``maxent``  maximum-likelihood maximum-entropy IRL, the paper's baseline (`maxent`),
            with beta given or estimated, or a model of people (`people/`), or on a
            time world's holds the timing model (`timing/`)
``auto``    lp for a deterministic expert whose lp is feasible, else maxent with beta
            estimated (docs/answers.md; the default)
==========  ====================================================================

The wings, one folder a family:

===============  ====================================================================
`choices`        the registries: one entry per method and per player model, and the one
                 place a fit's player model is decided (`player_model_for`)
`options`        `FitOptions`, one fit's settings; `notes`, the notes with their codes
`fitting`        `fit`: the sequence (fitter, intervals, checks, evaluation)
`fitters`        one function per method, keyed by its registry name
`intervals/`     the identified set (lp), the bootstrap (maxent, loss), a fit's choice
`people/`        models of people as they play, behind their package's face
`lp/`, `loss/`   the paper's two agents as optimisation problems
`timing/`        care from timing on a time world: the slip curve and the timing fit
`evaluation`     what an agent trained on the fitted reward would do
`fit_check`      whether the fitted player reproduces the recordings
===============  ====================================================================

May import: every wing below it (`support`, `worlds`, `recordings`, `play`, `players`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from irl_core.support.lazy import lazy_names

if TYPE_CHECKING:
    from irl_core.irl.fitting import METHODS, fit  # noqa: F401
    from irl_core.irl.notes import Note  # noqa: F401
    from irl_core.irl.options import FitOptions  # noqa: F401
    from irl_core.irl.result import BadInputError, FitError, FitResult, InfeasibleError, SolverError, at_bound  # noqa: F401
    from irl_core.support.stopping import Stopped  # noqa: F401

# Names are imported on first use, so that a registry (`irl_core.irl.choices`) can be read
# without loading the solvers.
_HOMES = {
    "METHODS": "irl_core.irl.fitting", "fit": "irl_core.irl.fitting", "Note": "irl_core.irl.notes",
    "FitOptions": "irl_core.irl.options", "BadInputError": "irl_core.irl.result", "FitError": "irl_core.irl.result",
    "FitResult": "irl_core.irl.result", "InfeasibleError": "irl_core.irl.result", "SolverError": "irl_core.irl.result",
    "at_bound": "irl_core.irl.result", "Stopped": "irl_core.support.stopping",
}

__all__ = sorted(_HOMES)


__getattr__, __dir__ = lazy_names(__name__, _HOMES, globals())
