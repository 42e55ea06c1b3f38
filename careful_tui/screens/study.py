"""`careful study run`'s screen: the study's flow (`irl_core.studies.flow`) in a terminal (docs/studies.md).

The flow keeps the stages (instructions, each block, between blocks, the end) and where the
participant stands; this screen draws the stage's text and, when space asks for the next block,
pushes a `PlayScreen` on the block's session. When the play screen hands back, the flow reads
the participant's folder again and says which stage comes next.

`q` (or SIGTERM) leaves from any screen, keeping what was recorded (the play screen records a running
episode as ``quit``); running the same participant again resumes where the files say, and an
interrupted episode is played again. A calibration made in hold mode carries over to the next
blocks. A study with a motor calibration block shows it (`careful_tui.screens.motor`) after the
instructions, before the first block.

The study's text (its name, instructions, world names) is shown as text: control characters are
escaped and nothing is read as markup.
"""

from __future__ import annotations

import asyncio
import os
import signal

from rich.console import Group
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import VerticalScroll
from textual.reactive import reactive
from textual.screen import Screen
from textual.widgets import Static

from careful_tui.render.palette import NOTE
from careful_tui.render.study_words import as_group
from careful_tui.screens.motor import MotorScreen
from careful_tui.screens.play import PlayScreen
from careful_tui.widgets import KeyBar
from irl_core.studies import words
from irl_core.studies.flow import Stage, StudyFlow
from irl_core.studies.study import Block, Protocol
from irl_core.support.safe_text import printable


def instructions_text(protocol: Protocol) -> Group:
    """The first screen: the study's own instructions, the plan, where a returning participant stands."""
    return as_group(words.opening(protocol))


def between_text(protocol: Protocol, finished: Block) -> Group:
    """Between blocks: practice over (same world, main episodes next) or a world done."""
    return as_group(words.between(protocol, finished))


def end_text(protocol: Protocol) -> Group:
    return as_group(words.end(protocol))


class StudyScreen(Screen[None]):
    """A participant's way through a study (`flow`): the stage's text, and each block played on
    a `PlayScreen` of the block's session.

    Build its app with `careful_tui.app.make_study_app`. `event_times` goes to the play screens.

    Reactives:
        stage: which text shows (``instructions``, ``practice_over``, ``next_world``, ``end``),
            the flow's; it is set again (and redrawn) after every block.
    """

    TITLE = "careful study"
    BINDINGS = [
        Binding("space,enter", "go_on('instructions')", "begin", key_display="space"),
        Binding("space,enter", "go_on('between')", "go on", key_display="space"),
        Binding("space,enter", "go_on('end')", "leave", key_display="space"),
    ]

    stage: reactive[Stage] = reactive("instructions", always_update=True, init=False)

    def __init__(self, flow: StudyFlow, *, event_times: bool | None = None) -> None:
        super().__init__()
        self.flow = flow
        self.event_times = event_times

    def compose(self) -> ComposeResult:
        yield Static(id="title")
        with VerticalScroll(id="study-body"):
            yield Static(id="study-text")
        yield KeyBar(id="keys")

    def on_mount(self) -> None:
        flow = self.flow
        self.query_one("#title", Static).update(Text.assemble(
            ("careful study", f"bold {NOTE}"), f" · {printable(flow.study.study.name, limit=60)} · participant ",
            (flow.participant, "bold"), f" · {flow.study.study.input} input",
            (f" · recording → {printable(str(flow.protocol.folder), limit=200)}", "dim"),
        ))
        self.stage = flow.stage
        if not self.app.is_headless:
            # Until a play screen puts in its own (which record the running episode first).
            loop = asyncio.get_running_loop()
            loop.add_signal_handler(signal.SIGTERM, self.app.exit)
            loop.add_signal_handler(signal.SIGHUP, self.hang_up)

    def hang_up(self) -> None:
        """The terminal was closed before any episode began: nothing to record, leave at once
        (Textual's orderly exit would block writing to the closed terminal; status 129)."""
        os._exit(128 + signal.SIGHUP)

    def watch_stage(self, stage: Stage) -> None:
        protocol = self.flow.protocol
        if stage == "instructions":
            text = instructions_text(protocol)
        elif stage == "end":
            text = end_text(protocol)
        else:
            assert self.flow.finished is not None
            text = between_text(protocol, self.flow.finished)
        self.query_one("#study-text", Static).update(text)
        self.query_one("#study-body", VerticalScroll).scroll_home(animate=False)
        self.refresh_bindings()

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "go_on":
            shown = {"instructions": "instructions", "end": "end"}.get(self.stage, "between")
            return parameters == (shown,)
        return super().check_action(action, parameters)

    def action_go_on(self, shown_on: str) -> None:
        """Space: begin or go on with the next block, or leave at the end (`shown_on` only picks
        which binding the key bar shows; `check_action` matches it to the stage)."""
        if self.flow.stage == "end":
            self.app.exit()
            return
        motor = self.flow.calibration()
        if motor is not None:
            block = self.flow.protocol.next_block
            assert block is not None, "calibration() is None for a finished participant"
            self.app.push_screen(MotorScreen(motor, self.flow.protocol.world(block), event_times=self.event_times),
                                 self.calibration_ended)
            return
        self._play_next()

    def calibration_ended(self, go_on: bool | None) -> None:
        """The calibration block's screen closed: practice follows, or the participant left."""
        self.flow.calibration_ended()
        if go_on:
            self._play_next()
        else:
            self.app.exit()

    def _play_next(self) -> None:
        session = self.flow.next_block()
        if session is None:
            self.stage = self.flow.stage
            return
        self.app.push_screen(PlayScreen(session, event_times=self.event_times),
                             lambda _result: self.block_ended())

    def block_ended(self) -> None:
        """The play screen played its episodes: the flow reads where the participant stands now."""
        self.stage = self.flow.block_ended()

