"""Whole studies as scripts of key events, and a front end of the play session that runs them
with no Textual (the terminal's run of the same scripts is in `test_session_headless`).

A script is a list of runs (each a fresh start of `careful study run` on the same folder), a
run a list of steps on one fake clock:

========================  ==================================================================
``("space",)``            begin, go on, next episode, leave at the end
``("key", k, repeat)``    key `k` went down; `repeat` True/False as a kitty terminal labels it,
                          None as a legacy terminal sends it (no release will come)
``("release", k)``        key `k` came up (a kitty terminal)
``("wait", s)``           `s` seconds pass, then the timer ticks
``("c",)``, ``("enter",)``  open calibration, take its result
``("disk_full",)``        from now on a step cannot be written
========================  ==================================================================

Run as a program (`python session_scenarios.py OUT`) it plays every mode's script into
`OUT/<mode>/` with an import finder that refuses Textual, Rich and `careful_tui`, and prints
the files each run wrote, in order, as JSON.
"""

from __future__ import annotations

import importlib.abc
import json
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

FRONT_ENDS = ("textual", "rich", "careful_tui")
SEED = 5
PERIOD = 0.033

Step = tuple
Script = list[list[Step]]


class NoFrontEnd(importlib.abc.MetaPathFinder):
    """Refuses to import any front end: the session must run without one."""

    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in FRONT_ENDS:
            raise ImportError(f"the headless session imported {name}")
        return None


# ---------------------------------------------------------------------- the scripts

def move(mode: str, key: str, level: int) -> list[Step]:
    """The steps of one move of `key` at `level` in `mode` ("hold" legacy, "hold-release" kitty,
    "tap", "digits")."""
    if mode == "digits":
        return [("key", str(level), None), ("key", key, None)]
    if mode == "tap":
        taps: list[Step] = []
        for i in range(level):
            taps += [("wait", 0.1)] * bool(i) + [("key", key, None)]
        return taps + [("wait", 1.0)]
    exact = mode == "hold-release"
    steps: list[Step] = [("key", key, False if exact else None)]
    if level == 1:
        return steps + ([("wait", 0.1), ("release", key)] if exact else [("wait", 1.0)])
    steps += [("wait", 0.5)]
    # The first autorepeat at 0.5 s, then one every 33 ms: 5 of them take about a level (150 ms).
    for _ in range(1 + 5 * (level - 2)):
        steps += [("key", key, True if exact else None), ("wait", PERIOD)]
    return steps + ([("release", key)] if exact else [("wait", 1.0)])


def calibration(mode: str) -> list[Step]:
    """Open calibration, hold up for about 0.8 s (autorepeat after 0.5 s, then every 33 ms, the
    rhythm `move` keys with), let go, take the result."""
    exact = mode == "hold-release"
    steps: list[Step] = [("c",), ("key", "up", False if exact else None), ("wait", 0.5)]
    for _ in range(10):
        steps += [("key", "up", True if exact else None), ("wait", PERIOD)]
    steps += [("release", "up")] if exact else [("wait", 0.5)]
    return steps + [("enter",)]


def study_script(mode: str) -> Script:
    """A whole two-world study (1 practice and 2 main episodes each): calibration first in hold
    modes; the disk fills in the first world's second main episode, after its first step; the
    second run resumes there and plays to the end."""
    m = lambda key, level: move(mode, key, level)  # noqa: E731
    timed = mode.startswith("hold")
    first = [("space",), *(calibration(mode) if timed else []), *m("right", 3), ("space",),
             ("space",), *m("right", 2), ("space",), *m("up", 1), ("disk_full",), *m("right", 1)]
    resume = [("space",), *m("right", 4), ("space",),
              ("space",), *m("left", 2), ("space",),
              ("space",), *m("left", 1), ("space",), *m("left", 5), ("space",),
              ("space",)]
    return [first, resume]


MODES = ("hold", "hold-release", "tap", "digits")


def study_input(mode: str) -> str:
    return "hold" if mode.startswith("hold") else mode


def write_mode_study(folder: Path, mode: str) -> Path:
    """The two-world test study (`study.study_run_files`) in `folder`, in `mode`'s input."""
    from study.study_run_files import write_study

    folder.mkdir(parents=True, exist_ok=True)
    path = write_study(folder)
    path.write_text(path.read_text().replace('input = "digits"', f'input = "{study_input(mode)}"'))
    return path


@contextmanager
def full_disk_switch() -> Iterator[list[bool]]:
    """A switch (`switch[0] = True`) after which writing a step fails as on a full disk."""
    from irl_core.recordings.writer import RecordingWriter

    switch = [False]
    write_step = RecordingWriter.write_step

    def failing(self, step):
        if switch[0]:
            raise OSError(28, "No space left on device")
        write_step(self, step)

    RecordingWriter.write_step = failing
    try:
        yield switch
    finally:
        RecordingWriter.write_step = write_step


# ---------------------------------------------------------------------- the headless front end

def installed_version() -> str:
    """The version the terminal's app records (`careful_tui.version`, which this process may not import)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("careful")
    except PackageNotFoundError:
        return "0+unknown"


def run_headless(study_path: Path, script: Script, participant: str = "p01") -> list[list[str]]:
    """Play `script` on the session with no front end; the files each run wrote, in order."""
    from play_fixtures import FakeClock

    from irl_core.studies.flow import StudyFlow
    from irl_core.studies.study import load_study

    written: list[list[str]] = []
    for run in script:
        clock = FakeClock()
        flow = StudyFlow(load_study(study_path), participant, clock=clock, seed=SEED, app_version=installed_version())
        with full_disk_switch() as disk_full:
            try:
                play_run(flow, clock, run, disk_full)
            finally:
                flow.quit()
        written.append([str(path) for session in flow.sessions for path in session.recorder.paths])
    return written


def play_run(flow, clock, run: list[Step], disk_full: list[bool]) -> None:
    """One run's steps, as the terminal's screens would take them."""
    session = calibrating = None
    for step in run:
        kind, played = step[0], None
        if kind == "disk_full":
            disk_full[0] = True
        elif kind == "wait":
            clock.advance(step[1])
            if calibrating is not None:
                calibrating.tick()
            elif session is not None:
                played = session.tick()
        elif kind == "space" and session is None:
            if flow.stage == "end":
                return
            session = flow.next_block()
            if session is not None:
                session.start()
        elif kind == "space":
            if session.next_episode():
                flow.block_ended()
                session = None
        elif kind == "c":
            calibrating = session.start_calibration()
        elif kind == "enter":
            session.use_profile(calibrating.result)
            calibrating = None
        elif calibrating is not None:
            calibrating.press(step[1], at=clock()) if kind == "key" else calibrating.release(step[1])
        else:
            played = (session.press(step[1], at=clock(), repeat=step[2]) if kind == "key"
                      else session.release(step[1], at=clock()))
        if played is not None and played.stopped:
            return  # the screen leaves: nothing more can be recorded


def main(out: Path) -> None:
    sys.meta_path.insert(0, NoFrontEnd())
    written = {mode: run_headless(write_mode_study(out / mode, mode), study_script(mode)) for mode in MODES}
    imported = sorted(name for name in sys.modules if name.split(".")[0] in FRONT_ENDS)
    print(json.dumps({"written": written, "front_ends_imported": imported}))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
