"""`careful study run`: one participant through a study's protocol (README "Studies"), on the one app.

The study screen is the flow around the play screen. It shows the study's instructions (space to
begin); then, for the next block of the participant's protocol (a world's practice or main
episodes, `irl_core.study.read_protocol`), it pushes a `PlayScreen` that plays the block's
remaining episodes into a new file of the participant's folder, the file's header carrying the
block's `study` tag and its episode numbers continuing the block's. When the play screen hands
back, the protocol is read again from the folder, so what comes next is always what the files
say: a note when practice ends and the main episodes begin, a short screen between worlds, and
the end screen when nothing is left.

`q` (or SIGTERM) leaves from any screen, keeping what was recorded (the play screen records a running
episode as ``quit``); running the same participant again resumes where the files say, and an
interrupted episode is played again. A calibration made in hold mode carries over to the next
blocks.

The study's text (its name, instructions, world names) is shown as text: control characters are
escaped and nothing is read as markup.
"""

from __future__ import annotations

import asyncio
import os
import signal
from collections.abc import Callable
from typing import Literal

from rich.console import Group
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import VerticalScroll
from textual.reactive import reactive
from textual.screen import Screen
from textual.widgets import Static

from careful_tui.keys.hold import HoldProfile
from careful_tui.render.palette import GOOD, NOTE, WARN
from careful_tui.screens.play import PlayScreen
from careful_tui.widgets import KeyBar
from irl_core.safe_text import cut, printable
from irl_core.study import Block, LoadedStudy, Protocol, read_protocol
from irl_core.words import plural

Stage = Literal["instructions", "practice_over", "next_world", "end"]
# How to choose a carefulness level, per input mode (the instructions' words; play says it shorter).
MODE_WORDS = {
    "hold": "Hold an arrow key down: the longer you hold it, the more careful the move. The move is "
            "made when you let go.",
    "tap": "Tap an arrow key k times quickly for a move at level k (one tap: level 1).",
    "digits": "Type the level (a number), then press the arrow key. An arrow alone is a level 1 move; "
              "backspace takes back a digit.",
}
PROBLEMS_SHOWN = 3
# The play screen shows this much of its heading; the study's name takes at most STUDY_NAME_LIMIT of it.
HEADING_LIMIT, STUDY_NAME_LIMIT = 60, 20

PlayBlock = Callable[[Protocol, Block, HoldProfile | None], PlayScreen]


def block_heading(protocol: Protocol, block: Block) -> str:
    """ "pilot · world 1 of 2 (paper) · practice", at most `HEADING_LIMIT` characters: a long
    study or world name is cut, never the place and the phase."""
    name = cut(printable(protocol.study.study.name), STUDY_NAME_LIMIT, say_length=False)
    place = f" · world {block.position + 1} of {len(protocol.order)} ("
    phase = f") · {block.phase}"
    room = max(8, HEADING_LIMIT - len(name) - len(place) - len(phase))
    world = cut(printable(protocol.world(block).name), room, say_length=False)
    return f"{name}{place}{world}{phase}"


def block_play_options(protocol: Protocol, block: Block) -> dict[str, object]:
    """The `PlayScreen` options of a block: its title, its remaining episodes and how they are counted."""
    return {
        "heading": block_heading(protocol, block),
        "episodes": block.remaining,
        "episodes_done": block.done,
        "episode_word": "Practice episode" if block.phase == "practice" else "Episode",
        "command": "careful study run",
    }


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
    text.append(f"You will play {plural(worlds, 'world')}" + (f". In each: {each}. " if worlds > 1 else f": {each}. "))
    text.append("Every episode ends when you reach a cell that ends it (the goal, or worse) or run out of steps.\n\n")
    if all(world.levels == 1 for world in protocol.study.worlds):
        text.append("Move with the arrow keys.")
        return text
    text.append("Each move has a carefulness level. ", style="bold")
    text.append("A careful move costs more points and slips less: a slip sends you another way than "
                "you chose. Beside the gauge on the left, every level shows its cost and its chance "
                "of slipping.\n\n")
    text.append(MODE_WORDS[study.input])
    return text


