"""Bad input never produces a traceback: every file in tests/corpus/, read and run through the CLI.

Each corpus file is checked twice:

- the reader (`read_recording`, `load_world`) raises its own documented error with the right
  line and field, warns (a truncated last line), or reads fine (a byte-order mark, CRLF);
- every command that reads it exits with status 2 and prints ONE line on stderr naming the file
  and the line or field, never a traceback.

The commands run as `python -m careful_tui.cli ARGS`, each in its own process with stdin at
/dev/null and a timeout. ~250 cold starts would take minutes, so the cases fork from one warm
parent that has imported the package (and NumPy, cvxpy, Textual) once; each child still runs the
CLI as `__main__` with its own stdin, stdout, stderr and exit status. A few `COLD` cases start a
fresh interpreter, so nothing that depends on the warm parent goes unnoticed.

Big files (a 2 MB line, binary junk, deep nesting) are made in a temporary folder at test time.
"""

from __future__ import annotations

import importlib.util
import json
import os
import random
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest

from irl_core.errors import RecordingError, WorldError
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.worlds.world import load_world

CORPUS = Path(__file__).parents[1] / "corpus"
RECORDINGS, WORLDS = CORPUS / "recordings", CORPUS / "worlds"
TIMEOUT_S = 30

# ---------------------------------------------------------------------------- what each file is

# file: (line, field, part of the problem); line and field are None for a whole-file problem.
BAD_RECORDINGS: dict[str, tuple[int | None, str | None, str]] = {
    "empty.jsonl": (None, None, "the file is empty"),
    "blank_lines_only.jsonl": (None, None, "the file is empty"),
    "not_utf8.jsonl": (1, None, "not UTF-8 text"),
    "utf16.jsonl": (1, None, "not UTF-8 text"),
    "truncated_header.jsonl": (1, None, "not valid JSON"),
    "first_line_not_header.jsonl": (1, "kind", "the first line must be the session header"),
    "schema_future.jsonl": (1, "schema", "schema version 2 is not supported"),
    "schema_missing.jsonl": (1, "schema", "missing"),
    "header_missing_player.jsonl": (1, "player", "missing"),
    "header_bad_created.jsonl": (1, "created", "valid datetime"),
    "header_world_not_object.jsonl": (1, "world", "valid dictionary"),
    "header_world_ragged.jsonl": (1, "world.layout", "the layout is ragged"),
    "header_world_start_in_wall.jsonl": (1, "world", "start [0, 0] is a wall"),
    "header_world_levels_huge.jsonl": (1, "world.levels", "less than or equal to 53"),
    "header_world_nan_reward.jsonl": (1, "world.rewards.C", "finite number"),
    "wrong_type_carefulness.jsonl": (3, "carefulness", "valid integer"),
    "wrong_type_state.jsonl": (2, "state", "valid tuple"),
    "state_three_numbers.jsonl": (2, "state", "at most 2 items"),
    "missing_score.jsonl": (2, "score", "missing"),
    "missing_direction.jsonl": (5, "direction", "missing"),
    "carefulness_zero.jsonl": (5, "carefulness", "greater than or equal to 1"),
    "carefulness_above_levels.jsonl": (3, "carefulness", "15 is above the world's 14 levels"),
    "state_outside_grid.jsonl": (5, "state", "[4, 0] is outside the grid"),
    "next_state_outside_grid.jsonl": (2, "next_state", "[2, 6] is outside the grid"),
    "negative_cell.jsonl": (5, "state", "[-1, 0] is outside the grid"),
    "state_in_wall.jsonl": (2, "state", "[0, 2] is a wall"),
    "step_from_terminal.jsonl": (5, "state", "[3, 1] is a terminal cell"),
    "jump_two_cells.jsonl": (5, "next_state", "cannot move from [0, 0] to [0, 2]"),
    "slip_none_wrong_way.jsonl": (2, "next_state", "cannot move from [1, 1] to [2, 1] going right"),
    "unknown_direction.jsonl": (2, "direction", "'up', 'right', 'down' or 'left'"),
    "negative_episode.jsonl": (3, "episode", "greater than or equal to 0"),
    "extra_field.jsonl": (2, "speed", "Extra inputs are not permitted"),
    "markup_field.jsonl": (2, "[/]", "Extra inputs are not permitted"),
    "newline_in_field_name.jsonl": (2, "'a\\nb'", "Extra inputs are not permitted"),
    "unknown_kind.jsonl": (3, "kind", "'jump'"),
    "second_header.jsonl": (4, "kind", "'session'"),
    "bad_outcome.jsonl": (4, "outcome", "'terminal', 'quit' or 'step_limit'"),
    "not_an_object.jsonl": (4, None, "a line must be a JSON object"),
    "invalid_json_middle.jsonl": (3, None, "not valid JSON"),
}
# Made at test time by `make_generated`.
GENERATED_BAD_RECORDINGS: dict[str, tuple[int | None, str | None, str]] = {
    "binary_junk.jsonl": (1, None, "not UTF-8 text"),
    "junk_after_header.jsonl": (2, None, "not UTF-8 text"),
    "long_line.jsonl": (2, None, "not valid JSON"),
    "deep_nesting.jsonl": (2, None, "nested too deeply"),
}

