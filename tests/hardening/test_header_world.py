"""The header's world always wins over a built-in of the same name (recordings/README.md).

A recording carries its whole world, so a file recorded when `paper` meant one thing stays
readable and fittable after the built-in `paper` changes.
"""

import json
import subprocess
import sys
from datetime import UTC, datetime
from importlib.util import find_spec

import numpy as np
import pytest

from irl_core.errors import RecordingError
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.world import BUILTIN_WORLDS, World

# "paper" as an older careful might have defined it: 5x5 with mud, other rewards, 5 levels.
OLD_PAPER = World(
    name="paper", layout=".....\n.UU..\n.....\n.....\n.CCCG\n", levels=5, cost_per_level=2.0,
    rewards={"C": -500.0, "G": 50.0, "U": -20.0},
)


def step(t, state, direction, c, next_state):
    return Step(episode=0, t=t, state=state, direction=direction, carefulness=c, hold_ms=700.0,
                next_state=next_state, slipped=False, reward=-2.0 * c, score=200.0 - 2.0 * c * (t + 1))


@pytest.fixture
def old_recording(tmp_path):
    header = SessionHeader(world=OLD_PAPER, player="ada", created=datetime(2020, 1, 1, tzinfo=UTC), seed=3)
    path = tmp_path / "old-paper.jsonl"
    with RecordingWriter(path, header) as writer:
        # Row 4 is outside the built-in paper (4 rows): read with it, the first step is an error.
        for t, (state, direction, c, next_state) in enumerate(
            [((4, 0), "up", 5, (3, 0)), ((3, 0), "right", 4, (3, 1)), ((3, 1), "right", 4, (3, 2)),
             ((3, 2), "right", 4, (3, 3)), ((3, 3), "right", 4, (3, 4)), ((3, 4), "down", 5, (4, 4))]
        ):
            writer.write_step(step(t, state, direction, c, next_state))
        writer.end_episode(EpisodeEnd(episode=0, outcome="terminal", terminal_symbol="G", steps=6,
                                      return_=-2.0, score=198.0))
    return path


def test_the_old_world_differs_from_the_built_in():
    assert OLD_PAPER.name == BUILTIN_WORLDS["paper"].name and OLD_PAPER != BUILTIN_WORLDS["paper"]


def test_read_recording_uses_the_header_world(old_recording):
    assert read_recording(old_recording).world == OLD_PAPER


def test_the_same_steps_would_not_read_in_the_built_in(old_recording):
    rows = old_recording.read_text().splitlines()
    header = json.loads(rows[0])
    header["world"] = BUILTIN_WORLDS["paper"].model_dump(mode="json")
    old_recording.write_text("\n".join([json.dumps(header), *rows[1:]]) + "\n")
    with pytest.raises(RecordingError, match=r":2: state: \[4, 0\] is outside the grid"):
        read_recording(old_recording)


def test_demonstrations_use_the_header_world(old_recording):
    demos = Demonstrations.read([old_recording])
    mdp = demos.mdp
    assert mdp.world == OLD_PAPER
    assert (mdp.world.rows, mdp.world.cols, mdp.levels, mdp.n_actions) == (5, 5, 5, 20)
    assert mdp.R_S[mdp.state_of[(4, 4)]] == 50.0 and mdp.R_S[mdp.state_of[(1, 1)]] == -20.0
    np.testing.assert_array_equal(mdp.R_A, np.tile(-2.0 * np.arange(1, 6), 4))
    # down with carefulness 5 from (3, 4): a = d * L + (c - 1) = 2 * 5 + 4
    assert demos.counts[mdp.state_of[(3, 4)], 14] == 1 and demos.counts.sum() == 6


def test_the_header_world_is_not_mixed_with_the_built_in(old_recording, tmp_path):
    header = SessionHeader(world=BUILTIN_WORLDS["paper"], player="bo", created=datetime.now(UTC))
    current = tmp_path / "paper-now.jsonl"
    with RecordingWriter(current, header) as writer:
        writer.write_step(Step(episode=0, t=0, state=(0, 0), direction="right", carefulness=1, next_state=(0, 1),
                               slipped=False, reward=-1.0, score=199.0))
    with pytest.raises(RecordingError) as info:
        Demonstrations.read([current, old_recording])
    assert info.value.field == "world" and "differ in layout, levels, cost_per_level, rewards" in info.value.problem


@pytest.mark.skipif(find_spec("careful_tui.commands.fit") is None, reason="careful_tui/commands/fit.py does not exist yet")
def test_fit_fits_the_header_world(old_recording, tmp_path):
    out = tmp_path / "fit.json"
    done = subprocess.run(
        # A few hand-written steps need not be optimal for any reward: the loss method fits them anyway.
        [sys.executable, "-m", "careful_tui.cli", "fit", str(old_recording), "--method", "loss", "--no-view",
         "--json", str(out)],
        stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60,
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(out.read_text())
    assert World.model_validate(result["world"]) == OLD_PAPER
    assert len(result["reward"]) == 5 and all(len(row) == 5 for row in result["reward"])
