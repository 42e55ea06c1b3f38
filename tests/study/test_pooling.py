"""Pooling people in `careful study report`: the pooled interval resamples participants, then their
episodes; a participant without whom a pooled reward would leave its interval is marked influential
(CSV column, a mark in the table, the pooled row's sentence)."""

import csv
import dataclasses
import io
from dataclasses import dataclass

import numpy as np
import pytest
import scipy.sparse as sp
from rich.console import Console
from study.conftest import write_block, write_study

from careful_tui.cli import main
from careful_tui.commands.study_report import INFLUENTIAL_MARK, OUTLIER_MARK, mark_legends, report_table
from irl_core.irl.intervals.bootstrap import bootstrap, two_level_weights
from irl_core.players.experts import boltzmann_policy, optimal_policy, rollouts, session_header, write_rollouts
from irl_core.recordings.lines import StudyTag
from irl_core.studies.report import POOLED, CellFit, gather, pooled_finding, report_rows, with_influence
from irl_core.studies.study import load_study
from irl_core.worlds.mdp import build_mdp


def test_two_level_weights_draw_participants_then_episodes_within_each():
    """Participant A holds episodes 0-2, B episodes 3-4. A resample draws 2 participants with
    replacement (AA, AB, BA or BB), then for each draw as many of that participant's episodes as
    they have, with replacement: a participant drawn m times weighs m * (their episodes) in all."""
    groups = np.array([0, 0, 0, 1, 1])
    weights = two_level_weights(groups, 20_000, seed=3)
    a, b = weights[:, :3].sum(axis=1), weights[:, 3:].sum(axis=1)
    assert np.all(a % 3 == 0) and np.all(b % 2 == 0)
    assert np.all(a / 3 + b / 2 == 2)  # two participants drawn in every resample
    # Hand-worked: A is drawn twice with probability 1/4, once 1/2, never 1/4.
    np.testing.assert_allclose([np.mean(a == 6), np.mean(a == 3), np.mean(a == 0)], [0.25, 0.5, 0.25], atol=0.015)
    # A drawn once: its 3 episodes are 3 draws from 3, all different (1, 1, 1) with probability 3!/3^3 = 2/9.
    once = weights[a == 3, :3]
    assert np.mean(np.all(once == 1, axis=1)) == pytest.approx(2 / 9, abs=0.02)
    # Every episode weighs 1 on average, as in an ordinary bootstrap.
    np.testing.assert_allclose(weights.mean(axis=0), 1.0, atol=0.03)
    # The same seed gives the same resamples; one episode per participant is resampling participants.
    np.testing.assert_array_equal(two_level_weights(groups, 50, seed=3), two_level_weights(groups, 50, seed=3))
    singles = two_level_weights(np.arange(4), 100, seed=0)
    assert np.all(singles.sum(axis=1) == 4)


@dataclass(frozen=True, eq=False)
class _Share:
    """A stand-in refit: the share of the resample's steps that are participant A's (episodes 0-2)."""

    mdp: object
    unknowns: object
    method: str = "loss"
    beta: float = 1.0
    size: int = 1

    def __call__(self, counts, *, resample=0):
        return np.array([counts[:3].sum() / counts.sum()])


def test_the_bootstrap_resamples_groups_when_given_them():
    """Five one-step episodes (A: 3, B: 2). Resampling episodes, A's share takes any of k/5; resampling
    participants first, only 0 (BB), 3/5 (AB) or 1 (AA)."""
    by_episode = sp.identity(5, format="csr")
    refit = _Share(mdp=type("M", (), {"n_states": 5, "n_actions": 1})(), unknowns=type("U", (), {"k": 1})())
    pooled = bootstrap(refit, by_episode, np.array([0.6]), confidence=0.9, resamples=200, seed=0, workers=1,
                       groups=np.array([0, 0, 0, 1, 1]))
    assert set(np.round(pooled.estimates[:, 0], 9)) == {0.0, 0.6, 1.0}
    plain = bootstrap(refit, by_episode, np.array([0.6]), confidence=0.9, resamples=200, seed=0, workers=1)
    assert {0.2, 0.4, 0.8} <= set(np.round(plain.estimates[:, 0], 9))


