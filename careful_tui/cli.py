"""The `careful` command line (docs/index.md).

Exit status: 0 success; 2 bad usage or bad input (argparse's, or any `irl_core.errors.InputError`:
one message on stderr, no traceback); 1 anything else. Heavy modules (Textual, cvxpy) are imported
only by the commands that need them, so `careful worlds` and `careful --help` answer at once.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.text import Text

from careful_tui.arguments import (
    add_fit_options,
    finite_float,
    non_negative_float,
    non_negative_int,
    player_names,
    positive_float,
    positive_int,
    probability,
    seed_int,
    text_argument,
)
from careful_tui.errors import EXIT_BAD_INPUT, EXIT_FAILURE, EXIT_OK, missing_extra, missing_extra_line
from careful_tui.version import app_version
from irl_core.errors import InputError
from irl_core.irl.choices import DEFAULT_POOL_MODEL, LEVEL_MODELS, PLAN_FITS, POOL_MODELS
from irl_core.play.input_modes import DEFAULT_INPUT_MODE, INPUT_MODE_NAMES, INPUT_MODES
from irl_core.play.reach_session import DEFAULT_TRIALS
from irl_core.players.person_like import KINDS as PERSON_LIKE
from irl_core.players.person_like import LEVEL_KINDS, REACH_KINDS
from irl_core.support.safe_text import one_line


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="careful",
        description="Play the careful cliff game, record demonstrations, and fit rewards to them "
        "with inverse RL that reads carefulness.",
        epilog="Run 'careful COMMAND --help' for a command's options.",
    )
    parser.add_argument("--version", action="version", version=f"careful {app_version()}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    _add_play(commands)
    _add_replay(commands)
    _add_fit(commands)
    _add_check(commands)
    _add_simulate(commands)
    _add_worlds(commands)
    _add_experiment(commands)
    _add_export(commands)
    _add_import(commands)
    _add_study(commands)
    _add_serve(commands)
    return parser


def _add_play(commands: Any) -> None:
    play = commands.add_parser("play", help="play the game and record every step", description=(
        "Play the cliff gridworld. Arrow keys move; hold a key longer to be more careful "
        "(careful moves cost more and slip less). Every step is saved as JSONL. On a reach world "
        "(reach, reach-mild, reach-severe or a reach world file) the arrow keys aim, holding space times "
        "the reach and letting go launches it (docs/reach.md)."))
    play.add_argument("--world", default="paper", metavar="NAME|FILE", help="built-in world or TOML file (default: paper)")
    play.add_argument("--player", type=text_argument, default=None, help="name recorded in the session (default: your user name)")
    play.add_argument("--out", type=Path, default=Path("recordings"), metavar="DIR",
                      help="folder for recordings (default: recordings/)")
    play.add_argument("--input", choices=INPUT_MODE_NAMES, default=DEFAULT_INPUT_MODE, help="; ".join(
        f"{mode.name}: {mode.cli_help}" + (" (default)" if mode.name == DEFAULT_INPUT_MODE else "")
        for mode in INPUT_MODES.values()))
    play.add_argument("--seed", type=seed_int, default=None, help="seed for the world's randomness (default: random)")
    play.add_argument("--calibrate", action="store_true", help="measure your keyboard's autorepeat before playing")
    play.add_argument("--trials", type=positive_int, default=None, metavar="N",
                      help=f"reach worlds: the reaches in the block (default {DEFAULT_TRIALS})")


def _add_replay(commands: Any) -> None:
    replay = commands.add_parser("replay", help="watch recorded sessions", description=(
        "Watch recorded sessions step by step or animated, one file after another: files in the order "
        "given, a folder's *.jsonl files in name order (numbers by value, so s-2 comes before s-10). "
        "careful play names its files YYYYMMDD-HHMMSS-PLAYER.jsonl, so a folder of them replays in the "
        "order they were recorded. Each file is shown in its own world. A file that cannot be read is "
        "named (file, line, field) and left out, and the others replay."))
    replay.add_argument("files", type=Path, nargs="+", metavar="FILE|FOLDER",
                        help="recordings, or folders of recordings (not searched below the folder)")


def _add_fit(commands: Any) -> None:
    fit = commands.add_parser("fit", help="fit a reward to recordings (inverse RL)", description=(
        "Fit the state rewards R_S that explain the recorded behaviour. With a terminal it opens "
        "the fit view; without one, or with --no-view, it prints the result and exits. On reach recordings it "
        "fits each circle's points and the spread law, and shows them in the reach fit view or prints them "
        "(docs/reach.md)."))
    fit.add_argument("files", type=Path, nargs="+", metavar="FILE",
                     help="recordings (JSONL) of one world, fitted together")
    add_fit_options(fit)
    fit.add_argument("--json", type=Path, metavar="PATH", help="write the result as JSON")
    fit.add_argument("--svg", type=Path, metavar="PATH", help="save a picture of the result as SVG")
    fit.add_argument("--figure", type=Path, metavar="PATH", help="save the result as a figure for a paper "
                     "(matplotlib; .pdf, .png at 300 dpi or .svg, by the suffix)")
    fit.add_argument("--no-view", action="store_true", help="print the result instead of opening the fit view")
    fit.add_argument("--spread-known", action="store_true", help=(
        "a reach world: use the world's own spread law instead of fitting it to the recorded aims and endpoints"))
    fit.add_argument("--spread-law", type=Path, metavar="FILE", help=(
        "a reach world: hold the spread law at the one in FILE (a participant's calibration, spread-<i>.json beside "
        "their recordings, or a JSON or TOML giving a and b), its interval carried into the points' intervals"))


def _add_check(commands: Any) -> None:
    check = commands.add_parser("check", help="measure how often a fit's intervals hold the truth", description=(
        "Measure the coverage of a fit's intervals on your own design: fit the recordings as careful fit does "
        "(the same options, intervals on), then simulate --datasets datasets of their size (one episode from each "
        "recorded start) from the fit (its player model with the fitted rewards and player) and from each rival "
        "player of --players (person-like players of the world's own rewards), fit each as the recordings were "
        "fitted, and count per symbol how often its interval held the reward the dataset was simulated with (per "
        "cell: every cell of the symbol). Prints the table and a verdict per player (nominal, or under-covering "
        "with the symbols) and writes check.csv to --out. --seed seeds the simulations and every refit's "
        "resampling: the same seed gives the same check.csv on any --workers or --scheduler."),
        epilog="Example: careful check x.jsonl --tie --datasets 50 --players loose,hasty; see docs/check.md.")
    check.add_argument("files", type=Path, nargs="+", metavar="FILE",
                       help="recordings (JSONL) of one world, fitted together")
    add_fit_options(check)
    check.add_argument("--datasets", type=positive_int, default=50, metavar="N",
                       help="simulated datasets per player, each as many episodes as the recordings (default 50)")
    check.add_argument("--players", type=player_names, default=None, metavar="KIND,...",
                       help="rival person-like players, as careful simulate --policy names them (loose, timed, hasty, "
                            "inverted, reckless, streaky, growing, learning; timing and steady on a time world "
                            "only); default loose,timed,hasty "
                            "(timing,steady on a time world); an empty list checks the fit's own model alone")
    check.add_argument("--out", type=Path, default=Path("."), metavar="DIR",
                       help="folder for check.csv (default: this folder; an earlier check.csv there is replaced)")
    check.add_argument("--workers", type=positive_int, default=None, metavar="N",
                       help="processes for the refits (default: every core)")
    check.add_argument("--scheduler", default=None, metavar="ADDRESS", type=text_argument,
                       help="refit on a Dask cluster instead of this machine's process pool: a scheduler's address "
                            "(tcp://HOST:8786), or local:N for a cluster of N processes started here; needs "
                            "careful[cluster]; the numbers are the same")


def _add_simulate(commands: Any) -> None:
    simulate = commands.add_parser("simulate", help="record a computer expert or a person-like player", description=(
        "Roll out a computer expert or a person-like player and write its episodes as a recording."))
    simulate.add_argument("--world", required=True, metavar="NAME|FILE", help="built-in world or TOML file")
    simulate.add_argument("--policy", choices=["optimal", "boltzmann", *PERSON_LIKE, *REACH_KINDS], required=True,
                          help="optimal: the best action in every state; boltzmann: actions with probability "
                               "proportional to exp(beta Q); loose, timed, hasty, inverted, reckless, streaky, "
                               "growing, learning: person-like players over the optimal plan (docs/people.md); timing, "
                               "steady: players of a time world who hold the key for a time (docs/timing.md); on a reach "
                               "world optimal is the expected-gain maximiser, boltzmann the soft-optimal reacher and "
                               "hand a person-like reacher with aim noise, timing noise and lapses (docs/reach.md)")
    simulate.add_argument("--beta", type=positive_float, default=None,
                          help="Boltzmann inverse temperature, for --policy boltzmann (default 1.0)")
    simulate.add_argument("--lapse", type=probability, default=None, metavar="P",
                          help="share of lapsed directions: loose, inverted, growing, learning, timing, steady 0.1 "
                               "(random), timed 0.1 (the previous one), streaky 0.1 (random, in streaks), reckless 0.25 "
                               "(random); hand: share of lapsed reaches, 0.1 (half aimed at random, half rushed)")
    simulate.add_argument("--streak", type=positive_float, default=None, metavar="STEPS",
                          help="streaky: the mean length of a streak of lapses, at least 1 (default 4)")
    simulate.add_argument("--spread", type=non_negative_float, default=None, metavar="LEVELS",
                          help="sd of the level's noise: loose, inverted, streaky, learning 1.75, hasty 1, growing 0.5 "
                               "(its sd at level 0)")
    simulate.add_argument("--growth", type=non_negative_float, default=None, metavar="LEVELS",
                          help="growing: the level noise's sd grows by this much per level aimed at (default 0.25)")
    simulate.add_argument("--fear", type=non_negative_float, default=None, metavar="SHARE",
                          help="learning: the share of each hazard's reward it believes in its first episode (default "
                               "0.1); the belief moves to the truth over the episodes")
    simulate.add_argument("--half-life", dest="half_life", type=positive_float, default=None, metavar="EPISODES",
                          help="learning: episodes for the belief to close half its gap to the truth (default 5)")
    simulate.add_argument("--weber", type=non_negative_float, default=None, metavar="SD",
                          help="timed, timing: sd of the log hold time (default 0.25, about 25%%); hand: sd of "
                               "the log reach duration (default 0.15)")
    simulate.add_argument("--aim-sd", dest="aim_sd", type=non_negative_float, default=None, metavar="UNITS",
                          help="hand: sd of the hand's own aim noise per axis, in field units (default 4)")
    simulate.add_argument("--poll-ms", dest="poll_ms", type=non_negative_float, default=None, metavar="MS",
                          help="timing: key-ups land on this polling grid, as a USB keyboard's (default 8)")
    simulate.add_argument("--hold-ms", dest="hold_ms", type=positive_float, default=None, metavar="MS",
                          help="steady: the one hold, whatever is at stake (default 600)")
    simulate.add_argument("--temperature", type=positive_float, default=None,
                          help="hasty: temperature of the direction's choice, in reward units (default 1.25)")
    simulate.add_argument("--bias", type=finite_float, default=None, metavar="LEVELS",
                          help="hasty: levels held short of the best one (default 2)")
    simulate.add_argument("--episodes", type=positive_int, required=True,
                          help="episodes to roll out (on a reach world: trials, one reach each)")
    simulate.add_argument("--seed", type=seed_int, required=True,
                          help="seed of the rollouts (the same seed writes the same file)")
    simulate.add_argument("--out", type=Path, required=True, metavar="FILE", help="the new recording (never overwritten)")


def _add_worlds(commands: Any) -> None:
    worlds = commands.add_parser("worlds", help="list the built-in worlds", description="List the built-in worlds, or show one.")
    worlds.add_argument("--show", metavar="NAME|FILE", help="draw one world and print it as TOML")


def _add_experiment(commands: Any) -> None:
    experiment = commands.add_parser("experiment", help="the paper's experiments, end to end", description=(
        "Run the paper's experiments end to end: figures as PDF and PNG (300 dpi), summary.json and report.md."))
    experiment.add_argument("--out", type=Path, default=Path("experiment"), metavar="DIR",
                            help="output folder (default: experiment/)")
    experiment.add_argument("--quick", action="store_true", help="reduced sizes, for a fast check")
    experiment.add_argument("--recordings", type=Path, default=None, metavar="DIR",
                            help="people's recordings of paper for the human stage (default: simulated noisy "
                            "experts, labelled so)")
    experiment.add_argument("--seed", type=seed_int, default=0, help="seed of every simulated expert and resampling (default 0)")


def _add_export(commands: Any) -> None:
    export = commands.add_parser("export", help="recordings as CSV, a Minari or a Psych-DS dataset", description=(
        "Export recordings for other tools: a CSV table with one row per step, a local Minari "
        "dataset (under $MINARI_DATASETS_PATH, or ~/.minari/datasets) of one world, one Minari episode "
        "per recorded episode, with the environment careful/Careful-v0 to recover, or a Psych-DS dataset "
        "(dataset_description.json and data/study-<name>_participant-<id>_data.csv, the CSV's rows per "
        "participant). Never overwrites."))
    export.add_argument("files", type=Path, nargs="+", metavar="FILE", help="recordings (JSONL) to export")
    export.add_argument("--format", choices=["csv", "minari", "psych-ds"], required=True,
                        help="csv: one row per step; minari: a Minari dataset, one episode per recorded episode; "
                        "psych-ds: a Psych-DS dataset, one CSV file per study and participant")
    export.add_argument("--out", required=True, metavar="PATH|DATASET_ID|DIR",
                        help="csv: the new CSV file; minari: the new dataset's id, e.g. careful/paper-human-v0; "
                        "psych-ds: the new dataset's folder")


def _add_import(commands: Any) -> None:
    imports = commands.add_parser("import", help="another lab's trial table as recordings", description=(
        "Read a trial table with one row per move (CSV, TSV, JSON lines or a JSON array of objects, by the file's "
        "suffix) into recordings of a world: one recording per participant, DIR/<participant>.jsonl. A column map "
        "(TOML) names the table's columns (participant, episode, t, state, next_state, action with its [actions] "
        "codes, rt_ms or rt_s, level) and its coordinates (axes, origin). Every refused row is named (file, line, "
        "column, why) and then nothing is written; the recordings are read back with the recordings' reader before "
        "they are put in place, and an existing file is never overwritten."),
        epilog="Example: careful import trials.csv --world maze.toml --map map.toml --out recordings/lab; "
        "see docs/import.md.")
    imports.add_argument("table", type=Path, metavar="TABLE", help="the trial table (.csv, .tsv, .jsonl, .json)")
    imports.add_argument("--world", required=True, metavar="NAME|FILE", help="the world the table's task was played in")
    imports.add_argument("--map", required=True, type=Path, metavar="MAP.toml", help="the column map (docs/import.md)")
    imports.add_argument("--out", required=True, type=Path, metavar="DIR",
                         help="folder for the recordings (made if missing; nothing in it is replaced)")


def _add_study(commands: Any) -> None:
    study = commands.add_parser("study", help="studies: one protocol for many participants, one report", description=(
        "Studies (a study file names the worlds, their order, practice and main episodes per world). "
        "'careful study run' takes one participant through the study; 'careful study report' fits "
        "every participant and the pool of them."))
    study_commands = study.add_subparsers(dest="study_command", metavar="COMMAND", required=True)
    _add_study_run(study_commands)
    _add_study_report(study_commands)
    _add_study_plan(study_commands)


def _add_study_run(study_commands: Any) -> None:
    run = study_commands.add_parser("run", help="take one participant through the study", description=(
        "Take one participant through the study in this terminal: the study's instructions (space to "
        "begin), then for each world, in the participant's order, its practice episodes and its main "
        "episodes, a short screen between worlds, and an end screen. Recordings go to <out>/<ID>/, a new "
        "file each time a block starts, its header tagged with the study, the phase and the world. q leaves at any "
        "time and keeps what was recorded; running the same participant again goes on where they "
        "stopped (an episode left mid-way is played again; nothing is overwritten). A participant who "
        "has finished is told so (exit 0)."),
        epilog="Example: careful study run pilot.toml --participant p07; when everyone has played, "
        "careful study report pilot.toml.")
    run.add_argument("study", type=Path, metavar="STUDY.toml", help="the study file")
    run.add_argument("--participant", required=True, metavar="ID", type=text_argument,
                     help="the participant's id, their folder's name: 1 to 80 letters, digits and _ . = -")


def _add_study_report(study_commands: Any) -> None:
    report = study_commands.add_parser("report", help="fit every participant and the pool, per world", description=(
        "Fit the main-phase episodes of every participant folder under the study's out folder, per world, with 95% "
        "confidence intervals (maxent, beta estimated, one reward per symbol; lp with its identified set for a "
        "deterministic player), and pool them: by default as the population of participants, each with their own "
        "player (the centre, the spread between people and a prediction interval for a new participant; outliers "
        "and influential participants marked), after the study file's [exclusions]. Prints a table, and writes "
        "report.csv and the figures (PNG and PDF) to <out>/report/. A file that cannot be used is named and left "
        "out."))
    report.add_argument("study", type=Path, metavar="STUDY.toml", help="the study file")
    report.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="folder for report.csv and the figures (default: <the study's out>/report/)")
    report.add_argument("--resamples", type=int, default=200, metavar="N",
                        help="bootstrap resamples per fit, at least 20 (default 200)")
    report.add_argument("--seed", type=seed_int, default=0, metavar="N", help="seed of the resampling (default 0)")
    report.add_argument("--workers", type=positive_int, default=None, metavar="N",
                        help="processes for the fits (default: every core)")
    report.add_argument("--scheduler", default=None, metavar="ADDRESS", type=text_argument,
                        help="fit on a Dask cluster instead of this machine's process pool: a scheduler's address "
                             "(tcp://HOST:8786), or local:N for a cluster of N processes started here; needs "
                             "careful[cluster] (docs/studies.md, \"On a cluster\"); the numbers are the same")
    report.add_argument("--rmax", type=positive_float, default=5000.0, metavar="X",
                        help="bound |R_S| <= rmax for every fit (default 5000, so a cliff at -1000 lies well inside)")
    report.add_argument("--pool-model", choices=tuple(POOL_MODELS), default=DEFAULT_POOL_MODEL,
                        help=_pool_help("the report pools them"))
    report.add_argument("--no-exclusions", action="store_true",
                        help="pool every participant, ignoring the study file's [exclusions] (to show what they change)")


def _add_study_plan(study_commands: Any) -> None:
    plan = study_commands.add_parser("plan", help="simulate whole studies: how many participants and episodes?",
                                     description=(
        "Simulate whole studies before running one: for each world of the study, with the hypothesised rewards "
        "(--truth), and each grid point (--participants x --episodes), --repeats studies of person-like "
        "participants (--players in turn, each with their own parameters, spread by --spread, first holding "
        "--calibration targets when the study has a calibration block), each participant fitted with a model of "
        "people and a Laplace interval (or, with --fits report, the whole study fitted as study report fits it), "
        "then pooled. Prints, per grid point, the share of "
        "studies whose pooled cliff interval lies below the nuisance's (the report's 'separates catastrophe from "
        "nuisance'), the share whose pooled intervals hold the hypothesised rewards, and the median interval "
        "widths; writes plan.csv and plan.pdf/plan.png to <out>/plan/."),
        epilog="Example: careful study plan pilot.toml --participants 5,10 --episodes 5,10 --repeats 20; the default "
        "grid (3 x 3, 20 studies each) took about 10 minutes per world on two busy cores.")
    plan.add_argument("study", type=Path, metavar="STUDY.toml", help="the study file")
    plan.add_argument("--truth", default=None, metavar="C=-1000,U=-30,G=100",
                      help="the hypothesised reward per symbol (default: the worlds' own)")
    plan.add_argument("--participants", default="5,10,20", metavar="N,N,...",
                      help="participants per study, the grid's rows (default 5,10,20)")
    plan.add_argument("--episodes", default="5,10,20", metavar="N,N,...",
                      help="main episodes per participant and world, the grid's columns (default 5,10,20)")
    plan.add_argument("--players", default="loose,timed,hasty", metavar="KIND,...",
                      help=f"person-like players drawn in turn ({', '.join(LEVEL_KINDS)}: the players of worlds "
                           "with levels, which the plan simulates; default loose,timed,hasty)")
    plan.add_argument("--spread", type=non_negative_float, default=0.3, metavar="S",
                      help="between participants, each player parameter is its default times exp(N(0, S)) "
                           "(default 0.3)")
    plan.add_argument("--calibration", type=non_negative_int, default=None, metavar="N",
                      help="motor calibration targets each participant holds before playing, their hand then held "
                           "fixed in the fit as study report does (default: the study file's calibration_block; 0: "
                           "none, the hand estimated from play)")
    plan.add_argument("--player-model", choices=LEVEL_MODELS, default="person",
                      help="the model of the player every simulated participant is fitted with (default person; "
                           "naive for players who do not make up for their hand, as study report chose for "
                           "under-holders with a calibration block)")
    plan.add_argument("--pool-model", choices=tuple(POOL_MODELS), default=DEFAULT_POOL_MODEL,
                      help=_pool_help("simulated as study report pools them"))
    plan.add_argument("--fits", choices=tuple(PLAN_FITS), default="plan",
                      help="how each simulated study is fitted: plan (default), the quick fit above, whose "
                           "coverage is a floor for a report's (its Laplace interval is narrower); report, as "
                           "careful study report fits it (the model the pool chooses, bootstrap intervals, the "
                           "study's exclusions), so the covered column forecasts reports of that size, at the cost "
                           "of that many reports (about 30 s per study of 5 x 10 on one core: use a small grid)")
    plan.add_argument("--resamples", type=positive_int, default=50, metavar="N",
                      help="with --fits report, the bootstrap resamples of each fit (default 50; a report's own "
                           "default is 200)")
    plan.add_argument("--repeats", type=positive_int, default=20, metavar="N",
                      help="simulated studies per grid point (default 20)")
    plan.add_argument("--seed", type=seed_int, default=0, metavar="N", help="seed of the simulations (default 0)")
    plan.add_argument("--workers", type=positive_int, default=None, metavar="N",
                      help="processes (default: every core)")
    plan.add_argument("--out", type=Path, default=None, metavar="DIR",
                      help="the files go to DIR/plan/ (default: the study's out folder)")


def _add_serve(commands: Any) -> None:
    serve = commands.add_parser("serve", help="serve a study to participants in a web browser", description=(
        "Serve the study to participants in a web browser: the same screens, blocks, files and resume rules as "
        "'careful study run', with every hold timed from key down to key up. Participants arrive by a link "
        "from --links (written to <out>/links.csv) or by a Prolific link (?PROLIFIC_PID=...&STUDY_ID=..."
        "&SESSION_ID=...). It listens on 127.0.0.1 unless --host says otherwise; put a public study behind a "
        "TLS reverse proxy. Ctrl+C stops it, every recording closed."),
        epilog="Example: careful serve pilot.toml --links 20; see docs/browser.md.")
    serve.add_argument("study", type=Path, metavar="STUDY.toml", help="the study file")
    serve.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    serve.add_argument("--port", type=port_number, default=8000, help="port to listen on (default 8000; 0: any free port)")
    serve.add_argument("--links", type=positive_int, default=0, metavar="N",
                       help="add N new participant links to <out>/links.csv (the old ones kept, the file written whole)")
    serve.add_argument("--prolific", action="store_true",
                       help="also take Prolific links when there are --links (without links they are on): each "
                       "Prolific id is a participant of its own (prolific-<PROLIFIC_PID>), never a link's")
    serve.add_argument("--completion-code", default=None, metavar="CODE",
                       help="Prolific's completion code: a Prolific participant who finishes is sent to Prolific's "
                       "completion address with it, once every episode is on disk")
    serve.add_argument("--workers", type=positive_int, default=1, metavar="N",
                       help="worker processes serving on the one port (default 1; at most 4 per core): any of them "
                       "serves any request, each page's seat kept in <out>/.<participant>.seat")
    serve.add_argument("--forwarded-allow-ips", default=None, metavar="IPS",
                       help="the reverse proxy's addresses or networks, separated by commas (127.0.0.1 for one on "
                       "this machine): a request from one of them is counted under the client address its "
                       "X-Forwarded-For names (default: none; every request under its own peer's address)")


def _pool_help(how: str) -> str:
    """--pool-model's help from its registry: each pool model, the default first (`how`: what pools them)."""
    return f"how participants are pooled ({how}): " + "; ".join(
        f"{name}{' (default)' if name == DEFAULT_POOL_MODEL else ''}: {what}" for name, what in POOL_MODELS.items())


