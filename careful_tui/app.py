"""The careful app and its factories: the command line and the tests build it here, the same
way, each opening it on its first screen (play, replay, the fit view or a study's flow).

The app: `CAREFUL_THEME` registers `careful_tui.render.palette`'s colours as Textual theme
variables, so `screens/careful.tcss` says `$good`, `$bad`, `$note`, `$warn`, `$busy`, `$slip`,
`$ink`, `$frame` and never a hex code. Play, replay and the fit view are `Screen`s of one
`CarefulApp`, which opens on the screen it is given and can push more; the stylesheet scopes
their differences by the screen's type (`ReplayScreen #gauge { ... }`). Each screen lists its
keys in `BINDINGS` and hides those that do nothing now with `check_action`; the app adds the
quit keys; the key bar (`careful_tui.widgets.keybar`) shows them.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Generic, TypeVar

from textual.app import App
from textual.binding import Binding, BindingType
from textual.driver import Driver
from textual.screen import Screen
from textual.theme import Theme

from careful_tui.arguments import fit_inputs, options_from_args
from careful_tui.render.palette import BACKGROUND, BAD, FRAME, GOOD, INK, NOTE, PANEL, SLIP, SURFACE, WARN
from careful_tui.screens.fit import FitScreen
from careful_tui.screens.play import PlayScreen
from careful_tui.screens.reach import ReachScreen
from careful_tui.screens.reach_fit import ReachFitScreen
from careful_tui.screens.replay import FRAME_S, ReplayScreen
from careful_tui.screens.study import StudyScreen
from careful_tui.version import app_version
from irl_core.irl import FitResult
from irl_core.play.hold import Clock, HoldProfile
from irl_core.play.input_modes import DEFAULT_INPUT_MODE
from irl_core.play.reach_session import ReachOptions, new_reach_session
from irl_core.play.session import PlayOptions, new_session
from irl_core.reach.fit import ReachFit
from irl_core.recordings.demonstrations import Demonstrations, Recording
from irl_core.recordings.lines import StudyTag
from irl_core.recordings.reach_reader import Reaches
from irl_core.studies.flow import StudyFlow
from irl_core.studies.study import LoadedStudy
from irl_core.worlds.reach import ReachWorld
from irl_core.worlds.world import World

CAREFUL_THEME = Theme(
    name="careful",
    primary=NOTE,
    foreground=INK,
    background=BACKGROUND,
    surface=SURFACE,
    panel=PANEL,
    success=GOOD,
    warning=WARN,
    error=BAD,
    dark=True,
    variables={
        "good": GOOD,
        "bad": BAD,
        "note": NOTE,
        "warn": WARN,
        "busy": WARN,
        "slip": SLIP,
        "ink": INK,
        "frame": FRAME,
    },
)


# The app quits with q, Ctrl+C or Ctrl+Q, whatever screen is on top (a screen that must save
# something as it goes, as play records the running episode, does it when it is unmounted).
QUIT_BINDINGS: list[BindingType] = [
    Binding("q", "quit", "quit", priority=True),
    Binding("ctrl+c,ctrl+q", "quit", "quit", priority=True, show=False),
]


FirstScreen = TypeVar("FirstScreen", bound=Screen)


class CarefulApp(App[None], Generic[FirstScreen]):
    """The careful app: the careful theme, `careful.tcss`, no command palette, opening on `first_screen`.

    Args:
        first_screen: the screen it opens on (play, replay or the fit view); it stays reachable
            as `first_screen` while other screens are pushed over it.
        driver_class: the terminal driver (the CLI passes the kitty driver).
    """

    CSS_PATH = "screens/careful.tcss"
    ENABLE_COMMAND_PALETTE = False
    BINDINGS = QUIT_BINDINGS

    def __init__(self, first_screen: FirstScreen, *, driver_class=None) -> None:
        super().__init__(driver_class=driver_class)
        self.register_theme(CAREFUL_THEME)
        self.theme = CAREFUL_THEME.name
        self.first_screen = first_screen
        self.title = first_screen.TITLE or self.title

    def get_default_screen(self) -> FirstScreen:
        return self.first_screen


def make_play_app(
    world: World,
    *,
    out: str | Path,
    player: str,
    seed: int,
    input_mode: str = DEFAULT_INPUT_MODE,
    clock: Clock = time.monotonic,
    calibrate: bool = False,
    driver_class: type[Driver] | None = None,
) -> CarefulApp[PlayScreen]:
    """The app on the play screen, recording to a new file in `out` (the CLI and the tests both build it here)."""
    screen = new_play_screen(world, out=out, player=player, seed=seed, input_mode=input_mode, clock=clock,
                             calibrate=calibrate)
    return CarefulApp(screen, driver_class=driver_class)


def new_play_screen(world: World, *, out: str | Path, player: str, seed: int, input_mode: str, clock: Clock,
                    profile: HoldProfile | None = None, study: StudyTag | None = None, first_episode: int = 0,
                    calibrate: bool = False, event_times: bool | None = None) -> PlayScreen:
    """A play screen on a new session recording to a new file in `out` (its header tagged with
    `study`, if given), its episodes numbered from `first_episode`; `event_times` goes to the screen."""
    options = PlayOptions(input_mode=input_mode, profile=profile, calibrate=calibrate, player=player)
    session = new_session(world, out=out, seed=seed, options=options, clock=clock, app_version=app_version(),
                          study=study, first_episode=first_episode)
    return PlayScreen(session, event_times=event_times)


def make_reach_app(world: ReachWorld, *, out: str | Path, player: str, seed: int, trials: int,
                   clock: Clock = time.monotonic, event_times: bool | None = None,
                   driver_class: type[Driver] | None = None) -> CarefulApp[ReachScreen]:
    """The app on the reach screen: a block of `trials` reaches recording to a new file in `out` (the CLI and
    the tests both build it here)."""
    session = new_reach_session(world, out=out, seed=seed, app_version=app_version(), clock=clock,
                                options=ReachOptions(player=player, trials=trials))
    return CarefulApp(ReachScreen(session, event_times=event_times), driver_class=driver_class)


def make_study_app(study: LoadedStudy, participant: str, *, clock: Clock = time.monotonic,
                   seed: int | None = None, driver_class: type[Driver] | None = None) -> CarefulApp[StudyScreen]:
    """The app on the study screen: `participant` through `study`'s protocol from where their folder
    stands (`careful study run` and the tests build it here). `seed` fixes every block's seed (a
    test's); without it each block draws one."""
    flow = StudyFlow(study, participant, clock=clock, seed=seed, app_version=app_version())
    return CarefulApp(StudyScreen(flow), driver_class=driver_class)


