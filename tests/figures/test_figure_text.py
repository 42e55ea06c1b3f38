"""Text from a file reaches every figure as text: never mathtext, never a control character.

Each command that draws figures gets a world (and, in a study, a participant) whose name holds
`$`, `$x^2$`, a `$` without its pair, a newline, an ESC sequence and `[bold]`, and layout symbols
`$`, `^` and `_`. The figure must draw; the SVG (saved with `svg.fonttype: none`, so that text
stays text, not paths) must hold what the figure shows of them as `printable` shows it (`$` as
`$`, ESC as `\\x1b`); and no Text artist may be mathtext or hold a control character, so a name
added to a figure later without `plain` fails here. The fit and experiment figures show symbols
only (no names); the study report's show the world's name and each participant's id.
"""

from __future__ import annotations

import dataclasses
import io
import xml.etree.ElementTree as ET

import matplotlib as mpl
import numpy as np
import pytest
from matplotlib.cbook import is_math_text
from matplotlib.text import Text

from careful_tui.cli import main
from careful_tui.render.figures import style
from careful_tui.render.figures.style import figure_style, plain
from irl_core.support.safe_text import printable
from irl_core.worlds.world import World

# Four `$`: read as mathtext, "$ \x1b[31m...a_b$" would not parse (matplotlib raises on "\x").
HOSTILE = "$5 $x^2$ \x1b[31m\n[bold] a_b$"
SHOWN = printable(HOSTILE)  # what a reader must see: `$` as it is, ESC and the newline as escapes
LAYOUT = """
......
.$^_..
......
.CCCCG
"""
SVG_TEXT = "{http://www.w3.org/2000/svg}text"


HOSTILE_WORLD = World(name=HOSTILE, layout=LAYOUT, levels=3,
                      rewards={"C": -100.0, "G": 10.0, "$": -5.0, "^": -3.0, "_": -2.0})


def svg_texts(svg: str) -> list[str]:
    """The text of every <text> element of an SVG saved with `svg.fonttype: none`."""
    return ["".join(element.itertext()) for element in ET.fromstring(svg).iter(SVG_TEXT)]


def figure_texts(figure) -> list[str]:
    """Save `figure` as SVG with its text kept as text; returns every text drawn."""
    buffer = io.StringIO()
    with figure_style(), mpl.rc_context({"svg.fonttype": "none"}):
        figure.savefig(buffer, format="svg")
    return svg_texts(buffer.getvalue())


def assert_every_text_is_plain(figure) -> None:
    """No Text artist of `figure` is mathtext or holds a control character (a line break of its own is fine)."""
    for text in figure.findobj(Text):
        content = text.get_text()
        assert not text.get_usetex(), content
        assert not is_math_text(content), f"{content!r} would be drawn as mathtext"
        assert printable(content, keep_newlines=True) == content, f"{content!r} holds a control character"


def test_plain_escapes_dollars_and_controls_and_matplotlib_draws_them_as_written():
    assert plain("a$b\x1b") == "a\\$b\\x1b"
    # A long name keeps as much of itself as fits, and the ellipsis says it was cut.
    assert plain("participant-" + "x" * 100) == "participant-" + "x" * 27 + "…"
    assert plain("y" * 40) == "y" * 40
    figure = mpl.figure.Figure()
    with figure_style():
        figure.subplots().set_title(plain(HOSTILE))
    assert any(text == SHOWN for text in figure_texts(figure))
    assert_every_text_is_plain(figure)


def test_a_users_usetex_setting_never_reaches_a_figure(monkeypatch):
    """`figure_style` starts from matplotlib's defaults, so a matplotlibrc's `text.usetex` is off in figures."""
    monkeypatch.setitem(mpl.rcParams, "text.usetex", True)
    with figure_style():
        assert mpl.rcParams["text.usetex"] is False
        assert mpl.rcParams["text.parse_math"] is True  # so `plain`'s `\$` is drawn as `$`


def test_fit_figure_of_a_hostile_world_draws_and_shows_its_symbols(tmp_path, monkeypatch):
    """`careful fit --figure`: the world's symbols in cells and interval rows, as written."""
    world = tmp_path / "hostile.toml"
    world.write_text(HOSTILE_WORLD.to_toml())
    recording = tmp_path / "hostile.jsonl"
    assert main(["simulate", "--world", str(world), "--policy", "optimal", "--episodes", "30", "--seed", "1",
                 "--out", str(recording)]) == 0
    out = tmp_path / "fit.svg"
    monkeypatch.setitem(style.RC, "svg.fonttype", "none")
    assert main(["fit", str(recording), "--no-view", "--method", "lp", "--intervals", "--figure", str(out)]) == 0
    texts = svg_texts(out.read_text())
    assert {"$ (1, 1)", "^ (1, 2)", "_ (1, 3)"} <= set(texts)  # the interval rows
    assert {"$", "^", "_"} <= set(texts)  # the symbols in the reward grids' cells

    from careful_tui.render.figures.fit_figure import fit_figure
    from irl_core.irl import fit
    from irl_core.recordings.demonstrations import Demonstrations

    assert_every_text_is_plain(fit_figure(fit(Demonstrations.read([recording]), method="lp", intervals=True)))


