"""Which rewards of a model of people the data bound on one side only, after the fit: moved to their bound,
they cost the likelihood less than a chi-square's 95% (their value is the optimiser's patience, not the
data's). Those no recorded action can lead into are found before the fit (`held`)."""

from __future__ import annotations

import numpy as np

from irl_core.irl.people.fit import PlayerFit
from irl_core.irl.people.held import FLAT_DROP, MAX_ONE_BY_ONE
from irl_core.irl.people.likelihood import log_likelihood
from irl_core.irl.qmap import Unknowns
from irl_core.worlds.mdp import MDP


def flat_toward_bound(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *, rmax: float) -> np.ndarray:
    """(k,) -1 where moving an unknown from its estimate to -rmax, +1 where moving it to +rmax, costs the
    likelihood less than `FLAT_DROP` (its value there is the optimiser's patience, not the data's), else 0.

    Each unknown moves toward the bound on its own side; all of one side move together first, and one
    by one only if that costs more (and there are at most `MAX_ONE_BY_ONE`)."""
    counts = np.asarray(counts, dtype=float)

    def ll(theta: np.ndarray) -> float:
        return log_likelihood(mdp, counts, unknowns.state_rewards(theta), model=fit.model, player=fit.player,
                              V0=fit.V1, gradient=False).value

    best = ll(fit.theta)
    out = np.zeros(unknowns.k, dtype=np.int64)
    for sign in (-1, 1):
        side = np.flatnonzero((np.sign(fit.theta) == sign) & (np.abs(fit.theta) < rmax * (1 - 1e-9)))
        if side.size == 0:
            continue
        moved = fit.theta.copy()
        moved[side] = sign * rmax
        if best - ll(moved) < FLAT_DROP:
            out[side] = sign
            continue
        if side.size > MAX_ONE_BY_ONE:
            continue
        for j in side:
            one = fit.theta.copy()
            one[j] = sign * rmax
            if best - ll(one) < FLAT_DROP:
                out[j] = sign
    return out
