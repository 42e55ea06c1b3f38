"""`careful study report` on simulated participants: rows, pools, CSV and figures; practice and
interrupted episodes never fitted; a corrupt file named and the rest reported."""

import csv
import io
import json

import numpy as np
import pytest
from rich.console import Console
from study.conftest import write_block, write_study

from careful_tui.cli import main
from careful_tui.commands.study_report import outcomes_text, report_table
from careful_tui.render.session import outcome_words
from irl_core.irl import Note
from irl_core.studies.report import POOLED, CellFit, fit_cell, gather, report_options, report_rows, run_fits
from irl_core.studies.simulated import simulated_participants, write_simulated_participant
from irl_core.studies.study import load_study

PARTICIPANTS = simulated_participants(3, betas=(0.3, 1.5))


@pytest.fixture(scope="module")
def study_path(tmp_path_factory):
    folder = tmp_path_factory.mktemp("study")
    path = write_study(folder, practice=1, episodes=4)
    study = load_study(path)
    for who in PARTICIPANTS:
        write_simulated_participant(study, who)
    # sim01 also has a main episode of paper cut off by a crash; sim02's folder holds a corrupt file.
    write_block(study, "sim01", 0, "main", name="crashed.jsonl", first=4, then="crash")
    good = next(study.participant_folder("sim02").glob("*-main.jsonl")).read_text().splitlines()
    step = json.loads(good[1])
    step["direction"] = "sideways"
    (study.participant_folder("sim02") / "corrupt.jsonl").write_text("\n".join([good[0], json.dumps(step), ""]))
    return path


def finished_steps(path):
    """Steps of the finished episodes of a recording, counted from its lines (independently of the reader)."""
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    finished = {line["episode"] for line in lines if line["kind"] == "episode_end" and line["outcome"] != "quit"}
    return sum(1 for line in lines if line["kind"] == "step" and line["episode"] in finished)


def test_only_finished_main_episodes_are_gathered(study_path):
    study = load_study(study_path)
    data = gather(study)
    assert data.participants == ("sim01", "sim02", "sim03")
    assert [(c.participant, c.world_index) for c in data.cells] == [
        ("sim01", 0), ("sim02", 0), ("sim03", 0), (POOLED, 0), ("sim01", 1), ("sim02", 1), ("sim03", 1), (POOLED, 1)]
    for cell in data.cells:
        mains = [] if cell.participant == POOLED else list(
            study.participant_folder(cell.participant).glob(f"*-w{cell.world_index}-main.jsonl"))
        if cell.participant != POOLED:
            assert cell.episodes == 4 and cell.demos.episodes == 4  # the practice episode is not among them
            assert cell.steps == cell.demos.steps == sum(finished_steps(p) for p in mains)
    assert data.cell("sim01", 0).interrupted == 1 and data.cell("sim02", 0).interrupted == 0
    pooled = data.cell(POOLED, 0)
    assert (pooled.episodes, pooled.interrupted, pooled.participants) == (12, 1, 3)
    assert pooled.steps == sum(data.cell(p, 0).steps for p in data.participants)
    assert sum(pooled.outcomes.values()) == 12


def test_a_corrupt_file_is_named_and_its_participant_still_reported(study_path):
    data = gather(load_study(study_path))
    corrupt = [p for p in data.problems if "corrupt.jsonl" in p]
    assert len(corrupt) == 1 and ":2: direction: " in corrupt[0] and corrupt[0].endswith("left out")
    assert data.left_out == {"sim02": 1}
    assert data.cell("sim02", 0).episodes == 4


def test_a_folder_named_pooled_is_left_out_not_taken_for_the_pool(study):
    """The report's pooled rows are the participant `pooled`: a folder of that name would be a second
    `pooled` row in the CSV, and the carefulness figure would take it for the pool."""
    recording = write_block(study, "p01", 0, "main", name="a.jsonl", finished=2)
    (study.out / "pooled").mkdir()
    (study.out / "pooled" / "a.jsonl").write_bytes(recording.read_bytes())
    data = gather(study)
    assert data.participants == ("p01",)
    assert [c.participant for c in data.cells if c.world_index == 0] == ["p01", POOLED]
    assert data.cell(POOLED, 0).episodes == 2
    assert any("pooled" in p and "left out" in p for p in data.problems)


