"""`careful study plan`'s figure: per world, how often a study of n participants and e episodes separates
catastrophe from nuisance, covers the hypothesised rewards, and how wide its hazard interval is."""

from __future__ import annotations

from matplotlib.figure import Figure

from careful_tui.render.figures.style import INK, OKABE_ITO, PAGE_WIDTH, QUIET, figure_style, new_figure, plain, symbol_label
from irl_core.studies.plan import PlanPoint
from irl_core.worlds.world import World

ROW_HEIGHT = 1.7  # inches per world


def plan_figure(points: list[PlanPoint], worlds: tuple[World, ...]) -> Figure:
    """A row per world, three panels (separated, covered, median width of the hazard's interval) over the
    episodes per participant, a line per number of participants."""
    names = list(dict.fromkeys(p.world for p in points))
    with figure_style():
        figure = new_figure(PAGE_WIDTH, ROW_HEIGHT * len(names) + 0.3)
        axes = figure.subplots(len(names), 3, squeeze=False)
        for row, name in enumerate(names):
            mine = [p for p in points if p.world == name]
            world = next(w for w in worlds if w.name == name)
            _row(axes[row], mine, world, first=row == 0, last=row == len(names) - 1)
        studies = points[0].studies if points else 0
        blocks = sorted({p.calibration for p in points if p.calibration})
        block = (f"\neach participant first holding a calibration block of {blocks[0]} targets"
                 if len(blocks) == 1 else "")
        figure.suptitle(f"Simulated studies ({studies} per point): what a study of this size would show{block}",
                        color=INK)
    return figure


def _row(axes, points: list[PlanPoint], world: World, *, first: bool, last: bool) -> None:
    episodes = sorted({p.episodes for p in points})
    sizes = sorted({p.participants for p in points})
    hazard = _hazard(points[0], world)
    pair = [p for p in points if p.separated is not None]
    panels = [("separates hazard from nuisance", lambda p: p.separated, True),
              ("every interval holds the truth", lambda p: p.covered, True),
              (f"median width ({symbol_label(hazard)})" if hazard else "median width",
               lambda p: p.width.get(hazard, float("nan")) if hazard else float("nan"), False)]
    for ax, (title, value, share) in zip(axes, panels):
        for colour, n in zip(OKABE_ITO, sizes):
            ys = [value(p) for e in episodes for p in points if p.participants == n and p.episodes == e]
            if all(y is None for y in ys):
                continue
            ax.plot(episodes, [float("nan") if y is None else y for y in ys], marker="o", markersize=2.5,
                    color=colour, label=f"{n} participants")
        if first:
            ax.set_title(title, loc="left")
        ax.set_xticks(episodes)
        ax.set_xlim(episodes[0] - 0.05 * (episodes[-1] - episodes[0] + 1), episodes[-1] + 0.05 * (episodes[-1] - episodes[0] + 1))
        if share:
            ax.set_ylim(-0.03, 1.03)
            ax.set_yticks([0, 0.5, 1])
            ax.set_yticklabels(["0%", "50%", "100%"])
            ax.axhline(0.8, color="#bbbbbb", linewidth=0.5, linestyle=":", zorder=0)
            ax.text(0.01, 0.81, "80%", transform=ax.get_yaxis_transform(), color=QUIET, fontsize=5, va="bottom")
        else:
            ax.set_ylim(bottom=0)
        if last and title.startswith("every"):
            ax.set_xlabel("main episodes per participant and world")
        if not pair and title.startswith("separates"):
            ax.text(0.5, 0.5, "no nuisance\nin this world", transform=ax.transAxes, ha="center", color=QUIET)
    axes[0].set_ylabel(f"{plain(world.name, limit=20)}\nshare of studies")
    axes[2].set_ylabel("reward units")
    if first:
        axes[1].legend(loc="best")


def _hazard(point: PlanPoint, world: World) -> str | None:
    """The worst terminal symbol with a negative hypothesised reward, or None."""
    hazards = sorted((t, s) for s, t in zip(point.symbols, point.truth) if s in world.terminal and t < 0)
    return hazards[0][1] if hazards else None
