"""Play's reach field: the world's circles at sub-character resolution, the aim, the ring and the last endpoint
(`careful_tui.render.reach_field.field_pixels`), sized to the largest field that fits the widget."""

from __future__ import annotations

from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget

from careful_tui.render.reach_field import FieldMarks, field_cells, field_pixels
from irl_core.worlds.reach import ReachWorld


class ReachField(Widget):
    """The field of `world` with `marks` drawn over it; setting `marks` redraws it."""

    marks: reactive[FieldMarks] = reactive(FieldMarks(aim=(0.0, 0.0)), layout=False)

    def __init__(self, world: ReachWorld, marks: FieldMarks, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.world = world
        self.set_reactive(ReachField.marks, marks)

    def render(self) -> Text:
        columns, rows = field_cells(self.world, self.content_size.width, self.content_size.height)
        return field_pixels(self.world, columns, rows, self.marks)
