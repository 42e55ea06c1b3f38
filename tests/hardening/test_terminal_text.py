"""Text from a file or a flag never drives the terminal: control characters are shown escaped, markup is text.

A world name or player holding `ESC ] 2 ; ... BEL` (retitle the terminal), `ESC [ 2 J` (clear it),
`[/]` (a Rich markup error) or `[link=...]` (a hyperlink) goes through every place that shows it:
`worlds --show`, `fit --no-view`, the error path, `replay`, `play` (the screens through Pilot, and
`play --player` in a real terminal), and the fit view's file name.
"""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from hardening_checks import RAW_CONTROL, assert_refused, careful, digest, recording
from tmux_terminal import needs_tmux, terminal

from careful_tui.app import make_play_app, make_replay_app
from careful_tui.screens.fit import default_svg_name
from irl_core.recordings.demonstrations import read_recording
from irl_core.support.safe_text import MESSAGE_LIMIT, cut, one_line, printable
from irl_core.worlds.world import World

RETITLE, CLEAR = "\x1b]2;pwned\x07", "\x1b[2J"
EVIL = f"{RETITLE}[/][link=file:///etc/passwd]y{CLEAR}"
SHOWN = r"\x1b]2;pwned\x07[/][link=file:///etc/passwd]y\x1b[2J"


def evil_world_toml(path: Path) -> Path:
    # TOML writes control characters as \u escapes; the name holds the raw characters once read.
    name = EVIL.encode("unicode_escape").decode().replace("\\x", "\\u00")
    path.write_text(f'name = "{name}"\nlayout = """\n...\n.CG\n"""\n[rewards]\nC = -100.0\nG = 10.0\n')
    return path


def evil_recording(tmp_path: Path) -> Path:
    """A recording whose world name and player are EVIL."""
    plain = recording(tmp_path / "plain.jsonl", episodes=2)
    lines = plain.read_text().splitlines()
    header = json.loads(lines[0])
    header["world"]["name"], header["player"] = EVIL, EVIL
    path = tmp_path / "evil.jsonl"
    path.write_text("\n".join([json.dumps(header), *lines[1:]]) + "\n")
    return path


def test_printable_escapes_what_moves_or_hides_text():
    assert printable(EVIL) == SHOWN
    assert printable("a\u202eb\u200bc\x85d\ud8ff") == r"a\u202eb\u200bc\x85d\ud8ff"
    assert printable("two\nlines", keep_newlines=True) == "two\nlines" and printable("a\nb") == r"a\x0ab"
    assert printable("ok: é ü 日本 ☺") == "ok: é ü 日本 ☺"
    assert cut("x" * 5000, 80).endswith("… (5,000 characters)") and len(cut("x" * 5000, 80)) <= 80


def test_one_line_keeps_the_end_of_a_long_message():
    message = one_line("f.jsonl:3: player: " + "p" * 5000 + " is the problem")
    assert len(message) <= MESSAGE_LIMIT + 20 and message.startswith("f.jsonl:3: player: ")
    assert message.endswith("is the problem") and "characters cut" in message


def test_worlds_show_prints_a_hostile_name_as_text(tmp_path, capsys):
    world = evil_world_toml(tmp_path / "evil.toml")
    status, out, err = careful(capsys, "worlds", "--show", world)
    assert status == 0, err
    assert SHOWN in out and not RAW_CONTROL.search(out + err)
    assert "\x1b]8;" not in out  # no hyperlink


def test_fit_no_view_prints_a_hostile_world_name_as_text(tmp_path, capsys):
    path = evil_recording(tmp_path)
    before = digest(path)
    status, out, err = careful(capsys, "fit", path, "--no-view")
    assert status == 0, err
    assert SHOWN in out and not RAW_CONTROL.search(out + err)
    assert digest(path) == before


@pytest.mark.parametrize("where", ["file name", "field name", "field value"])
def test_the_error_path_escapes_what_it_quotes(tmp_path, capsys, where):
    path = recording(tmp_path / "a.jsonl", episodes=1)
    lines = path.read_text().splitlines()
    step = json.loads(lines[1])
    if where == "file name":
        bad = tmp_path / f"{EVIL.replace('/', '_')}.jsonl"
        bad.write_text(lines[0] + "\n{not json\n")
        wanted = r"\x1b]2;pwned\x07"
    else:
        if where == "field name":
            step[EVIL] = 1
        else:
            step["direction"] = EVIL
        bad = tmp_path / "b.jsonl"
        bad.write_text("\n".join([lines[0], json.dumps(step)]) + "\n")
        wanted = ":2: "
    before = digest(bad)
    assert_refused(*careful(capsys, "fit", bad, "--no-view"), wanted)
    assert digest(bad) == before