# file: (steps, warning or None); all read without error.
VALID_RECORDINGS: dict[str, tuple[int, str | None]] = {
    "valid.jsonl": (3, None),
    "bom.jsonl": (3, None),
    "crlf.jsonl": (3, None),
    "no_episode_end.jsonl": (2, None),
    "truncated_last_line.jsonl": (3, ":6: the last line is truncated and was skipped"),
    "header_only.jsonl": (0, None),
    "different_world_a.jsonl": (3, None),
    "different_world_b.jsonl": (3, None),
    "same_name_other_world.jsonl": (3, None),
}
GENERATED_VALID_RECORDINGS = {"long_valid_line.jsonl": (3, None)}

# file: parts of the one-line message (after the file name).
BAD_WORLDS: dict[str, tuple[str, ...]] = {
    "empty.toml": ("layout: Field required",),
    "not_utf8.toml": ("cannot read the world file",),
    "invalid_toml.toml": ("not valid TOML", "line 7"),
    "missing_equals.toml": ("not valid TOML", "line 5"),
    "duplicate_key.toml": ("not valid TOML", "line 6"),
    "unclosed_table.toml": ("not valid TOML", "line 6"),
    "unterminated_layout.toml": ("not valid TOML", "end of document"),
    "missing_layout.toml": ("layout: Field required",),
    "layout_not_a_string.toml": ("layout: Input should be a valid string",),
    "ragged_layout.toml": ("layout: the layout is ragged: row 0 has 4 cells but row 1 has 3",),
    "space_in_row.toml": ("layout: the layout contains a space",),
    "blank_layout.toml": ("layout: the layout has no rows",),
    "start_in_wall.toml": ("start [0, 0] is a wall",),
    "start_outside_grid.toml": ("start [2, 0] is outside the 2x4 grid",),
    "start_on_terminal.toml": ("start [1, 3] is a terminal cell",),
    "start_wrong_shape.toml": ('start: must be "random" or a cell',),
    "start_unknown_word.toml": ('start: must be "random" or a cell',),
    "no_start_cell.toml": ("there is no cell to start from",),
    "levels_zero.toml": ("levels: Input should be greater than or equal to 1",),
    "levels_huge.toml": ("levels: Input should be less than or equal to 53",),
    "levels_wrong_type.toml": ("levels: Input should be a valid integer",),
    "gamma_one.toml": ("gamma: Input should be less than 1",),
    "negative_cost.toml": ("cost_per_level: Input should be greater than or equal to 0",),
    "inf_cost.toml": ("cost_per_level: Input should be a finite number",),
    "nan_reward.toml": ("rewards.C: Input should be a finite number",),
    "reward_wrong_type.toml": ("rewards.C: Input should be a valid number",),
    "rewards_not_a_table.toml": ("rewards: Input should be a valid dictionary",),
    "reward_unused_symbol.toml": ("a reward is given for 'U', which the layout does not use",),
    "reward_for_wall.toml": ("a wall '#' is not a state",),
    "reward_symbol_two_chars.toml": ("reward symbol 'CC' is not one character",),
    "terminal_two_chars.toml": ("terminal: terminal symbol 'CG' is not one character",),
    "unknown_slip.toml": ('slip: \'sometimes\' is not "halving", "none" or a table',),
    "slip_split_sum.toml": ("slip.others: [0.09, 0.05, 0.11] with intended 0.76 sum to 1.01", "not 1"),
    "slip_split_negative.toml": ("slip.others[1]: -0.04 is not a chance",),
    "slip_split_count.toml": ("slip.others: 1 chance; a move has three other directions",),
    "bump_unknown.toml": ("bump: 'bounce' is neither \"stay\"",),
    "max_steps_zero.toml": ("max_steps: Input should be greater than or equal to 1",),
    "unknown_field.toml": ("colour: Extra inputs are not permitted",),
    "markup_field.toml": ("[/]: Extra inputs are not permitted",),
}
GENERATED_BAD_WORLDS: dict[str, tuple[str, ...]] = {
    "binary_junk.toml": ("cannot read the world file",),
    "long_line.toml": ("not valid TOML", "line 1"),
    "deep_nesting.toml": ("not valid TOML", "nested too deeply"),
}
VALID_WORLDS = ("valid.toml", "bom.toml", "crlf.toml")


