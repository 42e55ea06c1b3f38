"""`careful simulate`: roll out a computer expert and write its episodes as a new recording."""

from __future__ import annotations

import argparse
from pathlib import Path

from rich.console import Console
from rich.progress import Progress
from rich.text import Text

from careful_tui.commands.notices import ignored, warn
from careful_tui.errors import EXIT_OK, UsageError
from irl_core.experts import NotConverged, boltzmann_policy, expert_name, optimal_policy, simulate_to_file
from irl_core.mdp import build_mdp
from irl_core.safe_files import check_output
from irl_core.safe_text import one_line
from irl_core.words import plural
from irl_core.world import load_world

DEFAULT_BETA = 1.0  # --beta's default (cli.py's help says so)


def run_simulate(args: argparse.Namespace) -> int:
    world_file = [args.world] if Path(args.world).exists() else []
    check_output(args.out, option="--out", inputs=world_file)
    if args.out.exists():
        raise UsageError(f"{args.out} already exists; recordings are never overwritten, choose another --out")
    mdp = build_mdp(load_world(args.world))
    if args.policy == "optimal" and args.beta is not None:
        warn(Console(stderr=True, highlight=False), ignored(["--beta"], "to --policy boltzmann"))
    beta = DEFAULT_BETA if args.beta is None else args.beta
    try:
        if args.policy == "optimal":
            policy, player = optimal_policy(mdp), expert_name("optimal")
        else:
            policy, player = boltzmann_policy(mdp, beta=beta), expert_name("boltzmann", beta)
    except NotConverged as exc:
        raise UsageError(str(exc)) from None
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
