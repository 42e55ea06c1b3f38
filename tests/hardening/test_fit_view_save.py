"""The fit view's save when its folder has been removed: a clear message, not a traceback.

Before, `s` in a fit view whose current folder had been removed ended the app with a
FileNotFoundError traceback (Path.cwd()).
"""

from __future__ import annotations

import asyncio
import shutil

import pytest
from hardening_checks import recording

from careful_tui.app import CarefulApp
from careful_tui.screens.fit import FitScreen
from irl_core.irl import FitOptions
from irl_core.recordings.demonstrations import Demonstrations


def saved_after_removing(folder, app, remove) -> list[str]:
    async def main() -> list[str]:
        async with app.run_test(size=(120, 40)) as pilot:
            for _ in range(200):
                await pilot.pause(0.05)
                if app.first_screen.result is not None:
                    break
            remove()
            await pilot.press("s")
            await pilot.pause()
            return [n.message for n in app._notifications]

    return asyncio.run(main())


@pytest.mark.parametrize("where", ["current folder", "--svg folder"])
def test_saving_into_a_removed_folder_says_so(tmp_path, monkeypatch, where):
    rec = recording(tmp_path / "a.jsonl", episodes=3)
    folder = tmp_path / "work"
    folder.mkdir()
    monkeypatch.chdir(folder)
    svg = folder / "view.svg" if where == "--svg folder" else None
    screen = FitScreen(Demonstrations.read([rec]), FitOptions(), sources=[rec], svg=svg)
    if svg is not None:
        screen._save_first = False  # only `s` saves here
    app = CarefulApp(screen)
    messages = saved_after_removing(folder, app, lambda: shutil.rmtree(folder))
    wanted = "the current folder is gone" if where == "current folder" else "does not exist"
    assert any(wanted in m for m in messages), messages
    assert screen.saved == []