def test_the_last_line_counts_the_folders_left_out_too(study):
    """A folder whose name cannot be a participant's ("P 07", a typo) holds a participant's files:
    the command's last line counts it beside the files left out, not only the warning above the tables."""
    from careful_tui.commands.study_report import left_out_text

    recording = write_block(study, "p01", 0, "main", name="a.jsonl", finished=2)
    assert left_out_text(gather(study)) == ""
    (study.out / "P 07").mkdir()
    (study.out / "P 07" / "a.jsonl").write_bytes(recording.read_bytes())
    data = gather(study)
    assert any("P 07: participant id 'P 07' cannot name a folder" in p for p in data.problems)
    assert left_out_text(data) == "; 1 folder left out (named above the tables)"
    (study.participant_folder("p01") / "b.jsonl").write_text("not json\n")
    assert left_out_text(gather(study)) == "; 1 file and 1 folder left out (named above the tables)"


def test_parallel_fits_equal_serial_ones(study_path):
    data = gather(load_study(study_path))
    cells = [data.cell("sim03", 1), data.cell(POOLED, 0)]
    options = report_options(resamples=20)
    parallel = run_fits(cells, options, workers=2)
    for cell, fit in zip(cells, parallel):
        serial = fit_cell(cell, options)
        assert fit.symbols == serial.symbols
        np.testing.assert_allclose(fit.estimate, serial.estimate)
        np.testing.assert_allclose(fit.intervals, serial.intervals)


def test_study_report_prints_a_row_per_participant_and_world_and_writes_csv_and_figures(study_path, capsys):
    code = main(["study", "report", str(study_path), "--resamples", "20", "--workers", "2"])
    out, err = capsys.readouterr()
    assert code == 0
    report = study_path.parent / "data" / "report"
    # The table: each participant in each world, and each world's pool.
    # Two tables: how each played, then the rewards (with each population's prediction for a new participant).
    table = [line for line in out.splitlines() if line.strip().startswith(("sim0", "population (", "95% prediction"))]
    assert len(table) == 8 + 10
    assert sum("population (3)" in line for line in table) == 4
    assert sum(line.strip().startswith("95% prediction") for line in table) == 2
    assert max(len(line) for line in out.splitlines() if line.strip().startswith(("sim0", "population ("))) <= 100
    assert "95% confidence interval" in out
    assert "corrupt.jsonl:2: direction:" in err.replace("\n", "")
    rows = list(csv.DictReader((report / "report.csv").open()))
    assert [(r["participant"], r["world"]) for r in rows] == [
        ("sim01", "paper"), ("sim02", "paper"), ("sim03", "paper"), ("pooled", "paper"),
        ("sim01", "mud"), ("sim02", "mud"), ("sim03", "mud"), ("pooled", "mud")]
    for row in rows:
        assert row["study"] == "pilot" and row["method"] == "maxent" and row["interval_kind"] == "confidence"
        assert row["pool_model"] == ("population" if row["participant"] == "pooled" else "")
        # A population whose every participant bounds the cliff on one side only has no centre, only a bound.
        centre = float(row["reward_C"] or row["reward_C_low"])
        assert float(row["reward_C_low"]) <= centre <= float(row["reward_C_high"])
        assert (row["reward_U"] != "") == (row["world"] == "mud")
        assert int(row["ended_C"]) + int(row["ended_G"]) + int(row["step_limit"]) == int(row["episodes"])
    assert rows[0]["interrupted"] == "1" and rows[1]["files_left_out"] == "1" and rows[3]["files_left_out"] == ""
    for name in ("rewards-w0-paper", "rewards-w1-mud", "carefulness-w0-paper", "carefulness-w1-mud",
                 "intervals-pooled"):
        for suffix in (".png", ".pdf"):
            assert (report / f"{name}{suffix}").stat().st_size > 1000