def test_experiment_figures_of_a_hostile_world_draw_as_text():
    """`careful experiment` draws its own worlds; its figure code still shows a world's symbols as written."""
    from careful_tui.render.figures.board import Board
    from careful_tui.render.figures.experiment_figures import draw_experiment_figure
    from irl_core.experiment.run import ExperimentResult, Figure

    world = HOSTILE_WORLD
    result = ExperimentResult(figures=[
        Figure("fig4-true-reward", HOSTILE, world, values=Board.for_world(world).rewards(world)),
        Figure("fig3-optimal-policy", HOSTILE, world, policy={(0, 0): ("right", 2)}),
    ])
    for figure in result.figures:
        drawn = draw_experiment_figure(figure, result, rmax=1000.0)
        assert {"$", "^", "_"} <= set(figure_texts(drawn))  # in the cells (without an arrow in the policy)
        assert_every_text_is_plain(drawn)


@pytest.fixture(scope="module")
def hostile_study(tmp_path_factory):
    """A study of one hostile world, two simulated participants, gathered (not fitted)."""
    from study.conftest import write_study

    from irl_core.studies.report import gather
    from irl_core.studies.simulated import simulated_participants, write_simulated_participant
    from irl_core.studies.study import load_study

    folder = tmp_path_factory.mktemp("study")
    (folder / "hostile.toml").write_text(HOSTILE_WORLD.to_toml())
    study = load_study(write_study(folder, worlds='["hostile.toml"]', practice=0, episodes=3))
    for who in simulated_participants(2, betas=(0.5, 2.0)):
        write_simulated_participant(study, who, phases=("main",))
    return gather(study)


def given_fits(data):
    """A fit per cell, made up (a study's fits take too long for a test): the true reward, ±5."""
    from irl_core.studies.report import CellFit

    world = data.study.worlds[0]
    symbols = tuple(sorted(world.rewards))
    estimate = np.array([world.reward_of(s) for s in symbols])
    grid = np.array([[world.reward_of(ch) for ch in row] for row in world.grid])
    return [CellFit(method="maxent", beta=1.0, beta_auto=True, symbols=symbols, estimate=estimate,
                    intervals=np.stack([estimate - 5, estimate + 5], axis=1), truth=estimate,
                    interval_kind="confidence", confidence=0.95, rmax=5000.0, reward_grid=grid)
            for _ in data.cells]


def test_study_report_figures_show_the_world_and_each_participant_as_written(hostile_study):
    """`careful study report`: the world's name in every title, participants' ids as panel titles.

    A participant id is a checked folder name today; the figures do not lean on that rule, so
    ids are given a hostile value here.
    """
    from careful_tui.render.figures.study_figures import report_figures, world_key

    renamed = {p: f"{p} {HOSTILE}" for p in hostile_study.participants}
    cells = tuple(dataclasses.replace(cell, participant=renamed.get(cell.participant, cell.participant))
                  for cell in hostile_study.cells)
    data = dataclasses.replace(hostile_study, cells=cells)
    figures = dict(report_figures(data, given_fits(data)))
    key = world_key(data, 0)
    assert sorted(figures) == [f"carefulness-{key}", "intervals-pooled", f"rewards-{key}"]
    for name, figure in figures.items():
        texts = figure_texts(figure)
        lines = " ".join(texts)  # a long title is drawn as lines broken at spaces
        assert SHOWN in lines, name  # in the title
        if not name.startswith("intervals"):
            for participant in renamed.values():
                assert printable(participant, limit=40) in lines, name  # a panel's title
        else:
            assert {"$", "^", "_"} <= set(texts)  # the interval rows of symbols without a name
        assert_every_text_is_plain(figure)
        # Long names are broken into lines: no title runs into another or off the figure.
        titles = [ax.title.get_window_extent() for ax in figure.axes if ax.get_visible() and ax.get_title()]
        titles += [text.get_window_extent() for text in figure.texts]  # suptitle, shared axis labels
        page = figure.bbox
        for i, box in enumerate(titles):
            assert page.x0 - 1 <= box.x0 and box.x1 <= page.x1 + 1, name
            assert not any(box.overlaps(other) for other in titles[i + 1:]), name


def test_study_report_command_writes_figures_of_a_hostile_world(hostile_study, tmp_path):
    """The whole command, with its fits (PNG and PDF only): every figure is written."""
    out = tmp_path / "report"
    code = main(["study", "report", str(hostile_study.study.path), "--out", str(out), "--resamples", "20",
                 "--workers", "1"])
    assert code == 0
    pngs = sorted(path.name for path in out.glob("*.png"))
    assert len(pngs) == 3, pngs
