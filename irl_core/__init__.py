"""careful's maths: worlds, the MDP, planning, demonstrations and inverse RL. No terminal code.

The public API, for a notebook or a script::

    import irl_core as careful

    demos = careful.Demonstrations.from_recordings([careful.read_recording("session.jsonl")])
    result = careful.fit(demos, intervals=True)
    result.reward_grid, result.interval_grid, result.evaluation

docs/tutorial.md walks through it; docs/api.md lists every name.

Names are imported on first use: the whole API pulls in cvxpy, HiGHS and Gymnasium (0.6 to 0.7 s
with `python -X importtime` on a 2-core machine, against 0.3 s for the world and game modules
`careful play` imports), which the game should not wait for.

May import: numpy, scipy, cvxpy, highspy, pydantic, threadpoolctl, gymnasium and itself; never
`careful_tui`, Rich or Textual (a test reads the imports).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # for type checkers and the API reference; at run time __getattr__ imports them
    from irl_core.demonstrations import Demonstrations, Recording, RecordingError, read_recording, read_recordings  # noqa: F401
    from irl_core.env import ENV_ID, CarefulEnv  # noqa: F401
    from irl_core.experts import boltzmann_policy, demonstrations_of, optimal_policy, rollouts, simulate_to_file  # noqa: F401
    from irl_core.irl.evaluation import Evaluation, evaluate  # noqa: F401
    from irl_core.irl.fit import METHODS, fit  # noqa: F401
    from irl_core.irl.options import FitOptions  # noqa: F401
    from irl_core.irl.result import FitError, FitResult, InfeasibleError  # noqa: F401
    from irl_core.mdp import MDP, build_mdp  # noqa: F401
    from irl_core.planning import value_iteration  # noqa: F401
    from irl_core.simulated_study import simulated_participants, write_simulated_participant  # noqa: F401
    from irl_core.study import LoadedStudy, Study, StudyError, load_study, read_protocol  # noqa: F401
    from irl_core.world import BUILTIN_WORLDS, World, WorldError, load_world, world_from_dict  # noqa: F401

# Each public name and the module it comes from.
_HOMES = {
    # worlds
    "World": "irl_core.world", "WorldError": "irl_core.world", "BUILTIN_WORLDS": "irl_core.world",
    "load_world": "irl_core.world", "world_from_dict": "irl_core.world",
    "MDP": "irl_core.mdp", "build_mdp": "irl_core.mdp", "value_iteration": "irl_core.planning",
    # reading recordings
    "read_recording": "irl_core.demonstrations", "read_recordings": "irl_core.demonstrations",
    "Recording": "irl_core.demonstrations", "Demonstrations": "irl_core.demonstrations",
    "RecordingError": "irl_core.demonstrations",
    # computer experts
    "optimal_policy": "irl_core.experts", "boltzmann_policy": "irl_core.experts", "rollouts": "irl_core.experts",
    "demonstrations_of": "irl_core.experts", "simulate_to_file": "irl_core.experts",
    # fitting
    "fit": "irl_core.irl.fit", "METHODS": "irl_core.irl.fit", "FitOptions": "irl_core.irl.options",
    "FitResult": "irl_core.irl.result", "FitError": "irl_core.irl.result", "InfeasibleError": "irl_core.irl.result",
    # what an agent trained on a fit would do
    "evaluate": "irl_core.irl.evaluation", "Evaluation": "irl_core.irl.evaluation",
    # the Gymnasium environment
    "CarefulEnv": "irl_core.env", "ENV_ID": "irl_core.env",
    # studies
    "Study": "irl_core.study", "LoadedStudy": "irl_core.study", "StudyError": "irl_core.study",
    "load_study": "irl_core.study", "read_protocol": "irl_core.study",
    "simulated_participants": "irl_core.simulated_study", "write_simulated_participant": "irl_core.simulated_study",
}

__all__ = sorted(_HOMES)


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'irl_core' has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_HOMES])