# ---------------------------------------------------------------------------- people and a reckless one


def person_like(mdp, *, lapse, level_spread, level=None):
    """(S, A) a person's play as a policy: the optimal direction, or now and then (`lapse`) any of the
    four; the optimal level give or take up to `level_spread` (uniformly, within 1..L), or always `level`."""
    best = optimal_policy(mdp).argmax(axis=1)
    levels = mdp.levels
    policy = np.zeros((mdp.n_states, mdp.n_actions))
    for s, a in enumerate(best):
        direction, careful = divmod(int(a), levels)
        chosen = [level - 1] if level is not None else range(max(0, careful - level_spread),
                                                             min(levels, careful + level_spread + 1))
        for d in range(4):
            p_direction = (1 - lapse) * (d == direction) + lapse / 4
            for c in chosen:
                policy[s, d * levels + c] += p_direction / len(chosen)
    return policy


def write_participant(study, participant, policy, *, seed):
    mdp = build_mdp(study.worlds[0])
    folder = study.participant_folder(participant)
    folder.mkdir(parents=True, exist_ok=True)
    tag = StudyTag(name=study.study.name, participant=participant, phase="main", world_index=0)
    header = session_header(mdp, player="simulated", seed=seed).model_copy(update={"player": participant,
                                                                                   "study": tag})
    result = rollouts(mdp, policy, episodes=study.study.episodes, seed=seed)
    write_rollouts(folder / f"{participant}-0-w0-main.jsonl", mdp, result, player="simulated", seed=seed,
                   header=header)


def test_a_reckless_participant_is_marked_an_outlier_of_the_population(tmp_path, capsys):
    """Four participants on mud whom the default fit models (Boltzmann experts) and one reckless one
    (level 1 everywhere, a quarter of moves random). The population row (the default) marks the reckless
    participant an outlier and influential (the CSV's columns, the table's marks, the finding), and nobody
    else an outlier; every participant's row says true or false; the pooled row names the pool model and
    gives each reward's spread and prediction interval around its centre's interval."""
    study = load_study(write_study(tmp_path, worlds='["mud"]', practice=0, episodes=10))
    mdp = build_mdp(study.worlds[0])
    for i, beta in enumerate((0.5, 0.8, 1.2, 2.0)):
        write_participant(study, f"p{i + 1}", boltzmann_policy(mdp, beta=beta), seed=i)
    write_participant(study, "reckless", person_like(mdp, lapse=0.25, level_spread=0, level=1), seed=99)
    assert main(["study", "report", str(study.path), "--resamples", "30", "--workers", "2"]) == 0
    out = capsys.readouterr().out
    rows = {row["participant"]: row for row in csv.DictReader((study.report_folder / "report.csv").open())}
    pooled = rows[POOLED]
    assert pooled["pool_model"] == "population"
    assert rows["reckless"]["outlier"] == "true" and pooled["outlier"].split() == ["reckless"]
    assert rows["reckless"]["influential"] == "true" and "reckless" in pooled["influential"].split()
    for who in ("p1", "p2", "p3", "p4"):
        assert rows[who]["outlier"] == "false" and rows[who]["influential"] in ("true", "false")
        assert rows[who]["excluded"] == "false" and rows[who]["excluded_why"] == ""
    for s in ("C", "U", "G"):
        low, centre, high = (float(pooled[f"reward_{s}{end}"]) for end in ("_low", "", "_high"))
        pred_low, pred_high = float(pooled[f"reward_{s}_pred_low"]), float(pooled[f"reward_{s}_pred_high"])
        assert pred_low <= low <= centre <= high <= pred_high and float(pooled[f"reward_{s}_spread"]) >= 0
    assert pooled["finding"].startswith("mud: the population's cliff interval")
    assert "reckless is outside where the others say a participant's fit would lie (outlier)" in pooled["finding"]
    assert pooled["finding"] in out.splitlines()
    assert any(line.strip().startswith(f"reckless {INFLUENTIAL_MARK} {OUTLIER_MARK}") for line in out.splitlines())
    assert any(line.startswith(f"{OUTLIER_MARK} outlier: ") for line in out.splitlines())