def _stand_in_fit(cell, options, *, stop=None):
    """A stand-in fit that checks `stop` as the solvers do, and marks each fit it ends (in the
    worker's process): the biggest cell (sent first) takes 0.1 s, the others 2 s."""
    import time

    from irl_core.errors import Stopped

    for _ in range(10 if cell.steps == 11 else 200):
        if stop is not None and stop():
            raise Stopped()
        time.sleep(0.01)
    with open(options, "a") as marks:
        marks.write("fit\n")
    return CellFit(error="stand-in")


def test_ctrl_c_during_the_fits_stops_the_running_ones_and_drops_the_rest(tmp_path, monkeypatch):
    """Ctrl+C (here KeyboardInterrupt in the parent after the first fit) leaves at once: the running
    fits stop at their next check and the queued ones are dropped, instead of every fit running to
    its end while the user waits (a 26-fit report went on for 24 s)."""
    from types import SimpleNamespace

    from irl_core.studies import report_fits as study_report

    marks = tmp_path / "marks"
    monkeypatch.setattr(study_report, "fit_cell", _stand_in_fit)

    def interrupt(done, total):
        raise KeyboardInterrupt

    cells = [SimpleNamespace(steps=i) for i in range(12)]
    with pytest.raises(KeyboardInterrupt):
        run_fits(cells, str(marks), workers=2, progress=interrupt)
    assert len(marks.read_text().splitlines()) <= 2


def test_a_bad_study_file_or_no_participants_exits_2_with_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('worlds = ["nowhere"]\n')
    assert main(["study", "report", str(bad)]) == 2
    assert "bad.toml: worlds[0]: 'nowhere' is neither a built-in world" in capsys.readouterr().err
    empty = write_study(tmp_path)
    assert main(["study", "report", str(empty)]) == 2
    assert "no participant folders" in capsys.readouterr().err
    assert main(["study", "report", str(empty), "--resamples", "5"]) == 2
    assert "--resamples must be at least 20" in capsys.readouterr().err


def test_the_figures_show_each_participant_the_pool_and_the_truth(study_path):
    """Figures drawn from given fits (no fitting): which panels there are, and what the cells hold."""
    from careful_tui.render.figures.study_figures import report_figures
    from careful_tui.render.figures.style import plain
    from irl_core.studies.report import CellFit

    data = gather(load_study(study_path))
    fits = []
    for cell in data.cells:
        world = data.study.worlds[cell.world_index]
        symbols = tuple(s for s in ("C", "U", "G") if s in world.layout)
        estimate = np.array([-900.0 - cell.world_index, -30.0, 90.0][: len(symbols)] if len(symbols) == 3
                            else [-900.0, 90.0])
        grid = np.array([[estimate[symbols.index(ch)] if ch in symbols else 0.0 for ch in row] for row in world.grid])
        fits.append(CellFit(method="maxent", beta=0.5, beta_auto=True, symbols=symbols, estimate=estimate,
                            intervals=np.stack([estimate - 50, estimate + 50], axis=1), truth=estimate,
                            interval_kind="confidence", rmax=5000.0, reward_grid=grid))
    figures = dict(report_figures(data, fits))
    assert sorted(figures) == ["carefulness-w0-paper", "carefulness-w1-mud", "intervals-pooled",
                               "rewards-w0-paper", "rewards-w1-mud"]
    titles = [ax.get_title() for ax in figures["rewards-w1-mud"].axes if ax.get_visible() and ax.get_title()]
    assert titles == ["true (world file)", "sim01", "sim02", "sim03", "pooled (3)"]
    sim02 = next(ax for ax in figures["rewards-w1-mud"].axes if ax.get_title() == "sim02")
    assert sim02.images[0].get_array()[3, 1] == -901.0  # the cliff cell shows that participant's fitted cliff
    careful = [ax.get_title() for ax in figures["carefulness-w0-paper"].axes if ax.get_visible()]
    assert careful == ["sim01", "sim02", "sim03"]
    panels = [ax for ax in figures["intervals-pooled"].axes if ax.get_title()]
    assert [ax.get_title() for ax in panels] == ["paper: pooled over 3 participants, 12 episodes",
                                                 "mud: pooled over 3 participants, 12 episodes"]
    assert [t.get_text() for t in panels[1].get_yticklabels()] == ["cliff", "mud", "goal"]
    assert plain("a$b\x1b") == "a\\$b\\x1b"