def make_replay_app(*recordings: Recording, skipped: Sequence[str] = (), playing: bool = False,
                    frame_seconds: float = FRAME_S, driver_class: type[Driver] | None = None
                    ) -> CarefulApp[ReplayScreen]:
    """The app on the replay screen of `recordings`, watched in that order (`skipped`: a line per
    file left out; the CLI plays at once; the tests start paused)."""
    return CarefulApp(ReplayScreen(recordings, skipped=skipped, playing=playing, frame_seconds=frame_seconds),
                      driver_class=driver_class)


def make_reach_fit_app(args: argparse.Namespace, fit: ReachFit, reaches: Reaches, *,
                       driver_class: type[Driver] | None = None) -> CarefulApp[ReachFitScreen]:
    """The app on the reach fit view `careful fit` opens for reach recordings (the CLI and the tests build it here)."""
    return CarefulApp(ReachFitScreen(fit, reaches.endpoints, sources=fit_inputs(args)), driver_class=driver_class)


def make_fit_app(args: argparse.Namespace, demos: Demonstrations, result: FitResult | None = None,
                 *, show_times: bool = True, driver_class: type[Driver] | None = None) -> CarefulApp[FitScreen]:
    """The app on the fit view `careful fit` opens for its parsed `args` (the CLI and the tests build it here)."""
    screen = FitScreen(demos, options_from_args(args), result=result, sources=args.files, svg=args.svg,
                       show_times=show_times)
    return CarefulApp(screen, driver_class=driver_class)
