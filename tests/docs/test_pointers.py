"""Every pointer from the code into the manual resolves: ``docs/X.md``, ``docs/X.md#anchor``,
``docs/X.md, "Heading"`` and ``README "Heading"`` in any module of irl_core, careful_tui or bench name a
real page and a real heading (a section that moved leaves no pointer behind)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
PAGE = re.compile(r"docs/([a-z0-9_-]+\.md)(?:#([a-z0-9-]+)|,? \"([^\"]+)\")?")
README = re.compile(r"README \"([^\"]+)\"")


def slug(heading: str) -> str:
    """The anchor MkDocs gives a heading (Python-Markdown's toc: lower case, punctuation dropped, dashes)."""
    text = re.sub(r"[^\w\s-]", "", heading).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def headings(path: Path) -> set[str]:
    lines = path.read_text(encoding="utf-8").splitlines()
    return {line.lstrip("#").strip() for line in lines if line.startswith("#")}


def pointers() -> list[tuple[str, str, str | None, str | None]]:
    found = []
    for package in ("irl_core", "careful_tui", "bench"):
        for path in sorted((ROOT / package).rglob("*.py")):
            text = path.read_text(encoding="utf-8")
            where = str(path.relative_to(ROOT))
            found += [(where, page, anchor, heading) for page, anchor, heading in PAGE.findall(text)]
            found += [(where, "README.md", None, heading) for heading in README.findall(text)]
    return found


def test_the_checker_finds_pointers_and_knows_a_slug():
    assert len(pointers()) > 50
    assert slug("On a cluster") == "on-a-cluster" and slug("Planning a study") == "planning-a-study"


@pytest.mark.parametrize("where, page, anchor, heading", pointers())
def test_every_pointer_names_a_real_page_and_heading(where, page, anchor, heading):
    path = ROOT / page if page == "README.md" else ROOT / "docs" / page
    assert path.is_file(), f"{where}: {page} does not exist"
    if anchor:
        assert anchor in {slug(h) for h in headings(path)}, f"{where}: {page}#{anchor} names no heading"
    if heading:
        assert heading in headings(path) or slug(heading) in {slug(h) for h in headings(path)}, (
            f"{where}: {page} has no heading {heading!r}")
