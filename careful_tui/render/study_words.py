"""A study's words (`irl_core.studies.words`) drawn in the terminal: each tone in the palette's colours."""

from __future__ import annotations

from rich.console import Group
from rich.text import Text

from careful_tui.render.palette import GOOD, NOTE, WARN
from irl_core.studies.words import Paragraph

STYLES = {"": "", "title": f"bold {NOTE}", "good": f"bold {GOOD}", "warn": f"bold {WARN}", "dim": "dim",
          "bold": "bold"}


def as_text(paragraph: Paragraph) -> Text:
    """One paragraph as Rich text (plain text: nothing in it is read as markup)."""
    return Text.assemble(*((span.text, STYLES[span.tone]) for span in paragraph))


def as_group(paragraphs: list[Paragraph]) -> Group:
    """Paragraphs with a blank line between them."""
    spaced: list[Text] = []
    for paragraph in paragraphs:
        if spaced:
            spaced.append(Text())
        spaced.append(as_text(paragraph))
    return Group(*spaced)
