"""A recording from the browser reads, replays, fits, exports and reports like one from the terminal."""

from __future__ import annotations

import asyncio
import csv

from starlette.testclient import TestClient
from web.conftest import Api, web_app

from careful_tui.app import make_replay_app
from careful_tui.cli import main
from careful_tui.widgets import Board
from irl_core.recordings.demonstrations import read_recording


def test_a_browser_participants_recording_goes_through_every_tool(web_study, tmp_path, capsys):
    app, tokens = web_app(web_study)
    with TestClient(app) as client:
        for participant in ("p001", "p002"):
            api = Api(client, token=tokens[participant])
            api.key("space")
            for block in range(2):
                for ms in (40, 260, 700, 1300):
                    api.hold("right", ms)
                api.key("space")
                api.key("space")
            assert api.view["stage"] == "end"
    folder = web_study.participant_folder("p001")
    main_file = next(path for path in sorted(folder.glob("*.jsonl")) if read_recording(path).header.study.phase == "main")
    recording = read_recording(main_file)
    assert recording.header.input["front_end"] == "browser"
    assert recording.steps.column("level").tolist() == [1, 1, 3, 7]  # the terminal's scale
    assert (recording.header.input["tap_ms"], recording.header.input["ms_per_level"]) == (500.0, 150.0)

    async def replay() -> tuple:
        replay_app = make_replay_app(recording, frame_seconds=3600)
        async with replay_app.run_test(size=(100, 35)) as pilot:
            await pilot.pause()
            await pilot.press("right")
            await pilot.pause()
            return replay_app.query_one(Board).player

    assert asyncio.run(replay()) == (0, 1)

    capsys.readouterr()
    assert main(["fit", str(main_file), "--no-view", "--json", str(tmp_path / "fit.json")]) == 0
    assert (tmp_path / "fit.json").exists()
    assert main(["export", str(main_file), "--format", "csv", "--out", str(tmp_path / "steps.csv")]) == 0
    with open(tmp_path / "steps.csv", newline="") as file:
        rows = list(csv.DictReader(file))
    assert [row["hold_exact"] for row in rows] == ["true"] * 4 or [row["hold_exact"] for row in rows] == ["True"] * 4
    assert [round(float(row["hold_ms"])) for row in rows] == [40, 260, 700, 1300]
    assert main(["study", "report", str(web_study.path), "--resamples", "20", "--workers", "1"]) == 0
    report = capsys.readouterr().out
    assert "p001" in report and "p002" in report and "pooled" in report
    assert (web_study.out / "report" / "report.csv").exists()
