"""The app's factories: the command line and the tests build the careful app here, the same way,
each opening it on its first screen (play, replay, the fit view or a study's flow)."""

from __future__ import annotations

import argparse
import secrets
import time
from collections.abc import Sequence
from dataclasses import replace
from datetime import datetime
from pathlib import Path

from textual.driver import Driver

from careful_tui.arguments import options_from_args

from careful_tui.keys.hold import Clock, HoldProfile
from careful_tui.keys.modes import make_input
from careful_tui.screens.careful_app import CarefulApp
from careful_tui.screens.fit import FitScreen
from careful_tui.screens.play import PlayScreen
from careful_tui.screens.replay import FRAME_S, ReplayScreen
from careful_tui.screens.study import StudyScreen, block_play_options
from careful_tui.version import app_version
from irl_core.demonstrations import Demonstrations, Recording
from irl_core.recording_lines import SessionHeader, StudyTag
from irl_core.recording_writer import SessionRecorder
from irl_core.game import Game
from irl_core.irl import FitResult
from irl_core.study import Block, LoadedStudy, Protocol
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
) -> CarefulApp:
    """The app on the play screen, recording to a new file in `out` (the CLI and the tests both build it here)."""
    screen = new_play_screen(world, out=out, player=player, seed=seed, input_mode=input_mode, clock=clock,
                             calibrate=calibrate)
    return CarefulApp(screen, driver_class=driver_class)


def new_play_screen(world: World, *, out: str | Path, player: str, seed: int, input_mode: str, clock: Clock,
                    profile: HoldProfile | None = None, study: StudyTag | None = None, first_episode: int = 0,
                    **options) -> PlayScreen:
    """A play screen recording to a new file in `out` (its header tagged with `study`, if given),
    its episodes numbered from `first_episode`; `options` go to `PlayScreen`."""
    profile = profile or HoldProfile(levels=world.levels)
    header = SessionHeader(
        world=world,
        player=player,
        created=datetime.now().astimezone(),
        seed=seed,
        input=make_input(input_mode, profile, clock=clock).header(),
        app_version=app_version(),
        study=study,
    )
    recorder = SessionRecorder(out, header)
    game = Game(world, seed=seed, sink=recorder, first_episode=first_episode)
    return PlayScreen(game, recorder, input_mode=input_mode, profile=profile, clock=clock, player=player, **options)


def make_study_app(study: LoadedStudy, participant: str, *, clock: Clock = time.monotonic,
                   seed: int | None = None, driver_class: type[Driver] | None = None) -> CarefulApp:
    """The app on the study screen: `participant` through `study`'s protocol from where their folder
    stands (`careful study run` and the tests build it here). `seed` fixes every block's seed (a
    test's); without it each block draws one."""

    def play_block(protocol: Protocol, block: Block, profile: HoldProfile | None) -> PlayScreen:
        world = protocol.world(block)
        block_seed = secrets.randbelow(2**32) if seed is None else seed
        # A calibration carries over; the level scale is the block's world's.
        profile = None if profile is None else replace(profile, levels=world.levels)
        return new_play_screen(world, out=protocol.folder, player=participant, seed=block_seed,
                               input_mode=study.study.input, clock=clock, profile=profile,
                               study=protocol.tag(block), first_episode=block.next_episode,
                               **block_play_options(protocol, block))

    return CarefulApp(StudyScreen(study, participant, play_block=play_block), driver_class=driver_class)


def make_replay_app(*recordings: Recording, skipped: Sequence[str] = (), playing: bool = False,
                    frame_seconds: float = FRAME_S, driver_class: type[Driver] | None = None) -> CarefulApp:
    """The app on the replay screen of `recordings`, watched in that order (`skipped`: a line per
    file left out; the CLI plays at once; the tests start paused)."""
    return CarefulApp(ReplayScreen(recordings, skipped=skipped, playing=playing, frame_seconds=frame_seconds),
                      driver_class=driver_class)


def make_fit_app(args: argparse.Namespace, demos: Demonstrations, result: FitResult | None = None,
                 *, show_times: bool = True, driver_class: type[Driver] | None = None) -> CarefulApp:
    """The app on the fit view `careful fit` opens for its parsed `args` (the CLI and the tests build it here)."""
    screen = FitScreen(demos, options_from_args(args), result=result, sources=args.files, svg=args.svg,
                       show_times=show_times)
    return CarefulApp(screen, driver_class=driver_class)
