"""A study's recordings gathered for its report: per participant and pooled cells of finished main episodes.

`gather` reads every participant folder under the study's ``out`` and keeps each one's finished
main-phase episodes per world (practice never enters a fit; an interrupted episode is counted, not
fitted; see `irl_core.studies.study`), with the participant's motor calibration trials (their hand,
which the people fit holds; the pool's are everyone's). A file that cannot be used is named in `StudyData.problems`
and left out; the participant's other files are still reported.
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from irl_core.errors import StudyError
from irl_core.recordings.demonstrations import Demonstrations, Recording
from irl_core.recordings.end_table import EndTable
from irl_core.recordings.step_table import StepTable
from irl_core.recordings.summary import distance_to_terminal, outcome_code
from irl_core.studies.study import (
    POOLED,
    TOOL_FOLDERS,
    LoadedStudy,
    check_participant,
    finished_episodes,
    interrupted_episodes,
    read_participant,
)


@dataclass(frozen=True)
class Cell:
    """One participant's (or the pool's) finished main episodes of one world.

    Attributes:
        participant: the id, or `POOLED` for everyone's episodes of the world together.
        world_index: the world's index in the study file.
        demos: the finished main episodes as demonstrations (None when there are none).
        episodes: finished main episodes (the ones fitted).
        steps: their steps.
        outcomes: finished episodes per `irl_core.recordings.summary.outcome_code` (a terminal symbol, or
            ``step_limit``).
        interrupted_outcomes: main episodes with steps that did not finish (not fitted), per
            outcome code (``quit``, or ``unfinished``: no end recorded).
        careful_next_to_terminal: mean carefulness level of the steps taken next to a terminal cell
            (one grid step away), or None when there were none or the world is a time world (no levels).
        hold_ms_next_to_terminal: on a time world, the geometric mean hold in ms of those steps (the hold is
            the care there; as the report's figure shows it), else None.
        participants: how many participants the cell holds (1, or how many have episodes in the pool).
        members: in a pool, the participants whose episodes it holds, in the order of
            ``demos.episode_groups`` (group g is members[g]).
        without: in a pool without one participant (`leave_out`), that participant: its fit is a
            point fit (no interval) that measures their influence on the pool.
        player_model: the model of the player to fit with, where the report has chosen it already
            (the world's pool chooses; its participants and the pools without one of them follow).
        rival: a participant's cell fitted again with the rival planning model (`player_model`), a point fit
            that tells the population how the participant's rewards move with the planning model.
    """

    participant: str
    world_index: int
    demos: Demonstrations | None
    episodes: int
    steps: int
    outcomes: dict[str, int]
    interrupted_outcomes: dict[str, int]
    careful_next_to_terminal: float | None
    hold_ms_next_to_terminal: float | None = None
    participants: int = 1
    members: tuple[str, ...] = ()
    without: str | None = None
    player_model: str | None = None
    rival: bool = False

    @property
    def interrupted(self) -> int:
        """Main episodes quit or cut off (counted, not fitted)."""
        return sum(self.interrupted_outcomes.values())


@dataclass(frozen=True)
class StudyData:
    """Every cell of the report (world by world: participants in name order, then the pool), and
    the files left out."""

    study: LoadedStudy
    participants: tuple[str, ...]
    cells: tuple[Cell, ...]
    problems: tuple[str, ...]
    left_out: dict[str, int]  # participant -> files left out (participants with none are not listed)
    folders_left_out: int = 0  # folders under out whose names cannot be participant ids

    def cell(self, participant: str, world_index: int) -> Cell:
        return next(c for c in self.cells if c.participant == participant and c.world_index == world_index)


def participant_ids(study: LoadedStudy) -> tuple[list[str], list[str]]:
    """The participant folders under the study's ``out`` (name order), and one line per folder
    that cannot be a participant's."""
    ids: list[str] = []
    problems: list[str] = []
    if not study.out.is_dir():
        return ids, problems
    for folder in sorted(p for p in study.out.iterdir() if p.is_dir()):
        if folder.name.lower() in TOOL_FOLDERS:
            continue
        try:
            ids.append(check_participant(folder.name))
        except StudyError as exc:
            problems.append(f"{folder}: {exc}; left out")
    return ids, problems


def gather(study: LoadedStudy, *, progress: Callable[[int, int], None] | None = None) -> StudyData:
    """Read every participant's main-phase recordings into cells (see `Cell`).

    Args:
        progress: called as progress(participants read, participants) after each participant.
    """
    ids, problems = participant_ids(study)
    folders_left_out = len(problems)
    per_world: dict[int, list[Recording]] = {i: [] for i in range(len(study.grid_worlds))}
    trials_of: dict[str, np.ndarray] = {}
    cells, left_out = [], {}
    for n, participant in enumerate(ids, 1):
        found = read_participant(study, participant)
        problems.extend(found.problems)
        if found.left_out:
            left_out[participant] = found.left_out
        mine: dict[int, list[Recording]] = {i: [] for i in range(len(study.grid_worlds))}
        for tag, recording in found.recordings:
            if tag.phase == "main":
                mine[tag.world_index].append(recording)
        # The calibration block's trials (in a practice-tagged file of their own) are the participant's hand.
        trials_of[participant] = calibration_trials([recording for _, recording in found.recordings])
        for world_index, recordings in mine.items():
            cells.append(_cell(study, participant, world_index, recordings, trials_of[participant]))
            per_world[world_index].extend(recordings)
        if progress:
            progress(n, len(ids))
    every_trial = np.concatenate([np.zeros((0, 2), dtype=np.int64), *trials_of.values()])
    for world_index, recordings in per_world.items():
        # The fixed-effect pool shares one player, so one hand: every participant's trials.
        pooled = _cell(study, POOLED, world_index, recordings, every_trial)
        contributing = sum(1 for cell in cells if cell.world_index == world_index and cell.episodes)
        cells.append(_grouped(dataclasses.replace(pooled, participants=contributing),
                              [cell for cell in cells if cell.world_index == world_index]))
    # World by world: its participants in name order, then its pool.
    cells.sort(key=lambda cell: (cell.world_index, cell.participant == POOLED))
    return StudyData(study=study, participants=tuple(ids), cells=tuple(cells), problems=tuple(problems),
                     left_out=left_out, folders_left_out=folders_left_out)


def _grouped(pool: Cell, mine: list[Cell]) -> Cell:
    """The pool with each of its episodes' participant (`mine`: the world's cells in the pool's order,
    whose episodes the pool's rows hold one participant after another)."""
    if pool.demos is None or pool.demos.by_episode is None:
        return pool
    members = [(cell.participant, cell.demos.by_episode.shape[0]) for cell in mine
               if cell.demos is not None and cell.demos.by_episode is not None]
    rows = [episodes for _, episodes in members]
    assert sum(rows) == pool.demos.by_episode.shape[0], "a pool's episodes are its participants' in order"
    groups = np.repeat(np.arange(len(members)), rows)
    return dataclasses.replace(pool, demos=dataclasses.replace(pool.demos, episode_groups=groups),
                               members=tuple(participant for participant, _ in members))


def leave_out(pool: Cell, participant: str) -> Cell:
    """The pool without `participant`'s episodes (its outcome counts are the pool's: only the fit is used)."""
    demos = pool.demos
    assert demos is not None and demos.by_episode is not None and demos.episode_groups is not None
    keep = demos.episode_groups != pool.members.index(participant)
    by_episode = demos.by_episode[keep]
    counts = np.asarray(by_episode.sum(axis=0)).reshape(demos.counts.shape)
    # files stays the pool's: a leave-one-out fit is never written out.
    facts = None if demos.episode_facts is None else demos.episode_facts.rows(keep)
    demos = dataclasses.replace(demos, counts=counts, episodes=int(keep.sum()), steps=int(counts.sum()),
                                by_episode=by_episode, episode_groups=None, episode_facts=facts)
    return dataclasses.replace(pool, demos=demos, episodes=demos.episodes, steps=demos.steps,
                               members=tuple(m for m in pool.members if m != participant), without=participant)


def influence_cells(data: StudyData) -> list[Cell]:
    """Every pool of two or more participants without each of them in turn."""
    return [leave_out(cell, member) for cell in data.cells if cell.participant == POOLED and len(cell.members) > 1
            for member in cell.members]


def _finished_only(recording: Recording) -> Recording:
    """The recording with only its finished episodes (steps and ends)."""
    keep = finished_episodes(recording)
    steps = StepTable()
    for step in recording.steps:
        if step.episode in keep:
            steps.append(step)
    ends = EndTable(end for end in recording.episode_ends if end.episode in keep)
    return dataclasses.replace(recording, steps=steps, episode_ends=ends, warnings=[])


def calibration_trials(recordings: list[Recording]) -> np.ndarray:
    """(n, 2) (target, produced) of every calibration trial in `recordings`, in file order."""
    return np.array([(t.target, t.produced) for r in recordings for t in r.calibration_trials],
                    dtype=np.int64).reshape(-1, 2)


def _cell(study: LoadedStudy, participant: str, world_index: int, recordings: list[Recording],
          trials: np.ndarray | None = None) -> Cell:
    interrupted: Counter[str] = Counter()
    for recording in recordings:
        ends = {end.episode: end for end in recording.episode_ends}
        interrupted.update(outcome_code(ends.get(episode)) for episode in interrupted_episodes(recording))
    finished = [_finished_only(r) for r in recordings]
    outcomes = Counter(outcome_code(end) for recording in finished for end in recording.episode_ends)
    world = study.grid_worlds[world_index]
    near = {cell for cell, d in distance_to_terminal(world).items() if d == 1}
    near_steps = [step for r in finished for step in r.steps if step.state in near]
    levels = [step.level for step in near_steps] if world.care == "levels" else []
    holds = [step.hold_ms for step in near_steps if step.hold_ms is not None] if world.care == "time" else []
    steps = sum(len(r.steps) for r in finished)
    demos = Demonstrations.from_recordings(finished) if steps else None
    if demos is not None and trials is not None and trials.size and int(trials.max()) <= world.levels:
        # Trials of levels this world lacks cannot be read on its levels: they stay with the worlds that have them.
        demos = dataclasses.replace(demos, calibration=trials)
    return Cell(participant=participant, world_index=world_index, demos=demos,
                episodes=sum(len(r.episode_ends) for r in finished), steps=steps, outcomes=dict(outcomes),
                interrupted_outcomes=dict(interrupted), careful_next_to_terminal=float(np.mean(levels)) if levels else None,
                hold_ms_next_to_terminal=float(np.exp(np.mean(np.log(np.maximum(holds, 1.0))))) if holds else None)


def without_participants(pool: Cell, participants: set[str]) -> Cell:
    """The pool without the episodes of `participants` (excluded before pooling), its episodes still grouped
    by participant for the pool's two-level bootstrap; the pool itself when none of them is in it."""
    gone = participants & set(pool.members)
    demos = pool.demos
    if not gone or demos is None or demos.by_episode is None or demos.episode_groups is None:
        return pool
    members = [m for m in pool.members if m not in gone]
    keep = ~np.isin(demos.episode_groups, [pool.members.index(m) for m in gone])
    if not keep.any():
        return dataclasses.replace(pool, demos=None, episodes=0, steps=0, members=(), participants=0)
    by_episode = demos.by_episode[keep]
    renumber = {pool.members.index(m): g for g, m in enumerate(members)}
    groups = np.array([renumber[int(g)] for g in demos.episode_groups[keep]])
    counts = np.asarray(by_episode.sum(axis=0)).reshape(demos.counts.shape)
    facts = None if demos.episode_facts is None else demos.episode_facts.rows(keep)
    demos = dataclasses.replace(demos, counts=counts, episodes=int(keep.sum()), steps=int(counts.sum()),
                                by_episode=by_episode, episode_groups=groups, episode_facts=facts)
    return dataclasses.replace(pool, demos=demos, episodes=demos.episodes, steps=demos.steps,
                               members=tuple(members), participants=len(members))