def port_number(text: str) -> int:
    value = int(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port from 0 to 65535, got {text}")
    return value


class _Parser(argparse.ArgumentParser):
    """argparse, with its error on one line (not the usage too) and made safe: a bad value can
    hold control characters. Every subcommand's parser is one of these (argparse builds them with
    the parent's class), so each refuses an abbreviated flag: `--participant 5` must not run as
    `--participants 5` and overwrite the last plan."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **{**kwargs, "allow_abbrev": False})

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: {one_line(message)} (see {self.prog} --help)\n")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    err = Console(stderr=True, highlight=False)

    def say(prefix: str, message: str) -> None:
        # Text, never markup; one line, control characters escaped (names come from files).
        err.print(Text.assemble((f"careful {args.command}: {prefix}", "bold red"), one_line(message)), soft_wrap=True)

    try:
        return COMMANDS[args.command](args) or EXIT_OK
    except InputError as exc:  # careful refused the input (a UsageError, an OutputError, a bad file, ...)
        say("", str(exc))
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        err.print(f"careful {args.command}: interrupted")
        return EXIT_FAILURE
    except Exception as exc:  # noqa: BLE001 - the last line of defence: no traceback reaches a user
        say("unexpected error: ", f"{type(exc).__name__}: {exc}")
        err.print("Please report this with the command you ran.")
        return EXIT_FAILURE


def _lazy(module: str, function: str) -> Callable[[argparse.Namespace], int]:
    """A command that imports its module when it runs: Textual, cvxpy and matplotlib load only
    for the commands that need them, so `careful --help` and `careful worlds` answer at once."""

    def run(args: argparse.Namespace) -> int:
        try:
            command = getattr(importlib.import_module(module), function)
            return command(args)
        except ModuleNotFoundError as exc:
            # An extra's module, missing here or mid-command (matplotlib for a figure): what to install.
            if (extra := missing_extra(exc)) is None:
                raise
            print(missing_extra_line(exc, extra), file=sys.stderr)
            return EXIT_FAILURE

    return run


COMMANDS = {
    "play": _lazy("careful_tui.commands.play", "run_play"),
    "replay": _lazy("careful_tui.commands.replay", "run_replay"),
    "fit": _lazy("careful_tui.commands.fit", "run_fit"),
    "check": _lazy("careful_tui.commands.check", "run_check_command"),
    "simulate": _lazy("careful_tui.commands.simulate", "run_simulate"),
    "worlds": _lazy("careful_tui.commands.worlds", "run_worlds"),
    "experiment": _lazy("careful_tui.commands.experiment", "run_experiment"),
    "export": _lazy("careful_tui.commands.export", "run_export"),
    "import": _lazy("careful_tui.commands.import_table", "run_import"),
    "serve": _lazy("careful_tui.commands.serve", "run_serve"),
    "study": lambda args: STUDY_COMMANDS[args.study_command](args),
}
STUDY_COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "run": _lazy("careful_tui.commands.study_run", "run_study_run"),
    "report": _lazy("careful_tui.commands.study_report", "run_study_report"),
    "plan": _lazy("careful_tui.commands.study_plan", "run_study_plan"),
}


if __name__ == "__main__":
    sys.exit(main())
