"""`careful fit --figure`: the file, its format, and that it draws the fit's own numbers."""

from __future__ import annotations

import json
import re
import struct
import subprocess
import sys

import numpy as np
import pytest

from careful_tui.cli import main


@pytest.fixture(scope="module")
def mud_recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "mud.jsonl"
    assert main(["simulate", "--world", "mud", "--policy", "optimal", "--episodes", "40", "--seed", "3",
                 "--out", str(path)]) == 0
    return path


@pytest.fixture(scope="module")
def mud_fit(mud_recording):
    from irl_core.irl import fit
    from irl_core.recordings.demonstrations import Demonstrations

    return fit(Demonstrations.read([mud_recording]), method="lp", intervals=True)


def png_dpi(path) -> tuple[float, float]:
    """Dots per inch from a PNG's pHYs chunk (pixels per metre)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    at = 8
    while at < len(data):
        length, kind = struct.unpack(">I4s", data[at : at + 8])
        if kind == b"pHYs":
            x, y, unit = struct.unpack(">IIB", data[at + 8 : at + 17])
            assert unit == 1, "pHYs unit is not the metre"
            return x * 0.0254, y * 0.0254
        at += 12 + length
    raise AssertionError("no pHYs chunk: the PNG does not say its resolution")


def embedded_fonts(path) -> tuple[list[str], int]:
    """The PDF's font names and how many TrueType font programs (FontFile2) it embeds."""
    data = path.read_bytes()
    names = sorted(set(re.findall(rb"/BaseFont /([A-Za-z0-9+-]+)", data)))
    return [n.decode() for n in names], data.count(b"/FontFile2")


def test_figure_as_pdf_embeds_its_font(mud_recording, tmp_path):
    out = tmp_path / "fit.pdf"
    assert main(["fit", str(mud_recording), "--no-view", "--intervals", "--figure", str(out)]) == 0
    assert out.read_bytes().startswith(b"%PDF")
    names, programs = embedded_fonts(out)
    assert names and all(name.split("+")[-1].startswith("DejaVuSans") for name in names)
    assert programs >= 1
    assert b"/Type3" not in out.read_bytes()  # no bitmap-like Type 3 fonts, which journals refuse


def test_figure_as_png_is_300_dpi(mud_recording, tmp_path):
    from PIL import Image

    out = tmp_path / "fit.png"
    assert main(["fit", str(mud_recording), "--no-view", "--figure", str(out)]) == 0
    assert png_dpi(out) == pytest.approx((300, 300), abs=0.01)
    width, _ = Image.open(out).size
    assert width == pytest.approx(5.5 * 300, abs=2)  # a page's text width


def test_figure_as_svg(mud_recording, tmp_path):
    out = tmp_path / "fit.svg"
    assert main(["fit", str(mud_recording), "--no-view", "--figure", str(out)]) == 0
    assert "<svg" in out.read_text()[:500]


def test_bad_suffix_is_refused_before_fitting(mud_recording, tmp_path, capsys, monkeypatch):
    import careful_tui.commands.fit as fit_command

    def no_fitting(*args, **kwargs):
        raise AssertionError("fitted before checking --figure")

    monkeypatch.setattr(fit_command, "fit_from_args", no_fitting)
    out = tmp_path / "fit.jpg"
    assert main(["fit", str(mud_recording), "--no-view", "--figure", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "fit.jpg" in err and ".pdf" in err
    assert not out.exists()


def test_missing_folder_is_refused(mud_recording, tmp_path, capsys):
    assert main(["fit", str(mud_recording), "--no-view", "--figure", str(tmp_path / "no" / "f.png")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_interval_bars_are_the_jsons_intervals(mud_fit):
    from matplotlib.patches import Rectangle

    from careful_tui.render.figures.fit_figure import fit_figure

    figure = fit_figure(mud_fit)
    ax = next(a for a in figure.axes if a.get_label() == "intervals")
    labels = [t.get_text() for t in ax.get_yticklabels()]
    bars = sorted((p for p in ax.patches if isinstance(p, Rectangle)), key=lambda p: p.get_y())
    assert len(bars) == len(labels) == len(mud_fit.labels)
    interval = mud_fit.to_json()["interval"]
    drawn = {}
    for label, bar in zip(labels, bars):
        cell = tuple(int(v) for v in re.findall(r"\d+", label))
        drawn[cell] = (bar.get_x(), bar.get_x() + bar.get_width())
        assert drawn[cell] == pytest.approx(tuple(interval[cell[0]][cell[1]]), abs=1e-9)
    # Each symbol's rows are together, the cliff's next to the mud's.
    symbols = [label.split()[0] for label in labels]
    assert symbols == sorted(symbols, key=["cliff", "mud", "goal"].index)
    assert "identified by the demonstrations" in ax.get_title()


def test_fit_figure_panels(mud_fit):
    from careful_tui.render.figures.fit_figure import fit_figure

    figure = fit_figure(mud_fit)
    names = {ax.get_label() for ax in figure.axes}
    assert {"fitted", "true", "policy", "intervals", "carefulness"} <= names
    fitted = next(ax for ax in figure.axes if ax.get_label() == "fitted")
    assert fitted.get_title() == "fitted reward (lp point estimate)"
    # The image holds the fitted reward, walls and all, cell for cell, except where the reward is bounded on one
    # side only: there no colour (a bound is no point) and the bound in words.
    from irl_core.irl.intervals.honest import bounded_cells

    bounded = bounded_cells(mud_fit)
    expected = np.array(mud_fit.reward_grid, dtype=float, copy=True)
    for row, col in bounded:
        expected[row, col] = np.nan
    shown = fitted.images[0].get_array()
    assert np.allclose(shown.filled(np.nan), expected, equal_nan=True)
    words = {text.get_text() for text in fitted.texts}
    for side, bound in bounded.values():
        assert any(("≤" if side < 0 else "≥") in word for word in words), (side, bound)


def test_playing_and_the_command_line_do_not_import_matplotlib():
    code = ("import sys, careful_tui.screens.play, careful_tui.cli, careful_tui.commands.fit, careful_tui.commands.experiment, "
            "careful_tui.render.figures; print(sorted(m for m in sys.modules if m.split('.')[0] == 'matplotlib'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert json.loads(out.replace("'", '"')) == []


def test_confidence_intervals_are_labelled_and_drawn_as_the_json_says(tmp_path):
    from careful_tui.render.figures.fit_figure import fit_figure
    from irl_core.irl import fit
    from irl_core.recordings.demonstrations import Demonstrations

    path = tmp_path / "noisy.jsonl"
    assert main(["simulate", "--world", "mud", "--policy", "boltzmann", "--beta", "0.5", "--episodes", "30",
                 "--seed", "2", "--out", str(path)]) == 0
    result = fit(Demonstrations.read([path]), method="maxent", beta="auto", tie=True, intervals=True,
                 resamples=20, workers=1)
    data = result.to_json()
    assert data["interval_kind"] == "confidence"
    ax = next(a for a in fit_figure(result).axes if a.get_label() == "intervals")
    assert ax.get_title().startswith("95% confidence intervals")
    labels = [t.get_text() for t in ax.get_yticklabels()]
    bars = sorted((p for p in ax.patches if type(p).__name__ == "Rectangle"), key=lambda p: p.get_y())
    first_cell = {"cliff": (3, 1), "mud": (1, 1), "goal": (3, 5)}
    for label, bar in zip(labels, bars):
        r, c = first_cell[label]
        assert (bar.get_x(), bar.get_x() + bar.get_width()) == pytest.approx(tuple(data["interval"][r][c]))
