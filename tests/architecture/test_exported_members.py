"""The public API, pinned: what `import irl_core` and its faces export changes only on purpose.

A name added here is a promise to users (docs/api.md documents them); a name that disappears breaks their
scripts. Each face's names resolve, and nothing else is exported by accident.
"""

import importlib

import pytest

PUBLIC = {
    "irl_core": [
        "BUILTIN_WORLDS", "CarefulEnv", "CarefulError", "Demonstrations", "ENV_ID", "Evaluation", "FitError", "FitOptions",
        "FitResult", "InfeasibleError", "InputError", "LoadedStudy", "MDP", "METHODS", "Recording", "RecordingError", "Study",
        "StudyError", "World", "WorldError", "boltzmann_policy", "build_mdp", "demonstrations_of", "evaluate", "fit",
        "load_study", "load_world", "optimal_policy", "read_protocol", "read_recording", "read_recordings",
        "rollouts", "simulate_to_file", "simulated_participants", "value_iteration", "world_from_dict",
        "write_simulated_participant",
        # reach worlds (docs/reach.md)
        "REACH_ENV_ID", "REACH_WORLDS", "ReachEnv", "ReachFit", "ReachWorld", "expected_gain", "fit_reaches",
        "load_reach_world", "reacher", "read_reaches", "simulate_reaches_to_file",
    ],
    "irl_core.irl": [
        "BadInputError", "FitError", "FitOptions", "FitResult", "InfeasibleError", "METHODS", "Note", "SolverError",
        "Stopped", "at_bound", "fit",
    ],
    "irl_core.irl.people": [
        "FLAT_DROP", "MAX_COMBINED", "ModelChoice", "NEARLY_FLAT", "PlayerFit", "PlayerRefit", "choose_player_model", "close_models",
        "curvature_scale", "fit_given_model", "hand_from_trials", "laplace_intervals", "log_likelihood", "note_of_bounds",
        "people_checks", "planning_rival",
    ],
}


@pytest.mark.parametrize("package", sorted(PUBLIC))
def test_a_face_exports_exactly_its_pinned_names_and_each_resolves(package):
    module = importlib.import_module(package)
    assert sorted(module.__all__) == sorted(PUBLIC[package])
    for name in module.__all__:
        assert getattr(module, name) is not None, name
