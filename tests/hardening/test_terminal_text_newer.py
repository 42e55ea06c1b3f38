"""The newer commands' text goes through one path too (`irl_core.support.safe_text`): printable, and literal in markup.

Before: a recording's `input.mode` reached replay's hold line raw (an OSC sequence retitled the
terminal); terminal symbols `[` and `]` crashed replay's summary panel with a MarkupError;
`worlds --show` printed C1 controls and bidi overrides raw in its TOML; `experiment --out '[/]x'`
wrote everything, then ended with exit 1.
"""

from __future__ import annotations

import asyncio
import json
import re

import pytest
from hardening_checks import RAW_CONTROL, careful, recording
from rich.markup import render

from careful_tui.app import make_replay_app
from irl_core.players.experts import optimal_policy, rollouts, write_rollouts
from irl_core.recordings.demonstrations import read_recording
from irl_core.support.safe_text import for_markup, is_unsafe
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import World, load_world

RETITLE = "\x1b]2;pwned\x07"
BIDI = re.compile("[\u202a-\u202e\u2066-\u2069]")


def _screenshot(app) -> str:
    async def main() -> str:
        async with app.run_test(size=(120, 40)) as pilot:
            await pilot.pause()
            await pilot.press("right")  # a step: the hold line shows the input mode
            await pilot.pause()
            return app.export_screenshot()

    return asyncio.run(main())


@pytest.mark.parametrize("mode", [RETITLE, "\x9b2J tap", "tap\u202e"])
def test_replays_hold_line_shows_the_input_mode_as_text(tmp_path, mode):
    path = recording(tmp_path / "a.jsonl", episodes=2)
    lines = path.read_text().splitlines()
    header = json.loads(lines[0])
    header["input"] = {"mode": mode}
    path.write_text("\n".join([json.dumps(header), *lines[1:]]) + "\n")
    svg = _screenshot(make_replay_app(read_recording(path), playing=False, frame_seconds=60))
    assert not RAW_CONTROL.search(svg) and not BIDI.search(svg), "a raw control reached the screen"
    assert "input" in svg


@pytest.mark.parametrize("terminal", [("[", "]"), ("[", "/", "]")])
def test_replays_summary_panel_shows_bracket_terminals_as_text(tmp_path, terminal):
    layout = "....\n." + "".join(terminal) + "\n" if len(terminal) == 3 else "....\n..[]\n"
    world = World(name="brackets", layout=layout, levels=3, terminal=terminal,
                  rewards={terminal[0]: -100.0, terminal[-1]: 10.0})
    mdp = build_mdp(world)
    path = write_rollouts(tmp_path / "b.jsonl", mdp, rollouts(mdp, optimal_policy(mdp), episodes=2, seed=0),
                          player="expert:optimal", seed=0)
    svg = _screenshot(make_replay_app(read_recording(path), playing=False, frame_seconds=60))
    assert "distance" in svg and "/".join(terminal) in svg.replace("&#160;", " ")


@pytest.mark.parametrize("hostile", ["\x9b2J", "\u202eevil", "a\u2066b\x85"])
def test_worlds_show_escapes_c1_controls_and_bidi_overrides(tmp_path, capsys, hostile):
    name = hostile.encode("unicode_escape").decode().replace("\\x", "\\u00")
    world = tmp_path / "w.toml"
    world.write_text(f'name = "x{name}y"\nlayout = """\n....\n.CCG\n"""\n')
    status, out, err = careful(capsys, "worlds", "--show", world)
    assert status == 0, err
    assert not RAW_CONTROL.search(out + err) and not BIDI.search(out + err), repr(out)
    # The TOML it prints reads back to the same name.
    toml = out[out.index("name = "):]
    (tmp_path / "again.toml").write_text(toml)
    assert load_world(tmp_path / "again.toml").name == f"x{hostile}y"


@pytest.mark.parametrize("text", ["[/]x", "a[bold]b[/bold]", "[link=file:///etc]x", "\\[/]", "[@click=quit]"])
def test_for_markup_is_literal(text):
    assert render(for_markup(text)).plain == text


def test_is_unsafe_covers_c1_bidi_and_surrogates():
    assert all(is_unsafe(ch) for ch in "\x1b\x9b\x85\u202e\u2066\u200b\ufeff\ud800")
    assert not any(is_unsafe(ch) for ch in "a[]/é日☺")


def test_experiment_out_with_markup_and_a_bad_recording_ends_well(tmp_path, capsys, monkeypatch):
    """`--out '[/]x'` wrote everything, then ended with exit 1 on its last line; a bad file in
    --recordings (episode 2^63) ended the whole experiment. Now: exit 0, the folder named as text,
    the bad file named in the notes."""
    monkeypatch.chdir(tmp_path)
    people = tmp_path / "people"
    people.mkdir()
    good = recording(people / "a.jsonl", episodes=3)
    text = good.read_text().replace('"expert:optimal"', '"ann"')
    good.write_text(text)
    (people / "b.jsonl").write_text(text.replace('"episode": 0,', f'"episode": {2**63},', 1))
    status, out, err = careful(capsys, "experiment", "--quick", "--recordings", people, "--out", "[/]x")
    assert status == 0, err
    assert "are in [/]x/" in out and (tmp_path / "[" / "]x" / "report.md").exists()
    assert "b.jsonl:2: episode" in " ".join(out.split()), out[-1500:]
