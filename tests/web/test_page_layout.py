"""The page's first screens in headless Chromium at a phone's and three screens' widths.

The first game screen clipped the goal column at 1024, 1280 and 1920 px (the hint widened the
side column after the board was sized); the root and invalid-link pages showed a tall empty
panel; "score 200" wrapped on its own (issue 31).
"""

from __future__ import annotations

import pytest
from web.conftest import start_server

from irl_core.studies.study import load_study

WIDTHS = {400: 800, 1024: 768, 1280: 800, 1920: 1080}
STUDY = 'name = "pilot"\ninstructions = "Reach the goal."\nworlds = ["paper", "mud"]\npractice_episodes = 1\nepisodes = 2\n'

VISIBLE_CELLS = """() => {
  const right = document.getElementById("right").getBoundingClientRect();
  const cells = [...document.querySelectorAll("#board .cell")].map((cell) => cell.getBoundingClientRect());
  const inside = (r) => r.left >= Math.max(0, right.left) - 0.5 && r.right <= Math.min(innerWidth, right.right) + 0.5
    && r.top >= 0 && r.bottom <= innerHeight + 0.5;
  return {cells: cells.length, outside: cells.filter((r) => !inside(r)).length};
}"""


@pytest.fixture(scope="module")
def paper_server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("layout")
    (folder / "pilot.toml").write_text(STUDY)
    live, server, thread = start_server(load_study(folder / "pilot.toml"), links=len(WIDTHS))
    yield live
    server.should_exit = True
    thread.join(10)


@pytest.mark.parametrize("width", list(WIDTHS))
def test_the_first_game_screen_shows_every_cell_of_the_board(browser, paper_server, width) -> None:
    context = browser.new_context(viewport={"width": width, "height": WIDTHS[width]})
    page = context.new_page()
    try:
        page.goto(list(paper_server.links.values())[list(WIDTHS).index(width)])
        page.wait_for_selector("#text:not([hidden])")
        page.keyboard.press(" ")
        page.wait_for_selector("#board .cell")
        page.wait_for_timeout(200)
        seen = page.evaluate(VISIBLE_CELLS)
        assert seen == {"cells": 24, "outside": 0}  # paper: 4 x 6
        score = page.locator("#status .score").bounding_box()
        label = page.locator("#status .sep").nth(1).bounding_box()
        assert score is not None and label is not None and abs(score["y"] - label["y"]) < 4, "score N on one line"
    finally:
        context.close()


@pytest.mark.parametrize("address", ["/", "/p/not-a-token-at-all-0000"])
def test_a_notice_page_is_as_tall_as_what_it_says(browser, paper_server, address) -> None:
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    page = context.new_page()
    try:
        page.goto(paper_server.url + address)
        box = page.locator(".notice-page").bounding_box()
        assert box is not None and box["height"] < 300
    finally:
        context.close()
