"""Recordings whose lines disagree, numbers JSON cannot hold, files that are not files, worlds too big.

Each bad recording is an error naming the file, the line and the field (exit 2, one line, the
file unchanged); a file given twice is read once and an empty file among others is skipped,
each with a warning; a FIFO is refused rather than waited on; a 2000x2000 world in a header is
refused before anything is allocated, within 15 s under a 4 GB memory limit.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import pytest
from hardening_checks import RAW_CONTROL, assert_refused, careful, careful_process, digest

from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import to_json_line
from irl_core.worlds.world import World

# Start top-left, no slip: right, right, down reaches the goal; right, down falls off the cliff.
WALK = World(name="walk", layout="...\n.CG\n", levels=3, slip="none", start=(0, 0), rewards={"C": -100.0, "G": 10.0})


def walk_lines() -> list[dict]:
    """The JSON objects of a two-episode recording of WALK (header first)."""
    header = SessionHeader(world=WALK, player="p", created=datetime(2026, 1, 2, tzinfo=UTC), seed=0)

    def step(episode: int, t: int, state, direction: str, next_state, score: float) -> Step:
        return Step(episode=episode, t=t, state=state, direction=direction, carefulness=1, hold_ms=100.0,
                    next_state=next_state, slipped=False, reward=-1.0, score=score, realised=direction)

    lines = [
        header,
        step(0, 0, (0, 0), "right", (0, 1), 199.0), step(0, 1, (0, 1), "right", (0, 2), 198.0),
        step(0, 2, (0, 2), "down", (1, 2), 197.0),
        EpisodeEnd(episode=0, outcome="terminal", terminal_symbol="G", steps=3, return_=7.0, score=207.0),
        step(1, 0, (0, 0), "right", (0, 1), 199.0), step(1, 1, (0, 1), "down", (1, 1), 198.0),
        EpisodeEnd(episode=1, outcome="terminal", terminal_symbol="C", steps=2, return_=-102.0, score=98.0),
    ]
    return [json.loads(to_json_line(line)) for line in lines]


def write_lines(path: Path, objects: list[dict]) -> Path:
    # json.dumps writes NaN and Infinity as JSON's non-standard tokens, as a foreign writer might.
    path.write_text("".join(json.dumps(obj) + "\n" for obj in objects))
    return path


def test_the_walk_reads_back_with_its_realised_directions(tmp_path):
    rec = read_recording(write_lines(tmp_path / "w.jsonl", walk_lines()))
    assert [s.realised for s in rec.steps] == ["right", "right", "down", "right", "down"]
    assert rec.episodes == [0, 1]


def test_an_older_file_without_realised_still_reads(tmp_path):
    objects = walk_lines()
    for obj in objects[1:]:
        obj.pop("realised", None)
    rec = read_recording(write_lines(tmp_path / "w.jsonl", objects))
    assert len(rec.steps) == 5 and all(s.realised is None for s in rec.steps)


def _move(objects, source, target):
    objects.insert(target, objects.pop(source))


MUTATIONS = {
    # name: (change the objects in place, bad line number, field, words of the problem)
    "step after its episode's end": (lambda o: o.insert(5, dict(o[3], t=3)), 6, "episode", "already ended on line 5"),
    "episode_end twice": (lambda o: o.insert(5, dict(o[4])), 6, "episode", "already ended on line 5"),
    "episodes out of order": (lambda o: [_move(o, 5, 1), _move(o, 6, 2), _move(o, 7, 3)], 5, "episode",
                              "episode 0 comes after episode 1"),
    "repeated t": (lambda o: o.insert(2, dict(o[1])), 3, "t", "0 repeats a step"),
    "skipped t": (lambda o: o.__setitem__(2, dict(o[2], t=2)), 3, "t", "2 skips a step"),
    "a step not starting where the last ended": (
        lambda o: o.__setitem__(6, dict(o[6], state=[0, 0], next_state=[1, 0], direction="down", realised="down")),
        7, "state", "[0, 0] is not where the previous step ended ([0, 1])"),
    "NaN reward": (lambda o: o[1].update(reward=float("nan")), 2, "reward", "finite number"),
    "Infinity score": (lambda o: o[2].update(score=float("inf")), 3, "score", "finite number"),
    "NaN hold_ms": (lambda o: o[1].update(hold_ms=float("nan")), 2, "hold_ms", "finite number"),
    "-Infinity episode_end score": (lambda o: o[4].update(score=float("-inf")), 5, "score", "finite number"),
    "schema true": (lambda o: o[0].update(schema=True), 1, "schema", "true is not supported"),
    "levels true in the header world": (lambda o: o[0]["world"].update(levels=True), 1, "world.levels",
                                        "valid integer"),
    "realised against next_state": (lambda o: o[1].update(realised="down"), 2, "realised", "never slips"),
    "a slip not marked as one": (lambda o: [o[0]["world"].update(slip="halving"),
                                            o[1].update(realised="down", next_state=[1, 0])], 2, "slipped",
                                 "went down for right"),
    # Episode ends that disagree with their steps (issue 31): a report counted these as goals reached.
    "terminal_symbol not in the world": (lambda o: o[4].update(terminal_symbol="Z"), 5, "terminal_symbol",
                                         "'Z', but the last step entered [1, 2], which is G"),
    "cliff for an episode that reached the goal": (lambda o: o[4].update(terminal_symbol="C"), 5,
                                                   "terminal_symbol", "'C', but the last step entered [1, 2], which is G"),
    "terminal after a last step on ground": (
        lambda o: o[6].update(direction="right", realised="right", next_state=[0, 2]), 8, "outcome",
        "terminal, but the last step ended on [0, 2], which is not a terminal cell"),
    "steps that were not played": (lambda o: o[4].update(steps=999), 5, "steps", "999, but episode 0 has 3 steps"),
    "quit after entering the goal": (lambda o: o[4].update(outcome="quit", terminal_symbol=None), 5, "outcome",
                                     "quit, but the last step entered [1, 2], which is G, a terminal cell"),
    "a symbol on an end that is no terminal": (lambda o: o[7].update(outcome="quit", terminal_symbol="G",
                                                                    steps=1), 8, "steps", "1, but episode 1 has 2"),
}


@pytest.mark.parametrize("case", list(MUTATIONS))
def test_inconsistent_lines_name_file_line_and_field(tmp_path, capsys, case):
    change, number, field, problem = MUTATIONS[case]
    objects = walk_lines()
    change(objects)
    path = write_lines(tmp_path / "bad.jsonl", objects)
    before = digest(path)
    assert_refused(*careful(capsys, "fit", path, "--no-view"), f"bad.jsonl:{number}: {field}: ", problem)
    assert_refused(*careful(capsys, "replay", path), f"bad.jsonl:{number}: {field}: ")
    assert digest(path) == before


def test_the_same_file_twice_is_read_once_with_a_warning(tmp_path, capsys):
    path = write_lines(tmp_path / "w.jsonl", walk_lines())
    (tmp_path / "same.jsonl").hardlink_to(path)
    status, out, err = careful(capsys, "fit", path, path, tmp_path / "same.jsonl", "--no-view")
    assert status == 0, err
    assert "from 1 file, 2 episodes, 5 steps" in " ".join(out.split())  # the title may wrap
    assert err.count("read once") == 2 and "given twice" in err and "the same file as" in err


def test_an_empty_file_among_others_is_skipped_with_a_warning(tmp_path, capsys):
    path = write_lines(tmp_path / "w.jsonl", walk_lines())
    empty = tmp_path / "empty.jsonl"
    empty.touch()
    status, out, err = careful(capsys, "fit", empty, path, "--no-view")
    assert status == 0, err
    assert "empty.jsonl: the file is empty (no session header); skipped" in err and "from 1 file" in out
    assert not RAW_CONTROL.search(out + err)


def test_only_empty_files_is_still_an_error(tmp_path, capsys):
    for name in ("a.jsonl", "b.jsonl"):
        (tmp_path / name).touch()
    status, out, err = careful(capsys, "fit", tmp_path / "a.jsonl", tmp_path / "b.jsonl", "--no-view")
    assert status == 2 and "every file given is empty" in err.splitlines()[-1]


@pytest.mark.parametrize("command", [["fit", "{fifo}", "--no-view"], ["replay", "{fifo}"],
                                     ["worlds", "--show", "{fifo}"],
                                     ["simulate", "--world", "{fifo}", "--policy", "optimal", "--episodes", "1",
                                      "--seed", "0", "--out", "{dir}/out.jsonl"]])
def test_a_fifo_is_refused_not_waited_on(tmp_path, command):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    args = [part.format(fifo=fifo, dir=tmp_path) for part in command]
    assert_refused(*careful_process(*args, timeout=30), "FIFO", "not a regular file")


def test_a_fifo_in_recordings_does_not_stop_experiment(tmp_path):
    (tmp_path / "recordings").mkdir()
    os.mkfifo(tmp_path / "recordings" / "stuck.jsonl")
    status, out, err = careful_process("experiment", "--quick", "--out", tmp_path / "exp", cwd=tmp_path, timeout=120)
    assert status == 0, err
    assert (tmp_path / "exp" / "summary.json").exists()


def _limit_memory() -> None:
    four_gb = 4 << 30
    resource.setrlimit(resource.RLIMIT_AS, (four_gb, four_gb))


@pytest.mark.parametrize("command", ["fit", "replay"])
def test_a_2000x2000_header_world_is_refused_before_allocating(tmp_path, command):
    objects = walk_lines()[:2]
    objects[0]["world"]["layout"] = ("." * 2000 + "\n") * 1999 + "C" * 1999 + "G\n"
    objects[0]["world"]["start"] = "random"
    path = write_lines(tmp_path / "huge.jsonl", objects)
    assert path.stat().st_size > 4_000_000
    args = [command, str(path), *(["--no-view"] if command == "fit" else [])]
    done = subprocess.run([sys.executable, "-m", "careful_tui.cli", *args], capture_output=True, text=True,
                          timeout=15, preexec_fn=_limit_memory)
    assert_refused(done.returncode, done.stdout, done.stderr, "huge.jsonl:1: world.layout: ", "4,000,000 cells",
                   "at most 16,384")


def test_a_world_file_beyond_the_size_limit(tmp_path, capsys):
    world = tmp_path / "big.toml"
    world.write_text('layout = """\n' + ("." * 200 + "\n") * 99 + "C" * 199 + 'G\n"""\n')
    assert_refused(*careful(capsys, "worlds", "--show", world), "20,000 cells", "at most 16,384")
    world.write_text('levels = 53\nlayout = """\n' + ("." * 100 + "\n") * 99 + "C" * 99 + 'G\n"""\n')
    assert_refused(*careful(capsys, "worlds", "--show", world), "state-actions")


def test_worlds_show_of_a_100k_character_name_is_quick(tmp_path):
    world = tmp_path / "long.toml"
    world.write_text('name = "' + "n" * 100_000 + '"\nlayout = """\n...\n.CG\n"""\n')
    status, out, err = careful_process("worlds", "--show", world, timeout=20)
    assert status == 0, err
    assert "(100,000 characters)" in out.splitlines()[0]


def test_reading_reports_progress_in_bytes(tmp_path):
    from irl_core.recordings.demonstrations import read_recordings

    objects = walk_lines()
    objects += [dict(obj, episode=obj["episode"] + 2 * k) for k in range(1, 3000) for obj in objects[1:]]
    path = write_lines(tmp_path / "long.jsonl", objects)
    seen = []
    (rec,), warnings = read_recordings([path], progress=seen.append)
    assert len(seen) > 2 and sum(seen) == path.stat().st_size and not warnings
    assert len(rec.steps) == 5 * 3000 and rec.episodes == list(range(6000))
