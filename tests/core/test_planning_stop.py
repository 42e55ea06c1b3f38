"""Value iteration asks the fit's stop check before every sweep: a fit no longer wanted ends
within one sweep of its planning (1.6 s of sweeps on a 64x64 world), and a check that never
says yes changes nothing. Counted in sweeps (`MDP.expected_next` calls), not seconds."""

import numpy as np
import pytest
from planning_sweeps import count_sweeps

from bench.worlds import cliff_world
from irl_core.errors import Stopped
from irl_core.support.stopping import stop_when
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import soft_value_iteration, value_iteration

PLANNERS = {"value iteration": value_iteration,
            "soft value iteration": lambda mdp: soft_value_iteration(mdp, beta=1.0)}


@pytest.fixture(scope="module")
def cliff():
    return build_mdp(cliff_world(16, 16))


@pytest.mark.parametrize("planner", PLANNERS)
def test_planning_told_to_stop_after_five_sweeps_stops_there(cliff, planner, monkeypatch):
    plan = PLANNERS[planner]
    sweeps = count_sweeps(monkeypatch)
    assert plan(cliff).iterations > 50  # the whole planning is long enough for the 5th to matter
    sweeps[0] = 0
    with stop_when(lambda: sweeps[0] >= 5), pytest.raises(Stopped):
        plan(cliff)
    assert sweeps[0] == 5


@pytest.mark.parametrize("planner", PLANNERS)
def test_a_check_that_never_says_yes_is_asked_every_sweep_and_changes_nothing(cliff, planner):
    plan = PLANNERS[planner]
    asked = [0]

    def never() -> bool:
        asked[0] += 1
        return False

    plain = plan(cliff)
    with stop_when(never):
        checked = plan(cliff)
    assert asked[0] == plain.iterations
    assert checked.iterations == plain.iterations and checked.residual == plain.residual
    for name in ("V", "Q", "policy"):
        assert np.array_equal(getattr(checked, name), getattr(plain, name)), name
