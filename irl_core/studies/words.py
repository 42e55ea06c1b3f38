"""The words a study's participant reads between blocks, for any front end: paragraphs of spans with tones.

A tone names what a span is, not how it looks; each front end draws the tones its own way (the
terminal with its palette, `careful_tui.render.study_words`; the browser with its stylesheet's classes):

========  ==============================================================
tone      used for
========  ==============================================================
``""``    plain text
``title`` a screen's title (the study's name, "Practice is over.")
``good``  good news ("Welcome back", the end of the study)
``warn``  what did not go as planned, and problems for the experimenter
``dim``   what to press next, counts
``bold``  a phrase to notice within a paragraph
========  ==============================================================

The study's own text (its name, instructions, world names) is made printable here, once.
"""

from __future__ import annotations

from dataclasses import dataclass

from irl_core.play.input_modes import input_mode
from irl_core.studies.study import Block, Protocol
from irl_core.support.plural import plural
from irl_core.support.safe_text import printable
from irl_core.worlds.reach import ReachWorld
from irl_core.worlds.world import World

TONES = ("", "title", "good", "warn", "dim", "bold")
PROBLEMS_SHOWN = 3
BEGIN = "Press space to begin. q leaves at any time; what you played is kept."
GO_ON = "Press space to go on. q leaves; what you played is kept."


@dataclass(frozen=True)
class Span:
    """Some text of a paragraph and its tone (`TONES`)."""

    text: str
    tone: str = ""

    def __post_init__(self) -> None:
        if self.tone not in TONES:
            raise ValueError(f"tone must be one of {TONES}, not {self.tone!r}")


Paragraph = tuple[Span, ...]


def paragraph(text: str, tone: str = "") -> Paragraph:
    """A paragraph of one span."""
    return (Span(text, tone),)


def where_next(protocol: Protocol) -> str:
    """The next block, as the participant is told: "World 2 of 2 (mud): episode 3 of 5.\""""
    block = protocol.next_block
    assert block is not None
    world = protocol.study_world(block)
    word = "practice episode" if block.phase == "practice" else "episode"
    return (f"World {block.position + 1} of {len(protocol.order)} ({printable(world.name, limit=40)}): "
            f"{word} {block.done + 1} of {block.target}.")


def plan(protocol: Protocol, *, input_name: str | None = None) -> Paragraph:
    """What the study asks of the participant, and how to play in `input_name` (default the study's input
    mode; the browser, which times every hold, says ``hold``)."""
    study = protocol.study.study
    worlds = len(protocol.order)
    each = plural(study.episodes, "episode")
    if study.practice_episodes:
        each = f"{plural(study.practice_episodes, 'practice episode')}, then {each} that count"
    spans = []
    if study.calibration_block:
        spans.append(Span(f"First, a short calibration: {plural(study.calibration_block, 'hold')} to a level the "
                          "gauge shows. "))
    spans.append(Span(f"You will play {plural(worlds, 'world')}" + (f". In each: {each}. " if worlds > 1
                                                                    else f": {each}. ")))
    reaches = [world for world in protocol.study.worlds if isinstance(world, ReachWorld)]
    worlds_played = [world for world in protocol.study.worlds if isinstance(world, World)]
    if reaches:
        own = any(world.noise == "own" for world in reaches)
        spans.append(Span("In a reach world each episode is one reach from the start: where it lands scores the "
                          "points of every circle holding it, less the time it took. " +
                          ("First, a calibration: a few reaches to a lone circle, each in about the time asked. "
                           if own else "")))
        if not worlds_played:
            return (*spans,)
    spans.append(Span("Every episode ends when you reach a cell that ends it (the goal, or worse) or run out of "
                      "steps.\n\n"))
    timed = [world.care == "time" for world in worlds_played]
    if all(timed):
        # A time world shows no levels: the hold itself is the care.
        return (*spans, Span("The longer you hold an arrow key, the more careful the move. ", "bold"),
                Span("A careful move costs more points and slips less: a slip sends you another way than you chose. "
                     "The move is made when you let go."))
    if all(world.levels == 1 for world in worlds_played):
        return (*spans, Span("Move with the arrow keys."))
    some_timed = (Span(" In a world without a gauge, care is how long you hold the arrow: the move is made when "
                       "you let go.") if any(timed) else Span(""))
    # Another lab's fixed split slips alike at every level: care then only costs, and the words say so.
    slips_less = not all(world.slip_is_fixed for world in worlds_played if world.care == "levels")
    return (*spans, Span("Each move has a carefulness level. ", "bold"),
            Span(("A careful move costs more points and slips less" if slips_less else
                  "A careful move costs more points and slips no less") +
                 ": a slip sends you another way than you chose. "
                 "On the gauge, every level shows its cost and its chance of slipping.\n\n"),
            Span(input_mode(input_name or study.input).study_words), some_timed)


