"""The colours of careful's terminal, named by what they mean.

Rich renderables take these directly; `careful_tui.theme` registers the same colours as a
Textual theme, so that stylesheets say `$good`, `$note`, `$warn` and never a hex code.
"""

from __future__ import annotations

GOOD = "#7ee787"  # the goal reached, a result that worked
BAD = "#ff6b6b"  # the cliff, a failure
NOTE = "#9ecbff"  # titles, notices, key chips
WARN = "#ffd54f"  # warnings, a score below the start, a fit in progress
SLIP = "#ff9f1c"  # a move that slipped
INK = "#cfd8e3"  # body text
BACKGROUND = "#12161c"
SURFACE = "#1c2330"  # title and key bars, boxes
PANEL = "#161b23"  # the fit screen's status line
FRAME = "#4a5568"  # widget borders
ON_NOTE = "#101418"  # text on a NOTE chip
EMPTY = "#262b33"  # an empty bar (gauge, calibration)
BAR = "#4fc3f7"  # the calibration's progress bar
HERE = "#2a3442"  # the current row of a table
WHITE = "#ffffff"

# Level colours run from cheap and risky (cool) to careful and costly (warm).
_LEVEL_STOPS = ((0x4F, 0xC3, 0xF7), (0xFF, 0xD5, 0x4F), (0xFF, 0x5A, 0x36))


def level_colour(level: float, levels: int) -> str:
    """The colour of carefulness `level` (1..levels, may be fractional) as #rrggbb."""
    f = 0.0 if levels <= 1 else min(1.0, max(0.0, (level - 1) / (levels - 1)))
    x = f * (len(_LEVEL_STOPS) - 1)
    i = min(int(x), len(_LEVEL_STOPS) - 2)
    a, b = _LEVEL_STOPS[i], _LEVEL_STOPS[i + 1]
    t = x - i
    return "#{:02x}{:02x}{:02x}".format(*(round(p + (q - p) * t) for p, q in zip(a, b)))
