"""Inverse RL for careful experts (SPEC section 3; the paper's "Simple IRL agent",
"Game and Loss IRL agent" and MaxEnt baseline).

Every method shares one affine Q map (`qmap`), returns one `FitResult` (`result`) and is
reached through `fit`:

==========  ====================================================================
``lp``      the simple IRL agent: rewards under which the most frequent actions are
            optimal, maximising the margin to the next best action (`lp`)
``loss``    the loss IRL agent: a convex loss for noisy demonstrations (`loss`)
``maxent``  maximum-likelihood maximum-entropy IRL, the paper's baseline (`maxent`)
==========  ====================================================================

`--intervals` bounds every unknown over the lp constraints (`intervals`).
"""

from irl_core.irl.fit import METHODS, fit
from irl_core.irl.result import BadInputError, FitError, FitResult, InfeasibleError, SolverError

__all__ = ["METHODS", "BadInputError", "FitError", "FitResult", "InfeasibleError", "SolverError", "fit"]