def test_figure_titles_say_the_rewards_are_point_estimates_and_count_in_words(study):
    """One participant with one episode: "1 participant, 1 episode", not "1 participants, 1 episodes";
    the rewards figure says its panels are point estimates (their intervals are in the table)."""
    from careful_tui.render.figures.study_figures import report_figures

    write_block(study, "p1", 0, "main", name="a.jsonl", finished=1)
    data = gather(study)
    fits = [fit_cell(cell, report_options(resamples=20)) if cell.world_index == 0 else CellFit(error="none")
            for cell in data.cells]
    figures = dict(report_figures(data, fits))
    pooled = [ax.get_title() for ax in figures["intervals-pooled"].axes if ax.get_title()]
    assert pooled == ["paper: pooled over 1 participant, 1 episode"]
    assert "point estimates" in figures["rewards-w0-paper"].get_suptitle()


def test_the_fits_caveats_are_printed_and_kept_in_the_csv(study):
    """A fit's notes that qualify its numbers (too few episodes for a bootstrap, beta not identified,
    not converged) reach the user: once each on stdout with the rows they apply to, and in the
    CSV's note column; the beta estimate the table shows already is not repeated."""
    from careful_tui.commands.study_report import fit_notes
    from irl_core.studies.report import report_rows

    for participant in ("p1", "p2"):
        write_block(study, participant, 0, "main", name="a.jsonl", finished=2)
    data = gather(study)
    rough = "only 2 episodes: a bootstrap interval from so few is rough (it tends to be too narrow)"
    fits = []
    for cell in data.cells:
        if cell.world_index == 0 and cell.participant != POOLED:
            fits.append(CellFit(method="maxent", beta=0.5, beta_auto=True,
                                notes=(Note("beta_estimated", "beta estimated by maximum likelihood: 0.5"),
                                       Note("few_episodes", rough))))
        else:
            fits.append(CellFit(error="no finished main episodes"))
    assert fit_notes(data, fits) == [f"{rough}: p1 · paper, p2 · paper"]
    columns, rows = report_rows(data, fits)
    notes = [row[columns.index("note")] for row in rows]
    assert notes[:2] == [f"beta estimated by maximum likelihood: 0.5; {rough}"] * 2
    assert notes[2] == "no finished main episodes"


def test_a_long_reason_for_no_fit_is_its_first_clause_in_the_table_and_whole_under_it(study):
    from careful_tui.commands.study_report import fit_notes

    write_block(study, "p1", 0, "main", name="a.jsonl", finished=2)
    data = gather(study)
    why = ("the demonstrations are not optimal for any reward within ±rmax; they may be noisy: try method=loss, "
           "or raise rmax")
    fits = [CellFit(error=why) if cell.participant == "p1" and cell.world_index == 0 else CellFit(error="none")
            for cell in data.cells]
    console = Console(width=250, file=io.StringIO(), record=True)
    console.print(report_table(data, fits))
    row = next(line for line in console.export_text().splitlines() if line.strip().startswith("p1"))
    assert "not optimal for any reward within ±rmax" in row and "noisy" not in row
    assert fit_notes(data, fits) == [f"not fitted: {why}: p1 · paper"]