def make_generated(folder: Path) -> Path:
    """Write the big and binary corpus files into `folder` (same names as the tables above)."""
    rng = random.Random(20261121)
    junk = b"\x89PNG\r\n\x1a\n" + rng.randbytes(64 * 1024)
    valid = (RECORDINGS / "valid.jsonl").read_bytes()
    header, rest = valid.split(b"\n", 1)
    files = {
        "binary_junk.jsonl": junk,
        "junk_after_header.jsonl": header + b"\n\x00\xff" + rng.randbytes(64 * 1024) + b"\n",
        "long_line.jsonl": header + b"\n" + b"x" * 2_000_000 + b"\n" + rest,
        "deep_nesting.jsonl": header + b"\n" + b"[" * 100_000 + b"\n" + rest,
        "long_valid_line.jsonl": header.replace(b'"player": "ada"', b'"player": "' + b"a" * 2_000_000 + b'"')
        + b"\n" + rest,
        "binary_junk.toml": junk,
        "long_line.toml": b"x" * 2_000_000 + b"\n",
        "deep_nesting.toml": b"a = " + b"[" * 100_000 + b"\n",
    }
    folder.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return folder


@pytest.fixture(scope="session")
def generated(tmp_path_factory) -> Path:
    return make_generated(tmp_path_factory.mktemp("generated-corpus"))


def recording_path(name: str, generated: Path) -> Path:
    made_at_test_time = name in GENERATED_BAD_RECORDINGS or name in GENERATED_VALID_RECORDINGS
    return (generated if made_at_test_time else RECORDINGS) / name


def world_path(name: str, generated: Path) -> Path:
    return generated / name if name in GENERATED_BAD_WORLDS else WORLDS / name


# ---------------------------------------------------------------------------- the manifest


def test_every_corpus_file_is_checked_and_listed_in_the_readme():
    readme = (CORPUS / "README.md").read_text()
    on_disk = {f"recordings/{p.name}" for p in RECORDINGS.iterdir()} | {f"worlds/{p.name}" for p in WORLDS.iterdir()}
    checked = {f"recordings/{n}" for n in [*BAD_RECORDINGS, *VALID_RECORDINGS]} | {
        f"worlds/{n}" for n in [*BAD_WORLDS, *VALID_WORLDS]
    }
    generated = [*GENERATED_BAD_RECORDINGS, *GENERATED_VALID_RECORDINGS, *GENERATED_BAD_WORLDS]
    assert on_disk == checked
    missing = [name for name in [*(Path(n).name for n in sorted(checked)), *generated] if f"| `{name}`" not in readme]
    assert not missing, f"add these to tests/corpus/README.md: {missing}"


