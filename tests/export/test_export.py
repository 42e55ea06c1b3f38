"""`careful export`: CSV rows are the steps; a Minari dataset holds the recordings and its world."""

import csv
import dataclasses
import json
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path
from types import SimpleNamespace

import minari
import numpy as np
import pytest

from careful_tui.cli import main
from irl_core.errors import RecordingError
from irl_core.play.game import Game
from irl_core.recordings import export
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.export import CSV_COLUMNS, STUDY_COLUMNS, csv_columns, csv_rows, recorded_episodes
from irl_core.recordings.lines import SessionHeader
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.mdp import DIRECTIONS, action_index, build_mdp
from irl_core.worlds.world import World

CORPUS = Path(__file__).parents[1] / "corpus" / "recordings"
# A world no built-in name or file gives: the dataset must carry it.
SHORT = World(name="paper-short", layout="......\n......\n......\n.CCCCG\n", levels=14, max_steps=8,
              rewards={"C": -1000.0, "G": 100.0})


def play_session(path: Path, world: World, *, seed: int, episodes: int) -> Path:
    """A session as `careful play` records it: random moves and hold times; some episodes quit."""
    header = SessionHeader(world=world, player="ada", created=datetime(2026, 1, 1, tzinfo=UTC),
                           seed=seed, input={"mode": "hold"})
    rng = np.random.default_rng(seed)
    with RecordingWriter(path, header) as writer:
        game = Game(world, seed=seed, sink=writer)
        for _ in range(episodes):
            game.begin_episode()
            quit_after = int(rng.integers(1, 12))
            for _ in range(quit_after):
                hold = None if rng.random() < 0.2 else float(rng.uniform(0, 3000))
                result = game.move(DIRECTIONS[rng.integers(4)], int(rng.integers(1, world.levels + 1)),
                                   hold_ms=hold, exact=bool(rng.random() < 0.3))
                if result.end:
                    break
            else:
                game.quit()
    return path


@pytest.fixture
def session(tmp_path):
    return play_session(tmp_path / "ada.jsonl", SHORT, seed=4, episodes=30)


@pytest.fixture
def datasets(tmp_path, monkeypatch):
    root = tmp_path / "minari-datasets"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    return root


def run(capsys, *args):
    code = main(["export", *map(str, args)])
    return code, capsys.readouterr().err


# ---------------------------------------------------------------------------- CSV