def test_the_shared_pool_is_still_there_by_name(tmp_path, capsys):
    """--pool-model shared fits everyone's episodes as one (the fixed-effect pool): its row says so and has no
    spread or prediction interval; influence is measured by refitting without each participant."""
    study = load_study(write_study(tmp_path, worlds='["mud"]', practice=0, episodes=6))
    mdp = build_mdp(study.worlds[0])
    for i, beta in enumerate((0.8, 2.0)):
        write_participant(study, f"p{i + 1}", boltzmann_policy(mdp, beta=beta), seed=i)
    assert main(["study", "report", str(study.path), "--resamples", "20", "--workers", "2",
                 "--pool-model", "shared"]) == 0
    rows = {row["participant"]: row for row in csv.DictReader((study.report_folder / "report.csv").open())}
    assert rows[POOLED]["pool_model"] == "shared" and rows[POOLED]["reward_C_spread"] == ""
    assert rows[POOLED]["finding"].startswith("mud: the pooled cliff interval")
    assert rows["p1"]["influential"] in ("true", "false") and rows["p1"]["outlier"] == ""
    assert "pooled (2)" in capsys.readouterr().out


def test_the_influential_column_mark_and_sentence_follow_the_leave_one_out_fits(study):
    """Given fits (no fitting): the pool's cliff is -1000 [-1200, -800]; without p2 it would be -500,
    without p1 -950. So p2 is influential, p1 not: the CSV's column, the table's mark and legend, and
    the pooled row's sentence say so; a pool whose fit has no interval measures no influence."""
    for participant in ("p1", "p2"):
        write_block(study, participant, 0, "main", name="a.jsonl", finished=2)
    data = gather(study)
    world = study.worlds[0]
    pool = CellFit(method="maxent", symbols=("C", "G"), estimate=np.array([-1000.0, 90.0]),
                   intervals=np.array([[-1200.0, -800.0], [60.0, 120.0]]), truth=np.array([-1000.0, 100.0]),
                   interval_kind="confidence")
    fits = [pool if cell.participant == POOLED and cell.world_index == 0 else CellFit(error="not fitted here")
            for cell in data.cells]
    without = {(0, "p1"): CellFit(symbols=("C", "G"), estimate=np.array([-950.0, 95.0])),
               (0, "p2"): CellFit(symbols=("C", "G"), estimate=np.array([-500.0, 100.0]))}
    marked = with_influence(data, fits, without)
    columns, rows = report_rows(data, marked)
    column = {(row[columns.index("participant")], row[columns.index("world_index")]): row[columns.index("influential")]
              for row in rows}
    assert column[("p1", "0")] == "false" and column[("p2", "0")] == "true" and column[(POOLED, "0")] == "p2"
    assert column[("p1", "1")] == "" and column[(POOLED, "1")] == ""  # world 1's pool has no fit
    finding = pooled_finding(data, data.cell(POOLED, 0), marked[data.cells.index(data.cell(POOLED, 0))])
    assert finding.startswith(f"{world.name}: ") and "without p2 the cliff -500, outside the pooled interval" in finding
    assert "every interval covers the world's reward" in finding
    console = Console(width=250, file=io.StringIO(), record=True)
    console.print(report_table(data, marked))
    text = console.export_text()
    lines = [line.strip() for line in text.splitlines()]
    assert any(line.startswith(f"p2 {INFLUENTIAL_MARK}") for line in lines)
    assert not any(line.startswith(f"p1 {INFLUENTIAL_MARK}") for line in lines)
    assert mark_legends(marked)[0].startswith(f"{INFLUENTIAL_MARK} influential: the pooled centre with this "
                                              "participant lies outside the pool's interval without them")
    # Nobody moves the pool: the column says so on the pooled row, and so does the sentence.
    calm = with_influence(data, fits, {**without, (0, "p2"): CellFit(symbols=("C", "G"),
                                                                      estimate=np.array([-1100.0, 80.0]))})
    _, rows = report_rows(data, calm)
    assert rows[data.cells.index(data.cell(POOLED, 0))][columns.index("influential")] == "none"
    # ... and names who moves it most, in widths of the interval (p2's cliff by 100 of 400).
    assert ("no participant alone moves a pooled reward out of its interval (the most: without p2 the cliff -1100 "
            "against -1000)") in pooled_finding(data, data.cell(POOLED, 0), calm[data.cells.index(data.cell(POOLED, 0))])
    assert mark_legends(calm) == []


