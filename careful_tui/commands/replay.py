"""`careful replay FILE`: read the recording, then watch it."""

from __future__ import annotations

import argparse

from rich.console import Console

from careful_tui.app import make_replay_app
from careful_tui.commands.reading import read_with_progress
from careful_tui.errors import require_terminal
from careful_tui.keys.kitty import PassiveKittyDriver


def run_replay(args: argparse.Namespace) -> int:
    """`careful replay FILE`: read the recording (bad files are reported without a terminal), then watch it."""
    (recording,) = read_with_progress([args.file], Console(stderr=True, highlight=False))
    require_terminal("replay")
    make_replay_app(recording, playing=True, driver_class=PassiveKittyDriver).run()
    return 0
