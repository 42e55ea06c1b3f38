"""The apps' factories: the command line and the tests build every app here, the same way."""

from __future__ import annotations

import argparse
import time
from datetime import datetime
from pathlib import Path

from textual.driver import Driver

from careful_tui.arguments import options_from_args

from careful_tui.keys.hold import Clock, HoldProfile
from careful_tui.keys.modes import make_input
from careful_tui.screens.fit import FitApp
from careful_tui.screens.play import PlayApp
from careful_tui.version import app_version
from irl_core.demonstrations import Demonstrations
from irl_core.recording_lines import SessionHeader
from irl_core.recording_writer import SessionRecorder
from irl_core.game import Game
from irl_core.irl import FitResult
from irl_core.world import World


def make_play_app(
    world: World,
    *,
    out: str | Path,
    player: str,
    seed: int,
    input_mode: str = "hold",
    clock: Clock = time.monotonic,
    calibrate: bool = False,
    driver_class: type[Driver] | None = None,
) -> PlayApp:
    """The play app, recording to a new file in `out` (the CLI and the tests both build it here)."""
    profile = HoldProfile(levels=world.levels)
    header = SessionHeader(
        world=world,
        player=player,
        created=datetime.now().astimezone(),
        seed=seed,
        input=make_input(input_mode, profile, clock=clock).header(),
        app_version=app_version(),
    )
    recorder = SessionRecorder(out, header)
    game = Game(world, seed=seed, sink=recorder)
    return PlayApp(game, recorder, input_mode=input_mode, profile=profile, clock=clock,
                   calibrate=calibrate, player=player, driver_class=driver_class)


def make_fit_app(args: argparse.Namespace, demos: Demonstrations, result: FitResult | None = None,
                 *, show_times: bool = True, driver_class: type[Driver] | None = None) -> FitApp:
    """The fit view `careful fit` opens for its parsed `args` (the CLI and the tests build it here)."""
    return FitApp(demos, options_from_args(args), result=result, sources=args.files, svg=args.svg,
                  show_times=show_times, driver_class=driver_class)
