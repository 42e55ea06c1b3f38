"""Where a replay is: a position in a recording's steps, with the episode ends in between, and
in which of several recordings replayed one after another.

No Textual here: the replay screen draws whatever frame the cursor is on, and the tests
drive the cursor directly.

A recording is watched as a row of frames. Each step gives two, and each episode closes
with one:

==========  ============================================================================
``before``  the player at the step's ``state``, about to move: the recorded direction
            and carefulness (the arrow, the gauge)
``after``   the player at the step's ``next_state``: where the move went (a slip shows)
``end``     the episode's end: its outcome and score, or, for an episode the file does
            not finish (a crash, a truncated file), that it is unfinished; the player
            stays where its last step left it
==========  ============================================================================

Episodes are taken in the order they first appear in the file, steps in file order (the
reader checks that an episode's steps are contiguous and in order). Nothing is built per step
in advance: an episode's steps are a window on the recording's step columns, and a frame is
worked out from its position, so a recording of millions of steps replays in little memory.

Several recordings are watched one after another (`ReplayFiles`): the moves carry on from one
file's frames into the next file's, and only the current file has a cursor.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from irl_core.recordings.demonstrations import Recording
from irl_core.recordings.lines import EpisodeEnd, Step
from irl_core.recordings.step_table import StepTable
from irl_core.worlds.world import Cell

Phase = Literal["before", "after", "end"]


@dataclass(frozen=True)
class Episode:
    """One episode of a recording: its number, its steps, and its end (None: unfinished)."""

    number: int
    steps: Sequence[Step]
    end: EpisodeEnd | None


@dataclass(frozen=True)
class Frame:
    """What the replay shows at one position.

    Attributes:
        index: the episode's position in the recording (0-based; `episode.number` is as recorded).
        t: the step's position in the episode; at the end frame, the number of steps.
        phase: "before" or "after" the step's move, or "end" of the episode.
    """

    episode: Episode
    index: int
    t: int
    phase: Phase

    @property
    def step(self) -> Step | None:
        """The step shown (None at an episode's end)."""
        return None if self.phase == "end" else self.episode.steps[self.t]

    @property
    def player(self) -> Cell | None:
        """The player's cell (None at the end of an episode without steps)."""
        if self.phase == "before":
            return self.episode.steps[self.t].state
        if self.phase == "after":
            return self.episode.steps[self.t].next_state
        return self.episode.steps[-1].next_state if self.episode.steps else None


def group_episodes(steps: Sequence[Step], ends: Sequence[EpisodeEnd]) -> list[Episode]:
    """The episodes of a recording: those with steps in the order of their first step, then
    those with only an end (as `Recording.episodes` orders them). Steps keep file order, each
    episode's steps contiguous (as the reader checks); an episode with several ends keeps the first.
    """
    if isinstance(steps, StepTable):
        numbers = steps.column("episode")
    else:
        numbers = np.array([step.episode for step in steps], dtype=np.int64)
    starts = [0, *(np.flatnonzero(np.diff(numbers)) + 1).tolist()] if len(numbers) else []
    bounds = zip(starts, [*starts[1:], len(numbers)])
    runs: dict[int, Sequence[Step]] = {
        int(numbers[start]): steps.window(start, stop) if isinstance(steps, StepTable) else tuple(steps[start:stop])
        for start, stop in bounds
    }
    end_of: dict[int, EpisodeEnd] = {}
    for end in ends:
        runs.setdefault(end.episode, ())
        end_of.setdefault(end.episode, end)
    return [Episode(number, episode_steps, end_of.get(number)) for number, episode_steps in runs.items()]


class ReplayCursor:
    """A position in a recording's frames, moved by step, by episode, or to either end.

    Every move stays inside the frames (moving past either end stays at it) and returns
    whether the position changed. A recording without steps or ends has no frames: `frame`
    is None and every move returns False.
    """

    def __init__(self, episodes: Sequence[Episode]) -> None:
        self.episodes = list(episodes)
        # An episode of n steps has 2n + 1 frames; these are the positions of each one's first.
        self._episode_start: list[int] = []
        self._frames = 0
        for episode in self.episodes:
            self._episode_start.append(self._frames)
            self._frames += 2 * len(episode.steps) + 1
        self.position = 0

    @classmethod
    def from_recording(cls, recording: Recording) -> ReplayCursor:
        return cls(group_episodes(recording.steps, recording.episode_ends))

    def __len__(self) -> int:
        return self._frames

    @property
    def frame(self) -> Frame | None:
        if not self._frames:
            return None
        index = bisect_right(self._episode_start, self.position) - 1
        episode = self.episodes[index]
        offset = self.position - self._episode_start[index]
        if offset == 2 * len(episode.steps):
            return Frame(episode, index, len(episode.steps), "end")
        return Frame(episode, index, offset // 2, "before" if offset % 2 == 0 else "after")

    @property
    def at_start(self) -> bool:
        return self.position == 0

    @property
    def at_end(self) -> bool:
        return self.position >= self._frames - 1

    def go_to(self, position: int) -> bool:
        """Move to frame `position`, clamped to the frames; whether the position changed."""
        new = max(0, min(position, self._frames - 1))
        changed = new != self.position
        self.position = new
        return changed

    def forward(self) -> bool:
        """One frame on: from before a move to after it, then to the next step (or the end)."""
        return self.go_to(self.position + 1)

    def back(self) -> bool:
        return self.go_to(self.position - 1)

    def next_episode(self) -> bool:
        """To the first frame of the next episode; in the last episode, to its end."""
        frame = self.frame
        if frame is None:
            return False
        if frame.index + 1 < len(self.episodes):
            return self.go_to(self._episode_start[frame.index + 1])
        return self.to_end()

    def previous_episode(self) -> bool:
        """To the first frame of the previous episode; in the first episode, to its start."""
        frame = self.frame
        if frame is None:
            return False
        return self.to_episode(frame.index - 1)

    def to_episode(self, index: int) -> bool:
        """To the first frame of episode `index` (a position in `episodes`, clamped to them)."""
        if not self.episodes:
            return False
        return self.go_to(self._episode_start[max(0, min(index, len(self.episodes) - 1))])

    def to_start(self) -> bool:
        return self.go_to(0)

    def to_end(self) -> bool:
        return self.go_to(self._frames - 1)


class ReplayFiles:
    """A position in several recordings watched one after another: which file, and a
    `ReplayCursor` in it.

    The cursor's moves carry on across files: a step on from a file's last frame is the next
    file's first frame, a step back from its first frame the previous file's last; the next
    episode after a file's last episode is the next file's first, the previous episode before
    its first is the previous file's last. `to_start` and `to_end` stay in the file;
    `next_file` and `previous_file` go to a file's first frame. Every move returns whether the
    place changed. Only the current file has a cursor (built when the replay comes to it).
    """

    def __init__(self, recordings: Sequence[Recording]) -> None:
        if not recordings:
            raise ValueError("nothing to replay: no recordings")
        self.recordings = list(recordings)
        self.index = 0
        self.cursor = ReplayCursor.from_recording(self.recordings[0])

    def __len__(self) -> int:
        return len(self.recordings)

    @property
    def recording(self) -> Recording:
        return self.recordings[self.index]

    @property
    def place(self) -> tuple[int, int]:
        """(file index, frame position in that file)."""
        return self.index, self.cursor.position

    @property
    def at_end(self) -> bool:
        """At the last frame of the last file."""
        return self.index == len(self.recordings) - 1 and self.cursor.at_end

    @property
    def last_file(self) -> bool:
        return self.index == len(self.recordings) - 1

    def go_to_file(self, index: int) -> bool:
        """To the first frame of file `index` (clamped to the files)."""
        index = max(0, min(index, len(self.recordings) - 1))
        if index == self.index:
            return self.cursor.to_start()
        self.index = index
        self.cursor = ReplayCursor.from_recording(self.recordings[index])
        return True

    def next_file(self) -> bool:
        """To the next file's first frame; in the last file, to its end."""
        return self.cursor.to_end() if self.last_file else self.go_to_file(self.index + 1)

    def previous_file(self) -> bool:
        """To the previous file's first frame; in the first file, to its start."""
        return self.go_to_file(self.index - 1)

    def forward(self) -> bool:
        if self.cursor.at_end and not self.last_file:
            return self.go_to_file(self.index + 1)
        return self.cursor.forward()

    def back(self) -> bool:
        if self.cursor.at_start and self.index > 0:
            self.go_to_file(self.index - 1)
            self.cursor.to_end()
            return True
        return self.cursor.back()

    def next_episode(self) -> bool:
        frame = self.cursor.frame
        if (frame is None or frame.index == len(self.cursor.episodes) - 1) and not self.last_file:
            return self.go_to_file(self.index + 1)
        return self.cursor.next_episode()

    def previous_episode(self) -> bool:
        frame = self.cursor.frame
        if (frame is None or frame.index == 0) and self.index > 0:
            self.go_to_file(self.index - 1)
            self.cursor.to_episode(len(self.cursor.episodes) - 1)
            return True
        return self.cursor.previous_episode()

    def to_start(self) -> bool:
        return self.cursor.to_start()

    def to_end(self) -> bool:
        return self.cursor.to_end()
