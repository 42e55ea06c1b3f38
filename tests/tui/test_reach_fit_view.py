"""The reach fit view: `careful fit REACH.jsonl` in a terminal draws the fit it prints with --no-view (the field
with every endpoint at sub-cell resolution and both best aims, each symbol's interval, the spread law), saves
an SVG with s, and looks as its snapshot does in a 100x45 terminal."""

from __future__ import annotations

import asyncio
import io

import numpy as np
import pytest
from rich.console import Console

from careful_tui.app import make_reach_fit_app
from careful_tui.cli import build_parser, main
from careful_tui.render.reach_fit import BOTH_MARK, ReachField, optima, shown_points, spread_line, view_box
from careful_tui.widgets import KeyBar
from irl_core.reach.fit import fit_reaches
from irl_core.recordings.reach_reader import read_reaches


def simulated(folder, world, policy, trials, seed):
    path = folder / f"{world}-{policy}.jsonl"
    assert main(["simulate", "--world", world, "--policy", policy, "--episodes", str(trials), "--seed", str(seed),
                 "--out", str(path)]) == 0
    return path


@pytest.fixture(scope="module")
def hand(tmp_path_factory):
    return simulated(tmp_path_factory.mktemp("hand"), "reach", "hand", 100, 1)


@pytest.fixture(scope="module")
def maximiser(tmp_path_factory):
    return simulated(tmp_path_factory.mktemp("max"), "reach", "optimal", 30, 0)


def app_of(path):
    args = build_parser().parse_args(["fit", str(path)])
    reaches = read_reaches([path])[0]
    return make_reach_fit_app(args, fit_reaches(reaches), reaches), reaches


def shown(app, selector: str) -> str:
    widget = app.query_one(selector)
    console = Console(width=widget.content_size.width, file=io.StringIO(), record=True)
    console.print(widget.content)
    return console.export_text()


def drive(app, body, size=(100, 45)) -> None:
    async def go() -> None:
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(go())


def test_the_view_shows_the_fit_it_prints(hand):
    app, reaches = app_of(hand)
    fit = app.first_screen.fit

    async def body(pilot):
        title = shown(app, "#title")
        assert "reach fit of reach: 100 trials from 1 file" in title
        intervals = shown(app, "#intervals")
        for symbol in fit.world.symbols:
            low, high = fit.interval[symbol]
            assert any(line.startswith(f"{symbol} ") for line in intervals.splitlines())
        assert " ".join(spread_line(fit).split()) in " ".join(shown(app, "#notes").split())  # however it wraps
        keys = dict(app.query_one(KeyBar).keys)
        assert keys == {"s": "save SVG", "PgUp PgDn": "scroll", "q": "quit"}
        await pilot.press("q")

    drive(app, body)


def test_every_endpoint_in_view_is_one_braille_dot(hand):
    app, reaches = app_of(hand)
    fit = app.first_screen.fit
    console = Console(width=80, file=io.StringIO(), record=True)
    console.print(ReachField(fit, reaches.endpoints, optima(fit)))
    rows = console.export_text().splitlines()
    low, high = view_box(fit.world)
    inside = np.all((reaches.endpoints >= low) & (reaches.endpoints < high), axis=1)
    # each braille character counts its dots; two endpoints may share a dot, never more dots than endpoints
    dots = sum(bin(ord(char) - 0x2800).count("1") for row in rows for char in row if 0x2800 < ord(char) <= 0x28FF
               and char != "⣿")  # the key's sample
    assert 0.9 * inside.sum() <= dots <= inside.sum()
    (where,) = [row for row in rows if "the start is at" in row]
    assert f"{(~inside).sum()} endpoint" in where or (~inside).sum() == 0


def test_a_one_sided_penalty_shows_its_bound_and_no_point(maximiser):
    app, reaches = app_of(maximiser)
    fit = app.first_screen.fit

    async def body(pilot):
        field, intervals = shown(app, "#field"), shown(app, "#intervals")
        assert f"C {shown_points(fit, 'C')}" in field and shown_points(fit, "C").startswith("≤")
        (penalty,) = [line for line in intervals.splitlines() if line.startswith("C ")]
        assert "◀" in penalty and "●" not in penalty  # no fitted point on a row bounded on one side
        assert BOTH_MARK in field  # the maximiser's fitted points make the world's best aim theirs too

    drive(app, body)


def test_s_saves_the_view_beside_never_over_a_recording(hand, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    app, _ = app_of(hand)

    async def body(pilot):
        await pilot.press("s")
        await pilot.pause()

    drive(app, body)
    (saved,) = app.first_screen.saved
    assert saved.name == "careful-fit-reach-reach.svg" and (tmp_path / saved).read_text().startswith("<svg")


def test_no_view_prints_the_table(hand, capsys):
    assert main(["fit", str(hand), "--no-view"]) == 0
    assert "reach fit of reach: 100 trials" in capsys.readouterr().out


def test_the_reach_fit_view_snapshot(snap_compare, hand) -> None:
    app, _ = app_of(hand)
    assert snap_compare(app, terminal_size=(100, 45))
