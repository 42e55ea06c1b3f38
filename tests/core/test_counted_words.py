"""Counts in printed and shown text agree with their nouns: "1 episode", "1 carefulness level", "1 file"."""

import asyncio
import json
from pathlib import Path

from careful_tui.app import CarefulApp
from careful_tui.cli import main
from careful_tui.screens.fit import FitScreen
from irl_core.irl import FitOptions
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.support.plural import plural

SAMPLE = Path(__file__).parents[2] / "recordings" / "samples" / "sample-expert-paper.jsonl"


def test_plural_counts_one_apart():
    assert [plural(n, "level") for n in (0, 1, 2)] == ["0 levels", "1 level", "2 levels"]


def test_simulating_one_episode_says_one_episode(tmp_path, capsys):
    out = tmp_path / "one.jsonl"
    assert main(["simulate", "--world", "mud", "--policy", "optimal", "--episodes", "1", "--seed", "0",
                 "--out", str(out)]) == 0
    assert capsys.readouterr().err.startswith(f"wrote 1 episode (ended: 1 G) to {out}")


def test_a_world_of_one_level_is_shown_with_one_level(capsys):
    assert main(["worlds", "--show", "paper-simple"]) == 0
    assert "4x6 cells, 1 carefulness level, slip" in capsys.readouterr().out


def test_a_level_beyond_a_one_level_world_is_refused_in_the_singular(tmp_path, capsys):
    recording = tmp_path / "simple.jsonl"
    assert main(["simulate", "--world", "paper-simple", "--policy", "optimal", "--episodes", "1", "--seed", "0",
                 "--out", str(recording)]) == 0
    lines = recording.read_text().splitlines()
    step = json.loads(lines[1])
    lines[1] = json.dumps({**step, "carefulness": 2})
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    assert main(["fit", str(bad), "--no-view"]) == 2
    assert "carefulness: 2 is above the world's 1 level\n" in capsys.readouterr().err


def test_the_fit_views_title_counts_one_file_as_one_file():
    """The view opened without its files' names (as a caller of FitScreen may) counts them in the singular."""
    demos = Demonstrations.read([SAMPLE])
    app = CarefulApp(FitScreen(demos, FitOptions(method="lp"), show_times=False))
    seen = {}

    async def go() -> None:
        async with app.run_test(size=(120, 40)) as pilot:
            await app.workers.wait_for_complete()
            await pilot.pause()
            seen["title"] = str(app.screen.query_one("#title").render())

    asyncio.run(go())
    assert "1 file: 3 episodes, 17 steps" in seen["title"]


def test_a_study_of_one_episode_counts_it_in_the_singular(tmp_path):
    from study.conftest import write_study

    from careful_tui.screens.study import end_text, instructions_text
    from irl_core.studies.study import load_study, read_protocol

    study = load_study(write_study(tmp_path, worlds='["paper"]', practice=0, episodes=1))
    protocol = read_protocol(study, "p01")

    def text(group) -> str:
        return " ".join(part.plain for part in group.renderables if hasattr(part, "plain"))

    assert "1 episode" in text(instructions_text(protocol)) and "1 episodes" not in text(instructions_text(protocol))
    assert "The episode is recorded in" in text(end_text(protocol))
