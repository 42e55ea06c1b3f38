"""A full disk never leaves a short file under a final name, and is a clear refusal.

`careful serve --links` on a full disk said "line 77: expected 3 fields" and left links.csv cut
mid-row, so every later start refused; a new participant got "Internal Server Error" from the
lock file's holder text (issue 31). Now: exit 2 with "disk full" and no links.csv (or the old
one whole); a 503 with the one JSON error shape for the page.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hardening_checks import fill, tiny_filesystem
from starlette.testclient import TestClient
from web.conftest import Api, web_app, write_web_study

from careful_tui.cli import main
from careful_tui.web.links import LINKS_FILE, read_links
from irl_core.studies.study import load_study


@pytest.fixture
def full_disk(tmp_path: Path):
    with tiny_filesystem(tmp_path / "disk", size="256k") as disk:
        yield disk


def test_links_on_a_full_disk_exit_2_saying_so_and_leave_no_short_file(full_disk: Path, capsys) -> None:
    study = write_web_study(full_disk)
    (full_disk / "data").mkdir()
    fill(full_disk)
    assert main(["serve", str(study), "--port", "0", "--links", "200"]) == 2
    err = capsys.readouterr().err
    assert "disk full" in err and len(err.strip().splitlines()) == 1, err
    assert not (full_disk / "data" / LINKS_FILE).exists()


def test_links_added_on_a_full_disk_leave_the_old_file_whole(full_disk: Path, capsys) -> None:
    study_path = write_web_study(full_disk)
    study = load_study(study_path)
    app, tokens = web_app(study, links=3)
    before = (full_disk / "data" / LINKS_FILE).read_bytes()
    fill(full_disk)
    assert main(["serve", str(study_path), "--port", "0", "--links", "500"]) == 2
    assert "disk full" in capsys.readouterr().err
    assert (full_disk / "data" / LINKS_FILE).read_bytes() == before
    (full_disk / "filler").unlink()
    assert set(read_links(study).values()) == set(tokens)


def test_a_new_participant_on_a_full_disk_gets_a_503_in_the_one_error_shape(full_disk: Path) -> None:
    study = load_study(write_web_study(full_disk))
    app, tokens = web_app(study, links=2)
    fill(full_disk)
    with TestClient(app) as client:
        answer = Api(client, token=tokens["p001"]).answer
    assert answer.status_code == 503
    body = answer.json()
    assert set(body) == {"error"} and "try again" in body["error"].lower()
    assert "Traceback" not in answer.text and "errno" not in answer.text.lower()