def opening(protocol: Protocol, *, input_name: str | None = None, experimenter: bool = True) -> list[Paragraph]:
    """The first screen: the study's name, where a returning participant stands, the study's own
    instructions, the plan, the folder's problems for the experimenter (where one may be looking:
    `experimenter`; not on a participant's web page) and what to press."""
    study = protocol.study.study
    parts: list[Paragraph] = [paragraph(printable(study.name, limit=80), "title")]
    if protocol.started:
        done, total = protocol.progress
        parts.append((Span(f"Welcome back: {done} of {plural(total, 'episode')} {'is' if total == 1 else 'are'} "
                           "done. You go on with: ", "good"), Span(where_next(protocol))))
    if study.instructions.strip():
        # Whole (the study file caps them at 20,000 characters; the screen scrolls).
        parts.append(paragraph(printable(study.instructions.strip(), keep_newlines=True)))
    shown = problems(protocol) if experimenter else []
    return [*parts, plan(protocol, input_name=input_name), *shown, paragraph(BEGIN, "dim")]


def between(protocol: Protocol, finished: Block) -> list[Paragraph]:
    """Between blocks: practice over (same world, main episodes next), a world done, or a block that ended
    without every episode recorded as finished."""
    block = protocol.next_block
    assert block is not None
    done, total = protocol.progress
    if block.world_index == finished.world_index and block.phase == finished.phase:
        parts = [paragraph("Not every episode of this part was recorded as finished.", "warn"),
                 paragraph(f"Next: {where_next(protocol)}")]
    elif block.world_index == finished.world_index and block.phase == "main":
        parts = [paragraph("Practice is over.", "title"),
                 paragraph(f"Now come the {plural(block.remaining, 'episode')} of this world that count. "
                           "Same world, same keys.")]
    else:
        parts = [paragraph(f"World {finished.position + 1} of {len(protocol.order)} is done.", "title"),
                 paragraph(f"Next: {where_next(protocol)} It may differ from the last one: look at the board and "
                           "the gauge before your first move.")]
    return [*parts, paragraph(f"{done} of {plural(total, 'episode')} done.", "dim"), paragraph(GO_ON, "dim")]


def end(protocol: Protocol, *, show_folder: bool = True, to_prolific: bool = False) -> list[Paragraph]:
    """The end of the study; the terminal names the folder, the browser (`show_folder` False) does not, and a
    Prolific participant is told they go back there."""
    done, total = protocol.progress
    recorded = f"{'The episode is' if total == 1 else f'All {total} episodes are'} recorded"
    parts = [paragraph("That is the end of the study. Thank you!", "good"),
             paragraph(f"{recorded} in {printable(str(protocol.folder), limit=200)}." if show_folder
                       else f"{recorded}.")]
    if to_prolific:
        parts.append(paragraph("You are being sent back to Prolific to complete your submission.", "dim"))
    if show_folder:
        parts += [*problems(protocol), paragraph("Press space or q to leave.", "dim")]
    return parts


def left(protocol: Protocol) -> list[Paragraph]:
    """A browser participant who left (q, or the page closed): what is kept and how to go on."""
    done, total = protocol.progress
    return [paragraph("You have left the study.", "title"),
            paragraph(f"What you played is kept: {done} of {plural(total, 'episode')} done."),
            paragraph("Open your link again to go on where you stopped.", "dim")]


def problems(protocol: Protocol) -> list[Paragraph]:
    """Files in the folder that are not counted, or counted in part, for the experimenter (a few, then how
    many more); each line says which."""
    if not protocol.problems:
        return []
    spans = [Span(f"For the experimenter: {plural(len(protocol.problems), 'problem')} in the folder:", "warn")]
    spans += [Span(f"\n- {printable(problem, limit=300)}", "warn") for problem in protocol.problems[:PROBLEMS_SHOWN]]
    if len(protocol.problems) > PROBLEMS_SHOWN:
        spans.append(Span(f"\n- and {len(protocol.problems) - PROBLEMS_SHOWN} more", "warn"))
    return [tuple(spans)]
