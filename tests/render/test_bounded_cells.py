"""A reward the data bound on one side only is shown as its bound, never as a point, in the grids of the printout,
the fit view and the figure (`shown_reward_grid`); cells the data pin keep their point."""

import numpy as np
from rich.console import Console

from careful_tui.render.fit_printout import reward_grids
from careful_tui.render.grid import format_value
from careful_tui.render.intervals import shown_reward_grid
from irl_core.irl import fit
from irl_core.irl.intervals.honest import bounded_cells, one_sided
from irl_core.players.experts import demonstrations_of, rollouts
from irl_core.players.person_like import person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def loose_fit():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    played = rollouts(mdp, person_like(mdp, "loose").choose, episodes=6, seed=3)
    return fit(demonstrations_of(mdp, played), method="maxent", player_model="naive", intervals=True, resamples=20,
               workers=1)


def test_one_sided_cells_show_their_bound_and_no_colour_and_the_rest_their_point():
    result = loose_fit()
    bounded = bounded_cells(result)
    sides = one_sided(np.asarray(result.intervals), result.rmax)
    assert bounded and len(set(bounded.values())) <= int((sides != 0).sum())  # the fixture has one-sided rewards
    grid, words = shown_reward_grid(result)
    for (row, col), (side, bound) in bounded.items():
        assert np.isnan(grid[row, col])
        assert words[(row, col)] == ("≤" if side < 0 else "≥") + format_value(bound)
    pinned = np.isfinite(grid)
    assert np.array_equal(grid[pinned], np.asarray(result.reward_grid)[pinned])
    console = Console(width=120, record=True)
    console.print(reward_grids(result, width=120))
    printed = console.export_text()
    assert "bounded on one side only, no point" in printed
    for word in words.values():
        assert word in printed


def test_the_interval_chart_marks_no_estimate_on_a_row_bounded_on_one_side():
    from careful_tui.render.intervals import IntervalChart

    result = loose_fit()
    sides = one_sided(np.asarray(result.intervals), result.rmax)
    console = Console(width=120, record=True)
    console.print(IntervalChart(result))
    printed = console.export_text()
    lines = {line.split("  ")[0].strip(): line for line in printed.splitlines() if "━" in line}
    for label, side in zip(result.labels, sides):
        if label in lines:
            marked = "●" in lines[label] or "◉" in lines[label]  # ◉: the estimate on the truth
            assert marked == (side == 0), (label, lines[label])
    assert "● fitted if two-sided" in printed
