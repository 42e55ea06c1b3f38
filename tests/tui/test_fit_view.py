"""The fit view: the numbers of `--json`, refits in a worker, intervals, errors and saving SVG."""

from __future__ import annotations

import asyncio
import io
import json
import re
import threading

import numpy as np
import pytest
from rich.console import Console

import careful_tui.screens.fit as fit_screen
from careful_tui.app import CarefulApp, make_fit_app
from careful_tui.cli import build_parser, main
from careful_tui.commands.fit import fit_from_args
from careful_tui.render.grid import format_value
from careful_tui.render.intervals import interval_span
from careful_tui.screens.fit import board_width
from careful_tui.widgets import Board, KeyBar
from irl_core.irl import fit
from irl_core.recordings.demonstrations import Demonstrations

NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


def simulate(folder, *options):
    path = folder / "recording.jsonl"
    assert main(["simulate", "--world", "mud", *options, "--seed", "0", "--out", str(path)]) == 0
    return path


@pytest.fixture(scope="module")
def mud_file(tmp_path_factory):
    return simulate(tmp_path_factory.mktemp("mud"), "--policy", "optimal", "--episodes", "100")


@pytest.fixture(scope="module")
def noisy_file(tmp_path_factory):
    """A Boltzmann expert's recording: its most frequent actions are optimal for no reward (lp fails)."""
    return simulate(tmp_path_factory.mktemp("noisy"), "--policy", "boltzmann", "--beta", "0.5", "--episodes", "30")


def make_app(*argv, fitted=True, **kwargs) -> CarefulApp:
    """The view as `careful fit ARGV` opens it (the first fit made before, as the CLI does)."""
    args = build_parser().parse_args(["fit", *map(str, argv)])
    if fitted:
        demos, result = fit_from_args(args, err=Console(file=io.StringIO()))
    else:
        demos, result = Demonstrations.read(args.files), None
    return make_fit_app(args, demos, result, **kwargs)


def text_of(widget) -> str:
    """What a widget shows, as plain text."""
    if isinstance(widget, Board):
        return "\n".join(widget.render_line(y).text for y in range(widget.content_size.height))
    console = Console(width=widget.content_size.width, file=io.StringIO(), record=True)
    console.print(widget.content)
    return console.export_text()


def shown(app: CarefulApp, selector: str) -> str:
    return text_of(app.query_one(selector))


def drive(app: CarefulApp, body, size=(100, 40)) -> None:
    """Run the view in a `size` terminal and hand it to `body(pilot)`."""

    async def go() -> None:
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(go())


async def settle(app, pilot) -> None:
    await app.workers.wait_for_complete()
    await pilot.pause()


def as_grid(rows) -> np.ndarray:
    return np.array([[np.nan if v is None else v for v in row] for row in rows], dtype=float)


def test_the_view_shows_the_numbers_of_json(tmp_path, mud_file, capsys):
    out = tmp_path / "fit.json"
    assert main(["fit", str(mud_file), "--intervals", "--no-view", "--json", str(out)]) == 0
    capsys.readouterr()
    data = json.loads(out.read_text())
    app = make_app(mud_file, "--intervals")

    async def body(pilot):
        fitted, true = app.query_one("#fitted", Board), app.query_one("#true", Board)
        # Every cell's printed value, row by row, is the JSON's: its reward, or where the JSON's interval is open on
        # one side only (at -rmax or +rmax), the interval's other end (the bound, drawn "≤-655", uncoloured).
        rmax = data["options"]["rmax"]
        expected, bounded = [], []
        for r, row in enumerate(data["reward"]):
            for c, value in enumerate(row):
                low, high = (data["interval"][r][c] or (None, None))
                if low is not None and low <= -rmax + 1e-6 * rmax and high < rmax - 1e-6 * rmax:
                    expected.append(format_value(high))
                    bounded.append((r, c))
                elif low is not None and high >= rmax - 1e-6 * rmax and low > -rmax + 1e-6 * rmax:
                    expected.append(format_value(low))
                    bounded.append((r, c))
                else:
                    expected.append(format_value(value))
        assert bounded, "the fixture's fit has rewards bounded on one side"
        grid = as_grid(data["reward"])
        for r, c in bounded:
            grid[r, c] = np.nan
        np.testing.assert_allclose(fitted.values, grid, atol=1e-6)
        assert NUMBER.findall(shown(app, "#fitted")) == expected
        assert shown(app, "#fitted").count("≤") + shown(app, "#fitted").count("≥") == len(bounded)
        assert NUMBER.findall(shown(app, "#true")) == [format_value(v) for v in true.values.ravel()]
        assert true.values[3, 1] == -1000 and true.values[1, 1] == -30
        assert fitted.scale == true.scale
        intervals = shown(app, "#intervals")
        for row in data["interval"]:
            for cell in row:
                if cell is not None:
                    assert interval_span(*cell, data["options"]["rmax"]) in intervals
        policy = shown(app, "#policy")
        for row in data["policy"]:
            for cell in row:
                if cell is not None:
                    assert f"{cell['carefulness']} ×{cell['count']}" in policy
        title = shown(app, "#title")
        assert "lp on mud" in title and "100 episodes" in title and f"{data['demonstrations']['steps']} steps" in title
        assert "status: optimal in" in shown(app, "#status")
    drive(app, body, size=(100, 40))


