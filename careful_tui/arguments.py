"""Parsed command-line arguments turned into the core's option objects, for the commands and
the app factory alike."""

from __future__ import annotations

import argparse

from irl_core.irl import FitOptions


def options_from_args(args: argparse.Namespace) -> FitOptions:
    """The fit's settings from `careful fit`'s parsed arguments (built once; the view refits with replace)."""
    return FitOptions(method=args.method, rmax=args.rmax, lam=args.lam, beta=args.beta,
                      player_model=getattr(args, "player_model", None),
                      reward_cells=args.reward_cells, tie=args.tie, intervals=args.intervals,
                      confidence=args.confidence, resamples=args.resamples, seed=args.seed)