def test_the_printed_caveats_are_chosen_by_code_not_by_wording(study):
    """A reworded note on beta is still left out of the printed caveats, and a caveat that happens
    to begin like one is still printed: the report reads the notes' codes."""
    from careful_tui.commands.study_report import fit_notes

    write_block(study, "p1", 0, "main", name="a.jsonl", finished=2)
    data = gather(study)
    fits = [CellFit(method="maxent", beta=0.5, beta_auto=True,
                    notes=(Note("beta_estimated", "the estimated beta: 0.5"),
                           Note("few_episodes", "beta's interval is rough: only 2 episodes")))
            if cell.participant != POOLED and cell.world_index == 0 else CellFit(error="none") for cell in data.cells]
    assert fit_notes(data, fits) == ["beta's interval is rough: only 2 episodes: p1 · paper"]


def test_a_caveat_with_each_rows_own_numbers_is_one_line_for_many_rows(study):
    """A calibrated hand's note carries each participant's own bias and noise: a study of many would print a line
    per participant, so past a few they are one line that says where the numbers are."""
    from careful_tui.commands.study_report import SPELLED_OUT, fit_notes
    from irl_core.irl.notes import CODES

    ids = [f"p{i}" for i in range(1, SPELLED_OUT + 3)]
    for participant in ids:
        write_block(study, participant, 0, "main", name="a.jsonl", finished=2)
    data = gather(study)
    fits = []
    for cell in data.cells:
        if cell.world_index == 0 and cell.participant != POOLED:
            n = ids.index(cell.participant)
            fits.append(CellFit(method="maxent", beta=0.5, beta_auto=True, notes=(
                Note("hand_calibrated", f"the hand from 10 calibration trials: bias -{n}.5 levels"),
                Note("few_episodes", "only 2 episodes" if n % 2 else "only 2 episodes, rough"))))
        else:
            fits.append(CellFit(error="none"))
    rows = ", ".join(f"{p} · paper" for p in ids[:6]) + (f" and {len(ids) - 6} more" if len(ids) > 6 else "")
    assert fit_notes(data, fits) == [
        f"{CODES['hand_calibrated']} ({len(ids)} rows, each with its own numbers in report.csv's note column): {rows}",
        "only 2 episodes, rough: " + ", ".join(f"{p} · paper" for p in ids[::2]),
        "only 2 episodes: " + ", ".join(f"{p} · paper" for p in ids[1::2]),
    ]


def test_outcomes_are_worded_as_replay_and_play_word_them(study, capsys):
    # Two falls, then a quit mid-episode; another file's episode cut off without an end.
    write_block(study, "p1", 0, "main", name="a.jsonl", finished=2, then="quit")
    write_block(study, "p1", 0, "main", name="b.jsonl", first=3, then="crash")
    data = gather(study)
    cell = data.cell("p1", 0)
    assert (cell.outcomes, cell.interrupted_outcomes, cell.interrupted) == ({"C": 2}, {"quit": 1, "unfinished": 1}, 2)
    console = Console(width=250, file=io.StringIO(), record=True)
    console.print(report_table(data, [CellFit(error="not fitted here")] * len(data.cells)))
    row = next(line for line in console.export_text().splitlines() if line.strip().startswith("p1"))
    # The words of the replay's panel and play's status, not codes of its own.
    assert "2 fell off the cliff; 1 quit, 1 unfinished" in row
    assert [outcome_words(code) for code in ("C", "quit", "unfinished")] == ["fell off the cliff", "quit", "unfinished"]
    assert outcomes_text({"G": 8, "C": 1, "step_limit": 1}, {}) == \
        "1 fell off the cliff, 8 reached the goal, 1 ran out of steps"
    assert outcomes_text({}, {}) == "-"


def _worst_case_fits(data):
    """Fits with the longest texts a report shows: wide rewards with intervals on three symbols, every mark, an
    exclusion, and each pool a population with its prediction."""
    wide = dict(method="maxent", beta=0.27, beta_auto=True, symbols=("C", "U", "G"), confidence=0.95, rmax=5000.0,
                estimate=np.array([-1935.44, -46.55, 427.3]), interval_kind="confidence",
                intervals=np.array([[-5000.0, -1325.7], [-3269.2, -18.66], [92.71, 4815.5]]))
    fits = []
    for cell in data.cells:
        if cell.participant == POOLED:
            fits.append(CellFit(**wide, pool_model="population", pooled=cell.participants,
                                prediction=np.array([[-5000.0, -83.41], [-1720.5, -0.61], [0.21, 5000.0]])))
        else:
            fits.append(CellFit(**wide, influential=True, outlier=True, fit_check_passed=False,
                                excluded_why="fit check failed"))
    return fits


