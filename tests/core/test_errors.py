"""One tree of exceptions: every exception class of irl_core and careful_tui is defined in `irl_core.errors`, under
`CarefulError`, and drawn in its docstring; a refusal of the input is caught by one `except InputError`."""

from __future__ import annotations

import ast
import builtins
import pickle
import re
from pathlib import Path

import pytest

import irl_core.errors as errors
from careful_tui.cli import main
from irl_core.errors import CarefulError, FitError, InputError, InternalError, RecordingError, WorldError
from irl_core.irl.notes import worded
from irl_core.recordings.demonstrations import read_recording
from irl_core.support.safe_text import VALUE_LIMIT, cut
from irl_core.worlds.world import load_world

ROOT = Path(__file__).parents[2]
ERRORS_FILE = ROOT / "irl_core" / "errors.py"
BUILTIN_EXCEPTIONS = {name for name, value in vars(builtins).items()
                      if isinstance(value, type) and issubclass(value, BaseException)}


def base_names(node: ast.ClassDef) -> set[str]:
    """The names a class's bases are written with: `ValueError`, `errors.InputError` -> `InputError`."""
    return {base.id if isinstance(base, ast.Name) else base.attr
            for base in node.bases if isinstance(base, ast.Name | ast.Attribute)}


def looks_like_exception(name: str, known: set[str]) -> bool:
    return name in known or name.endswith(("Error", "Exception", "Warning"))


def defined_classes(path: Path) -> list[ast.ClassDef]:
    return [node for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))) if isinstance(node, ast.ClassDef)]


def test_every_exception_class_is_defined_in_the_errors_module():
    tree_names = {node.name for node in defined_classes(ERRORS_FILE)}
    known = BUILTIN_EXCEPTIONS | tree_names
    classes = [(path, node) for package in ("irl_core", "careful_tui") for path in sorted((ROOT / package).rglob("*.py"))
               if path != ERRORS_FILE for node in defined_classes(path)]
    # Until nothing changes: a subclass of an exception found in the project is an exception too.
    elsewhere: dict[str, str] = {}
    while True:
        found = {node.name: f"{path.relative_to(ROOT)}:{node.lineno}" for path, node in classes
                 if any(looks_like_exception(name, known | elsewhere.keys()) for name in base_names(node))}
        if found.keys() <= elsewhere.keys():
            break
        elsewhere |= found
    assert elsewhere == {}, f"exception classes outside irl_core/errors.py: {elsewhere}"
    # The search can fail: it finds every class of the tree when it is read as if it were elsewhere.
    assert {node.name for node in defined_classes(ERRORS_FILE)
            if any(looks_like_exception(name, BUILTIN_EXCEPTIONS | tree_names) for name in base_names(node))} == tree_names


def tree_classes() -> dict[str, type]:
    return {node.name: getattr(errors, node.name) for node in defined_classes(ERRORS_FILE)}


def test_every_class_of_the_errors_module_is_a_careful_error():
    classes = tree_classes()
    assert len(classes) > 25
    assert [name for name, cls in classes.items() if not issubclass(cls, CarefulError)] == []


def drawn_tree() -> list[tuple[int, str]]:
    """The docstring's tree: (indent, class name) for each line that names a class, in order."""
    doc = errors.__doc__ or ""
    block = doc.split("::\n", 1)[1].split("\n\n", 1)[0]  # the literal block after "::", to its first blank line
    names = tree_classes()
    return [(len(match[1]), match[2]) for line in block.splitlines()
            if (match := re.match(r"( +)(\w+)\s", line)) and match[2] in names]


