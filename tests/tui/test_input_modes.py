"""The registry of input modes: every place that offers or explains a mode reads it, and an
unknown name is refused where it enters."""

from __future__ import annotations

import pytest

from careful_tui.cli import build_parser
from careful_tui.screens.play import PlayScreen
from irl_core.play.input_modes import DEFAULT_INPUT_MODE, INPUT_MODE_NAMES, INPUT_MODES, input_mode
from irl_core.play.session import PlayOptions
from irl_core.studies.study import Study


def test_the_study_file_takes_exactly_the_registered_modes() -> None:
    # The study file's field reads the registry: every registered mode, nothing else, the registry's default.
    for name in INPUT_MODE_NAMES:
        assert Study(name="s", worlds=("mud",), input=name).input == name
    with pytest.raises(ValueError, match="unknown input mode 'joystick': use one of hold, tap, digits"):
        Study(name="s", worlds=("mud",), input="joystick")
    assert Study.model_fields["input"].default == DEFAULT_INPUT_MODE


def test_the_command_line_offers_and_explains_every_registered_mode() -> None:
    play = build_parser()._subparsers._group_actions[0].choices["play"]
    (option,) = [action for action in play._actions if action.dest == "input"]
    assert tuple(option.choices) == INPUT_MODE_NAMES and option.default == DEFAULT_INPUT_MODE
    for mode in INPUT_MODES.values():
        assert f"{mode.name}: {mode.cli_help}" in option.help


@pytest.mark.parametrize("name", INPUT_MODE_NAMES)
def test_every_mode_builds_its_input_and_names_its_keys(name: str) -> None:
    from irl_core.play.hold import HoldProfile

    mode = input_mode(name)
    made = mode.make(HoldProfile(levels=5), lambda: 0.0)
    assert made.mode == name and mode.header(HoldProfile(levels=5))["mode"] == name
    assert mode.study_words.endswith(".") and mode.cli_help
    for k in (2, 3):  # the narrowest gauge holds 17 characters a line
        assert all(len(line) <= 17 for line in mode.gauge_help(k).splitlines())
    named = {key for hint in mode.key_hints for key in hint.keys.split(",")}
    assert named <= made.keys | {"escape"} and {"up", "right", "down", "left"} <= named
    shown = [b.description for b in PlayScreen.BINDINGS if b.action == f"move({name!r})"]
    assert shown == [hint.words for hint in mode.key_hints]


def test_an_unknown_mode_is_refused_where_it_enters() -> None:
    with pytest.raises(ValueError, match="unknown input mode 'joystick': use one of hold, tap, digits"):
        PlayOptions(input_mode="joystick")
    with pytest.raises(ValueError, match="use one of hold, tap, digits"):
        input_mode("joystick")
    with pytest.raises(SystemExit):
        build_parser().parse_args(["play", "--input", "joystick"])