def test_switching_method_refits_in_a_worker(mud_file, monkeypatch):
    release = threading.Event()

    def slow_fit(*args, **kwargs):
        assert release.wait(10)
        return fit(*args, **kwargs)

    app = make_app(mud_file)

    async def body(pilot):
        lp_values = app.query_one("#fitted", Board).values.copy()
        monkeypatch.setattr(fit_screen, "fit", slow_fit)
        await pilot.press("o")
        # Busy: the last result stays, dimmed, under a "fitting" status.
        assert app.first_screen.busy and "fitting loss" in shown(app, "#status")
        assert app.query_one("#body").has_class("-busy") and app.first_screen.result.method == "lp"
        release.set()
        await settle(app, pilot)
        assert not app.first_screen.busy and app.first_screen.result.method == "loss"
        assert "loss on mud" in shown(app, "#title") and "fitted R_S · loss point estimate" in app.query_one("#fitted").border_title
        loss_values = app.query_one("#fitted", Board).values
        np.testing.assert_allclose(loss_values, app.first_screen.result.reward_grid)
        assert not np.allclose(loss_values, lp_values)
        assert NUMBER.findall(shown(app, "#fitted")) == [format_value(v) for v in loss_values.ravel()]
        await pilot.press("tab")
        await settle(app, pilot)
        assert app.first_screen.result.method == "maxent" and "β 1" in shown(app, "#status")
        await pilot.press("tab")
        await settle(app, pilot)
        assert app.first_screen.result.method == "lp"
        np.testing.assert_allclose(app.query_one("#fitted", Board).values, lp_values)
    drive(app, body, size=(100, 40))


def test_tab_cycles_auto_lp_loss_maxent_from_the_default_auto(mud_file):
    """The view opens on auto (the default); tab crashed there (auto was not in the cycle)."""
    app = make_app(mud_file, "--method", "auto")

    async def body(pilot):
        seen = []
        for _ in range(4):
            await pilot.press("tab")
            await settle(app, pilot)
            assert app.is_running and app.first_screen.error is None
            seen.append(app.first_screen.options.method)
        assert seen == ["lp", "loss", "maxent", "auto"]
    drive(app, body, size=(100, 40))


def test_intervals_toggle(mud_file):
    # maxent's intervals are bootstrap confidence intervals: 20 resamples keep the test quick.
    app = make_app(mud_file, "--resamples", "20")

    async def body(pilot):
        assert app.first_screen.result.intervals is None and "press i" in shown(app, "#intervals")
        await pilot.press("i")
        await settle(app, pilot)
        assert app.first_screen.result.intervals is not None and app.first_screen.result.method == "lp"
        intervals = shown(app, "#intervals")
        assert "Cliff: at most" in intervals and "catastrophic next to mud's" in intervals
        assert "Goal: between" in intervals and "● fitted" in intervals
        await pilot.press("i")
        await pilot.pause()
        assert not app.first_screen.busy and "press i" in shown(app, "#intervals")
        # Back on: the intervals are there already; nothing to refit.
        await pilot.press("i")
        assert not app.first_screen.busy and "Cliff:" in shown(app, "#intervals")
        # loss on an optimal expert: many rewards minimise it, so resampling measures nothing; the view says so.
        await pilot.press("o")
        await settle(app, pilot)
        assert app.first_screen.result.method == "loss" and app.first_screen.result.intervals is None
        assert "could not be computed" in shown(app, "#intervals")
        assert "many rewards minimise the loss equally" in shown(app, "#notes")
        await pilot.press("m")
        await settle(app, pilot)
        assert app.first_screen.result.method == "maxent" and app.first_screen.result.intervals is not None
        assert app.first_screen.result.interval_kind == "confidence" and "95% confidence" in shown(app, "#intervals")
    drive(app, body, size=(100, 40))


