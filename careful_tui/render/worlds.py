"""`careful worlds`: the built-in worlds as a table, or one world drawn."""

from __future__ import annotations

from rich.console import Console
from rich.syntax import Syntax
from rich.table import Table
from rich.text import Text

from careful_tui.render.grid import WorldGrid, format_value, symbol_legend
from careful_tui.render.reach_field import reach_table_rows
from irl_core.support.plural import plural
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.reach import REACH_PURPOSES, REACH_WORLDS
from irl_core.worlds.world import BUILTIN_WORLDS, WORLD_PURPOSES, World


def print_world_table(console: Console) -> None:
    table = Table(title="Built-in worlds (careful worlds --show NAME draws one)")
    for column in ("name", "size", "levels", "slip", "rewards", "what it is for"):
        table.add_column(column)
    for name, world in BUILTIN_WORLDS.items():
        rewards = ", ".join(f"{k} {format_value(v)}" for k, v in world.rewards.items())
        # A time world's care is the hold: no levels, and a slip curve instead of halving.
        levels, slip = ("hold", f"p(d), tau {world.tau_ms:g} ms") if world.care == "time" else (str(world.levels),
                                                                                              world.slip_label)
        table.add_row(name, f"{world.rows}x{world.cols}", levels, slip, rewards, WORLD_PURPOSES[name])
    for row in reach_table_rows(REACH_WORLDS):
        table.add_row(*row, REACH_PURPOSES[row[0]])
    console.print(table)


def print_world(console: Console, world: World) -> None:
    # The name is text from a file: shown escaped and cut, never as markup.
    care = (f"care is the hold (slips {world.p_inf:g} + {world.p0 - world.p_inf:g} e^(-d / {world.tau_ms:g} ms), costs "
            f"{world.cost_per_second:g} a second, {plural(world.levels, 'duration bin')} for planning)"
            if world.care == "time" else f"{plural(world.levels, 'carefulness level')}, slip {world.slip_label}")
    console.print(Text.assemble((printable(world.name, limit=VALUE_LIMIT), "bold"),
                                f": {world.rows}x{world.cols} cells, {care}, gamma {world.gamma}"), soft_wrap=True)
    # The rules a move follows, in words: what a researcher checks a task from another lab against.
    rules = [f"moves: {world.describe_slip()}", f"bump: {world.describe_bump()}",
             f"step limit: {plural(world.max_steps, 'step')} an episode"]
    if world.care == "levels":
        rules.append(f"each level costs {format_value(world.cost_per_level)}"
                     + (" (moves cost nothing)" if world.cost_per_level == 0 else ""))
    console.print(Text("\n".join(rules)), soft_wrap=True)
    console.print(WorldGrid(world))
    console.print(symbol_legend(world))
    console.print(Syntax(world.to_toml(), "toml", theme="ansi_dark", background_color="default", word_wrap=True))
