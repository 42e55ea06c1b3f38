"""A world wider than the console is printed in strips of whole columns, each named, none cut off."""

import io

import numpy as np
from rich.console import Console

from careful_tui.render.grid import WorldGrid
from irl_core.worlds.world import World


def _printed(grid: WorldGrid, width: int) -> str:
    console = Console(file=io.StringIO(), width=width, color_system=None)
    console.print(grid)
    return console.file.getvalue()


def test_a_wide_world_comes_in_named_strips_of_whole_columns_and_every_value_is_printed():
    cols = 24
    world = World(name="wide", layout="." * (cols - 1) + "G\n", levels=1, rewards={"G": 10.0})
    values = np.arange(cols, dtype=float)[None, :] * 11  # each column's own number: 0, 11, ..., 253
    text = _printed(WorldGrid(world, values=values), width=80)
    assert max(len(line) for line in text.splitlines()) <= 80
    assert [line for line in text.splitlines() if line.startswith("columns")] == [
        "columns 0 to 7 (of 0 to 23)", "columns 8 to 15 (of 0 to 23)", "columns 16 to 23 (of 0 to 23)"]
    for value in values[0]:
        assert f"{value:.0f}" in text.split()


def test_a_world_that_fits_is_printed_whole_without_strips():
    world = World(name="narrow", layout="....G\n", levels=1, rewards={"G": 10.0})
    text = _printed(WorldGrid(world), width=80)
    assert "columns" not in text and len(text.splitlines()) == 3


def test_a_saved_page_is_as_wide_as_the_world_so_its_grids_stay_whole():
    from bench.worlds import cliff_world
    from careful_tui.render.fit_printout import fit_page_svg
    from irl_core.irl import fit
    from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
    from irl_core.worlds.mdp import build_mdp

    mdp = build_mdp(cliff_world(4, 24))
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=5, seed=0))
    svg = fit_page_svg(demos, fit(demos, method="lp"), width=80, title="wide").replace("&#160;", " ")
    assert "columns" not in svg  # no strips: one picture of the world
    assert "fitted R_S" in svg and "demonstrated policy" in svg


def test_a_one_line_cell_is_highlighted_by_a_bar_at_each_end() -> None:
    # A slip's frame needs three lines; on a board of 3x1 cells (a big world) the cell shows a bar at each end.
    from irl_core.worlds.world import load_world

    grid = WorldGrid(load_world("paper"), cell_width=3, cell_height=1, highlight={(0, 0): "#ff8800"})
    [line] = grid.cell_lines((0, 0))
    assert line.plain[0] == "▐" and line.plain[-1] == "▌" and len(line.plain) == 3
    [plain] = grid.cell_lines((0, 1))
    assert "▐" not in plain.plain
