"""The plan's simulated studies reported as `careful study report` reports them (``study plan --fits report``).

The plan's own fit (one model of the player, a Laplace interval) is quick but narrower than a report's
(the auto choice of model, bootstrap intervals, the union over planning models the data cannot tell apart),
so its coverage is a floor. With ``fits = "report"`` each simulated study is written as a study folder
(a study file, the world file, each participant's recordings as a study writes them) and read and fitted by
the report's own code (`gather`, `fit_report`): what the plan counts is then what reports of that size show,
by the same machinery, at the cost of that many reports.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from irl_core.irl.qmap import Unknowns
from irl_core.players.experts import Rollouts, session_header, write_rollouts
from irl_core.recordings.lines import StudyTag
from irl_core.studies.report_cells import POOLED, gather
from irl_core.studies.report_fits import fit_report, report_options
from irl_core.studies.simulated import write_calibration_file
from irl_core.studies.study import Exclusions, load_study
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import World

STUDY_NAME = "plan"
WORLD_FILE = "world.toml"


def write_simulated_study(folder: Path, world: World, played: list[tuple[str, Rollouts]], trials: list[np.ndarray],
                          *, calibration: int, seed: int) -> Path:
    """A study of one world in `folder` (new files only): its study file and world file, and for participant i
    (``p01``, ``p02``, ...) the rollouts ``played[i]`` (player name, rollouts) as their main episodes, after their
    calibration block ``trials[i]`` (n, 2) in a file of its own where it has trials. Returns the study file."""
    episodes = max(len(rollouts.length) for _, rollouts in played)
    (folder / WORLD_FILE).write_text(world.to_toml(), encoding="utf-8")
    path = folder / "study.toml"
    path.write_text(f'name = "{STUDY_NAME}"\nworlds = ["{WORLD_FILE}"]\npractice_episodes = 0\nepisodes = {episodes}\n'
                    f'out = "data"\ncalibration_block = {calibration}\n', encoding="utf-8")
    study = load_study(path)
    mdp = build_mdp(study.grid_worlds[0])
    width = max(2, len(str(len(played))))
    for i, ((player, rollouts), block) in enumerate(zip(played, trials)):
        who = f"p{i + 1:0{width}d}"
        out = study.participant_folder(who)
        out.mkdir(parents=True)
        tag = StudyTag(name=STUDY_NAME, participant=who, phase="main", world_index=0)
        header = session_header(mdp, player=player, seed=seed).model_copy(update={"player": who, "study": tag})
        if block.size:  # a session of its own (its own seed), as a study's calibration block writes it
            write_calibration_file(out / f"{who}-0-w0-main.jsonl", header.model_copy(update={"seed": seed + 1}), block)
        write_rollouts(out / f"{who}-1-w0-main.jsonl", mdp, rollouts, player=player, seed=seed, header=header)
    return path


def reported_intervals(world: World, unknowns: Unknowns, played: list[tuple[str, Rollouts]],
                       trials: list[np.ndarray], *, calibration: int, pool: str, resamples: int, rmax: float,
                       exclusions: Exclusions, seed: int) -> np.ndarray:
    """(k, 2) the pooled row's intervals (in `unknowns`' symbol order) that `careful study report` gives for these
    participants (see `write_simulated_study`), with `resamples` bootstrap resamples, the `pool` model and the
    study's `exclusions`; NaN rows where the report has no interval (counted as holding nothing)."""
    with tempfile.TemporaryDirectory(prefix="careful-plan-") as folder:
        path = write_simulated_study(Path(folder), world, played, trials, calibration=calibration, seed=seed)
        data = gather(load_study(path))
        fits = fit_report(data, report_options(resamples=resamples, seed=seed, rmax=rmax), pool_model=pool,
                          exclusions=exclusions, workers=1)
    pooled = next(fitted for cell, fitted in zip(data.cells, fits) if cell.participant == POOLED)
    out = np.full((len(unknowns.symbols), 2), np.nan)
    if pooled.intervals is None:
        return out
    ends = dict(zip(pooled.symbols, np.asarray(pooled.intervals, dtype=float)))
    for j, symbol in enumerate(unknowns.symbols):
        if symbol in ends:
            out[j] = ends[symbol]
    return out