def test_csv_has_one_row_per_step_with_the_step_fields(tmp_path, session, capsys):
    out = tmp_path / "steps.csv"
    code, err = run(capsys, session, "--format", "csv", "--out", out)
    assert code == 0 and f"to {out}" in err
    recording = read_recording(session)
    with open(out, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert tuple(rows[0]) == CSV_COLUMNS
    assert len(rows) == len(recording.steps) > 30
    for row, step in zip(rows, recording.steps):
        assert row["file"] == str(session) and row["player"] == "ada"
        assert (int(row["episode"]), int(row["t"])) == (step.episode, step.t)
        assert (int(row["row"]), int(row["col"])) == step.state
        assert (int(row["next_row"]), int(row["next_col"])) == step.next_state
        assert (row["direction"], int(row["carefulness"])) == (step.direction, step.carefulness)
        assert row["hold_ms"] == ("" if step.hold_ms is None else repr(step.hold_ms))
        assert row["hold_exact"] == str(step.hold_exact).lower() and row["slipped"] == str(step.slipped).lower()
        assert (float(row["reward"]), float(row["score"])) == (step.reward, step.score)
    assert {row["hold_ms"] for row in rows} >= {""}  # a move without a hold time is an empty cell


def test_csv_takes_many_files_of_many_worlds(tmp_path, capsys):
    out = tmp_path / "both.csv"
    files = [CORPUS / "different_world_a.jsonl", CORPUS / "different_world_b.jsonl"]
    assert run(capsys, *files, "--format", "csv", "--out", out)[0] == 0
    with open(out, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["file"] for row in rows] == [str(f) for f in files for _ in read_recording(f).steps]


def test_csv_study_columns_come_from_a_study_header():
    recording = read_recording(CORPUS / "valid.jsonl")
    study = {"name": "pilot", "participant": "p7", "phase": "main", "world_index": 1}
    in_study = dataclasses.replace(recording, header=SimpleNamespace(player="p7", study=study, world=recording.world))
    assert csv_columns([recording]) == CSV_COLUMNS
    assert csv_columns([recording, in_study]) == CSV_COLUMNS + STUDY_COLUMNS
    rows = list(csv_rows(in_study, study_columns=True))
    assert [row[-4:] for row in rows] == [["pilot", "p7", "main", "1"]] * len(recording.steps)
    assert [row[-4:] for row in csv_rows(recording, study_columns=True)] == [["", "", "", ""]] * 3


def test_csv_never_overwrites(tmp_path, session, capsys):
    out = tmp_path / "taken.csv"
    out.write_text("mine\n")
    code, err = run(capsys, session, "--format", "csv", "--out", out)
    assert code == 2 and "already exists" in err and len(err.strip().splitlines()) == 1
    assert out.read_text() == "mine\n"
    before = session.read_bytes()
    assert run(capsys, session, "--format", "csv", "--out", session)[0] == 2
    assert session.read_bytes() == before


def test_a_path_with_control_characters_is_shown_escaped(tmp_path, session, capsys):
    """`ESC ] 0 ; ... BEL` in a file name would retitle the terminal (Rich drops the BEL, not the ESC)."""
    out = tmp_path / "o\x1b]0;title\x07.csv"
    code, err = run(capsys, session, "--format", "csv", "--out", out)
    assert code == 0 and out.exists()
    assert "\x1b" not in err and "o\\x1b]0;title\\x07.csv" in err


# ---------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("path", sorted(CORPUS.glob("*.jsonl")), ids=lambda p: p.name)
def test_every_corpus_recording_exports_or_fails_with_one_line(path, tmp_path, datasets, capsys):
    try:
        read_recording(path)
        problem = None
    except RecordingError as exc:
        problem = str(exc)
    out = tmp_path / "out.csv"
    code, err = run(capsys, path, "--format", "csv", "--out", out)
    if problem is None:
        assert code == 0 and out.exists()
        return
    assert code == 2 and len(err.strip().splitlines()) == 1 and path.name in err and "Traceback" not in err
    assert not out.exists()
    code, err = run(capsys, path, "--format", "minari", "--out", "careful/bad-v0")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert not (datasets / "careful" / "bad-v0").exists()


def test_minari_refuses_mixed_worlds_empty_input_and_bad_ids(datasets, capsys):
    code, err = run(capsys, CORPUS / "different_world_a.jsonl", CORPUS / "different_world_b.jsonl",
                    "--format", "minari", "--out", "mixed-v0")
    assert code == 2 and "different_world_b.jsonl" in err and "one world" in err
    code, err = run(capsys, CORPUS / "header_only.jsonl", "--format", "minari", "--out", "empty-v0")
    assert code == 2 and "no steps" in err
    for bad in ["no-version", "../escape-v0", "with space-v0"]:
        code, err = run(capsys, CORPUS / "valid.jsonl", "--format", "minari", "--out", bad)
        assert code == 2 and "not a Minari dataset id" in err
    assert not any(datasets.rglob("*.hdf5"))


def test_an_episode_whose_steps_do_not_join_up_is_an_error(tmp_path):
    lines = (CORPUS / "valid.jsonl").read_text().splitlines()
    steps = [json.loads(line) for line in lines if '"step"' in line]
    broken = [lines[0]]
    for t, (cell, next_cell) in enumerate([([0, 0], [0, 0]), ([2, 2], [1, 2])]):
        step = dict(steps[0], episode=0, t=t, state=cell, next_state=next_cell, direction="up", slipped=False)
        broken.append(json.dumps(step))
    path = tmp_path / "jump.jsonl"
    path.write_text("\n".join(broken) + "\n")
    # The reader refuses it (file:line: field), before export sees it.
    with pytest.raises(RecordingError, match=r"jump.jsonl:3: state: \[2, 2\] is not where the previous step ended \(\[0, 0\]\)"):
        recorded_episodes(read_recording(path))


# ---------------------------------------------------------------------------- Minari


def test_minari_round_trip_keeps_episodes_actions_rewards_and_hold_times(session, datasets, capsys):
    code, err = run(capsys, session, "--format", "minari", "--out", "careful/ada-v0")
    assert code == 0 and "minari.load_dataset('careful/ada-v0')" in err
    assert (datasets / "careful" / "ada-v0" / "data" / "main_data.hdf5").exists()
    recording = read_recording(session)
    world, mdp = recording.world, build_mdp(recording.world)
    dataset = minari.load_dataset("careful/ada-v0")
    assert dataset.total_episodes == len(recording.episode_ends) == 30
    assert dataset.total_steps == len(recording.steps)
    outcomes = set()
    for episode, end in zip(dataset.iterate_episodes(), recording.episode_ends):
        steps = [s for s in recording.steps if s.episode == end.episode]
        T = len(steps)
        cells = [s.state for s in steps] + [steps[-1].next_state]
        assert episode.observations.tolist() == [r * world.cols + c for r, c in cells]
        assert episode.actions.tolist() == [action_index(s.direction, s.carefulness, world.levels) for s in steps]
        terminal = world.reward_of(end.terminal_symbol) if end.outcome == "terminal" else 0.0
        assert episode.rewards.tolist() == [s.reward for s in steps[:-1]] + [steps[-1].reward + terminal]
        assert episode.rewards.sum() == pytest.approx(end.return_)
        assert episode.terminations.tolist() == [False] * (T - 1) + [end.outcome == "terminal"]
        assert episode.truncations.tolist() == [False] * (T - 1) + [end.outcome != "terminal"]
        hold = [np.nan if s.hold_ms is None else s.hold_ms for s in steps]
        np.testing.assert_array_equal(episode.infos["hold_ms"][1:], hold)
        assert episode.infos["hold_exact"][1:].tolist() == [s.hold_exact for s in steps]
        assert episode.infos["slipped"][1:].tolist() == [s.slipped for s in steps]
        assert episode.infos["carefulness"].tolist() == [0] + [s.carefulness for s in steps]
        assert episode.infos["cell"].tolist() == [list(c) for c in cells]
        outcomes.add(end.outcome)
    assert outcomes == {"terminal", "quit", "step_limit"}
    assert mdp.n_actions == dataset.action_space.n


def test_the_recovered_environment_is_the_recorded_world_and_gives_the_recorded_rewards(session, datasets, capsys):
    assert run(capsys, session, "--format", "minari", "--out", "ada-v0")[0] == 0
    dataset = minari.load_dataset("ada-v0")
    env = dataset.recover_environment()
    assert env.unwrapped.world == SHORT
    mdp = env.unwrapped.mdp
    R = mdp.reward_matrix()
    state_of_obs = {r * SHORT.cols + c: s for s, (r, c) in enumerate(mdp.cells)}
    for episode in dataset.iterate_episodes():
        for t, a in enumerate(episode.actions):
            s, s_next = state_of_obs[episode.observations[t]], state_of_obs[episode.observations[t + 1]]
            assert mdp.P[s * mdp.n_actions + a, s_next] > 0
            expected = R[s, a] + (mdp.R_S[s_next] if mdp.terminal[s_next] else 0.0)
            assert episode.rewards[t] == pytest.approx(expected)
    obs, _ = env.reset(seed=0)
    assert obs in env.observation_space
    assert env.step(env.action_space.sample())[1] <= 0


def test_a_fresh_python_recovers_the_environment_without_importing_careful_first(session, datasets, capsys):
    assert run(capsys, session, "--format", "minari", "--out", "careful/fresh-v0")[0] == 0
    code = (
        "import minari; env = minari.load_dataset('careful/fresh-v0').recover_environment(); "
        "obs, info = env.reset(seed=1); print(env.unwrapped.world.name, env.unwrapped.world.max_steps)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          env={"MINARI_DATASETS_PATH": str(datasets), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["paper-short", "8"]


def test_minari_never_overwrites_a_dataset(session, datasets, capsys):
    assert run(capsys, session, "--format", "minari", "--out", "careful/once-v0")[0] == 0
    data = datasets / "careful" / "once-v0" / "data" / "main_data.hdf5"
    before = data.read_bytes()
    code, err = run(capsys, CORPUS / "valid.jsonl", "--format", "minari", "--out", "careful/once-v0")
    assert code == 2 and "already exists" in err
    assert data.read_bytes() == before


def test_large_exports_are_written_in_batches_with_progress(tmp_path, datasets, monkeypatch):
    monkeypatch.setattr(export, "MINARI_BATCH", 7)
    recordings = [read_recording(play_session(tmp_path / f"{k}.jsonl", SHORT, seed=k, episodes=10)) for k in range(2)]
    seen = []
    dataset = export.write_minari("batched-v0", recordings, description="test", progress=seen.append)
    assert seen == [7, 14, 20]
    assert dataset.total_episodes == 20
    ids = [episode.id for episode in minari.load_dataset("batched-v0").iterate_episodes()]
    assert ids == list(range(20))
    second_file_first_action = minari.load_dataset("batched-v0")[10].actions[0]
    first = recordings[1].steps[0]
    assert second_file_first_action == action_index(first.direction, first.carefulness, SHORT.levels)


def test_a_failed_export_leaves_no_dataset(tmp_path, session, datasets, monkeypatch):
    monkeypatch.setattr(export, "MINARI_BATCH", 5)
    real = export.episode_arrays
    calls = []

    def failing(episode, mdp):
        calls.append(1)
        if len(calls) > 7:
            raise OSError("disk full")
        return real(episode, mdp)

    monkeypatch.setattr(export, "episode_arrays", failing)
    with pytest.raises(OSError, match="disk full"):
        export.write_minari("careful/partial-v0", [read_recording(session)], description="test")
    assert not (datasets / "careful" / "partial-v0").exists()


def test_the_game_does_not_import_gymnasium_or_minari():
    code = (
        "import sys, careful_tui.cli, careful_tui.screens.play, careful_tui.commands.export, irl_core.recordings.export; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'gymnasium', 'minari', 'h5py', 'jax'}))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
