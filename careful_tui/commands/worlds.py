"""`careful worlds`: list the built-in worlds, or draw one and print it as TOML."""

from __future__ import annotations

import argparse

from rich.console import Console

from careful_tui.errors import EXIT_OK
from careful_tui.render.reach_field import print_reach_world
from careful_tui.render.worlds import print_world, print_world_table
from irl_core.worlds.reach import is_reach_world, load_reach_world
from irl_core.worlds.world import load_world


def run_worlds(args: argparse.Namespace) -> int:
    console = Console(highlight=False)
    if args.show and is_reach_world(args.show):
        print_reach_world(console, load_reach_world(args.show))
    elif args.show:
        print_world(console, load_world(args.show))
    else:
        print_world_table(console)
    return EXIT_OK
