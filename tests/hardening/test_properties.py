"""No input makes the readers raise anything but their own documented error.

`read_recording` raises only `RecordingError` (one line, naming the file), `load_world` and
`world_from_dict` only `WorldError`, whatever bytes, JSON or TOML they are given. And what they
accept is usable: a recording can be counted, a world can be built, written and read back.

The examples are derandomized, so every run (and CI) tries the same ones.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from irl_core.errors import RecordingError, WorldError
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.recordings.lines import SessionHeader
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import World, load_world, world_from_dict

CORPUS = Path(__file__).parents[1] / "corpus"
HEADER, *BODY = (json.loads(line) for line in (CORPUS / "recordings" / "valid.jsonl").read_text().splitlines())
WORLD_TOML = (CORPUS / "worlds" / "valid.toml").read_text()

fast = settings(
    max_examples=200, deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow]
)


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    """One folder for the whole module: each example overwrites its own file name."""
    return tmp_path_factory.mktemp("properties")


def write(folder: Path, name: str, data: bytes) -> Path:
    path = folder / name
    path.write_bytes(data)
    return path


# ---------------------------------------------------------------------------- strategies

json_scalars = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12)
json_values = st.recursive(
    json_scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
    max_leaves=8,
)
# Values that get past the type checks and reach the rules: cells near the grid, levels, names.
plausible = (
    st.integers(-2, 60)
    | st.lists(st.integers(-2, 7), min_size=1, max_size=3)
    | st.sampled_from(["up", "right", "down", "left", "session", "step", "episode_end", "terminal", "quit",
                       "step_limit", "G", "C", "random", "halving", "none", "2026-11-21T12:00:00Z"])
    | st.floats(-2000, 2000)
)
layouts = st.lists(st.text(alphabet=".CGU#X \\\"'", min_size=1, max_size=6), min_size=1, max_size=5).map("\n".join)
world_values = plausible | json_values | layouts | st.dictionaries(st.sampled_from("CGU#.X"), st.floats(-1e3, 1e3))


@st.composite
def mutated(draw, base: dict, values: st.SearchStrategy = plausible | json_values) -> dict:
    """`base` with a few fields deleted or replaced, and perhaps one added."""
    obj = dict(base)
    for key in draw(st.lists(st.sampled_from(sorted(base)), unique=True, max_size=3)):
        if draw(st.booleans()):
            del obj[key]
        else:
            obj[key] = draw(values)
    if draw(st.integers(0, 4)) == 0:
        obj[draw(st.text(max_size=6))] = draw(values)
    return obj


@st.composite
def headers(draw) -> dict:
    """The valid header (a third of the time), or one with mutated fields or a mutated world."""
    which = draw(st.sampled_from(["valid", "fields", "world"]))
    header = draw(mutated(HEADER)) if which == "fields" else dict(HEADER)
    if which == "world":
        header["world"] = draw(mutated(HEADER["world"], world_values))
    return header


@st.composite
def recording_bytes(draw) -> bytes:
    lines = [draw(headers())]
    lines += draw(st.lists(st.sampled_from(BODY).flatmap(lambda line: st.just(line) | mutated(line)), max_size=6))
    text = [json.dumps(line) for line in lines]
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    data = (newline.join(text) + newline).encode()
    if draw(st.integers(0, 3)) == 0:
        data = data[: -draw(st.integers(1, 300))]  # a crash mid-write
    if draw(st.integers(0, 3)) == 0:
        data += draw(st.binary(max_size=40))
    return (b"\xef\xbb\xbf" if draw(st.integers(0, 4)) == 0 else b"") + data


WORLD_KEYS = sorted(World.model_fields)
toml_lines = st.one_of(
    st.sampled_from(WORLD_TOML.splitlines()),
    st.text(alphabet=".CGU#X", min_size=1, max_size=5),  # a layout row, when it lands inside the layout
    st.builds(
        "{} = {}".format,
        st.sampled_from([*WORLD_KEYS, "C", "G", "U", '"#"', "[rewards]", "x"]),
        st.sampled_from(['"random"', "[0, 0]", "[1, 3]", "[9]", "3", "0", "-1", "1e9", "nan", "inf", "0.95", "true",
                         '"halving"', '"none"', '["C", "G"]', '"""\n....\n.CCG\n"""', '"..\\n.G"', "{}", "[", '"']),
    ),
    st.text(alphabet='[]{}="\'.,#\n CGU0123abc\\', max_size=20),
)


@st.composite
def toml_texts(draw) -> str:
    """A valid world file with a few lines inserted, replaced or deleted."""
    lines = WORLD_TOML.splitlines()
    for _ in range(draw(st.integers(0, 4))):
        i = draw(st.integers(0, len(lines)))
        edit = draw(st.sampled_from(["insert", "replace", "delete"]))
        if edit == "insert":
            lines.insert(i, draw(toml_lines))
        elif lines and i < len(lines):
            lines[i : i + 1] = [draw(toml_lines)] if edit == "replace" else []
    return "\n".join(lines) + draw(st.sampled_from(["\n", ""]))


# ---------------------------------------------------------------------------- recordings


def check_read(path: Path) -> None:
    """The documented error, on one line naming the file; or a recording that can be counted."""
    try:
        recording = read_recording(path)
    except RecordingError as error:
        text = str(error)
        assert error.path == str(path) and text.startswith(str(path))
        assert "\n" not in text and "\r" not in text, text
        assert error.line is None or error.line >= 1
        return
    demos = Demonstrations.from_recordings([recording])
    assert demos.steps == len(recording.steps) == demos.counts.sum()


@fast
@given(st.binary(max_size=400))
def test_any_bytes(scratch, data):
    check_read(write(scratch, "bytes.jsonl", data))


@fast
@given(st.binary(max_size=200))
def test_any_bytes_after_a_valid_header(scratch, data):
    check_read(write(scratch, "after-header.jsonl", (json.dumps(HEADER) + "\n").encode() + data))


@fast
@given(recording_bytes())
def test_lines_with_mutated_fields(scratch, data):
    check_read(write(scratch, "mutated.jsonl", data))


# ---------------------------------------------------------------------------- worlds


def check_world_accepted(world: World, folder: Path) -> None:
    """A world that validates can be built, saved as TOML and in a header, and read back equal."""
    mdp = build_mdp(world)
    assert mdp.P.shape == (mdp.n_states * mdp.n_actions, mdp.n_states)
    path = write(folder, "round-trip.toml", world.to_toml().encode())
    assert load_world(path) == world
    header = SessionHeader(world=world, player="p", created=datetime(2026, 1, 1, tzinfo=UTC))
    recording = folder / "round-trip.jsonl"
    recording.unlink(missing_ok=True)
    RecordingWriter(recording, header).close()
    assert read_recording(recording).world == world


@fast
@given(st.dictionaries(st.sampled_from(WORLD_KEYS) | st.text(max_size=6), world_values, max_size=8))
def test_world_from_any_dict(scratch, data):
    try:
        world = world_from_dict(data)
    except WorldError as error:
        assert "\n" not in str(error), str(error)
        return
    check_world_accepted(world, scratch)


@fast
@given(mutated(HEADER["world"], world_values))
def test_world_from_a_mutated_valid_world(scratch, data):
    try:
        world = world_from_dict(data)
    except WorldError as error:
        assert "\n" not in str(error), str(error)
        return
    check_world_accepted(world, scratch)


@fast
@given(toml_texts())
def test_world_from_toml_ish_text(scratch, text):
    path = write(scratch, "world.toml", text.encode())
    try:
        world = load_world(path)
    except WorldError as error:
        assert str(error).startswith(str(path)) and "\n" not in str(error), str(error)
        return
    check_world_accepted(world, scratch)


@fast
@given(st.binary(max_size=300))
def test_world_from_any_bytes(scratch, data):
    path = write(scratch, "bytes.toml", data)
    try:
        world = load_world(path)
    except WorldError as error:
        assert "\n" not in str(error), str(error)
        return
    check_world_accepted(world, scratch)
