"""Inverse RL for careful experts (docs/fitting.md; the paper's "Simple IRL agent",
"Game and Loss IRL agent" and MaxEnt baseline).

Every method shares one affine Q map (`qmap`), returns one `FitResult` (`result`) and is
reached through `fit` (`irl_core.irl.fit_methods` holds one entry per method):

==========  ====================================================================
``lp``      the simple IRL agent: rewards under which the most frequent actions are
            optimal, maximising the margin to the next best action (`lp`)
``loss``    the loss IRL agent: a convex loss for noisy demonstrations (`loss_model`
            states it, `loss` solves it)
``maxent``  maximum-likelihood maximum-entropy IRL, the paper's baseline (`maxent`),
            with beta given or estimated with the rewards
``auto``    lp for a deterministic expert whose lp is feasible, else maxent with beta
            estimated (docs/answers.md; the default)
==========  ====================================================================

``intervals=True`` bounds every unknown: over the lp constraints for lp (`intervals`, the
identified set), by resampling episodes for maxent and loss (`bootstrap`, a confidence
interval). `evaluation` says what an agent trained on the fitted reward would do.

The registries live here too: `fit_methods` (one entry per method: where a new method goes) and
`player_models` (one entry per model of the player).

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

# Names are imported on first use, so that a registry (`irl_core.irl.fit_methods`) can be read
# without loading the solvers.
_HOMES = {
    "METHODS": "irl_core.irl.fitting", "fit": "irl_core.irl.fitting", "Note": "irl_core.irl.notes",
    "FitOptions": "irl_core.irl.options", "BadInputError": "irl_core.irl.result", "FitError": "irl_core.irl.result",
    "FitResult": "irl_core.irl.result", "InfeasibleError": "irl_core.irl.result", "SolverError": "irl_core.irl.result",
    "at_bound": "irl_core.irl.result", "Stopped": "irl_core.support.stopping",
}

__all__ = sorted(_HOMES)


__getattr__, __dir__ = lazy_names(__name__, _HOMES, globals())
