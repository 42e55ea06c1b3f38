"""`careful fit` on simulated recordings: the fit JSON, the printout and the errors."""

import json
from datetime import UTC, datetime

import pytest

import careful_tui.commands.fit as fit_command
from careful_tui.cli import main
from irl_core.irl import SolverError
from irl_core.players.experts import optimal_policy, rollouts, write_rollouts
from irl_core.recordings.lines import SessionHeader, Step
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS, World

WALLED = World(name="walled", layout="..#.\n....\n.C.G\n", levels=3, rewards={"C": -100.0, "G": 10.0})


def simulate(path, world, episodes=30, seed=0):
    mdp = build_mdp(world)
    write_rollouts(path, mdp, rollouts(mdp, optimal_policy(mdp), episodes=episodes, seed=seed),
                   player="expert:optimal", seed=seed)
    return path


def header(world):
    return SessionHeader(world=world, player="tester", created=datetime(2000, 1, 1, tzinfo=UTC), seed=0)


def run(capsys, *argv):
    code = main(["fit", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def mud_file(tmp_path_factory):
    return simulate(tmp_path_factory.mktemp("rec") / "mud.jsonl", BUILTIN_WORLDS["mud"], episodes=100)


def test_json_has_the_spec_structure(tmp_path, capsys, mud_file):
    out_json = tmp_path / "fit.json"
    code, out, err = run(capsys, mud_file, "--intervals", "--json", out_json, "--no-view")
    assert code == 0, err
    data = json.loads(out_json.read_text())
    assert list(data) == ["method", "world", "options", "reward", "unknown", "interval", "interval_kind", "policy",
                          "demonstrations", "evaluation", "status", "elapsed_s", "fit_check", "notes", "note_codes",
                          "interval_method"]
    assert data["interval_method"] == "identified"
    assert data["method"] == "lp" and data["status"] == "optimal" and data["interval_kind"] == "identified"
    assert data["world"] == BUILTIN_WORLDS["mud"].model_dump(mode="json")
    assert data["options"] == {"rmax": 1000.0, "lambda": 0.0, "beta": 1.0, "reward_cells": "special",
                               "tie": False, "intervals": True, "confidence": 0.95, "resamples": 200, "seed": 0,
                               "beta_auto": False, "player_model": None}
    assert any(note.startswith("method auto chose lp") for note in data["notes"])
    assert len(data["note_codes"]) == len(data["notes"]) and data["note_codes"][0] == "auto_chose"
    assert set(data["evaluation"]) >= {"ends", "return", "optimal_return"}
    for key in ("reward", "unknown", "interval", "policy"):
        assert len(data[key]) == 4 and all(len(row) == 6 for row in data[key])
    assert data["unknown"][3][1] is True and data["unknown"][0][0] is False
    assert data["reward"][0][0] == 0.0 and data["reward"][3][1] < -500
    assert data["interval"][0][0] is None
    low, high = data["interval"][1][1]
    assert low <= -30.0 <= high
    assert data["policy"][3][1] is None  # a cliff cell: nobody acts there
    cell = data["policy"][2][2]
    assert set(cell) == {"direction", "carefulness", "count"} and cell["direction"] in ("up", "right", "down", "left")
    assert data["demonstrations"]["files"] == 1 and data["demonstrations"]["episodes"] == 100
    assert data["demonstrations"]["steps"] >= sum(cell["count"] for row in data["policy"] for cell in row if cell)
    assert isinstance(data["elapsed_s"], float)
    assert "fitted R_S" in out and "status: optimal" in out


def test_walls_are_null_and_intervals_null_when_not_asked(tmp_path, capsys):
    recording = simulate(tmp_path / "walled.jsonl", WALLED)
    out_json = tmp_path / "fit.json"
    code, _, err = run(capsys, recording, "--method", "loss", "--json", out_json)
    assert code == 0, err
    data = json.loads(out_json.read_text())
    assert data["reward"][0][2] is None and data["policy"][0][2] is None and data["interval"][0][2] is None
    assert data["unknown"][0][2] is False
    assert all(cell is None for row in data["interval"] for cell in row)


@pytest.mark.parametrize("method", ["lp", "loss", "maxent"])
def test_every_method_prints_and_saves_svg(tmp_path, capsys, mud_file, method):
    svg = tmp_path / "fit.svg"
    code, out, err = run(capsys, mud_file, "--method", method, "--svg", svg)
    assert code == 0, err
    assert svg.read_text().startswith("<svg") and "fitted R_S" in out and "demonstrated policy" in out
    # The grid is one reward among those that fit: it says it is a point estimate.
    assert "fitted R_S (point estimate)" in out
    # The SVG keeps every sentence whole (wrapped at its width, not cut there): the evaluation's
    # last words are in it, though the sentence is longer than the 80 columns of a pipe.
    evaluation = next(line for line in out.splitlines() if line.startswith("An agent trained"))
    assert len(evaluation) > 80 and evaluation.split()[-1] in svg.read_text().replace("&#160;", " ")


def assert_one_line_error(code, err, *fragments):
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in lines[0]


def test_recordings_of_different_worlds(tmp_path, capsys):
    a = simulate(tmp_path / "a.jsonl", BUILTIN_WORLDS["paper"], episodes=3)
    b = simulate(tmp_path / "b.jsonl", BUILTIN_WORLDS["mud"], episodes=3)
    code, _, err = run(capsys, a, b)
    assert_one_line_error(code, err, "one world at a time")


def test_recording_without_steps(tmp_path, capsys):
    empty = tmp_path / "empty.jsonl"
    RecordingWriter(empty, header(BUILTIN_WORLDS["paper"])).close()
    code, _, err = run(capsys, empty)
    assert_one_line_error(code, err, "no steps")


def test_demonstrations_no_reward_explains(tmp_path, capsys):
    path = tmp_path / "wall.jsonl"
    with RecordingWriter(path, header(BUILTIN_WORLDS["paper"])) as writer:
        for t in range(5):
            writer.write_step(Step(episode=0, t=t, state=(0, 0), direction="up", carefulness=14, hold_ms=900.0,
                                   next_state=(0, 0), slipped=False, reward=-14.0, score=200.0 - 14 * (t + 1)))
    # The default, auto, falls back to maxent (the lp has no answer); lp itself says why not.
    code, out, err = run(capsys, path, "--no-view")
    assert code == 0, err
    assert "auto chose maxent" in out and "no reward within ±rmax makes those actions optimal" in out
    code, _, err = run(capsys, path, "--method", "lp")
    assert_one_line_error(code, err, "not optimal for any reward, however large", "--method loss")
    assert "--rmax" not in err  # no bound makes walking into a wall optimal


def test_missing_output_folder_is_bad_usage(tmp_path, capsys, mud_file):
    code, _, err = run(capsys, mud_file, "--json", tmp_path / "nowhere" / "fit.json")
    assert_one_line_error(code, err, "does not exist")


def test_solver_failure_exits_1_with_one_line(capsys, mud_file, monkeypatch):
    def broken(*args, **kwargs):
        raise SolverError("the LP solver HiGHS stopped without an answer (Time limit reached)")

    monkeypatch.setattr(fit_command, "fit", broken)
    code, _, err = run(capsys, mud_file)
    assert code == 1
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "HiGHS" in lines[0] and "Traceback" not in err



class Terminal:
    """Standard input or output that says it is a terminal."""

    def isatty(self):
        return True


@pytest.fixture
def opened(monkeypatch):
    """`careful fit` sees a terminal on standard input and output; the fit views it runs are collected."""
    from types import SimpleNamespace

    from careful_tui.app import CarefulApp

    apps = []
    monkeypatch.setattr(CarefulApp, "run", lambda app: apps.append(app))
    monkeypatch.setattr(fit_command, "sys", SimpleNamespace(stdin=Terminal(), stdout=Terminal()))
    return apps


def test_a_terminal_opens_the_view_after_writing_json(tmp_path, capsys, opened, mud_file):
    out_json, svg = tmp_path / "fit.json", tmp_path / "view.svg"
    code, out, err = run(capsys, mud_file, "--method", "loss", "--json", out_json, "--svg", svg)
    assert code == 0, err
    [app] = opened
    assert app.first_screen.result.method == "loss" and app.first_screen.options.method == "loss" and app.first_screen.svg == svg
    assert json.loads(out_json.read_text())["method"] == "loss"
    assert not svg.exists()  # the view saves it once drawn; the printout is not made
    assert "fitted R_S" not in out


def test_no_view_prints_even_with_a_terminal(capsys, opened, mud_file):
    code, out, err = run(capsys, mud_file, "--no-view")
    assert code == 0, err
    assert opened == [] and "fitted R_S" in out


def test_bad_input_with_a_terminal_exits_2_before_the_view(tmp_path, capsys, opened):
    a = simulate(tmp_path / "a.jsonl", BUILTIN_WORLDS["paper"], episodes=3)
    b = simulate(tmp_path / "b.jsonl", BUILTIN_WORLDS["mud"], episodes=3)
    code, _, err = run(capsys, a, b)
    assert_one_line_error(code, err, "one world at a time")
    assert opened == []


def test_the_interval_chart_marks_an_open_end_even_under_the_estimate(capsys, mud_file):
    """On mud every cliff cell's identified set runs to -rmax, and its truth (-1000) sits at that end: the ◀ that
    says "no lower bound" must still be drawn beside it. A reward bounded on one side is its bound, so no estimate
    is marked (the truth's ○ only)."""
    code, out, err = run(capsys, mud_file, "--intervals", "--no-view")
    assert code == 0, err
    chart = [line for line in out.splitlines() if line.startswith("C (") and "─" in line]
    assert len(chart) == 4
    for line in chart:
        assert "◀" in line and "○" in line and "●" not in line and "◉" not in line, line
        assert "▶" not in line
    goal = next(line for line in out.splitlines() if line.startswith("G (") and "─" in line)
    assert "◀" not in goal and "▶" not in goal


@pytest.mark.parametrize("command", ["fit", "simulate", "replay", "experiment"])
def test_every_argument_says_what_it_is_in_help(command):
    from careful_tui.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a.choices, dict) and command in a.choices)
    arguments = [a for a in sub.choices[command]._actions if a.dest != "help"]
    assert arguments and all(a.help for a in arguments), [a.dest for a in arguments if not a.help]


def test_one_episode_is_counted_in_the_singular(tmp_path, capsys):
    one = simulate(tmp_path / "one.jsonl", BUILTIN_WORLDS["paper"], episodes=1)
    code, out, err = run(capsys, one, "--no-view")
    assert code == 0, err
    assert "from 1 file, 1 episode, " in out and "1 episodes" not in out


def test_two_outputs_on_one_path_are_refused_before_fitting(tmp_path, capsys, mud_file):
    """--figure x.svg --svg x.svg would write the figure, then the printout over it."""
    same = tmp_path / "x.svg"
    code, out, err = run(capsys, mud_file, "--no-view", "--figure", same, "--svg", same)
    assert_one_line_error(code, err, "--svg", "--figure", "x.svg")
    assert not same.exists()
