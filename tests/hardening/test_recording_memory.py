"""A recording's episode ends are stored as columns (`irl_core.recordings.end_table`), so memory follows the file's size.

Before, each end was a pydantic object of about 600 bytes: a recording of a million one-step
episodes (365 MB) peaked at 1,349 MB when read (3.7x; 4.4x in a command), and a 943 MB one
failed under a 4 GB cap. Memory is measured with tracemalloc (what Python allocates), not time.
"""

from __future__ import annotations

import tracemalloc

from irl_core.players.experts import optimal_policy, rollouts, write_rollouts
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.end_table import EndTable
from irl_core.recordings.lines import EpisodeEnd
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import World

ONE_STEP = World(name="one", layout="....\n.CCG\n", levels=3, max_steps=1, rewards={"C": -100.0, "G": 10.0})


def test_reading_many_one_step_episodes_takes_less_memory_than_the_file(tmp_path):
    mdp = build_mdp(ONE_STEP)
    path = write_rollouts(tmp_path / "many.jsonl", mdp, rollouts(mdp, optimal_policy(mdp), episodes=30_000, seed=0),
                          player="expert:optimal", seed=0)
    size = path.stat().st_size
    tracemalloc.start()
    try:
        recording = read_recording(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(recording.episode_ends) == 30_000 and len(recording.steps) == 30_000
    assert peak < 0.6 * size, f"reading peaked at {peak / size:.2f}x the file's {size:,} bytes"


def test_end_table_gives_back_the_ends_it_was_given():
    ends = [EpisodeEnd(episode=i, outcome=o, terminal_symbol=s, steps=i, score=1.5 * i, **{"return": -0.5 * i})
            for i, (o, s) in enumerate([("terminal", "G"), ("quit", None), ("step_limit", None), ("terminal", "[")] * 3000)]
    table = EndTable(ends)
    assert len(table) == len(ends) and table == ends and table[-1] == ends[-1] and table[5:7] == ends[5:7]
    assert table.column("episode").tolist() == list(range(len(ends)))
