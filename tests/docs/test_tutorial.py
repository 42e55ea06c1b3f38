"""docs/tutorial.md runs as written: its Python blocks in order, each printed output as the page shows it."""

import contextlib
import io
import re
import shutil
from pathlib import Path

import matplotlib

ROOT = Path(__file__).parents[2]
BLOCK = re.compile(r"```(python|text)\n(.*?)```", re.DOTALL)


def blocks(page: Path) -> list[tuple[str, str | None]]:
    """Each python block with the text block right after it (None when there is none)."""
    found = BLOCK.findall(page.read_text(encoding="utf-8"))
    out: list[tuple[str, str | None]] = []
    for kind, body in found:
        if kind == "python":
            out.append((body, None))
        elif out and out[-1][1] is None:
            out[-1] = (out[-1][0], body)
    return out


def test_the_tutorial_runs_and_prints_what_it_shows(tmp_path, monkeypatch):
    matplotlib.use("Agg")
    shutil.copytree(ROOT / "recordings", tmp_path / "recordings")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    code_blocks = blocks(ROOT / "docs" / "tutorial.md")
    assert len(code_blocks) >= 6
    for code, shown in code_blocks:
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            exec(compile(code, "docs/tutorial.md", "exec"), namespace)
        if shown is not None:
            assert printed.getvalue() == shown, code
    assert (tmp_path / "fit.png").stat().st_size > 10_000
