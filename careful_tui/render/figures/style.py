"""The look every figure shares, `plain` for text from a file, and `save_figure`.

Sizes are for a paper: a single-panel figure is `PANEL_WIDTH` inches wide, drawn with 7-pt
text, so that at a third of a page's width (NeurIPS: 0.3 x 5.5 in) the text is still about
5-6 pt. DejaVu Sans (shipped with matplotlib) is embedded in PDFs as TrueType (`pdf.fonttype`
42), so a journal's checker finds every font. The default style is reset first, so a user's
matplotlibrc cannot change what a figure looks like (nor turn on `text.usetex`: the default is off).

Text from a file (a world's name or symbols, a participant's id) goes into a figure only through
`plain`, so it is shown as written: outside `$...$` matplotlib draws `_`, `^` and `\\` as they
are, and `plain` keeps every `$` from starting mathtext.
"""

from __future__ import annotations

import io
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

import matplotlib as mpl
import matplotlib.style
from matplotlib.figure import Figure

from careful_tui.render.figures import FIGURE_SUFFIXES
from careful_tui.render.grid import SYMBOL_NAMES
from irl_core.support.safe_files import write_output
from irl_core.support.safe_text import cut, printable

DPI = 300
PANEL_WIDTH = 2.2  # inches: a third of a page's width
PAGE_WIDTH = 5.5  # inches: a page's text width

RC = {
    "font.family": "sans-serif",
    "font.sans-serif": ["DejaVu Sans"],
    "font.size": 7,
    "axes.titlesize": 7,
    "axes.labelsize": 7,
    "xtick.labelsize": 6,
    "ytick.labelsize": 6,
    "legend.fontsize": 6,
    "legend.frameon": False,
    "axes.linewidth": 0.6,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "xtick.minor.width": 0.4,
    "ytick.minor.width": 0.4,
    "xtick.major.size": 2.5,
    "ytick.major.size": 2.5,
    "xtick.minor.size": 1.5,
    "ytick.minor.size": 1.5,
    "lines.linewidth": 1.0,
    "hatch.linewidth": 0.5,
    "hatch.color": "#7a7a7a",
    "figure.facecolor": "white",
    "axes.facecolor": "white",
    "savefig.facecolor": "white",
    "savefig.dpi": DPI,
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
    "svg.fonttype": "path",
    "axes.unicode_minus": True,
}

# Okabe & Ito's colour-blind-safe palette, for lines and bars that are not on the reward scale.
INK = "#222222"
QUIET = "#9a9a9a"  # text that is there for completeness
OKABE_ITO = ("#D55E00", "#0072B2", "#CC79A7", "#009E73", "#E69F00", "#56B4E9", "#F0E442")


def plain(text: str, *, limit: int = 40) -> str:
    """Text from a file for a figure: control characters escaped, and `$` kept from starting mathtext.

    matplotlib reads a text with an even number of unescaped `$` as mathtext (and raises on bad
    mathtext); it draws an escaped `\\$` as `$`. A text longer than `limit` characters keeps its first
    `limit - 1` and an ellipsis: a figure's title has no room for "(N characters)".
    """
    return cut(printable(text), limit, say_length=False).replace("$", r"\$")


def symbol_label(symbol: str) -> str:
    """A layout symbol's name in a figure: "cliff" for C, any other symbol as itself (through `plain`)."""
    return SYMBOL_NAMES.get(symbol, plain(symbol))


@contextmanager
def figure_style() -> Iterator[None]:
    """matplotlib's defaults, then `RC`: wrap both drawing and saving in it."""
    # RC's keys are rc names, which matplotlib checks when it applies them; its stubs want them as literals.
    with mpl.style.context("default"), mpl.rc_context(RC):  # type: ignore[arg-type]
        yield


def new_figure(width: float, height: float) -> Figure:
    """A figure of `width` x `height` inches with constrained layout (call inside `figure_style`)."""
    return Figure(figsize=(width, height), layout="constrained")


def save_figure(figure: Figure, path: Path, *, option: str = "--figure", inputs: Iterable[Path] = ()) -> None:
    """Write `figure` to `path` as PDF, PNG (300 dpi) or SVG, by the suffix.

    The file goes through the one output guard (`irl_core.support.safe_files.write_output`): it never
    replaces a recording or one of `inputs`, and a failed write leaves no half-written file.

    Text is plain (no mathtext): every PDF then embeds one font, DejaVu Sans, and embedding
    (subsetting with fontTools) is most of the time a PDF takes. Raises ValueError for another suffix
    (`careful_tui.render.figures.figure_suffix_problem` says it in a sentence first). No creation date
    is stored, so the same figure gives the same file.
    """
    fmt = path.suffix.lower()
    if fmt not in FIGURE_SUFFIXES:
        raise ValueError(f"cannot write a figure as {path.suffix!r}; use one of {FIGURE_SUFFIXES}")
    metadata = {"pdf": {"Creator": "careful", "Producer": None, "CreationDate": None},
                "png": {"Software": "careful"}, "svg": {"Creator": "careful", "Date": None}}[fmt[1:]]
    buffer = io.BytesIO()
    with figure_style():
        figure.savefig(buffer, format=fmt[1:], dpi=DPI, metadata=metadata)
    write_output(path, buffer.getvalue(), option=option, inputs=inputs)
    # The layout is done: keep it for the next format instead of solving it again (it is in inches).
    figure.set_layout_engine("none")