def test_an_infeasible_refit_is_shown_and_the_view_keeps_running(noisy_file):
    app = make_app(noisy_file, "--method", "loss")

    async def body(pilot):
        loss_values = app.query_one("#fitted", Board).values.copy()
        await pilot.press("l")
        await settle(app, pilot)
        assert app.is_running and app.first_screen.result.method == "loss"
        status = shown(app, "#status")
        assert "✗ lp" in status and "not optimal for any reward" in status and "press o" in status
        assert "showing loss" in status
        np.testing.assert_allclose(app.query_one("#fitted", Board).values, loss_values)
        await pilot.press("o")
        await settle(app, pilot)
        assert app.first_screen.error is None and "✓" in shown(app, "#status")
    drive(app, body, size=(100, 40))


def test_after_a_failed_refit_i_bounds_the_fit_on_screen(noisy_file):
    """lp fails on noisy play and the view keeps showing maxent: i then asks for maxent's intervals,
    not the failed lp's again (which said "could not be computed: see the notes", with no such note)."""
    app = make_app(noisy_file, "--method", "maxent", "--resamples", "20")

    async def body(pilot):
        await pilot.press("l")
        await settle(app, pilot)
        assert "✗ lp" in shown(app, "#status") and app.first_screen.result.method == "maxent"
        await pilot.press("i")
        await settle(app, pilot)
        result = app.first_screen.result
        assert result.method == "maxent" and result.interval_kind == "confidence" and result.intervals is not None
        assert app.first_screen.error is None and "95% confidence" in shown(app, "#intervals")
    drive(app, body, size=(100, 40))


def test_a_first_fit_in_the_worker(mud_file):
    app = make_app(mud_file, "--method", "maxent", fitted=False)

    async def body(pilot):
        await settle(app, pilot)
        assert app.first_screen.result.method == "maxent" and "maxent on mud" in shown(app, "#title")
        assert app.query_one("#policy", Board).labels
    drive(app, body, size=(100, 40))


def test_s_saves_an_svg(tmp_path, mud_file, monkeypatch):
    monkeypatch.chdir(tmp_path)
    app = make_app(mud_file)

    async def body(pilot):
        await pilot.press("s")
        await pilot.press("s")
        assert app.first_screen.saved == [tmp_path / "careful-fit-mud-lp.svg", tmp_path / "careful-fit-mud-lp-2.svg"]
        svg = app.first_screen.saved[0].read_text().replace("&#160;", " ")
        assert svg.startswith("<svg") and "careful fit: lp on mud" in svg
    drive(app, body, size=(100, 40))


def test_svg_option_saves_once_the_first_fit_is_drawn(tmp_path, mud_file):
    path = tmp_path / "view.svg"
    app = make_app(mud_file, "--intervals", "--svg", path)

    async def body(pilot):
        await pilot.pause()
        assert app.first_screen.saved == [path]
        svg = path.read_text().replace("&#160;", " ")
        assert "fitted R_S" in svg and "catastrophic" in svg
        # `s` saves to the same path.
        await pilot.press("s")
        assert app.first_screen.saved == [path, path]
    drive(app, body, size=(100, 40))


def test_80x24_stacks_the_boards_and_scrolls(mud_file):
    app = make_app(mud_file, "--intervals")

    async def body(pilot):
        assert app.query_one("#rewards").has_class("-stacked")
        assert not app.screen.has_class("-too-small")
        body = app.query_one("#body")
        assert body.max_scroll_y > 0
        await pilot.press("end")
        await pilot.pause()
        assert body.scroll_y > 0
    drive(app, body, size=(80, 24))
    wide = make_app(mud_file)

    async def body_wide(pilot):
        assert not wide.query_one("#rewards").has_class("-stacked")
        fitted, true = wide.query_one("#fitted"), wide.query_one("#true")
        assert fitted.region.y == true.region.y and fitted.region.right <= true.region.x
    drive(wide, body_wide, size=(100, 30))


def test_a_tiny_terminal_says_so(mud_file):
    app = make_app(mud_file)

    async def body(pilot):
        assert app.screen.has_class("-too-small")
        message = shown(app, "#too-small")
        assert "The terminal is 40x10" in message and "48x12" in message
        assert app.query_one(KeyBar).keys == (("q", "quit"),)
        await pilot.press("q")
        assert not app.is_running
    drive(app, body, size=(40, 10))