# ---------------------------------------------------------------------------- the readers


@pytest.mark.parametrize("name", [*BAD_RECORDINGS, *GENERATED_BAD_RECORDINGS])
def test_bad_recording_names_file_line_and_field(name, generated):
    line, field, problem = {**BAD_RECORDINGS, **GENERATED_BAD_RECORDINGS}[name]
    path = recording_path(name, generated)
    with pytest.raises(RecordingError) as info:
        read_recording(path)
    error = info.value
    assert (error.path, error.line, error.field) == (str(path), line, field)
    assert problem in error.problem
    text = str(error)
    assert text.startswith(str(path) if line is None else f"{path}:{line}: ")
    assert "\n" not in text and len(text) < len(str(path)) + 300


@pytest.mark.parametrize("name", [*VALID_RECORDINGS, *GENERATED_VALID_RECORDINGS])
def test_valid_recording_reads(name, generated):
    steps, warning = {**VALID_RECORDINGS, **GENERATED_VALID_RECORDINGS}[name]
    path = recording_path(name, generated)
    recording = read_recording(path)
    assert len(recording.steps) == steps
    if warning is None:
        assert recording.warnings == []
    else:
        assert recording.warnings == [f"{path}{warning}"]


def test_bom_and_crlf_read_exactly_like_the_plain_file():
    plain = read_recording(RECORDINGS / "valid.jsonl")
    for name in ("bom.jsonl", "crlf.jsonl"):
        other = read_recording(RECORDINGS / name)
        assert (other.header, other.steps, other.episode_ends) == (plain.header, plain.steps, plain.episode_ends)
    assert load_world(WORLDS / "bom.toml") == load_world(WORLDS / "crlf.toml") == load_world(WORLDS / "valid.toml")


def test_header_only_reads_as_no_demonstrations():
    demos = Demonstrations.read([RECORDINGS / "header_only.jsonl"])
    assert (demos.files, demos.episodes, demos.steps) == (1, 0, 0) and not demos.demonstrated.any()


@pytest.mark.parametrize(
    ("first", "second", "names"),
    [
        ("different_world_a.jsonl", "different_world_b.jsonl", ("'mud'", "'paper'", "layout", "rewards")),
        # Same name, different rewards: the message must still say what differs.
        ("different_world_a.jsonl", "same_name_other_world.jsonl", ("'paper'", "differ in rewards")),
    ],
)
def test_recordings_of_two_worlds_are_refused(first, second, names):
    with pytest.raises(RecordingError) as info:
        Demonstrations.read([RECORDINGS / first, RECORDINGS / second])
    assert info.value.path == str(RECORDINGS / second) and info.value.field == "world"
    assert all(name in info.value.problem for name in names), info.value.problem


@pytest.mark.parametrize("name", [*BAD_WORLDS, *GENERATED_BAD_WORLDS])
def test_bad_world_file_gets_one_line_naming_file_and_field(name, generated):
    path = world_path(name, generated)
    with pytest.raises(WorldError) as info:
        load_world(path)
    text = str(info.value)
    assert text.startswith(f"{path}: ")
    for part in {**BAD_WORLDS, **GENERATED_BAD_WORLDS}[name]:
        assert part in text
    assert "\n" not in text and len(text) < len(str(path)) + 300


# ---------------------------------------------------------------------------- the commands


def command_exists(command: str) -> bool:
    return importlib.util.find_spec(f"careful_tui.commands.{command}") is not None


def needs(command: str):
    return pytest.mark.skipif(not command_exists(command), reason=f"careful_tui/commands/{command}.py does not exist yet")


@dataclass(frozen=True)
class Case:
    """One CLI run: `python -m careful_tui.cli ARGS`."""

    args: tuple[str, ...]
    cold: bool = False  # a fresh interpreter instead of a fork of the warm parent


@dataclass(frozen=True)
class Outcome:
    status: int | None  # None: killed at the timeout
    stdout: str
    stderr: str