def test_the_docstring_draws_every_class_once_under_a_class_it_derives_from():
    drawn = drawn_tree()
    names = [name for _, name in drawn]
    assert sorted(names) == sorted(tree_classes()) and len(names) == len(set(names))
    assert drawn[0] == (4, "CarefulError")
    classes = tree_classes()
    parents: list[tuple[int, str]] = []
    for indent, name in drawn:
        while parents and parents[-1][0] >= indent:
            parents.pop()
        if parents:
            assert issubclass(classes[name], classes[parents[-1][1]]), f"{name} is drawn under {parents[-1][1]}"
        parents.append((indent, name))


def test_the_builtin_bases_of_before_the_tree_are_kept():
    # An `except ValueError`, `except OSError` or `except RuntimeError` catches what it caught before the tree.
    kept = {ValueError: ("InputError", "WorldError", "RecordingError", "StudyError", "OutputError", "PlanError",
                         "SchedulerError", "LinksError", "NotConverged", "Mismatch", "KeyRefused"),
            RuntimeError: ("FitError", "SolverError", "BadInputError", "LostCall", "GameOver", "Stopped"),
            OSError: ("RecordingLost",)}
    for builtin, names in kept.items():
        assert [name for name in names if not issubclass(getattr(errors, name), builtin)] == []
    assert not issubclass(errors.Stopped, InputError | InternalError)


def test_the_copied_helpers_say_what_the_originals_say():
    for text in ("short", "x" * 80, "y" * 81, "z" * 5000):
        for limit in (VALUE_LIMIT, 200):
            assert errors._cut(text, limit) == cut(text, limit)
    assert errors._VALUE_LIMIT == VALUE_LIMIT
    for sentence in ("raise {rmax}", "try {method=loss}, {intervals=True} or {beta=2.5}, not {x=None} {y=a b}", "{}"):
        assert str(FitError(sentence)) == worded(sentence)


def test_a_fit_error_keeps_its_kind_and_code_through_a_pickle():
    for kind in (errors.FitError, errors.BadInputError, errors.InfeasibleError, errors.SolverError):
        back = pickle.loads(pickle.dumps(kind("no reward with {rmax}", code="fine_code")))
        assert type(back) is kind and back.code == "fine_code" and str(back) == "no reward with rmax"


def test_a_bad_world_file_and_a_bad_recording_are_input_errors(tmp_path):
    world = tmp_path / "world.toml"
    world.write_text('layout = "no such layout"\nlevels = "many"\n', encoding="utf-8")
    recording = tmp_path / "session.jsonl"
    recording.write_text('{"kind": "session"}\nnot json\n', encoding="utf-8")
    caught = []
    for call in (lambda: load_world(world), lambda: read_recording(recording), lambda: load_world(tmp_path / "none.toml")):
        try:
            call()
        except InputError as exc:
            caught.append(type(exc))
    assert caught == [WorldError, RecordingError, WorldError]


def test_the_command_line_says_an_input_error_in_one_line_and_exits_2(tmp_path, capsys):
    recording = tmp_path / "session.jsonl"
    recording.write_text("not json\n", encoding="utf-8")
    assert main(["fit", str(recording), "--no-view"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"careful fit: {recording}:1: ") and len(err.strip().splitlines()) == 1
    assert "unexpected" not in err


def test_a_careful_error_the_cli_does_not_take_as_input_is_an_unexpected_error(monkeypatch, capsys):
    import careful_tui.cli as cli

    def lost(args):
        raise errors.LostCall("the worker died")

    monkeypatch.setitem(cli.COMMANDS, "worlds", lost)
    assert main(["worlds"]) == 1
    assert "unexpected error: LostCall: the worker died" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["FitError", "InfeasibleError", "RecordingError", "StudyError", "WorldError"])
def test_the_public_names_of_the_tree_are_the_errors_modules(name):
    import irl_core
    import irl_core.irl
    import irl_core.irl.result as result

    assert getattr(irl_core, name) is getattr(errors, name)
    if hasattr(result, name):
        assert getattr(result, name) is getattr(errors, name) is getattr(irl_core.irl, name)
    assert irl_core.InputError is InputError and irl_core.CarefulError is CarefulError