def test_board_width():
    assert board_width(6, 0) == 6 * 7 + 2
    assert board_width(6, 100) == 6 * 11 + 2
    assert board_width(6, 6 * 8 + 2) == 6 * 7 + 2


def test_a_noisy_recording_opens_on_auto_maxent_with_confidence_intervals(noisy_file):
    app = make_app(noisy_file, "--intervals", "--resamples", "20")

    async def body(pilot):
        result = app.first_screen.result
        assert result.options.method == "auto" and result.method == "maxent" and result.beta_auto
        notes = shown(app, "#notes")
        assert "An agent trained on this reward falls off the cliff in" in notes and "auto chose maxent" in notes
        assert "95% confidence" in shown(app, "#intervals") and "identified" not in shown(app, "#intervals")
        assert "(estimated)" in shown(app, "#status")
        # Back to auto after another method: a refit, and the same answer.
        await pilot.press("m")  # maxent as asked: beta fixed at 1
        await settle(app, pilot)
        assert app.first_screen.result.method == "maxent" and not app.first_screen.result.beta_auto and app.first_screen.result.beta == 1.0
        await pilot.press("a")
        await settle(app, pilot)
        assert app.first_screen.result.method == "maxent" and app.first_screen.result.options.method == "auto"
        np.testing.assert_allclose(app.first_screen.result.intervals, result.intervals)
    drive(app, body, size=(100, 40))


def test_each_change_redraws_the_view_once(mud_file, monkeypatch):
    # A refit sets `fitting` as it starts, and `fitting`, `options` and `result` as it ends: one
    # redraw each time, not one per reactive.
    draws = []
    show = fit_screen.FitScreen.show
    monkeypatch.setattr(fit_screen.FitScreen, "show", lambda screen: (draws.append(screen.busy), show(screen)))
    release = threading.Event()

    def slow_fit(*args, **kwargs):
        assert release.wait(10)
        return fit(*args, **kwargs)

    app = make_app(mud_file, "--resamples", "20")

    async def body(pilot):
        assert draws == [False]  # on mount
        monkeypatch.setattr(fit_screen, "fit", slow_fit)
        await pilot.press("i")
        await pilot.pause()
        assert draws == [False, True] and "fitting auto" in shown(app, "#status")
        release.set()
        await settle(app, pilot)
        assert draws == [False, True, False] and "Cliff: at most" in shown(app, "#intervals")
        # Hiding the intervals changes only the options: one more.
        await pilot.press("i")
        await pilot.pause()
        assert len(draws) == 4 and "press i" in shown(app, "#intervals")
    drive(app, body, size=(100, 40))


def test_a_world_wider_than_the_terminal_opens_and_scrolls_sideways(tmp_path):
    # A 24-wide world needs 170 columns of board: at 100 the view opened only to say the terminal was too
    # small. Now its boards keep their size, the body scrolls sideways, and the key bar says how.
    from bench.worlds import cliff_world

    world_file = tmp_path / "wide.toml"
    world_file.write_text(cliff_world(4, 24).to_toml(), encoding="utf-8")
    recording = tmp_path / "wide.jsonl"
    assert main(["simulate", "--world", str(world_file), "--policy", "optimal", "--episodes", "10", "--seed", "0",
                 "--out", str(recording)]) == 0
    app = make_app(recording, "--method", "lp")

    async def body(pilot):
        assert not app.screen.has_class("-too-small")
        assert ("←→", "sideways") in app.query_one(KeyBar).keys
        fitted = app.query_one("#fitted")
        assert fitted.region.width == board_width(24, 0)  # whole, not squeezed
        scroller = app.query_one("#body")
        assert scroller.max_scroll_x > 0 and scroller.scroll_x == 0
        await pilot.press("right")
        await pilot.pause()
        assert scroller.scroll_x > 0
        await pilot.press("left")
        await pilot.pause()
        assert scroller.scroll_x == 0
    drive(app, body, size=(100, 35))
    narrow = make_app(recording, "--method", "lp")

    async def body_roomy(pilot):
        assert all(label != "sideways" for _, label in narrow.query_one(KeyBar).keys)
        assert narrow.query_one("#body").max_scroll_x == 0
    drive(narrow, body_roomy, size=(200, 60))
