"""Figures for papers: matplotlib pictures of rewards, policies, intervals and carefulness.

The modules here are the only ones that import matplotlib, and only `careful fit --figure`
and `careful experiment` import them, so the game starts without it. Each figure is a pure
function over arrays and labels that returns a `matplotlib.figure.Figure`; `save_figure`
writes one in the format its path's suffix names.

- `board`: a world's cells as arrays (symbols, walls, terminal cells), no matplotlib.
- `style`: the look every figure shares (font, sizes, colours), `plain` (text from a file, shown
  as written) and `save_figure`.
- `heatmap`: rewards on a symmetric-log diverging colour scale with a colour bar.
- `policy`: arrows whose width and number show carefulness, opacity how often.
- `intervals`: one row per unknown, interval as a bar, estimate as a dot, truth as a mark.
- `carefulness`: mean carefulness against distance to the nearest terminal cell.
- `fit_figure`: the panels of one `careful fit` result in one figure.
- `reach_figure`: a reach fit in one figure (the field with the reaches, durations by distance, intervals).
- `small_multiples`: a small panel per participant (rewards, carefulness) on shared scales.
- `study_figures`: the figures of `careful study report`, named as their files.

This file imports no matplotlib: `careful fit` checks a `--figure` suffix before fitting.
"""

from __future__ import annotations

from pathlib import Path

FIGURE_SUFFIXES = (".pdf", ".png", ".svg")


def figure_suffix_problem(path: Path) -> str | None:
    """A one-line complaint when `path` does not end in a figure format's suffix, else None."""
    if path.suffix.lower() in FIGURE_SUFFIXES:
        return None
    return f"{path}: a figure must end in {', '.join(FIGURE_SUFFIXES)} (the suffix picks the format)"
