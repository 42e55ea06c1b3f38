"""Study fixtures: a study file in a temporary folder, and recordings of a study written line by line."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import pytest

from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step, StudyTag
from irl_core.recordings.writer import RecordingWriter
from irl_core.studies.study import LoadedStudy, load_study

STUDY_TOML = """\
name = "pilot"
instructions = "Reach the goal; do not fall."
worlds = {worlds}
order = "{order}"
practice_episodes = {practice}
episodes = {episodes}
input = "digits"
out = "data"
"""


def write_study(folder: Path, *, worlds: str = '["paper", "mud"]', order: str = "shuffled", practice: int = 1,
                episodes: int = 3) -> Path:
    path = folder / "pilot.toml"
    path.write_text(STUDY_TOML.format(worlds=worlds, order=order, practice=practice, episodes=episodes))
    return path


@pytest.fixture
def study(tmp_path: Path) -> LoadedStudy:
    return load_study(write_study(tmp_path))


def write_block(study: LoadedStudy, participant: str, world_index: int, phase: str, *, name: str,
                finished: int = 0, first: int = 0, then: str | None = None) -> Path:
    """A recording of `finished` one-step episodes (each falls off the cliff) numbered from `first`,
    then optionally one more episode that is interrupted: ``then="quit"`` (q mid-way: an end saying
    quit) or ``then="crash"`` (a step and no end at all)."""
    folder = study.participant_folder(participant)
    folder.mkdir(parents=True, exist_ok=True)
    header = SessionHeader(world=study.worlds[world_index], player=participant,
                           created=datetime(2026, 1, 1, tzinfo=UTC), input={"mode": "digits"},
                           study=StudyTag(name=study.study.name, participant=participant, phase=phase,
                                          world_index=world_index))
    # From (2, 1) down into the cliff at (3, 1): one step, then the episode ends in C.
    fall = dict(t=0, state=(2, 1), direction="down", carefulness=2, next_state=(3, 1), slipped=False,
                reward=-2.0, score=198.0, realised="down")
    # Into the top edge at (0, 0): the player stays put, and the episode goes on (until interrupted).
    bump = dict(t=0, state=(0, 0), direction="up", carefulness=1, next_state=(0, 0), slipped=False,
                reward=-1.0, score=199.0, realised="up")
    with RecordingWriter(folder / name, header) as writer:
        for episode in range(first, first + finished):
            writer.write_step(Step(episode=episode, **fall))
            writer.end_episode(EpisodeEnd(episode=episode, outcome="terminal", terminal_symbol="C", steps=1,
                                          return_=-1002.0, score=-802.0))
        if then is not None:
            episode = first + finished
            writer.write_step(Step(episode=episode, **bump))
            if then == "quit":
                writer.end_episode(EpisodeEnd(episode=episode, outcome="quit", steps=1, return_=-1.0, score=199.0))
    return folder / name
