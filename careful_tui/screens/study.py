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

from careful_tui.render.palette import GOOD, NOTE, WARN
from careful_tui.screens.motor import MotorScreen
from careful_tui.screens.play import PlayScreen
from careful_tui.widgets import KeyBar
from irl_core.play.input_modes import input_mode
from irl_core.studies.flow import Stage, StudyFlow
from irl_core.studies.study import Block, Protocol
from irl_core.support.safe_text import printable
from irl_core.support.words import plural

PROBLEMS_SHOWN = 3


def where_next(protocol: Protocol) -> Text:
    """The next block, as the participant is told: "World 2 of 2 (mud): episode 3 of 5.\""""
    block = protocol.next
    assert block is not None
    world = protocol.world(block)
    word = "practice episode" if block.phase == "practice" else "episode"
    return Text(f"World {block.position + 1} of {len(protocol.order)} ({printable(world.name, limit=40)}): "
                f"{word} {block.done + 1} of {block.target}.")


def plan_text(protocol: Protocol) -> Text:
    """What the study asks of the participant, and how to play."""
    study = protocol.study.study
    worlds = len(protocol.order)
    each = plural(study.episodes, "episode")
    if study.practice_episodes:
        each = f"{plural(study.practice_episodes, 'practice episode')}, then {each} that count"
    text = Text()
    if study.calibration_block:
        text.append(f"First, a short calibration: {plural(study.calibration_block, 'hold')} to a level the gauge "
                    "shows. ")
    text.append(f"You will play {plural(worlds, 'world')}" + (f". In each: {each}. " if worlds > 1 else f": {each}. "))
    text.append("Every episode ends when you reach a cell that ends it (the goal, or worse) or run out of steps.\n\n")
    if all(world.levels == 1 for world in protocol.study.worlds):
        text.append("Move with the arrow keys.")
        return text
    text.append("Each move has a carefulness level. ", style="bold")
    text.append("A careful move costs more points and slips less: a slip sends you another way than "
                "you chose. Beside the gauge on the left, every level shows its cost and its chance "
                "of slipping.\n\n")
    text.append(input_mode(study.input).study_words)
    return text


BEGIN = "Press space to begin. q leaves at any time; what you played is kept."


def opening_texts(protocol: Protocol) -> list[Text]:
    """The first screen's paragraphs, for every front end: the study's name, where a returning participant
    stands, the study's own instructions and the plan."""
    study = protocol.study.study
    parts: list[Text] = [Text(printable(study.name, limit=80), style=f"bold {NOTE}")]
    if protocol.started:
        done, total = protocol.progress
        back = Text(f"Welcome back: {done} of {plural(total, 'episode')} {'is' if total == 1 else 'are'} done."
                    " You go on with: ", style=f"bold {GOOD}")
        back.append_text(where_next(protocol))
        parts.append(back)
    if study.instructions.strip():
        # Whole (the study file caps them at 20,000 characters; the screen scrolls).
        parts.append(Text(printable(study.instructions.strip(), keep_newlines=True)))
    parts.append(plan_text(protocol))
    return parts


def instructions_text(protocol: Protocol) -> Group:
    """The first screen: the study's own instructions, the plan, where a returning participant stands."""
    return _spaced([*opening_texts(protocol), *problems_text(protocol), Text(BEGIN, style="dim")])


def between_text(protocol: Protocol, finished: Block) -> Group:
    """Between blocks: practice over (same world, main episodes next) or a world done."""
    block = protocol.next
    assert block is not None
    done, total = protocol.progress
    if block.world_index == finished.world_index and block.phase == finished.phase:
        parts = [Text("Not every episode of this part was recorded as finished.", style=f"bold {WARN}"),
                 Text.assemble("Next: ", where_next(protocol))]
    elif block.world_index == finished.world_index and block.phase == "main":
        parts = [Text("Practice is over.", style=f"bold {NOTE}"),
                 Text(f"Now come the {plural(block.remaining, 'episode')} of this world that count. "
                      "Same world, same keys.")]
    else:
        parts = [Text(f"World {finished.position + 1} of {len(protocol.order)} is done.", style=f"bold {NOTE}"),
                 Text.assemble("Next: ", where_next(protocol),
                               " It may differ from the last one: look at the board and the gauge before "
                               "your first move.")]
    parts.append(Text(f"{done} of {plural(total, 'episode')} done.", style="dim"))
    parts.append(Text("Press space to go on. q leaves; what you played is kept.", style="dim"))
    return _spaced(parts)


def end_text(protocol: Protocol) -> Group:
    done, total = protocol.progress
    return _spaced([
        Text("That is the end of the study. Thank you!", style=f"bold {GOOD}"),
        Text(f"{'The episode is' if total == 1 else f'All {total} episodes are'} recorded in "
             f"{printable(str(protocol.folder), limit=200)}."),
        *problems_text(protocol),
        Text("Press space or q to leave.", style="dim"),
    ])


def problems_text(protocol: Protocol) -> list[Text]:
    """Files in the folder that are not counted, or counted in part, for the experimenter (a few,
    then how many more); each line says which."""
    if not protocol.problems:
        return []
    text = Text(f"For the experimenter: {plural(len(protocol.problems), 'problem')} in the folder:",
                style=f"bold {WARN}")
    for problem in protocol.problems[:PROBLEMS_SHOWN]:
        text.append(f"\n- {printable(problem, limit=300)}", style=WARN)
    if len(protocol.problems) > PROBLEMS_SHOWN:
        text.append(f"\n- and {len(protocol.problems) - PROBLEMS_SHOWN} more", style=WARN)
    return [text]


def _spaced(parts: list[Text]) -> Group:
    """Paragraphs with a blank line between them."""
    spaced: list[Text] = []
    for part in parts:
        if spaced:
            spaced.append(Text())
        spaced.append(part)
    return Group(*spaced)


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
            block = self.flow.protocol.next
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

