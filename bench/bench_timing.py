"""Care from timing alone, measured where it can fail (docs/timing.md, "Validation").

Thirty person-like ``timing`` players on `mud-time`, each with their own hand (the Weber fraction of their
holds and their lapse rate drawn around the defaults, log-normal with sd 0.3), 20 episodes each, pooled
into one fit (one reward per symbol, the slip curve learnt, bootstrap intervals resampling players then
episodes). None of them is a model the fit contains: they hold for continuous times, slip with the exact
hold, and release on an 8 ms polling grid; the fit sees duration bins. Per seed:

- ``ratio``: the fitted cliff / mud against the truth's 1000 / 30, within 20%;
- ``tau``: the fitted tau_ms within 10% of 400;
- ``covered``: each reward's 95% interval holds its truth;
- ``falls``: an agent trained on the fit falls off the cliff in at most 1% of episodes;
- ``seconds``: with the cost unknown, the cliff in seconds of holding within 20% of 1000 / 5 = 200 s.

Then a ``steady`` player (600 ms everywhere, whatever is at stake): does the fit check fail, and does the fit
say the cliff is not separated from the mud? And the time of a 30 x 20 fit with intervals against the people
fit of 30 ``loose`` players x 20 episodes on `mud` (the same layout, with levels), in the same process.

    python -m bench.bench_timing --seeds 20 --resamples 200

Each seed's row is printed as JSON (one line) as it finishes; the summary last.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import scipy.sparse as sp

from irl_core.irl import fit
from irl_core.players.experts import demonstrations_of, rollouts
from irl_core.players.person_like import KINDS, person_like
from irl_core.recordings.demonstrations import Demonstrations, EpisodeFacts
from irl_core.worlds.mdp import MDP, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

PLAYERS, EPISODES = 30, 20
TRUTH = {"C": -1000.0, "U": -30.0, "G": 100.0}
# The cliff's truth is the default rmax itself: a bound there would decide half of every interval, so the
# bench widens it (a user's fit at the default says "at ±rmax" instead).
RMAX = 5000.0
SPREAD = 0.3


def pooled_players(mdp: MDP, kind: str, *, seed: int, players: int = PLAYERS, episodes: int = EPISODES,
                   **fixed: float) -> Demonstrations:
    """`players` person-like players of `kind`, each with parameters drawn around the defaults, `episodes` each,
    pooled into one `Demonstrations` whose episode groups are the players."""
    rng = np.random.default_rng(seed)
    parts = []
    for i in range(players):
        values = {name: default * float(np.exp(rng.normal(0.0, SPREAD))) for name, default in KINDS[kind].items()
                  if name not in ("poll_ms", "hold_ms")}
        values = {name: min(value, 0.5) if name == "lapse" else value for name, value in values.items()}
        player = person_like(mdp, kind, **{**values, **fixed})
        parts.append(demonstrations_of(mdp, rollouts(mdp, player.choose, episodes=episodes, seed=seed * 1000 + i)))
    facts = [p.episode_facts for p in parts if p.episode_facts is not None]
    rows = [p.by_episode for p in parts if p.by_episode is not None]
    return Demonstrations(
        mdp=mdp, counts=np.sum([p.counts for p in parts], axis=0), files=0, episodes=sum(p.episodes for p in parts),
        steps=sum(p.steps for p in parts), by_episode=sp.vstack(rows).tocsr(),
        episode_groups=np.concatenate([np.full(r.shape[0], i) for i, r in enumerate(rows)]),
        episode_facts=EpisodeFacts(start=np.concatenate([f.start for f in facts]),
                                   length=np.concatenate([f.length for f in facts]),
                                   end=tuple(e for f in facts for e in f.end)),
        hold_steps=np.concatenate([_shifted(p.hold_steps, sum(r.shape[0] for r in rows[:i]))
                                   for i, p in enumerate(parts)]))


def _shifted(steps: np.ndarray, rows: int) -> np.ndarray:
    """`Demonstrations.hold_steps` whose episode rows start `rows` further down (a later player's)."""
    out = steps.copy()
    out[:, 4] += rows
    return out


def one_seed(seed: int, *, resamples: int) -> dict:
    mdp = build_mdp(BUILTIN_WORLDS["mud-time"])
    demos = pooled_players(mdp, "timing", seed=seed)
    start = time.perf_counter()
    known = fit(demos, tie=True, intervals=True, rmax=RMAX, resamples=resamples, seed=seed, workers=2)
    seconds_taken = time.perf_counter() - start
    unknown = fit(demos, tie=True, cost="unknown", rmax=RMAX)
    got = dict(zip(known.unknowns.labels, known.theta.tolist()))
    seconds = dict(zip(unknown.unknowns.labels, unknown.theta.tolist()))
    assert known.intervals is not None and known.slip_curve is not None
    intervals = dict(zip(known.unknowns.labels, known.intervals.tolist()))
    ratio, true_ratio = got["C"] / got["U"], TRUTH["C"] / TRUTH["U"]
    falls = known.evaluation.agent.ends.get("C", 0.0)
    return {
        "seed": seed, "fit_s": round(seconds_taken, 1),
        "rewards": {s: round(v, 1) for s, v in got.items()},
        "intervals": {s: [round(x, 1) for x in iv] for s, iv in intervals.items()},
        "ratio": round(ratio, 2), "ratio_ok": bool(abs(ratio / true_ratio - 1) <= 0.2),
        "tau": round(known.slip_curve.tau_ms, 1), "tau_ok": bool(abs(known.slip_curve.tau_ms / 400 - 1) <= 0.1),
        "tau_interval": [round(x, 1) for x in known.slip_curve.interval["tau_ms"]] if known.slip_curve.interval else None,
        "covered": {s: bool(iv[0] <= TRUTH[s] <= iv[1]) for s, iv in intervals.items()},
        "falls": round(falls, 5), "falls_ok": bool(falls <= 0.01),
        "cliff_seconds": round(seconds["C"], 1), "seconds_ok": bool(abs(seconds["C"] / (TRUTH["C"] / 5.0) - 1) <= 0.2),
        "intervals_from": "scores" if "intervals_scores" in [n.code for n in known.notes] else "curvature",
        "player_model": known.player_model, "fit_check": None if known.fit_check is None else known.fit_check.passed,
        "curve": [round(known.slip_curve.p0, 3), round(known.slip_curve.p_inf, 4), round(known.slip_curve.tau_ms, 1)],
    }


def steady(*, resamples: int) -> dict:
    """A player whose hold does not depend on danger: the check should fail and the cliff not stand apart."""
    mdp = build_mdp(BUILTIN_WORLDS["mud-time"])
    demos = pooled_players(mdp, "steady", seed=7, hold_ms=600.0)
    result = fit(demos, tie=True, intervals=True, rmax=RMAX, resamples=resamples, seed=7, workers=2)
    codes = [n.code for n in result.notes]
    return {"fit_check_failed": bool(result.fit_check is not None and result.fit_check.passed is False),
            "not_separated": "cliff_not_separated" in codes,
            "rewards": dict(zip(result.unknowns.labels, np.round(result.theta, 1).tolist())),
            "intervals": dict(zip(result.unknowns.labels, np.round(result.intervals, 1).tolist()))
            if result.intervals is not None else None}


def speed(*, resamples: int) -> dict:
    """Seconds of a 30 x 20 fit with intervals on mud-time, and of the people fit of 30 x 20 on mud."""
    out = {}
    for name, kind in (("mud", "loose"), ("mud-time", "timing")):
        mdp = build_mdp(BUILTIN_WORLDS[name])
        demos = pooled_players(mdp, kind, seed=3)
        start = time.perf_counter()
        fit(demos, tie=True, intervals=True, resamples=resamples, seed=3, workers=2)
        out[name] = round(time.perf_counter() - start, 1)
    out["ratio"] = round(out["mud-time"] / out["mud"], 2)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="python -m bench.bench_timing", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--resamples", type=int, default=200)
    parser.add_argument("--part", choices=["seeds", "steady", "speed", "all"], default="all")
    args = parser.parse_args()
    rows = []
    if args.part in ("seeds", "all"):
        for seed in range(args.seeds):
            rows.append(one_seed(seed, resamples=args.resamples))
            print(json.dumps(rows[-1]), flush=True)
        n = len(rows)
        coverage = {s: sum(r["covered"][s] for r in rows) for s in TRUTH}
        print(json.dumps({"seeds": n, "ratio_within_20pct": sum(r["ratio_ok"] for r in rows),
                          "tau_within_10pct": sum(r["tau_ok"] for r in rows), "covered": coverage,
                          "falls_at_most_1pct": sum(r["falls_ok"] for r in rows),
                          "seconds_within_20pct": sum(r["seconds_ok"] for r in rows),
                          "fit_check_passed": sum(bool(r["fit_check"]) for r in rows)}), flush=True)
    if args.part in ("steady", "all"):
        print(json.dumps({"steady": steady(resamples=args.resamples)}), flush=True)
    if args.part in ("speed", "all"):
        print(json.dumps({"speed": speed(resamples=args.resamples)}), flush=True)


if __name__ == "__main__":
    main()
