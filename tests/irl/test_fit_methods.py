"""One registry of IRL methods, notes with codes, and options said as the reader's words."""

import dataclasses
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from careful_tui.cli import build_parser
from careful_tui.option_words import FLAGS, said
from careful_tui.screens.fit import FitScreen
from irl_core.irl import FitOptions, InfeasibleError, Note, SolverError, choices, fit
from irl_core.irl.intervals.bootstrap import Refit
from irl_core.irl.notes import CODES
from irl_core.irl.qmap import build_unknowns
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

DOCS = Path(__file__).resolve().parents[2] / "docs" / "fit-json.md"


def test_an_unknown_method_is_refused_where_it_enters():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    with pytest.raises(ValueError, match="method must be one of auto, lp, loss, maxent, not 'lasso'"):
        FitOptions(method="lasso")
    with pytest.raises(ValueError, match="no bootstrap refit for method 'lp'"):
        Refit(mdp=mdp, unknowns=build_unknowns(mdp, reward_cells="special", tie=False), method="lp", rmax=1.0,
              lam=0.0, beta=1.0, start=(np.zeros(0), 1.0))
    with pytest.raises(SystemExit):
        build_parser().parse_args(["fit", "x.jsonl", "--method", "lasso"])


def test_every_reader_of_a_method_name_takes_it_from_the_registry():
    # One fitter per registry entry, one refit per resampled method; a bootstrap interval has a refit, nothing else.
    from irl_core.irl.fitters import FITTERS
    from irl_core.irl.intervals.bootstrap import REFITS

    assert set(FITTERS) == set(choices.METHODS) and all(callable(f) for f in FITTERS.values())
    assert set(REFITS) == set(choices.RESAMPLED)
    for entry in choices.METHODS.values():
        assert entry.resampled == (entry.interval_kind == "confidence")
    method_flag = next(a for a in build_parser()._subparsers._group_actions[0].choices["fit"]._actions
                       if a.dest == "method")
    assert tuple(method_flag.choices) == choices.NAMES and method_flag.default == choices.DEFAULT
    keys = {b.key: b.action for b in FitScreen.BINDINGS if b.action.startswith("method(")}
    assert keys == {m.key: f"method('{m.name}')" for m in choices.METHODS.values()}


def test_the_registries_names_are_their_literal_types():
    from typing import get_args

    assert set(get_args(choices.MethodName)) == set(choices.METHODS)
    assert set(get_args(choices.PlayerModelName)) == set(choices.PLAYER_MODELS)


@pytest.mark.parametrize(("given", "after_auto", "fixed_beta", "holds", "runs"), [
    (None, True, False, False, "auto"), (None, True, True, False, "boltzmann"), (None, False, False, False, "boltzmann"),
    (None, True, False, True, "timing"), (None, False, True, True, "timing"), ("person", False, False, True, "person"),
    ("timing", True, False, False, "timing"), ("naive", True, False, False, "naive"),
])
def test_one_place_decides_the_player_model(given, after_auto, fixed_beta, holds, runs):
    assert choices.player_model_for(given, after_auto=after_auto, fixed_beta=fixed_beta, holds=holds) == runs


def test_the_library_defaults_to_auto_as_the_command_line_does():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    assert FitOptions().method == "auto" == build_parser().parse_args(["fit", "x.jsonl"]).method
    result = fit(demos)
    assert result.options.method == "auto" and result.method == "lp" and result.notes[0].code == "auto_chose"
    assert np.array_equal(result.theta, fit(demos, method="lp").theta)


def test_a_note_is_a_code_and_a_sentence_said_as_parameters_or_as_flags():
    note = Note("beta_fixed", "beta fixed at 2, not estimated ({beta=auto} estimates it; try {rmax} "
                              "or {intervals=True})")
    assert str(note) == 'beta fixed at 2, not estimated (beta="auto" estimates it; try rmax or intervals=True)'
    assert said(note) == "beta fixed at 2, not estimated (--beta auto estimates it; try --rmax or --intervals)"
    assert pickle.loads(pickle.dumps(note)) == note
    with pytest.raises(ValueError, match="unknown note code 'beta_fixd'"):
        Note("beta_fixd", "beta fixed at 2")


def test_every_option_has_its_flag():
    assert set(FLAGS) == {field.name for field in dataclasses.fields(FitOptions)}


def test_an_error_keeps_its_code_across_processes_and_speaks_parameters():
    error = SolverError("did not converge: try a smaller {rmax}", code="soft_bellman_diverged")
    back = pickle.loads(pickle.dumps(error))
    assert type(back) is SolverError and back.code == "soft_bellman_diverged"
    assert str(back) == "did not converge: try a smaller rmax" and said(back) == "did not converge: try a smaller --rmax"
    assert InfeasibleError("x").code == "infeasible"


def test_a_bad_option_is_said_as_a_parameter_to_the_library():
    problem = FitOptions(method="loss", beta="auto").problem()
    assert problem.code == "beta_needs_maxent"
    assert str(problem) == 'beta="auto" needs method="maxent" or auto: loss has no temperature to estimate'


def test_no_note_the_core_writes_names_a_flag():
    """The core's sentences name `fit`'s parameters; only the command line's table names flags."""
    core = Path(__file__).resolve().parents[2] / "irl_core" / "irl"
    flags = re.compile(r'"[^"\n]*--(?:method|rmax|lambda|beta|reward-cells|tie|intervals|confidence|resamples|seed)\b')
    for path in core.glob("*.py"):
        code = "\n".join(line for line in path.read_text().splitlines() if not line.lstrip().startswith("#"))
        code = re.sub(r'"""[\s\S]*?"""', "", code)
        assert not flags.findall(code), path.name


def test_the_json_notes_have_their_codes_and_the_docs_list_every_code():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    data = fit(demos, method="maxent", beta=2.0).to_json()
    assert data["note_codes"] == [note.code for note in fit(demos, method="maxent", beta=2.0).notes]
    assert "beta_fixed" in data["note_codes"] and len(data["notes"]) == len(data["note_codes"])
    documented = set(re.findall(r"^\| `(\w+)` \|", DOCS.read_text().split("## Note codes")[1], flags=re.MULTILINE))
    fit_codes = set(CODES) - {"beta_needs_maxent", "bad_confidence", "too_few_resamples",
                                  "beta_needs_boltzmann"}
    assert documented == fit_codes
