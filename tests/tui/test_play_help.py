"""What the play screen tells a player: each level's slip chance beside its cost, how to choose a
level in the current input mode, and only the keys that mode uses; episode numbers that start
where a game is told to."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from textual.widgets import Static

from careful_tui.app import make_play_app
from careful_tui.screens.play import minimum_size
from careful_tui.widgets import Gauge, KeyBar
from careful_tui.widgets.gauge import format_chance
from irl_core.play.game import Game, level_slip_chances
from irl_core.recordings.lines import EpisodeEnd, Step
from irl_core.worlds.world import World, load_world

NO_SLIP = World(name="flat", layout="...\n.CG\n", levels=3, slip="none", start=(0, 0),
                rewards={"C": -1000.0, "G": 100.0})


@pytest.mark.parametrize(("p", "shown"), [
    (0.5, "50%"), (0.25, "25%"), (0.125, "13%"),          # halves round up
    (2.0**-4, "6.3%"), (2.0**-6, "1.6%"), (2.0**-7, "0.8%"), (2.0**-10, "0.1%"),
    (2.0**-14, "0.006%"), (0.0, "0%"), (1.0, "100%"), (0.9999, ">99%"), (1e-7, "<0.001%"),
])
def test_a_chance_is_a_short_percentage_never_rounded_to_zero_or_certainty(p: float, shown: str) -> None:
    assert format_chance(p) == shown


def test_slip_chances_come_from_the_worlds_dynamics() -> None:
    paper = load_world("paper")
    assert level_slip_chances(paper) == pytest.approx([2.0**-c for c in range(1, 15)])
    assert level_slip_chances(NO_SLIP) == [0.0, 0.0, 0.0]


def gauge_lines(gauge: Gauge) -> list[str]:
    return [gauge.render_line(y).text for y in range(gauge.levels)]


def screen_texts(world: World, input_mode: str, tmp_path: Path) -> dict[str, object]:
    app = make_play_app(world, out=tmp_path / "rec", player="p", seed=0, input_mode=input_mode,
                        clock=lambda: 100.0)
    seen: dict[str, object] = {}

    async def go() -> None:
        async with app.run_test(size=minimum_size(world)) as pilot:
            await pilot.pause()
            screen = app.first_screen
            seen["gauge"] = gauge_lines(screen.query_one(Gauge))
            seen["subtitle"] = str(screen.query_one(Gauge).border_subtitle)
            seen["help"] = str(screen.query_one("#hold-info", Static).render())
            seen["status"] = str(screen.query_one("#status", Static).render())
            seen["title"] = str(screen.query_one("#board").border_title)
            seen["keys"] = screen.query_one(KeyBar).keys
            bar = screen.query_one(KeyBar).render()
            bar.rstrip()
            seen["keys_fit"] = bar.cell_len <= minimum_size(world)[0]
            seen["too_small"] = screen.has_class("-too-small")

    asyncio.run(go())
    return seen


def test_the_gauge_shows_each_levels_cost_and_slip_chance_and_fits_the_minimum_size(tmp_path: Path) -> None:
    paper = load_world("paper")
    assert minimum_size(paper) == (71, 18)  # the gauge's 14 levels set the height; the board's cells shrink to fit
    seen = screen_texts(paper, "hold", tmp_path)
    assert not seen["too_small"]
    top, bottom = seen["gauge"][0], seen["gauge"][-1]
    assert top.split()[0] == "14" and top.split()[-1] == "0.006%" and "-14" in top
    assert bottom.split() == ["1", "-1", "50%"]
    assert seen["subtitle"] == "points slip"
    assert "Careful moves cost more and slip less." in seen["status"]
    assert seen["title"] == "paper · 14 levels · slip halving"
    assert [line.split()[-1] for line in screen_texts(NO_SLIP, "hold", tmp_path / "flat")["gauge"]] == ["0%"] * 3


def test_a_world_of_one_level_does_not_speak_of_carefulness(tmp_path: Path) -> None:
    seen = screen_texts(load_world("paper-simple"), "hold", tmp_path)
    assert seen["title"] == "paper-simple · 1 level · slip halving"
    assert "Move with the arrow keys." in seen["status"] and "Careful" not in seen["status"]
    assert seen["help"] == "arrows: move"
    assert list(seen["keys"]) == [("←↑→↓", "move"), ("q", "quit")]  # no calibration: it only times levels


@pytest.mark.parametrize(("mode", "first_line", "keys"), [
    ("hold", "hold = careful", [("←↑→↓", "move · hold longer: more careful"),
                                ("c", "calibrate"), ("q", "quit")]),
    ("tap", "tap k× = level k", [("←↑→↓", "move · tap ×k: level k"), ("q", "quit")]),
    ("digits", "level, then arrow", [("←↑→↓", "move"), ("1-9", "level"), ("⌫", "fix"), ("q", "quit")]),
])
def test_each_input_mode_says_its_own_keys_and_never_hold_in_another(tmp_path: Path, mode: str, first_line: str,
                                                                   keys: list) -> None:
    seen = screen_texts(load_world("paper"), mode, tmp_path)
    assert seen["help"].splitlines()[0] == first_line
    assert list(seen["keys"]) == keys
    assert seen["keys_fit"]  # q quit shows even in the smallest terminal play accepts
    if mode != "hold":
        assert "hold" not in seen["help"] and not any("hold" in what for _, what in seen["keys"])


class Lines(list):
    def write_step(self, step: Step) -> None:
        self.append(step)

    def end_episode(self, end: EpisodeEnd) -> None:
        self.append(end)


def test_a_game_numbers_its_episodes_from_first_episode() -> None:
    lines = Lines()
    game = Game(NO_SLIP, seed=0, sink=lines, first_episode=4)
    game.begin_episode()
    assert game.quit() is None and game.episode == 3  # an episode without steps is not counted
    game.begin_episode()
    game.move("down", 1)
    game.move("right", 2)
    assert [line.episode for line in lines] == [4, 4, 4] and lines[-1].outcome == "terminal"
    game.begin_episode()
    assert game.episode == 5


def test_another_labs_world_shows_its_split_and_bump_rule_and_no_claim_that_care_slips_less(tmp_path: Path) -> None:
    lab = World(name="lab", layout="....\n.CCG\n", levels=3, slip={"intended": 0.76, "others": [0.09, 0.05, 0.10]},
                bump="drop", start=(0, 0), rewards={"C": -10.0, "G": 10.0})
    seen = screen_texts(lab, "hold", tmp_path)
    assert seen["title"] == "lab · 3 levels · slip 0.76/0.09/0.05/0.1, bump drop"
    assert [line.split()[-1] for line in seen["gauge"]] == ["24%"] * 3
    assert "Careful moves cost more; they slip no less." in seen["status"]