def instructions_text(protocol: Protocol) -> Group:
    """The first screen: the study's own instructions, the plan, where a returning participant stands."""
    study = protocol.study.study
    parts: list[Text] = [Text(printable(study.name, limit=80), style=f"bold {NOTE}")]
    if protocol.started:
        done, total = protocol.progress
        back = Text(f"Welcome back: {done} of {plural(total, 'episode')} {'is' if total == 1 else 'are'} done. You go on with: ", style=f"bold {GOOD}")
        back.append_text(where_next(protocol))
        parts.append(back)
    if study.instructions.strip():
        # Whole (the study file caps them at 20,000 characters; the screen scrolls).
        parts.append(Text(printable(study.instructions.strip(), keep_newlines=True)))
    parts.append(plan_text(protocol))
    parts.extend(problems_text(protocol))
    parts.append(Text("Press space to begin. q leaves at any time; what you played is kept.", style="dim"))
    return _spaced(parts)


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
    """A participant's way through a study: instructions, each block played on a `PlayScreen`
    (built by `play_block`), the screens between blocks, the end.

    Build its app with `careful_tui.app.make_study_app`. `plays` holds every play screen pushed,
    so the command can say what was recorded.

    Reactives:
        stage: which text shows (``instructions``, ``practice_over``, ``next_world``, ``end``);
            it is set again (and redrawn) after every block.
    """

    TITLE = "careful study"
    BINDINGS = [
        Binding("space,enter", "go_on('instructions')", "begin", key_display="space"),
        Binding("space,enter", "go_on('between')", "go on", key_display="space"),
        Binding("space,enter", "go_on('end')", "leave", key_display="space"),
    ]

    stage: reactive[Stage] = reactive("instructions", always_update=True, init=False)

    def __init__(self, study: LoadedStudy, participant: str, *, play_block: PlayBlock) -> None:
        super().__init__()
        self.study = study
        self.participant = participant
        self.play_block = play_block
        self.protocol = read_protocol(study, participant)
        self.plays: list[PlayScreen] = []
        self.profile: HoldProfile | None = None
        self._finished: Block | None = None

    def compose(self) -> ComposeResult:
        yield Static(id="title")
        with VerticalScroll(id="study-body"):
            yield Static(id="study-text")
        yield KeyBar(id="keys")

    def on_mount(self) -> None:
        self.query_one("#title", Static).update(Text.assemble(
            ("careful study", f"bold {NOTE}"), f" · {printable(self.study.study.name, limit=60)} · participant ",
            (self.participant, "bold"), f" · {self.study.study.input} input",
            (f" · recording → {printable(str(self.protocol.folder), limit=200)}", "dim"),
        ))
        self.stage = "end" if self.protocol.finished else "instructions"
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
        if stage == "instructions":
            text = instructions_text(self.protocol)
        elif stage == "end":
            text = end_text(self.protocol)
        else:
            assert self._finished is not None
            text = between_text(self.protocol, self._finished)
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
        if self.stage == "end":
            self.app.exit()
            return
        block = self.protocol.next  # read at the start and again after each block
        if block is None:
            self.stage = "end"
            return
        play = self.play_block(self.protocol, block, self.profile)
        self.plays.append(play)
        self.app.push_screen(play, lambda _result: self.block_ended(play, block))

    def block_ended(self, play: PlayScreen, block: Block) -> None:
        """The play screen played its episodes: read where the participant stands now."""
        self.profile = play.profile
        self.protocol = read_protocol(self.study, self.participant)
        self._finished = block
        if self.protocol.finished:
            self.stage = "end"
        else:
            following = self.protocol.next
            same_world = following is not None and following.world_index == block.world_index
            self.stage = "practice_over" if same_world and following.phase == "main" else "next_world"

    def record_quit(self) -> None:
        """End the running block's episode as ``quit`` and close its file (safe to call more than once)."""
        for play in self.plays:
            play.record_quit()
