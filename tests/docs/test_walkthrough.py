"""The README's walkthrough works after `make play`: its `careful fit` glob takes the session `make play`
recorded (named by the user's name, not "me"), and no shipped example is caught by it."""

import fnmatch
import re
from datetime import datetime
from pathlib import Path

from careful_tui.commands.play import default_player
from irl_core.recordings.writer import slug

ROOT = Path(__file__).parents[2]
MAKE_PLAY = re.compile(r"^play:.*\n\t\$\(BIN\)/careful play(.*)$", re.MULTILINE)


def walkthrough_fit_globs() -> list[str]:
    return re.findall(r"^careful fit (recordings/\S+)", (ROOT / "README.md").read_text(encoding="utf-8"), re.MULTILINE)


def test_make_play_names_its_recording_by_the_user_and_the_walkthrough_fits_it():
    assert MAKE_PLAY.search((ROOT / "Makefile").read_text()).group(1).strip() == ""  # no --player: the user's name
    # As RecordingWriter.create_in names a session of the default player.
    recorded = f"recordings/{datetime(2026, 12, 2, 2, 0, 53):%Y%m%d-%H%M%S}-{slug(default_player())}.jsonl"
    globs = walkthrough_fit_globs()
    assert globs and all(fnmatch.fnmatch(recorded, pattern) for pattern in globs), (recorded, globs)


def test_no_shipped_example_lies_where_the_walkthrough_globs():
    shipped = ROOT / "recordings" / "samples" / "sample-expert-paper.jsonl"
    assert shipped.is_file()
    for pattern in walkthrough_fit_globs():
        caught = [p.name for p in ROOT.glob(pattern) if p.name.startswith("sample-")]
        assert caught == [], pattern
    assert "samples/" in (ROOT / "recordings" / "README.md").read_text()
