"""`careful play`: check the world and the recordings folder, play, then say what was recorded."""

from __future__ import annotations

import argparse
import getpass
import secrets

from rich.console import Console

from careful_tui.app import make_play_app, make_reach_app
from careful_tui.commands.notices import ignored, warn
from careful_tui.errors import require_terminal
from careful_tui.keys.kitty import KittyDriver
from careful_tui.keys.probe import reports_key_releases
from irl_core.errors import UsageError
from irl_core.play.input_modes import DEFAULT_INPUT_MODE, INPUT_MODES, input_mode
from irl_core.play.reach_session import DEFAULT_TRIALS
from irl_core.recordings.writer import SessionRecorder, check_writable
from irl_core.support.safe_text import printable
from irl_core.worlds.reach import ReachWorld, is_reach_world, load_reach_world
from irl_core.worlds.world import load_world


def default_player() -> str:
    try:
        return getpass.getuser() or "player"
    except (KeyError, OSError):
        return "player"


def run_play(args: argparse.Namespace) -> int:
    """`careful play`: check the world and the recordings folder, then play."""
    if is_reach_world(args.world):
        return play_reach(args, load_reach_world(args.world))
    world = load_world(args.world)
    if args.trials is not None:
        warn(Console(stderr=True, highlight=False), ignored(["--trials"], "to reach worlds"))
    check_out(args)
    require_terminal("play")
    if world.care == "time":
        time_world_playable(world.name, args.input)
    # Calibration times how long a held key takes per level: other inputs and one level time nothing.
    times_holds = input_mode(args.input).times_holds
    calibrate = args.calibrate and times_holds and world.levels > 1
    if args.calibrate and not calibrate:
        timed = " or ".join(f"--input {mode.name}" for mode in INPUT_MODES.values() if mode.times_holds)
        applies = f"to {timed}" if not times_holds else f"to a world of several levels ({world.name!r} has one)"
        warn(Console(stderr=True, highlight=False), ignored(["--calibrate"], applies))
    seed = args.seed if args.seed is not None else secrets.randbelow(2**32)
    player = args.player or default_player()
    app = make_play_app(world, out=args.out, player=player, seed=seed, input_mode=args.input,
                        calibrate=calibrate, driver_class=KittyDriver)
    session = app.first_screen.session
    try:
        app.run()
    finally:
        session.quit()
    recorder = session.recorder
    say_recorded(recorder)
    if session.write_error is not None:
        kept = "the steps before it are kept" if recorder.paths else "nothing was recorded"
        raise UsageError(f"cannot write the recording in {args.out} ({write_problem(session.write_error)}); "
                         f"the game stopped and {kept}")
    if not recorder.paths:
        print("nothing was played, so nothing was recorded")
    return 0


def check_out(args: argparse.Namespace) -> None:
    """Refuse an --out that is no folder careful can write recordings in, in one line."""
    if args.out.exists() and not args.out.is_dir():
        raise UsageError(f"{args.out} is a file, not a folder; choose a folder for recordings with --out")
    if args.out.is_symlink() and not args.out.exists():
        raise UsageError(f"{args.out} is a link to nothing; choose a folder for recordings with --out")
    try:
        check_writable(args.out)
    except OSError as exc:
        raise UsageError(f"cannot write recordings to {args.out} ({exc.strerror or exc}); "
                         "choose a writable folder with --out") from None


def play_reach(args: argparse.Namespace, world: ReachWorld) -> int:
    """`careful play` on a reach world: a block of reaches, aimed with the arrows and timed by holding space."""
    if world.noise == "own":
        raise UsageError(f"{printable(world.name, limit=40)!r} has noise = \"own\": each reach is a pointer's real "
                         "movement, which a terminal has no pointer for; play it in the browser (careful serve)")
    options = [name for name, given in (("--calibrate", args.calibrate),
                                        ("--input", args.input != DEFAULT_INPUT_MODE)) if given]
    if options:
        warn(Console(stderr=True, highlight=False), ignored(options, "to grid worlds"))
    check_out(args)
    require_terminal("play")
    seed = args.seed if args.seed is not None else secrets.randbelow(2**32)
    app = make_reach_app(world, out=args.out, player=args.player or default_player(), seed=seed,
                         trials=args.trials or DEFAULT_TRIALS, driver_class=KittyDriver)
    session = app.first_screen.session
    try:
        app.run()
    finally:
        session.quit()
    say_recorded(session.recorder)
    if session.write_error is not None:
        kept = "the trials before it are kept" if session.recorder.paths else "nothing was recorded"
        raise UsageError(f"cannot write the recording in {args.out} ({write_problem(session.write_error)}); "
                         f"the block stopped and {kept}")
    if not session.recorder.paths:
        print("nothing was played, so nothing was recorded")
    return 0


def time_world_playable(name: str, mode: str) -> None:
    """A time world is played by holding keys, timed from key-down to key-up: refuse another input, or a
    terminal that does not report key-ups, in one line (rather than guessing holds from autorepeats)."""
    shown = printable(name, limit=40)
    if mode != "hold":
        raise UsageError(f"{shown!r} is a time world: care is how long an arrow is held, so --input {mode} does not "
                         "apply (leave --input out)")
    if not reports_key_releases():
        raise UsageError(f"{shown!r} is a time world: care is how long each arrow is held, timed from key-down to "
                         "key-up, and this terminal does not report key-ups; play it in a terminal that speaks "
                         "kitty's keyboard protocol (kitty, WezTerm, foot, Ghostty) or in the browser "
                         "(careful serve)")


def say_recorded(recorder: SessionRecorder) -> None:
    """Print the files a session recorded (and any deleted under it, whose steps were written again)."""
    for path in recorder.lost:
        print(f"{printable(str(path))} was deleted during the session; its steps were written again below")
    for path in recorder.paths:
        print(f"recorded to {printable(str(path))}")


def write_problem(error: OSError | ValueError) -> str:
    """Why a recording could not be written, in a few words ("No space left on device")."""
    return getattr(error, "strerror", None) or str(error)
