"""The tied lp fit's first round (solved from no basis) under HiGHS settings, one per process.

Run: .venv/bin/python -m bench.tied_first_round SIZE SETTING [--untied] [--limit SECONDS]
SETTING is one of SETTINGS' names. Prints status, objective, seconds and simplex iterations.
"""

from __future__ import annotations

import argparse
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from irl_core.irl.lp.highs import Options

SETTINGS: dict[str, Options] = {
    "dual-dantzig": {"simplex_dual_edge_weight_strategy": 0},
    "dual-dantzig-nopresolve": {"simplex_dual_edge_weight_strategy": 0, "presolve": "off"},
    "dual-steepest": {"simplex_dual_edge_weight_strategy": 2},
    "dual-steepest-nopresolve": {"simplex_dual_edge_weight_strategy": 2, "presolve": "off"},
    "dual-devex-nopresolve": {"simplex_dual_edge_weight_strategy": 1, "presolve": "off"},
    "primal": {"simplex_strategy": 4},
    "primal-nopresolve": {"simplex_strategy": 4, "presolve": "off"},
    "ipx-crossover": {"solver": "ipx", "run_crossover": "on"},
    "ipx-crossover-nopresolve": {"solver": "ipx", "run_crossover": "on", "presolve": "off"},
}


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("size")
    parser.add_argument("setting", choices=SETTINGS)
    parser.add_argument("--untied", action="store_true", help="per-cell rewards instead of tied ones")
    parser.add_argument("--limit", type=float, default=120.0, help="HiGHS time_limit in seconds (default 120)")
    args = parser.parse_args()

    from bench.bench_scaling import _setup
    from bench.fit_stage import demonstrations_for
    from irl_core.irl.lp.margin import lp_constraints, margin_lp
    from irl_core.irl.lp.solve import RowGeneration
    from irl_core.irl.qmap import build_qmap, build_unknowns

    mdp = _setup(args.size)
    demos = demonstrations_for(mdp, episodes=100, seed=0)
    unknowns = build_unknowns(mdp, reward_cells="special", tie=not args.untied)
    problem = margin_lp(lp_constraints(build_qmap(mdp, unknowns), demos.most_frequent, rmax=1000.0))
    run = RowGeneration(problem, options={**SETTINGS[args.setting], "time_limit": args.limit})
    highs = run.model.highs
    rows, cols = highs.getNumRow(), highs.getNumCol()
    start = time.perf_counter()
    highs.run()
    seconds = time.perf_counter() - start
    info = highs.getInfo()
    print(f"{args.size} {'untied' if args.untied else 'tied'} k={unknowns.k} {rows}x{cols} {args.setting}: "
          f"{highs.modelStatusToString(highs.getModelStatus())}, objective {info.objective_function_value:.10g}, "
          f"{seconds:.1f} s, {info.simplex_iteration_count} simplex + {info.ipm_iteration_count} ipm iterations",
          flush=True)


if __name__ == "__main__":
    main()
