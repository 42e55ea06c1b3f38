"""`careful serve --workers N` against what issue 45 found (items 1, 2, 3, 5, 6): a step numbered twice when a
seat write is lost, two servers on one out folder, a worker killed as it starts, X-Forwarded-For from anyone,
a restarted worker reading a study file edited since the start."""

from __future__ import annotations

import contextlib

import pytest
from web.conftest import write_web_study
from web.test_workers import begin_and_move, claim

from careful_tui.web.seat_files import SharedSeats
from irl_core.errors import SeatUnavailable
from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.study import load_study

# ---------------------------------------------------------------------- item 1: a seat write lost


@pytest.mark.parametrize("lost", ["the worker died before writing the seat", "the disk was full"])
def test_a_step_is_never_numbered_twice_when_another_workers_seat_write_is_lost(tmp_path, monkeypatch, lost):
    """Worker B plays a key (its step appended) and its seat never lands; the page's next key reaches worker A,
    whose seat in memory still matches the file: it must see the recording ahead and not write that step's t
    again (the old code did: `t: 15 repeats a step`, the participant's file left out of the report)."""
    web_study = load_study(write_web_study(tmp_path))
    said: list[str] = []
    first = SharedSeats(web_study, key=b"k" * 32, say=said.append)
    second = SharedSeats(web_study, key=b"k" * 32, say=lambda line: None)
    seat = claim(first)
    begin_and_move(first, seat.page)  # the first worker wrote the seat last: it keeps it in memory

    def lose(participant, record):
        if lost == "the disk was full":
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(second, "_write", lose)
    with contextlib.suppress(SeatUnavailable), second.playing(seat.page) as playing:
        playing.session.press("right", 200.0)
        playing.session.release("right", 280.0)
    with first.playing(seat.page) as playing:  # the page's next key
        if playing is not None:
            playing.session.press("right", 400.0)
            playing.session.release("right", 480.0)
    recordings = sorted(web_study.participant_folder("p001").glob("*.jsonl"))
    for path in recordings:
        read_recording(path)  # every step numbered once
    assert playing is None and any("behind its recording" in line for line in said), said
    again = claim(first)  # the page reloads and resumes where the files say
    assert again is not None
    begin_and_move(first, again.page)
    assert len(recordings) == 1 and len(list(web_study.participant_folder("p001").glob("*.jsonl"))) == 2
    for path in web_study.participant_folder("p001").glob("*.jsonl"):
        read_recording(path)
