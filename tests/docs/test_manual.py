"""The manual builds with --strict (every link and anchor resolves), every page is in it, and the README stays short."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]


def test_the_manual_builds_strictly(tmp_path):
    if shutil.which("mkdocs", path=str(Path(sys.executable).parent)) is None:
        pytest.skip("mkdocs is not installed (it comes with the test extra: pip install -e '.[test]')")
    mkdocs = str(Path(sys.executable).parent / "mkdocs")
    run = subprocess.run([mkdocs, "build", "--strict", "--site-dir", str(tmp_path / "site")], cwd=ROOT,
                         capture_output=True, text=True, env={"NO_MKDOCS_2_WARNING": "1", "PATH": "/usr/bin:/bin"})
    assert run.returncode == 0, run.stderr[-3000:]
    api = (tmp_path / "site" / "api" / "index.html").read_text(encoding="utf-8")
    # The API reference is generated from the docstrings, not written by hand.
    assert "Fit the state rewards that explain" in api and "FitOptions" in api


def test_every_page_is_in_the_nav():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for page in sorted((ROOT / "docs").glob("*.md")):
        assert re.search(rf"\b{re.escape(page.name)}\b", nav), f"docs/{page.name} is not in mkdocs.yml's nav"


def test_the_readme_is_a_start_and_links_only_to_what_exists():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 250
    for target in re.findall(r"\]\(((?!https?:)[^)#]+)(?:#[^)]*)?\)", readme):
        assert (ROOT / target).exists(), f"README links to {target}, which does not exist"


# Measurements, each stated in the one page that measures it (others link there).
MEASURED_ONCE = {"685 s": "benchmarks.md", "363 ms": "benchmarks.md", "20.8 s": "benchmarks.md",
                 "147 MB": "benchmarks.md", "| percentile (used) | 20/20 | 19/20": "fitting.md"}


def test_a_measured_number_is_stated_in_one_page():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for number, home in MEASURED_ONCE.items():
        found = [page.name for page in pages if number in page.read_text(encoding="utf-8")]
        assert found == [home], f"{number!r} is stated in {found}, not only in {home}"
