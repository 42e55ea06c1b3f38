"""Every benchmark, one after another: `make bench` or `.venv/bin/python -m bench`.

Each prints its measurements side by side with a baseline run in the same process;
ratios, not absolute times, are what to compare across these shared machines.
"""

import argparse
import importlib
import sys

BENCHMARKS = ("bench_fit", "bench_rollouts", "bench_planning", "bench_play", "bench_reader", "bench_scaling",
              "bench_export", "bench_noisy", "bench_calibration", "bench_figures", "bench_study",
              "bench_maxent_stop", "bench_evaluation_stop", "bench_people", "bench_people_speed", "bench_people_big",
              "bench_study_cluster", "bench_serve", "bench_serve_workers", "bench_seat_growth", "bench_laplace",
              "bench_plan", "bench_fit_memory", "bench_population", "bench_timing", "bench_invariants", "bench_import",
              "bench_reach", "bench_battery")


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="python -m bench", description=__doc__,
                                     epilog="One NAME may be followed by its own options: python -m bench "
                                            "bench_people_big --sizes 24")
    parser.add_argument("only", nargs="*", metavar="NAME", help="run only these: " + ", ".join(BENCHMARKS))
    args, options = parser.parse_known_args()
    names = args.only or BENCHMARKS
    unknown = set(names) - set(BENCHMARKS)
    if unknown:
        parser.error(f"unknown benchmark {', '.join(sorted(unknown))}")
    if options and len(names) != 1:
        parser.error(f"options ({' '.join(options)}) go to one benchmark: name exactly one")
    for name in names:
        print(f"\n=== {name} ===", flush=True)
        module = importlib.import_module(f"bench.{name}")
        sys.argv = [f"bench.{name}", *options]  # its own options; without them its own defaults
        module.main()


if __name__ == "__main__":
    main()