# The warm parent: import once, read the cases from stdin, fork one child per case (a few at a
# time) that runs `careful_tui.cli` as __main__, and print every [status, stdout, stderr] as JSON.
WARM_PARENT = r"""
import importlib, json, os, runpy, signal, sys, tempfile, time, traceback, warnings

for module in ("careful_tui.cli", "cvxpy", "textual.app", "careful_tui.commands.fit", "careful_tui.screens.replay", "careful_tui.screens.play"):
    try:
        importlib.import_module(module)
    except Exception:
        pass  # a command still being written: its cases fail (or skip) on their own

def child(args, out, err):
    os.dup2(os.open(os.devnull, os.O_RDONLY), 0)
    os.dup2(os.open(out, os.O_WRONLY), 1)
    os.dup2(os.open(err, os.O_WRONLY), 2)
    # `python -m` would find careful_tui.cli not yet imported; here it is, and runpy says so.
    warnings.filterwarnings("ignore", message=".*found in sys.modules", category=RuntimeWarning)
    sys.argv = ["careful", *args]
    try:
        runpy.run_module("careful_tui.cli", run_name="__main__", alter_sys=True)
        status = 0
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        if not isinstance(exc.code, int) and exc.code is not None:
            print(exc.code, file=sys.stderr)
    except BaseException:
        traceback.print_exc()
        status = 1
    sys.stdout.flush(); sys.stderr.flush()
    os._exit(status)

cases, timeout, workers = json.load(sys.stdin)
folder = tempfile.mkdtemp()
running, killed, outcomes, waiting = {}, set(), [None] * len(cases), list(enumerate(cases))
while waiting or running:
    while waiting and len(running) < workers:
        i, args = waiting.pop(0)
        out, err = (os.path.join(folder, f"{i}.{k}") for k in ("out", "err"))
        open(out, "w").close(); open(err, "w").close()
        pid = os.fork()
        if pid == 0:
            try:
                child(args, out, err)
            finally:
                os._exit(99)
        running[pid] = (i, out, err, time.monotonic())
    pid, wait_status = os.waitpid(-1, os.WNOHANG)
    if pid == 0:
        for pid, (i, out, err, started) in list(running.items()):
            if time.monotonic() - started > timeout and pid not in killed:
                os.kill(pid, signal.SIGKILL)
                killed.add(pid)
        time.sleep(0.005)
        continue
    i, out, err, started = running.pop(pid)
    status = None if pid in killed else os.waitstatus_to_exitcode(wait_status)
    texts = [open(path, encoding="utf-8", errors="replace").read() for path in (out, err)]
    outcomes[i] = [status, *texts]
json.dump(outcomes, sys.stdout)
"""


