"""Play's reach field in half-block pixels: square pixels, the marks where the field puts them, the ring at the
aim's distance of one sd, checked by measuring the drawn pixels rather than re-running the drawing's maths."""

from __future__ import annotations

import math

from careful_tui.render.palette import WHITE
from careful_tui.render.reach_field import (
    AIM_MARK,
    END_MARK,
    HALF_BLOCK,
    FieldMarks,
    field_cells,
    field_legend,
    field_pixels,
)
from irl_core.worlds.reach import REACH_WORLDS

WORLD = REACH_WORLDS["reach"]


def cells(text):
    """{(col, row): (character, style)} of a drawn field."""
    out, col, row = {}, 0, 0
    for index, character in enumerate(text.plain):
        if character == "\n":
            col, row = 0, row + 1
            continue
        styles = [span.style for span in text.spans if span.start <= index < span.end]
        out[(col, row)] = (character, styles[-1] if styles else None)
        col += 1
    return out


def test_the_field_fits_with_square_pixels():
    for width, height in ((68, 29), (48, 19), (200, 20)):
        columns, rows = field_cells(WORLD, width, height)
        assert columns <= width and rows <= height
        # A pixel is a column wide and half a row tall: 400 x 300 field units make 4 columns to 3 pixel rows.
        assert abs(columns * 3 / 4 - 2 * rows) <= 2


def test_marks_sit_in_their_cells_and_the_ring_is_one_sd_from_the_aim():
    columns, rows = 80, 30  # 5 field units a pixel, both ways
    aim, sd = (250.0, 150.0), 40.0
    drawn = cells(field_pixels(WORLD, columns, rows, FieldMarks(aim=aim, ring_sd=sd, endpoint=(100.0, 50.0))))
    assert drawn[(50, 15)][0] == AIM_MARK and drawn[(20, 5)][0] == END_MARK
    assert drawn[(40, 28)][0] == "S" and drawn[(33, 8)][0] == "C"
    ring = []
    for (col, row), (character, style) in drawn.items():
        if character == HALF_BLOCK:
            for half, colour in ((0, style.color), (1, style.bgcolor)):
                if colour is not None and colour.triplet is not None and colour.triplet.hex == WHITE:
                    ring.append(math.dist(((col + 0.5) * 5, (2 * row + half + 0.5) * 5), aim))
    assert len(ring) > 40 and all(abs(d - sd) <= 2.5 for d in ring)


def test_the_legend_fits_the_border_at_80_columns():
    legend = field_legend(REACH_WORLDS["reach-severe"]).plain
    assert "G 100" in legend and "C -5000" in legend and "G+C" in legend and len(legend) <= 44
