"""careful's maths: worlds, the MDP, planning, demonstrations and inverse RL. No terminal code.

The public API, for a notebook or a script::

    import irl_core as careful

    demos = careful.Demonstrations.from_recordings([careful.read_recording("session.jsonl")])
    result = careful.fit(demos, intervals=True)
    result.reward_grid, result.interval_grid, result.evaluation

docs/tutorial.md walks through it; docs/api.md lists every name.

The wings, each importing only from those before it in this list (a test reads the imports):

==============  ==============================================================================
``support``     safe files and text, CSV cells, counted words, the process pool, the stop check
``worlds``      world files and the built-in worlds, the MDP, planning, the Gymnasium environment
``recordings``  the JSONL lines, writer, reader, column tables, replay's model, export formats
``play``        the game's rules and one play session for any front end; the input modes
``players``     computer experts and person-like players
``reach``       reach worlds' expected gain, computer reachers and fit (the world itself is ``worlds``)
``irl``         the fitting methods and their registry, the models of the player, intervals
``coverage``    ``careful check``: how often a fit's intervals hold the truth
``experiment``  the paper's experiment and its claims
``studies``     study files, a participant's flow, the lock, simulated participants, the report
==============  ==============================================================================

Below every wing, `irl_core.errors` holds every exception class of careful in one tree (its
docstring draws it) and imports nothing of the project, so any module may import it.

Names are imported on first use: the whole API pulls in cvxpy, HiGHS and Gymnasium (0.6 to 0.7 s
with `python -X importtime` on a 2-core machine, against 0.3 s for the world and game modules
`careful play` imports), which the game should not wait for.

May import: numpy, scipy, cvxpy, highspy, pydantic, threadpoolctl, gymnasium and itself; never
`careful_tui`, Rich or Textual (a test reads the imports).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from irl_core.support.lazy import lazy_names

if TYPE_CHECKING:  # for type checkers and the API reference; at run time __getattr__ imports them
    from irl_core.errors import CarefulError, FitError, InfeasibleError, InputError, RecordingError, StudyError, WorldError  # noqa: F401
    from irl_core.irl.evaluation import Evaluation, evaluate  # noqa: F401
    from irl_core.irl.fitting import METHODS, fit  # noqa: F401
    from irl_core.irl.options import FitOptions  # noqa: F401
    from irl_core.irl.result import FitResult  # noqa: F401
    from irl_core.players.experts import boltzmann_policy, demonstrations_of, optimal_policy, rollouts, simulate_to_file  # noqa: F401
    from irl_core.reach.fit import ReachFit, fit_reaches  # noqa: F401
    from irl_core.reach.gain import expected_gain  # noqa: F401
    from irl_core.reach.players import reacher, simulate_reaches_to_file  # noqa: F401
    from irl_core.recordings.demonstrations import Demonstrations, Recording, read_recording, read_recordings  # noqa: F401
    from irl_core.recordings.reach_reader import read_reaches  # noqa: F401
    from irl_core.studies.simulated import simulated_participants, write_simulated_participant  # noqa: F401
    from irl_core.studies.study import LoadedStudy, Study, load_study, read_protocol  # noqa: F401
    from irl_core.worlds.env import ENV_ID, REACH_ENV_ID, CarefulEnv, ReachEnv  # noqa: F401
    from irl_core.worlds.mdp import MDP, build_mdp  # noqa: F401
    from irl_core.worlds.planning import value_iteration  # noqa: F401
    from irl_core.worlds.reach import REACH_WORLDS, ReachWorld, load_reach_world  # noqa: F401
    from irl_core.worlds.world import BUILTIN_WORLDS, World, load_world, world_from_dict  # noqa: F401

# Each public name and the module it comes from.
_HOMES = {
    # worlds
    "World": "irl_core.worlds.world", "WorldError": "irl_core.errors", "BUILTIN_WORLDS": "irl_core.worlds.world",
    "load_world": "irl_core.worlds.world", "world_from_dict": "irl_core.worlds.world",
    "MDP": "irl_core.worlds.mdp", "build_mdp": "irl_core.worlds.mdp", "value_iteration": "irl_core.worlds.planning",
    # reading recordings
    "read_recording": "irl_core.recordings.demonstrations", "read_recordings": "irl_core.recordings.demonstrations",
    "Recording": "irl_core.recordings.demonstrations", "Demonstrations": "irl_core.recordings.demonstrations",
    "RecordingError": "irl_core.errors",
    # computer experts
    "optimal_policy": "irl_core.players.experts", "boltzmann_policy": "irl_core.players.experts",
    "rollouts": "irl_core.players.experts", "demonstrations_of": "irl_core.players.experts",
    "simulate_to_file": "irl_core.players.experts",
    # fitting
    "fit": "irl_core.irl.fitting", "METHODS": "irl_core.irl.fitting", "FitOptions": "irl_core.irl.options",
    "FitResult": "irl_core.irl.result", "FitError": "irl_core.errors", "InfeasibleError": "irl_core.errors",
    # what an agent trained on a fit would do
    "evaluate": "irl_core.irl.evaluation", "Evaluation": "irl_core.irl.evaluation",
    # the Gymnasium environment
    "CarefulEnv": "irl_core.worlds.env", "ENV_ID": "irl_core.worlds.env",
    # studies
    "Study": "irl_core.studies.study", "LoadedStudy": "irl_core.studies.study", "StudyError": "irl_core.errors",
    "load_study": "irl_core.studies.study", "read_protocol": "irl_core.studies.study",
    "simulated_participants": "irl_core.studies.simulated", "write_simulated_participant": "irl_core.studies.simulated",
    # reach worlds
    "ReachWorld": "irl_core.worlds.reach", "REACH_WORLDS": "irl_core.worlds.reach",
    "load_reach_world": "irl_core.worlds.reach", "expected_gain": "irl_core.reach.gain",
    "reacher": "irl_core.reach.players", "simulate_reaches_to_file": "irl_core.reach.players",
    "read_reaches": "irl_core.recordings.reach_reader", "fit_reaches": "irl_core.reach.fit",
    "ReachFit": "irl_core.reach.fit", "ReachEnv": "irl_core.worlds.env", "REACH_ENV_ID": "irl_core.worlds.env",
    # the tree's root, and its branch that `except` takes for every refusal of the input (irl_core.errors draws it)
    "CarefulError": "irl_core.errors", "InputError": "irl_core.errors",
}

__all__ = sorted(_HOMES)


__getattr__, __dir__ = lazy_names(__name__, _HOMES, globals())
