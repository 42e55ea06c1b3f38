"""`careful simulate`: roll out a computer expert or a person-like player and write its episodes as a new recording."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import Progress
from rich.text import Text

from careful_tui.commands.notices import ignored, warn
from careful_tui.errors import EXIT_OK
from irl_core.errors import NotConverged, UsageError
from irl_core.players.experts import Chooser, boltzmann_policy, expert_name, optimal_policy, simulate_to_file
from irl_core.players.person_like import KINDS, REACH_KINDS, person_like
from irl_core.reach.players import reacher, simulate_reaches_to_file
from irl_core.support.plural import plural
from irl_core.support.safe_files import check_output
from irl_core.support.safe_text import one_line
from irl_core.worlds.mdp import MDP, build_mdp
from irl_core.worlds.reach import is_reach_world, load_reach_world
from irl_core.worlds.world import load_world

DEFAULT_BETA = 1.0  # --beta's default (cli.py's help says so)
# The person-like players' options: one per parameter of irl_core.players.person_like.KINDS and REACH_KINDS,
# named as it is.
PLAYER_OPTIONS = tuple(dict.fromkeys(name for kinds in (KINDS, REACH_KINDS) for parameters in kinds.values()
                                     for name in parameters))


def run_simulate(args: argparse.Namespace) -> int:
    world_file = [args.world] if Path(args.world).exists() else []
    check_output(args.out, option="--out", inputs=world_file)
    if args.out.exists():
        raise UsageError(f"{args.out} already exists; recordings are never overwritten, choose another --out")
    if is_reach_world(args.world):
        return _simulate_reaches(args)
    mdp = build_mdp(load_world(args.world))
    policy, player = _player(mdp, args)
    with Progress(console=Console(stderr=True), transient=True, disable=args.episodes < 2000) as progress:
        task = progress.add_task("simulating and writing episodes", total=args.episodes)
        try:
            ended = simulate_to_file(args.out, mdp, policy, episodes=args.episodes, seed=args.seed, player=player,
                                     progress=lambda done: progress.update(task, completed=done))
        except OSError as exc:
            raise UsageError(f"--out {args.out}: cannot write the recording ({exc.strerror or exc}); "
                             "nothing was kept") from None
    summary = ", ".join(f"{ended[k]} {k}" for k in sorted(ended))
    Console(stderr=True, highlight=False).print(
        Text(one_line(f"wrote {plural(args.episodes, 'episode')} (ended: {summary}) to {args.out}")), soft_wrap=True
    )
    return EXIT_OK


def _simulate_reaches(args: argparse.Namespace) -> int:
    """A reach world's computer player: one reach a trial, each trial an episode (docs/reach.md)."""
    world = load_reach_world(args.world)
    players = ("optimal", "boltzmann", *REACH_KINDS)
    if args.policy not in players:
        raise UsageError(f"--policy {args.policy}: a reach world has the {', '.join(players[:-1])} and "
                         f"{players[-1]} players")
    err = Console(stderr=True, highlight=False)
    _warn_unused_options(args, REACH_KINDS, "the person-like players of grid worlds")
    taken = REACH_KINDS.get(args.policy, {})
    parameters = {name: getattr(args, name) for name in taken if getattr(args, name) is not None}
    try:
        player = reacher(world, args.policy, beta=DEFAULT_BETA if args.beta is None else args.beta, **parameters)
    except ValueError as exc:
        raise UsageError(f"--policy {args.policy}: {exc}") from None
    try:
        hits = simulate_reaches_to_file(args.out, world, player, trials=args.episodes, seed=args.seed)
    except OSError as exc:
        raise UsageError(f"--out {args.out}: cannot write the recording ({exc.strerror or exc}); "
                         "nothing was kept") from None
    summary = ", ".join(f"{hits[k]} {k}" for k in sorted(hits))
    err.print(Text(one_line(f"wrote {plural(args.episodes, 'trial')} (endpoints in: {summary}) to {args.out}")),
              soft_wrap=True)
    return EXIT_OK


def _warn_unused_options(args: argparse.Namespace, kinds: dict[str, dict[str, float]], elsewhere: str) -> None:
    """Name in a warning each option given that `--policy` does not take, and the policies of this kind of world
    (`kinds`: the person-like players' registry) that do; an option none of them takes is for `elsewhere`."""
    for name in ("beta", *PLAYER_OPTIONS):
        policies = ["boltzmann"] if name == "beta" else [kind for kind, names in kinds.items() if name in names]
        if getattr(args, name) is not None and args.policy not in policies:
            listed = (f"--policy {policies[0]}" if len(policies) == 1 else
                      f"--policy {', '.join(policies[:-1])} and {policies[-1]}" if policies else elsewhere)
            warn(Console(stderr=True, highlight=False), ignored([_flag(name)], f"to {listed}"))


def _flag(name: str) -> str:
    """The command-line flag of a player's parameter (``aim_sd`` is ``--aim-sd``)."""
    return "--" + name.replace("_", "-")


def _player(mdp: MDP, args: argparse.Namespace) -> tuple[np.ndarray | Chooser, str]:
    """The policy (or chooser) `--policy` and its options ask for, and its player name; an option the
    policy does not take is named in a warning and ignored."""
    if args.policy in REACH_KINDS:
        raise UsageError(f"--policy {args.policy}: a player of reach worlds (docs/reach.md), not of a grid world")
    _warn_unused_options(args, KINDS, "the person-like player of reach worlds")
    try:
        if args.policy == "optimal":
            return optimal_policy(mdp), expert_name("optimal")
        if args.policy == "boltzmann":
            beta = DEFAULT_BETA if args.beta is None else args.beta
            return boltzmann_policy(mdp, beta=beta), expert_name("boltzmann", beta)
        player = person_like(mdp, args.policy, **{name: getattr(args, name) for name in KINDS[args.policy]
                                                  if getattr(args, name) is not None})
    except NotConverged as exc:
        raise UsageError(str(exc)) from None
    except ValueError as exc:  # a player for the other kind of world (levels or time)
        raise UsageError(f"--policy {args.policy}: {exc}") from None
    return player.choose, player.player