def test_the_tables_are_readable_in_100_columns(study):
    """Issue 45, item 18: the report's table needed about 190 columns and wrapped into `particip…` at 110. Now two
    tables fit a terminal of 100 columns: no line longer, no name cut, every row's id, world and rewards whole on
    its line, however long the outcomes (which wrap within their cell)."""
    for participant in ("p0001", "participant-long-7"):
        write_block(study, participant, 0, "main", name="a.jsonl", finished=9, then="quit")
        write_block(study, participant, 0, "main", name="b.jsonl", first=10, then="crash")
        write_block(study, participant, 1, "main", name="c.jsonl", finished=3)
    data = gather(study)
    fits = _worst_case_fits(data)
    console = Console(width=100, file=io.StringIO(), record=True)
    console.print(report_table(data, fits))
    lines = console.export_text().splitlines()
    assert max(len(line) for line in lines) <= 100
    assert "…" not in "\n".join(lines)
    headers = [line.split() for line in lines if line.strip().startswith("participant ")]
    assert headers == [["participant", "world", "episodes", "outcomes", "careful", "fit"],
                       ["participant", "world", "cliff", "mud", "goal"]]
    for cell in data.cells:
        who = "population" if cell.participant == POOLED else cell.participant
        rows = [line for line in lines if line.strip().startswith(who + " ")
                and f" {data.study.worlds[cell.world_index].name} " in line]
        assert len(rows) == 2, (who, rows)  # one in each table
        played, rewards = rows
        assert f" {cell.episodes} " in played and "maxent β 0.27" in played  # the steps are in the CSV
        for text in ("-1935 [-5000, -1326]", "-46.5 [-3269, -18.7]", "427 [92.7, 4816]"):
            assert text in rewards
        if who != "population":  # the marks beside the fit they qualify; the rewards keep their room
            assert all(mark in played and mark not in rewards for mark in ("†", "‡", "✗", "(excluded)"))
    predictions = [line for line in lines if line.strip().startswith("95% prediction")]
    assert len(predictions) == 2 and all("[-5000, -83.4]" in line and "[0.2, 5000]" in line for line in predictions)
    # The longest outcomes wrap within their cell, whole words on each line: read down the column, they are whole.
    start = lines[2].index("outcomes")
    column = " ".join(" ".join(line[start:start + 16].split()) for line in lines[4:10])
    assert "9 fell off the cliff; 1 quit, 1 unfinished" in column, column


@pytest.mark.parametrize("show_rewards", [True, False])
def test_the_report_says_whether_the_participants_saw_the_rewards(tmp_path, show_rewards):
    """Issue 45, item 14: the study file's show_rewards decides both front ends' legend; the report says which the
    participants saw, in the CSV (a column, every row) and the first table's caption."""
    path = write_study(tmp_path)
    path.write_text(path.read_text() + f"show_rewards = {str(show_rewards).lower()}\n")
    study = load_study(path)
    write_block(study, "p1", 0, "main", name="a.jsonl", finished=2)
    data = gather(study)
    fits = [CellFit(error="not fitted here")] * len(data.cells)
    columns, rows = report_rows(data, fits)
    assert {row[columns.index("show_rewards")] for row in rows} == {str(show_rewards).lower()}
    console = Console(width=100, file=io.StringIO(), record=True)
    console.print(report_table(data, fits))
    text = " ".join(console.export_text().split())
    said = ("Participants saw each symbol's reward in the board's legend (the study file's show_rewards = true)"
            if show_rewards else "Participants saw the symbols' names only, no rewards (the study file's show_rewards = "
            "false)")
    assert said in text