def test_the_pooled_sentence_says_whether_carefulness_separates_cliff_and_mud(tmp_path):
    study = load_study(write_study(tmp_path, worlds='["mud", "mud-simple"]', practice=0))
    for world_index in (0, 1):
        write_block(study, "p1", world_index, "main", name=f"a{world_index}.jsonl", finished=2)
    data = gather(study)

    def pooled(cliff, mud, world_index=0):
        fit = CellFit(method="maxent", symbols=("C", "U", "G"), estimate=np.array([-1000.0, -30.0, 100.0]),
                      intervals=np.array([cliff, mud, [50.0, 150.0]]), truth=np.array([-1000.0, -30.0, 100.0]),
                      interval_kind="confidence")
        return pooled_finding(data, data.cell(POOLED, world_index), fit)

    assert pooled([-1400.0, -800.0], [-50.0, -20.0]) == (
        "mud: the pooled cliff interval [-1400, -800] lies below the mud's [-50, -20]: carefulness separates "
        "catastrophe from nuisance; every interval covers the world's reward.")
    overlap = pooled([-1400.0, -10.0], [-50.0, -20.0])
    assert "overlaps the mud's [-50, -20]: these participants' play does not separate catastrophe from nuisance" \
        in overlap
    missed = pooled([-900.0, -800.0], [-50.0, -20.0])
    assert "the cliff's interval misses the world's -1000" in missed
    simple = pooled([-1400.0, -800.0], [-50.0, -20.0], world_index=1)
    assert simple.startswith("mud-simple: ") and "not carefulness, that separate them" in simple


def test_a_world_without_a_nuisance_gets_the_signs(study):
    write_block(study, "p1", 0, "main", name="a.jsonl", finished=2)
    data = gather(study)

    def pooled(cliff, goal):
        fit = CellFit(method="maxent", symbols=("C", "G"), estimate=np.array([-1000.0, 100.0]),
                      intervals=np.array([cliff, goal]), truth=np.array([-1000.0, 100.0]), interval_kind="confidence")
        return pooled_finding(data, data.cell(POOLED, 0), fit)

    assert pooled([-1170.0, -769.0], [68.2, 120.0]).startswith(
        "paper: the pooled cliff interval [-1170, -769] lies below 0 and the goal's [68.2, 120] lies above it; ")
    assert "lies below 0, but the goal's [-20, 120] does not lie above it" in pooled([-1170.0, -769.0], [-20.0, 120.0])


def test_a_population_too_small_to_centre_shows_no_numbers_and_says_who_was_missing():
    """With one participant fitted with intervals (the others without, or excluded), the pooled row is not the
    choice fit's point dressed as a population: it has no rewards, and its reason counts each kind left out."""
    from irl_core.studies.report_fits import population_row

    choice = CellFit(symbols=("C", "G"), estimate=np.array([-900.0, 100.0]), method="maxent", rmax=1000.0,
                     confidence=0.95)
    with_interval = CellFit(symbols=("C", "G"), estimate=np.array([-800.0, 90.0]),
                            intervals=np.array([[-1000.0, -500.0], [50.0, 150.0]]), rmax=1000.0)
    fits = [with_interval, dataclasses.replace(with_interval, intervals=None),
            dataclasses.replace(with_interval, intervals=None), dataclasses.replace(with_interval, excluded_why="x")]
    members = [(j, type("Cell", (), {"participant": f"p{j}"})()) for j in range(4)]
    row = population_row(choice, members, fits, layout="C.G")
    assert row.error == ("a population needs 2 or more included participants fitted with intervals; 1 here, "
                         "1 excluded, 2 fitted without intervals")
    assert row.symbols == () and row.estimate.size == 0 and row.intervals is None and row.reward_grid is None
    assert row.pool_model == "population" and [f.outlier for f in fits] == [None] * 4