def test_a_5000_character_value_gives_a_short_line(tmp_path, capsys):
    path = recording(tmp_path / "a.jsonl", episodes=1)
    lines = path.read_text().splitlines()
    for key, value in (("direction", "d" * 5000), ("x" * 5000, 1)):
        step = json.loads(lines[1])
        step[key] = value
        bad = tmp_path / "b.jsonl"
        bad.write_text("\n".join([lines[0], json.dumps(step)]) + "\n")
        line = assert_refused(*careful(capsys, "fit", bad, "--no-view"), "b.jsonl:2: ")
        assert len(line) < 300, len(line)


def test_a_hostile_flag_value_is_escaped_in_the_usage_error(capsys):
    assert_refused(*careful(capsys, "fit", "a.jsonl", "--rmax", f"1{CLEAR}"), r"\x1b[2J", "--rmax")


def _screenshot(app) -> str:
    async def main() -> str:
        async with app.run_test(size=(110, 40)) as pilot:
            await pilot.pause()
            return app.export_screenshot()

    return asyncio.run(main())


def test_replay_shows_hostile_names_as_text(tmp_path):
    svg = _screenshot(make_replay_app(read_recording(evil_recording(tmp_path)), playing=False, frame_seconds=60))
    assert "pwned" in svg and "\x1b" not in svg and "\x07" not in svg
    assert "[/]" in svg.replace("&#160;", " ")


def test_play_shows_a_hostile_world_and_player_as_text(tmp_path):
    world = World(name=EVIL, layout="...\n.CG\n", levels=3, rewards={"C": -100.0, "G": 10.0})
    app = make_play_app(world, out=tmp_path / "rec", player=EVIL, seed=1)
    svg = _screenshot(app)
    assert svg.count("pwned") >= 2 and "\x1b" not in svg and "\x07" not in svg


def test_the_fit_views_svg_name_stays_in_its_folder(tmp_path):
    path = default_svg_name("../../etc/x/" + EVIL, "lp", tmp_path)
    assert path.parent == tmp_path and path.name.startswith("careful-fit-") and path.suffix == ".svg"
    assert not RAW_CONTROL.search(path.name) and "/" not in path.name[len("careful-fit-"):]


@needs_tmux
def test_play_player_cannot_retitle_the_terminal(tmp_path):
    world = tmp_path / "w.toml"
    world.write_text('name = "w"\nlayout = """\n...\n.CG\n"""\nlevels = 3\n')
    args = ["play", "--world", str(world), "--out", str(tmp_path / "rec"), "--player", EVIL, "--seed", "1"]
    with terminal(tmp_path, args) as term:
        title_before = term.tmux("display-message", "-p", "-t", term.name, "#{pane_title}")
        screen = term.wait_for("pwned")
        assert r"\x1b]2;pwned\x07" in screen
        term.send("Right")
        term.wait_for("step 1/")
        term.send("q")
        assert term.wait_exit() == 0
        assert term.tmux("display-message", "-p", "-t", term.name, "#{pane_title}") == title_before
    (path,) = (tmp_path / "rec").glob("*.jsonl")
    assert read_recording(path).header.player == EVIL  # recorded as given, shown escaped
    assert RAW_CONTROL.search(path.name) is None


def test_player_names_that_are_not_utf8_are_refused_before_anything_is_written(tmp_path, capsys):
    out = tmp_path / "rec"
    line = assert_refused(*careful(capsys, "play", "--out", out, "--player", "a\udcff"), "--player", "UTF-8")
    assert not out.exists() and len(line) < 200


def test_the_fit_view_shows_a_hostile_world_name_as_text_and_saves_beside_it(tmp_path, monkeypatch):
    from careful_tui.app import CarefulApp
    from careful_tui.screens.fit import FitScreen
    from irl_core.irl import FitOptions
    from irl_core.recordings.demonstrations import Demonstrations

    path = evil_recording(tmp_path)
    monkeypatch.chdir(tmp_path)
    app = CarefulApp(FitScreen(Demonstrations.read([path]), FitOptions(method="lp"), sources=[path]))

    async def main() -> str:
        async with app.run_test(size=(140, 45)) as pilot:
            for _ in range(100):
                await pilot.pause(0.05)
                if app.first_screen.result is not None:
                    break
            await pilot.press("s")
            await pilot.pause()
            return app.export_screenshot()

    svg = asyncio.run(main())
    assert "pwned" in svg and "\x1b" not in svg and "\x07" not in svg
    (saved,) = app.first_screen.saved
    assert saved.parent == tmp_path and saved.exists() and "\x1b" not in saved.read_text()
