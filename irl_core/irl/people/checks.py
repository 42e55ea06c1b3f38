"""What is read off a people fit once it is chosen, worked out side by side.

Four things depend only on the chosen fit, not on each other's answers: the fit check (the recordings
against simulations of the fitted player, `fit_check`), the rewards bounded on one side only
(`flat`) with those pinned only in combination (`laplace.pinned_together`), and each held reward's
upper bound (`held`). One after the other they took 1.5 s of a 24x24 world's 5.4 s fit (an instrumented
run), the bounds on two processes and the rest on one; here they are one batch of calls on the fit's processes,
the longest first (1.0 s). Each answer is the one its own function gives (the fit check draws from its own seeded
stream), on any number of processes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from irl_core.irl.fit_check import FitCheck, fit_check
from irl_core.irl.people.fit import PlayerFit
from irl_core.irl.people.flat import flat_toward_bound
from irl_core.irl.people.held import bound_groups, bounds_of, upper_bound
from irl_core.irl.people.laplace import pinned_together
from irl_core.irl.people.likelihood import log_likelihood
from irl_core.irl.qmap import Unknowns
from irl_core.recordings.demonstrations import EpisodeFacts
from irl_core.support.executor import map_calls
from irl_core.worlds.mdp import MDP

FIT_CHECK, SIDES, HELD = "fit_check", "sides", "held"


@dataclass(frozen=True)
class PeopleChecks:
    """held_upper (k,): each held reward's upper bound (NaN elsewhere; None when none is held); flat (k,): -1/+1 where
    a reward is bounded on that side only (`flat_toward_bound`); together (k, 2) or None (`pinned_together`);
    fit_check: None when the recordings keep no episodes."""

    held_upper: np.ndarray | None
    flat: np.ndarray
    together: np.ndarray | None
    fit_check: FitCheck | None


def people_checks(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *, rmax: float,
                  episodes: tuple[sp.csr_matrix, EpisodeFacts] | None, seed: int, workers: int = 1) -> PeopleChecks:
    """The checks of `fit` to counts N (S, A), on up to `workers` processes; `episodes`: the recordings' episodes
    (rows (E, S * A)) and their facts, for the fit check (seeded by `seed`)."""
    counts = np.asarray(counts, dtype=float)
    held = _held(fit, unknowns.k)
    groups = bound_groups(held) if held.any() else []
    best, V_best = np.nan, fit.V1
    if groups:
        at_fit = log_likelihood(mdp, counts, unknowns.state_rewards(fit.theta), model=fit.model, player=fit.player,
                                V0=fit.V1, gradient=False)
        best, V_best = at_fit.value, at_fit.plan.V
    # The longest first: the fit check simulates the recordings 200 times over.
    calls: list[tuple[str, list[int]]] = [(FIT_CHECK, [])] if episodes is not None else []
    calls += [(SIDES, [])] + [(HELD, group) for group in groups]
    shared = (mdp, unknowns, counts, fit, rmax, best, V_best, episodes, seed)
    answers = map_calls(_check, calls, shared=shared, workers=workers)
    by_kind = {kind: [answer for (each, _), answer in zip(calls, answers) if each == kind] for kind in (FIT_CHECK, SIDES, HELD)}
    [(flat, together)] = by_kind[SIDES]
    return PeopleChecks(held_upper=bounds_of(unknowns.k, groups, by_kind[HELD]) if groups else None, flat=flat,
                        together=together, fit_check=by_kind[FIT_CHECK][0] if episodes is not None else None)


def _check(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, rmax: float, best: float,
           V_best: np.ndarray, episodes: tuple[sp.csr_matrix, EpisodeFacts] | None, seed: int, kind: str,
           group: list[int]):
    if kind == FIT_CHECK:
        assert episodes is not None
        return fit_check(mdp, fit.plan.observed, *episodes, seed=seed)
    if kind == SIDES:
        flat = flat_toward_bound(mdp, unknowns, counts, fit, rmax=rmax)
        return flat, pinned_together(mdp, unknowns, counts, fit, rmax=rmax, settled=_held(fit, unknowns.k) | (flat != 0))
    return upper_bound(mdp, unknowns, counts, fit.theta, fit.model, fit.player, rmax, best, V_best, group)


def _held(fit: PlayerFit, k: int) -> np.ndarray:
    """(k,) which rewards the fit held at -rmax (none when it did not hold any)."""
    return fit.held if fit.held.size else np.zeros(k, dtype=bool)
