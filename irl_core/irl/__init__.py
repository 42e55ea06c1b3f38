"""Inverse RL for careful experts (README "Fitting a reward"; the paper's "Simple IRL agent",
"Game and Loss IRL agent" and MaxEnt baseline).

Every method shares one affine Q map (`qmap`), returns one `FitResult` (`result`) and is
reached through `fit` (`irl_core.fit_methods` holds one entry per method):

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
"""

from irl_core.irl.fit import METHODS, fit
from irl_core.irl.notes import Note
from irl_core.irl.options import FitOptions
from irl_core.irl.result import BadInputError, FitError, FitResult, InfeasibleError, SolverError, at_bound
from irl_core.stopping import Stopped

__all__ = ["METHODS", "BadInputError", "FitError", "FitOptions", "FitResult", "InfeasibleError", "Note",
           "SolverError", "Stopped", "at_bound", "fit"]