def run_cases(cases: list[Case], cwd: Path) -> dict[Case, Outcome]:
    """Run every case at once: warm ones through one parent, cold ones as fresh interpreters."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "NO_COLOR": "1"}
    warm = [case for case in cases if not case.cold]
    cold = [case for case in cases if case.cold]
    workers = max(2, os.cpu_count() or 2)

    def run_warm() -> dict[Case, Outcome]:
        done = subprocess.run(
            [sys.executable, "-c", WARM_PARENT], input=json.dumps([[list(c.args) for c in warm], TIMEOUT_S, workers]),
            capture_output=True, text=True, cwd=cwd, env=env, timeout=TIMEOUT_S * (1 + len(warm) // workers),
        )
        assert done.returncode == 0, done.stderr
        return {case: Outcome(*found) for case, found in zip(warm, json.loads(done.stdout))}

    def run_cold(case: Case) -> Outcome:
        try:
            done = subprocess.run(
                [sys.executable, "-m", "careful_tui.cli", *case.args], stdin=subprocess.DEVNULL,
                capture_output=True, text=True, errors="replace", cwd=cwd, env=env, timeout=TIMEOUT_S,
            )
        except subprocess.TimeoutExpired as exc:
            return Outcome(None, str(exc.stdout or ""), str(exc.stderr or ""))
        return Outcome(done.returncode, done.stdout, done.stderr)

    with ThreadPoolExecutor(max_workers=1 + len(cold)) as pool:
        warm_future = pool.submit(run_warm)
        cold_futures = {case: pool.submit(run_cold, case) for case in cold}
        outcomes = warm_future.result()
        outcomes.update({case: future.result() for case, future in cold_futures.items()})
    return outcomes


def world_cases(name: str, folder: Path) -> dict[str, Case]:
    """Every command that reads a world file, run on `folder/name`."""
    path = str(folder / name)
    return {
        "simulate": Case(("simulate", "--world", path, "--policy", "optimal", "--episodes", "2", "--seed", "1",
                          "--out", f"out-{name}.jsonl")),
        "worlds": Case(("worlds", "--show", path)),
        "play": Case(("play", "--world", path, "--out", f"play-{name}", "--seed", "1")),
    }


def recording_cases(name: str, folder: Path) -> dict[str, Case]:
    """Every command that reads one recording, run on `folder/name`."""
    path = str(folder / name)
    return {"fit": Case(("fit", path, "--no-view")), "replay": Case(("replay", path))}


COMMAND_MODULE = {"simulate": "simulate", "worlds": "worlds", "play": "play", "fit": "fit", "replay": "replay"}
COLD = {  # one fresh interpreter per command, on a file whose error each reader reports differently
    ("worlds", "invalid_toml.toml"), ("simulate", "start_in_wall.toml"), ("play", "ragged_layout.toml"),
    ("fit", "jump_two_cells.jsonl"), ("replay", "schema_future.jsonl"),
}


def module_of(label: str) -> str:
    """The module a case needs: "cold fit" and "fit two worlds" need careful_tui/fit.py."""
    return COMMAND_MODULE[label.removeprefix("cold ").split()[0]]


@pytest.fixture(scope="session")
def cli_cwd(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("cli")


@pytest.fixture(scope="session")
def cli(generated, cli_cwd) -> dict[tuple[str, str], Outcome]:
    """Every command case of this module, run once: (command or case name, file) -> outcome."""
    planned: dict[tuple[str, str], Case] = {}
    for name in [*BAD_WORLDS, *GENERATED_BAD_WORLDS, *VALID_WORLDS]:
        for command, case in world_cases(name, world_path(name, generated).parent).items():
            planned[command, name] = case
    for name in [*BAD_RECORDINGS, *GENERATED_BAD_RECORDINGS]:
        for command, case in recording_cases(name, recording_path(name, generated).parent).items():
            planned[command, name] = case
    for name in ("valid.jsonl", "bom.jsonl", "crlf.jsonl", "no_episode_end.jsonl", "truncated_last_line.jsonl",
                 "header_only.jsonl"):
        planned["fit", name] = recording_cases(name, RECORDINGS)["fit"]
    planned["fit two worlds", "different_world_b.jsonl"] = Case(
        ("fit", str(RECORDINGS / "different_world_a.jsonl"), str(RECORDINGS / "different_world_b.jsonl"), "--no-view"))
    planned["fit", "missing.jsonl"] = Case(("fit", str(cli_cwd / "missing.jsonl"), "--no-view"))
    planned["fit", "a folder"] = Case(("fit", str(cli_cwd), "--no-view"))
    planned["replay", "missing.jsonl"] = Case(("replay", str(cli_cwd / "missing.jsonl")))
    planned["worlds", "missing.toml"] = Case(("worlds", "--show", str(cli_cwd / "missing.toml")))
    for (command, name) in COLD:
        planned["cold " + command, name] = Case(planned[command, name].args, cold=True)
    runnable = {key: case for key, case in planned.items() if command_exists(module_of(key[0]))}
    outcomes = run_cases(list(runnable.values()), cli_cwd)
    return {key: outcomes[case] for key, case in runnable.items()}


def assert_one_message(outcome: Outcome, *parts: str) -> None:
    """Exit status 2 and exactly one line on stderr holding every part; no traceback."""
    assert outcome.status is not None, f"still running after {TIMEOUT_S} s (did it open the app?)"
    assert "Traceback" not in outcome.stderr + outcome.stdout, outcome.stderr
    lines = [line for line in outcome.stderr.splitlines() if line.strip()]
    assert outcome.status == 2, outcome.stderr
    assert len(lines) == 1, f"expected one message, got:\n{outcome.stderr}"
    for part in parts:
        assert part in lines[0], f"{part!r} is not in {lines[0]!r}"


def recording_message_parts(path: Path, line: int | None, field: str | None) -> tuple[str, ...]:
    where = str(path) if line is None else f"{path}:{line}:"
    return (where,) if field is None else (where, f" {field}: ")


@pytest.mark.parametrize("command", ["simulate", "worlds", pytest.param("play", marks=needs("play"))])
@pytest.mark.parametrize("name", [*BAD_WORLDS, *GENERATED_BAD_WORLDS])
def test_bad_world_file_exits_2_with_one_message(cli, generated, command, name):
    parts = {**BAD_WORLDS, **GENERATED_BAD_WORLDS}[name]
    assert_one_message(cli[command, name], f"{world_path(name, generated)}: ", *parts)


@pytest.mark.parametrize("command", [pytest.param(command, marks=needs(command)) for command in ("fit", "replay")])
@pytest.mark.parametrize("name", [*BAD_RECORDINGS, *GENERATED_BAD_RECORDINGS])
def test_bad_recording_exits_2_with_one_message(cli, generated, command, name):
    line, field, _ = {**BAD_RECORDINGS, **GENERATED_BAD_RECORDINGS}[name]
    assert_one_message(cli[command, name], *recording_message_parts(recording_path(name, generated), line, field))


@pytest.mark.parametrize(
    ("command", "name"),
    [pytest.param(command, name, marks=needs(module_of(command))) for command, name in sorted(COLD)],
)
def test_a_fresh_interpreter_says_the_same(cli, command, name):
    warm, cold = cli[command, name], cli["cold " + command, name]
    assert (cold.status, cold.stderr) == (warm.status, warm.stderr)


@pytest.mark.parametrize("name", VALID_WORLDS)
def test_valid_world_files_work(cli, name):
    for command in ("worlds", "simulate"):
        outcome = cli[command, name]
        assert outcome.status == 0 and "Traceback" not in outcome.stderr, outcome.stderr


@needs("play")
def test_play_without_a_terminal_is_bad_usage(cli):
    assert_one_message(cli["play", "valid.toml"], "terminal")


@needs("fit")
@pytest.mark.parametrize("name", ["valid.jsonl", "bom.jsonl", "crlf.jsonl", "no_episode_end.jsonl"])
def test_fit_reads_valid_recordings(cli, name):
    outcome = cli["fit", name]
    assert outcome.status == 0 and "Traceback" not in outcome.stderr, outcome.stderr


@needs("fit")
def test_fit_reads_a_truncated_last_line_and_shows_the_warning(cli):
    outcome = cli["fit", "truncated_last_line.jsonl"]
    assert outcome.status == 0, outcome.stderr
    assert "truncated_last_line.jsonl:6: the last line is truncated" in outcome.stdout + outcome.stderr


@needs("fit")
def test_fit_says_a_header_only_file_has_no_demonstrations(cli):
    outcome = cli["fit", "header_only.jsonl"]
    assert_one_message(outcome, str(RECORDINGS / "header_only.jsonl"))
    assert "no demonstrations" in outcome.stderr or "no steps" in outcome.stderr, outcome.stderr


@needs("fit")
def test_fit_refuses_two_worlds_naming_the_second_file(cli):
    outcome = cli["fit two worlds", "different_world_b.jsonl"]
    assert_one_message(outcome, str(RECORDINGS / "different_world_b.jsonl"), "world", "one world at a time")


@pytest.mark.parametrize(
    ("command", "name"),
    [
        pytest.param("fit", "missing.jsonl", marks=needs("fit")),
        pytest.param("fit", "a folder", marks=needs("fit")),
        pytest.param("replay", "missing.jsonl", marks=needs("replay")),
        ("worlds", "missing.toml"),
    ],
)
def test_a_file_that_cannot_be_read_exits_2(cli, cli_cwd, command, name):
    assert_one_message(cli[command, name], str(cli_cwd if name == "a folder" else cli_cwd / name))
