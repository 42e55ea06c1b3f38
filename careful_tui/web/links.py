"""Participant links (`careful serve --links N`): unguessable tokens bound to participant ids in
``<out>/links.csv``, and the ids a Prolific link brings.

The two never meet: a Prolific participant's id is ``prolific-<PROLIFIC_PID>`` (`PROLIFIC_PREFIX`),
and no link's id may start so, so a Prolific link can never name (play as, or end as) a link
participant, whose ids are guessable; only a link's token reaches its participant.

``links.csv`` has the columns ``participant,token,path``; the path is the link without its host
(``/p/<token>``), as the server may sit behind a proxy whose address only the experimenter knows.
New links come after the ones the file holds, their ids continuing the numbering (``p001``,
``p002``, ...) and skipping any id that already has a folder; the old rows are kept as they are.
The file is written whole beside itself and renamed into place (`built_beside`), so a full disk or
a kill leaves the old file (or none), never a row cut short. It is readable by its owner only, as
its tokens let anyone play as the participant.
"""

from __future__ import annotations

import csv
import io
import os
import re
import secrets

from irl_core.errors import LinksError, StudyError
from irl_core.studies.study import LoadedStudy, check_participant
from irl_core.support.safe_files import built_beside, write_problem
from irl_core.support.safe_text import printable

LINKS_FILE = "links.csv"
PROLIFIC_PREFIX = "prolific-"
# The most links one start may add: each is a row and a check of the folders (a billion ran out of memory).
MOST_LINKS = 100_000
FIELDS = ("participant", "token", "path")
_NUMBERED = re.compile(r"p(\d+)")
_TOKEN = re.compile(r"[A-Za-z0-9_-]{16,64}")
# Prolific's study and session ids: 24 hex digits today; anything like a name of at most 80 is taken.
_PROLIFIC_ID = re.compile(r"[A-Za-z0-9_.=-]{1,80}")


def link_path(token: str) -> str:
    return f"/p/{token}"


def read_links(study: LoadedStudy) -> dict[str, str]:
    """The links in ``<out>/links.csv`` (none when it does not exist), as token -> participant."""
    path = study.out / LINKS_FILE
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return {}
    except (OSError, UnicodeDecodeError) as exc:
        raise LinksError(f"{path}: cannot read the links file ({getattr(exc, 'strerror', None) or exc})") from None
    rows = csv.reader(io.StringIO(text))
    links: dict[str, str] = {}
    for number, row in enumerate(rows, start=1):
        if number == 1 and tuple(row) == FIELDS:
            continue
        if len(row) != len(FIELDS):
            raise LinksError(f"{path}: line {number}: expected {len(FIELDS)} fields ({', '.join(FIELDS)}), "
                             f"got {len(row)}")
        participant, token, _ = row
        try:
            check_participant(participant)
        except StudyError as exc:
            raise LinksError(f"{path}: line {number}: participant: {exc}") from None
        if participant.startswith(PROLIFIC_PREFIX):
            raise LinksError(f"{path}: line {number}: participant: {participant!r} starts with {PROLIFIC_PREFIX!r}, "
                             "which only Prolific participants' ids do")
        if not _TOKEN.fullmatch(token):
            raise LinksError(f"{path}: line {number}: token: {printable(token, limit=40)!r} is not a link token")
        links[token] = participant
    return links


def add_links(study: LoadedStudy, count: int) -> list[tuple[str, str]]:
    """Add `count` new links to ``<out>/links.csv`` (creating it), written whole; returns them as (participant, token).

    Raises:
        LinksError: the file cannot be read or written.
    """
    path = study.out / LINKS_FILE
    existing = read_links(study)
    taken = set(existing.values())
    numbers = [int(m.group(1)) for m in map(_NUMBERED.fullmatch, taken) if m]
    width = max(3, len(str(max(numbers, default=0) + count)))
    new: list[tuple[str, str]] = []
    n = max(numbers, default=0)
    while len(new) < count:
        n += 1
        participant = f"p{n:0{width}d}"
        if participant in taken or study.participant_folder(participant).exists():
            continue
        new.append((participant, secrets.token_urlsafe(16)))
    try:
        old = path.read_bytes() if existing else b""
    except FileNotFoundError:
        old = b""
    except OSError as exc:
        raise LinksError(f"{path}: cannot read the links file ({exc.strerror or exc})") from None
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    if not old:
        writer.writerow(FIELDS)
    elif not old.endswith(b"\n"):
        out.write("\n")
    writer.writerows((participant, token, link_path(token)) for participant, token in new)
    try:
        study.out.mkdir(parents=True, exist_ok=True)
        with built_beside(path, replace=True) as temporary:
            fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o600)
            with os.fdopen(fd, "wb") as file:  # a buffered file writes all or raises (os.write may write part)
                file.write(old + out.getvalue().encode("utf-8"))
    except OSError as exc:
        raise LinksError(f"{path}: cannot write the links file ({write_problem(exc)})") from None
    return new


def prolific_ids(pid: str, study_id: str, session_id: str) -> tuple[str, str, str]:
    """A Prolific link's ``PROLIFIC_PID``, ``STUDY_ID`` and ``SESSION_ID``, checked; returns the
    participant's id (``prolific-<PROLIFIC_PID>``) and the other two.

    Raises:
        StudyError: the participant id fails the study's id rules, or another id is not a plain name.
    """
    check_participant(pid)
    participant = check_participant(PROLIFIC_PREFIX + pid) if len(pid) <= 80 - len(PROLIFIC_PREFIX) else None
    if participant is None:
        raise StudyError(f"PROLIFIC_PID {printable(pid, limit=40)!r} is too long: Prolific's are 24 letters and digits")
    for name, value in (("STUDY_ID", study_id), ("SESSION_ID", session_id)):
        if not _PROLIFIC_ID.fullmatch(value):
            raise StudyError(f"{name} {printable(value, limit=40)!r} is not an id: Prolific's are letters and digits")
    return participant, study_id, session_id
