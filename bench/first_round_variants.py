"""What was tried to make a big world's first round of row generation cheaper, one variant per process.

Run: .venv/bin/python -m bench.first_round_variants SIZE VARIANT [--limit SECONDS] [--option NAME=VALUE ...]

The per-cell lp fit's first round is solved from no basis, and on 128x128 it is where the fit
stops (docs/benchmarks.md#how-cost-grows). Variants:

  plain                      the first round (base rows and the seed) from HiGHS's own start
  policy-start               the same from the policy's vertex, as the fit now starts it
  policy-start-sip, policy-start-pami
                             the same with HiGHS's parallel dual simplex (SIP or PAMI, on
                             every core)
  scale-terminal-distance    rows of state s divided by w(s), V(s) and m_s by w(s) (V = w W),
                             w(s) = gamma^(steps from s to the nearest terminal cell)
  scale-true-discount        the same with w(s) = the world's optimal policy's expected
                             discount at its end, gamma^T (needs the true reward: a probe)
  ipx                        HiGHS's interior point method without crossover
  ipx-crossover              the same with crossover
  seed-none, seed-careful, seed-one
                             the whole row generation, the seed at undemonstrated states
                             changed: no rows, the four directions at the most careful
                             level, or one row (the first action); demonstrated states keep theirs
                             (from HiGHS's own start, as they were measured)

policy-start's first round also holds the rows its start makes tight, so its margin is not
plain's.

The seed variants solve round after round with the fit's retries, which have no time limit: run
them under `timeout`. Prints status, seconds, simplex/IPM iterations and the margin (of the first round, or of the
whole fit for the seed variants), all in the original variables.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.sparse as sp

from bench.option_values import name_and_value

VARIANTS = ("plain", "policy-start", "policy-start-sip", "policy-start-pami",
            "scale-terminal-distance", "scale-true-discount", "ipx", "ipx-crossover",
            "seed-none", "seed-careful", "seed-one")


def steps_to_terminal(mdp) -> np.ndarray:
    """(S,) the fewest steps from each state to a terminal cell over any action's possible outcomes."""
    S, A = mdp.n_states, mdp.n_actions
    successors = (sp.csr_matrix((np.ones(S * A), (np.repeat(np.arange(S), A), np.arange(S * A))), shape=(S, S * A))
                  @ (mdp.P != 0).astype(np.int8)).tocsr()
    steps = np.where(mdp.terminal, 0.0, np.inf)
    steps[mdp.exit_state] = 0.0
    frontier = 0
    while True:
        reached = np.isfinite(steps)
        new = (np.asarray(successors[:, reached].sum(axis=1)).ravel() > 0) & ~reached
        if not new.any():
            return steps
        frontier += 1
        steps[new] = frontier


def true_discount(mdp) -> np.ndarray:
    """(S,) E[gamma^T] at the end of an episode under the world's optimal policy."""
    from irl_core.players.experts import optimal_policy

    policy = optimal_policy(mdp)
    action = policy.argmax(axis=1) if policy.ndim == 2 else policy
    follow = mdp.P.tocsr()[np.arange(mdp.n_states) * mdp.n_actions + action]
    ends = mdp.terminal.copy()
    ends[mdp.exit_state] = True
    w = ends.astype(float)
    for _ in range(100_000):
        new = np.where(ends, 1.0, mdp.gamma * (follow @ w))
        if np.abs(new - w).max() < 1e-15:
            return new
        w = new
    return w


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("size")
    parser.add_argument("variant", choices=VARIANTS)
    parser.add_argument("--limit", type=float, default=600.0, help="HiGHS time_limit in seconds (default 600)")
    parser.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                        help="a HiGHS option for the solve (repeatable): true/false, an integer, a float or a word")
    args = parser.parse_args()

    import irl_core.irl.lp.solve as lp
    from bench.bench_scaling import _setup
    from bench.fit_stage import demonstrations_for
    from irl_core.irl.lp.highs import HighsModel, LinearProgram
    from irl_core.irl.lp.margin import lp_constraints
    from irl_core.irl.qmap import build_qmap, build_unknowns

    mdp = _setup(args.size)
    demos = demonstrations_for(mdp, episodes=100, seed=0)
    qmap = build_qmap(mdp, build_unknowns(mdp, reward_cells="special"))
    problem = lp.margin_lp(lp_constraints(qmap, demos.most_frequent, rmax=1000.0))
    n, d = qmap.n, problem.demonstrated
    options = {**lp.margin_options(problem), "time_limit": args.limit, **dict(map(name_and_value, args.option))}
    start = time.perf_counter()
    if args.variant.startswith("policy-start"):
        if args.variant != "policy-start":
            options = {**options, "parallel": "on", "simplex_strategy": 2 if args.variant.endswith("sip") else 3}
        run = lp.RowGeneration(problem, options=options)
        lp.start_from_policy(run)
        run.model.highs.run()  # one attempt, within the limit
        highs = run.model.highs
        info = highs.getInfo()
        z = np.array(highs.getSolution().col_value)
        status = highs.modelStatusToString(highs.getModelStatus())
        iterations, what = info.simplex_iteration_count, "first round"
    elif args.variant.startswith("seed-"):
        shown = problem.policy >= 0
        care = np.arange(mdp.n_actions) % mdp.levels + 1
        elsewhere = {"seed-none": np.zeros(mdp.n_actions, bool), "seed-careful": care == mdp.levels,
                     "seed-one": np.arange(mdp.n_actions) == 0}[args.variant]
        seed = lp.seed_pairs(problem)
        seed[~shown] = (elsewhere[None, :] & problem.rivals)[~shown]
        lp.seed_pairs = lambda problem: seed
        run = lp.RowGeneration(problem, options=options)
        z = run.solve()
        status, iterations, what = "optimal", run.model.iterations, f"whole fit, {run.rounds} rounds"
    else:
        states, actions = np.nonzero(lp.seed_pairs(problem))
        family, q0 = problem.rows(states, actions)
        base = problem.base
        terminal = np.append(np.flatnonzero(mdp.terminal), mdp.exit_state)
        row_state = np.concatenate([terminal, d, states])
        w = {"scale-terminal-distance": lambda: mdp.gamma ** steps_to_terminal(mdp),
             "scale-true-discount": lambda: true_discount(mdp)}.get(args.variant, lambda: np.ones(mdp.n_states))()
        column = np.concatenate([np.ones(qmap.k), w, w[d]])
        row = 1.0 / w[row_state]
        A = sp.vstack([base.A, family], format="csr")
        low = np.concatenate([base.row_lower, q0])
        high = np.concatenate([base.row_upper, np.full(q0.size, np.inf)])
        scaled = LinearProgram((sp.diags(row) @ A @ sp.diags(column)).tocsr(), low * row, high * row,
                               base.lower / column, base.upper / column, base.cost * column)
        if args.variant.startswith("ipx"):
            options = {**options, "solver": "ipx", "run_crossover": "on" if args.variant == "ipx-crossover" else "off"}
        highs = HighsModel(scaled, options=options).highs
        highs.run()  # one attempt, within the limit (a HighsModel's retries have none)
        info = highs.getInfo()
        z = np.array(highs.getSolution().col_value) * column
        status = highs.modelStatusToString(highs.getModelStatus())
        iterations = info.simplex_iteration_count + info.ipm_iteration_count
        what = f"first round, w in [{w.min():.3g}, 1]"
    seconds = time.perf_counter() - start
    print(f"{args.size} {args.variant}: {status}, {seconds:.2f} s, {iterations} iterations, "
          f"margin {z[n : n + d.size].sum():.10g} ({what})")


if __name__ == "__main__":
    main()
