"""The population pool measured where it can fail (docs/studies-pooling.md, "Validation").

Two studies, over seeds:

- ``reckless``: 11 careful person-like participants on mud (the optimal direction but for 5% random
  ones, the optimal level give or take N(0, 1.5) levels: ``loose`` with lapse 0.05 and spread 1.5) and one
  reckless one (level 1 always, 25% random directions), 10 episodes each, through the whole report
  (`fit_report` on files written as a study's): does the population's interval hold each truth, and is
  the reckless participant marked an outlier?
- ``differ``: 12 participants whose true cliff differs (log-normal around -1000, sd 0.3 in log) and whose
  players differ (loose, timed, and the careful player above, in turn): does the centre's interval hold the
  population's cliff (-1000, the log-normal's median), and does the prediction interval of 11 of them hold
  the 12th's own cliff?

    python -m bench.bench_population --part reckless --seeds 10 --resamples 100
    python -m bench.bench_population --part differ --seeds 20 --resamples 100

Each seed's row is printed as JSON (one line) as it finishes; the summary last.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from irl_core.irl import fit
from irl_core.players.experts import demonstrations_of, rollouts, session_header, write_rollouts
from irl_core.players.person_like import person_like
from irl_core.recordings.lines import StudyTag
from irl_core.studies.population import pool_participants
from irl_core.studies.report import POOLED, fit_report, gather, report_options
from irl_core.studies.study import load_study
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

CAREFUL = {"lapse": 0.05, "spread": 1.5}
SYMBOLS = ("C", "U", "G")


def reckless_study(seed: int, *, resamples: int, folder: Path) -> dict:
    """One 11 + 1 study through the report: coverage of each truth, and the reckless participant's marks."""
    path = folder / f"s{seed}" / "study.toml"
    path.parent.mkdir(parents=True)
    path.write_text('name = "bench"\nworlds = ["mud"]\npractice_episodes = 0\nepisodes = 10\nout = "data"\n')
    study = load_study(path)
    mdp = build_mdp(study.grid_worlds[0])
    players = [(f"p{i + 1:02d}", person_like(mdp, "loose", **CAREFUL)) for i in range(11)]
    players.append(("reckless", person_like(mdp, "reckless")))
    for i, (who, player) in enumerate(players):
        folder_of = study.participant_folder(who)
        folder_of.mkdir(parents=True)
        tag = StudyTag(name="bench", participant=who, phase="main", world_index=0)
        header = session_header(mdp, player=player.player, seed=seed * 100 + i).model_copy(
            update={"player": who, "study": tag})
        played = rollouts(mdp, player.choose, episodes=10, seed=seed * 100 + i)
        write_rollouts(folder_of / f"{who}-0-w0-main.jsonl", mdp, played, player=player.player,
                       seed=seed * 100 + i, header=header)
    data = gather(study)
    fits = fit_report(data, report_options(resamples=resamples, seed=seed), workers=2)
    rows = dict(zip((c.participant for c in data.cells), fits))
    pooled = rows[POOLED]
    truth = dict(zip(pooled.symbols, pooled.truth))
    assert pooled.intervals is not None
    covered = {s: bool(low <= truth[s] <= high) for s, (low, high) in zip(pooled.symbols, pooled.intervals)}
    return {"seed": seed, "covered": covered, "reckless_outlier": bool(rows["reckless"].outlier),
            "careful_outliers": sum(bool(rows[w].outlier) for w, _ in players[:-1]),
            "reckless_influential": bool(rows["reckless"].influential),
            "centre": dict(zip(pooled.symbols, np.round(pooled.estimate, 1).tolist())),
            "intervals": {s: np.round(iv, 1).tolist() for s, iv in zip(pooled.symbols, pooled.intervals)}}


def differ_study(seed: int, *, resamples: int) -> dict:
    """One study of 12 participants whose true cliffs differ: the centre's and the prediction's coverage."""
    rng = np.random.default_rng(seed)
    world = BUILTIN_WORLDS["mud"]
    cliffs = -1000.0 * np.exp(rng.normal(0.0, 0.3, 12))
    kinds = [("loose", {}), ("timed", {}), ("loose", CAREFUL)]
    intervals, shifts, any_rival = [], [], False
    for i, cliff in enumerate(cliffs):
        mdp = build_mdp(world.model_copy(update={"rewards": {**world.rewards, "C": float(cliff)}}))
        kind, parameters = kinds[i % 3]
        played = rollouts(mdp, person_like(mdp, kind, **parameters).choose, episodes=10, seed=seed * 100 + i)
        result = fit(demonstrations_of(mdp, played), report_options(resamples=resamples, seed=seed), workers=2)
        assert result.intervals is not None
        intervals.append(result.intervals)
        rival = result.rival_theta
        any_rival |= rival is not None
        shifts.append(np.zeros(result.unknowns.k) if rival is None else rival - result.theta)
        symbols = list(result.unknowns.labels)
    c = symbols.index("C")
    ivs, shift = np.array(intervals), np.array(shifts) if any_rival else None
    population = pool_participants(ivs, rmax=5000.0, rival_shift=shift)
    low, high = population.intervals[c]
    held_out = pool_participants(ivs[:11], rmax=5000.0, rival_shift=None if shift is None else shift[:11])
    pred_low, pred_high = held_out.predictions[c]
    return {"seed": seed, "centre_covered": bool(low <= -1000.0 <= high),
            "prediction_covers_held_out": bool(pred_low <= cliffs[11] <= pred_high),
            "centre": round(float(population.centre[c]), 1), "interval": [round(low, 1), round(high, 1)],
            "prediction": [round(pred_low, 1), round(pred_high, 1)], "held_out_truth": round(float(cliffs[11]), 1)}


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("reckless", "differ"), default="reckless")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--resamples", type=int, default=100)
    args = parser.parse_args()
    rows, start = [], time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        for seed in range(args.seeds):
            row = (reckless_study(seed, resamples=args.resamples, folder=Path(folder)) if args.part == "reckless"
                   else differ_study(seed, resamples=args.resamples))
            rows.append(row)
            print(json.dumps(row), flush=True)
    n = len(rows)
    summary: dict[str, object]
    if args.part == "reckless":
        summary = {s: f"{sum(r['covered'][s] for r in rows)}/{n}" for s in SYMBOLS}
        summary["reckless_outlier"] = f"{sum(r['reckless_outlier'] for r in rows)}/{n}"
        summary["careful_marked_outlier"] = f"{sum(r['careful_outliers'] for r in rows)}/{11 * n}"
    else:
        summary = {"centre_covered": f"{sum(r['centre_covered'] for r in rows)}/{n}",
                   "prediction_covers_held_out": f"{sum(r['prediction_covers_held_out'] for r in rows)}/{n}"}
    summary.update(part=args.part, seeds=n, resamples=args.resamples, seconds=round(time.perf_counter() - start))
    print(json.dumps({"summary": summary}), flush=True)


if __name__ == "__main__":
    main()
