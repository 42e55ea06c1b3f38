"""Session summaries: outcomes, final score, carefulness by distance to danger."""

from careful_tui.cli import main
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.summary import distance_to_terminal, summarise
from irl_core.worlds.world import BUILTIN_WORLDS, World


def test_distance_to_terminal_by_hand():
    d = distance_to_terminal(BUILTIN_WORLDS["paper"])
    assert d[(3, 1)] == 0 and d[(2, 1)] == 1 and d[(3, 0)] == 1 and d[(0, 0)] == 4 and d[(0, 5)] == 3
    walled = distance_to_terminal(World(layout=".#G\n...\n"))
    assert walled[(0, 0)] == 4  # around the wall, not through it
    assert (0, 1) not in walled


def test_summary_of_an_optimal_session(tmp_path):
    out = tmp_path / "o.jsonl"
    assert main(["simulate", "--world", "paper", "--policy", "optimal", "--episodes", "40", "--seed", "2",
                 "--out", str(out)]) == 0
    recording = read_recording(out)
    summary = summarise(recording)
    assert summary.episodes == 40 and sum(summary.outcomes.values()) == 40
    assert summary.steps == len(recording.steps)
    assert summary.final_score == recording.episode_ends[-1].score
    by_distance = summary.carefulness_by_distance
    # The optimal expert is most careful right beside the cliff.
    assert by_distance[1][0] > by_distance[3][0]
