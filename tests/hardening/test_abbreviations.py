"""No flag is read as the start of another: `--participant 5` on `study plan` is refused (exit 2), never
run as `--participants 5` over the last plan's files; argparse's `allow_abbrev` is off on every parser."""

from __future__ import annotations

import argparse
from collections.abc import Iterator

import pytest

from careful_tui.cli import build_parser
from hardening_checks import careful
from study.conftest import write_study


def every_parser(parser: argparse.ArgumentParser) -> Iterator[argparse.ArgumentParser]:
    """`parser` and every subcommand's parser below it."""
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                yield from every_parser(child)


def test_no_parser_of_the_command_line_takes_an_abbreviated_flag():
    parsers = list(every_parser(build_parser()))
    assert len(parsers) > 10  # the walk reached the subcommands (play, ..., study plan)
    assert [p.prog for p in parsers if p.allow_abbrev] == []


@pytest.mark.parametrize("argv", [
    # With the bug this ran a plan: kept small (one study of 2 episodes) so that a regression fails fast.
    ["study", "plan", "{study}", "--participant", "2", "--episodes", "2", "--repeats", "1", "--workers", "1"],
    ["fit", "recordings/x.jsonl", "--interval"],
    ["serve", "{study}", "--link", "3"],
])
def test_an_abbreviated_flag_is_refused_with_one_line(capsys, tmp_path, argv):
    study = write_study(tmp_path)
    status, out, err = careful(capsys, *(a.format(study=study) for a in argv))
    assert status == 2, (out, err)
    assert "unrecognized arguments" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "data").exists()
