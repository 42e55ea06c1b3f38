"""Every exception careful raises on purpose, in one tree, so that a caller catches a branch in one `except`.

The tree; a builtin base in brackets is the one the class had before the tree, kept so that an
``except ValueError`` or ``except OSError`` catches what it always caught::

    CarefulError            anything careful raises on purpose; any other exception is a bug
        InputError          careful refused the user's input [ValueError]: one line on stderr, exit 2
            UsageError      a command's value found bad after parsing (out of range, a file that exists)
            OutputError     an output path a command must not write, or could not write
            WorldError      a world file or name that cannot be used
            RecordingError  a recording that cannot be used: `file:line: field: problem`
                EmptyRecording    a recording without a single line
            SpreadLawError  a spread law file (`careful fit --spread-law`) that cannot be used: `file:line: field: problem`
            TableError      a trial table (or its column map) `careful import` refuses: every refused row, one line each
            Mismatch        a recording's line at odds with its world or the lines before (read as a RecordingError)
            StudyError      a study file or participant id that cannot be used
                ParticipantBusy   another session holds this participant
                SeatUnavailable   careful serve: a request's seat cannot be read (participant busy, disk full)
            LinksError      careful serve's links.csv cannot be read or written
            PlanError       an option of `careful study plan` (`field` names it)
            SchedulerError  a --scheduler that cannot be used
                ClusterLost       the cluster lost every worker, or its scheduler, mid-run (`missing`: calls not done)
            CalibrationError  a calibration file that cannot be used, or one learned on another design
            NotConverged    value iteration stopped at its cap: no expert for this world's gamma (or beta)
            BadInputError   demonstrations that cannot be fitted as given (also a FitError: its `code`)
                InfeasibleError   no reward satisfies the constraints: the demonstrations or the bound
        FitError            a fit that produced no reward [RuntimeError]: a stable `code` and one sentence;
                            its kinds are BadInputError (the input's fault) and SolverError (careful's)
        InternalError       careful failed on input it had accepted: a solver, a worker, the system, a bug
            SolverError     the solver failed or gave up (also a FitError: its `code`)
            LostCall        a call whose worker died, and which the cluster could not rerun [RuntimeError]
            RecordingLost   the recording being written was deleted, or its folder was [OSError]
            GameOver        a move asked for when no episode is running: a programmer's error [RuntimeError]
        RequestRefused      careful serve refused a browser's request: a 4xx answer, never raised past the server
            SeatRefused     no seat for this page: `status` and a sentence for the participant
            KeyRefused      a key event the session cannot take [ValueError]
            BodyTooLarge    a request body over the server's limit (413)
            BodyTooSlow     a request body that did not arrive in time (408)
        Stopped             not an error: the work was stopped on request (`stop_when`) [RuntimeError]

`Stopped` is control flow, not a failure: it sits under `CarefulError` because careful raises it on
purpose, but beside the error branches, so neither ``except InputError`` nor ``except InternalError``
takes it. `careful_tui.cli` catches `InputError` in one place (one line on stderr, exit 2); anything else
that reaches it is an unexpected error (exit 1). Commands that say an error in their own words (`careful
fit`'s `SolverError`, `careful study plan`'s `PlanError`) catch it first, as before.

The terminal's and the web server's exceptions are here too (careful_tui imports irl_core, never the
reverse). This module imports nothing of the project, so every module may import it.
"""

from __future__ import annotations

import re
from pathlib import Path

# As `irl_core.support.safe_text.VALUE_LIMIT` and `cut`, and `irl_core.irl.notes`'s wording of an option:
# copied, since this module imports nothing of the project (tests/core/test_errors.py holds them alike).
_VALUE_LIMIT = 80
_OPTION = re.compile(r"\{(\w+)(?:=([^{}]*))?\}")


def _cut(text: str, limit: int) -> str:
    """`text` cut to about `limit` characters, saying how long it was (`safe_text.cut`)."""
    return text if len(text) <= limit else f"{text[: max(1, limit - 24)]}… ({len(text):,} characters)"


def _python_option(match: re.Match[str]) -> str:
    """An option of a sentence as `fit`'s keyword: rmax, method="loss", intervals=True (`notes.python_option`)."""
    name, value = match[1], match[2]
    if value is None:
        return name
    try:
        float(value)
        literal = True
    except ValueError:
        literal = value in ("True", "False", "None")
    return f"{name}={value}" if literal else f'{name}="{value}"'


class CarefulError(Exception):
    """Anything careful raises on purpose (the module's docstring draws the tree)."""


# ---------------------------------------------------------------------- the user's input (exit 2)


class InputError(CarefulError, ValueError):
    """Careful refused the user's input: a file, a name or a value it was given that cannot be used.

    The command line prints the message (one line) and exits 2. Every reader raises its own subclass
    (`RecordingError`, `WorldError`, `StudyError`) for every problem of what it reads, and nothing
    else, so that a caller who catches this one type never lets one bad file stop a command (or a
    study's other participants).
    """


class UsageError(InputError):
    """Bad input found after parsing (a value out of range, a file that exists): exit 2."""


class OutputError(InputError):
    """An output path a command must not write, or could not write; the message is one line."""


class WorldError(InputError):
    """A world file or name that cannot be used; the message is one sentence for the user."""


def _file_line_field(path: str, line: int | None, field: str | None, problem: str) -> str:
    """`file:line: field: problem`, the path and field cut to a readable length."""
    where = _cut(path, 200) if line is None else f"{_cut(path, 200)}:{line}"
    field = None if field is None else _cut(field, _VALUE_LIMIT)
    return f"{where}: {field}: {problem}" if field else f"{where}: {problem}"


class RecordingError(InputError):
    """A recording that cannot be used. `str()` is `file:line: field: problem`."""

    def __init__(self, path: str | Path, line: int | None, field: str | None, problem: str):
        self.path, self.line, self.field, self.problem = str(path), line, field, problem
        super().__init__(_file_line_field(self.path, line, field, problem))


class EmptyRecording(RecordingError):
    """A recording without a single line (what a failed first write used to leave)."""


class SpreadLawError(InputError):
    """A spread law file `careful fit --spread-law` refuses (not a law, another world's, a negative a or b).
    `str()` is `file:line: field: problem`, as a `RecordingError`'s."""

    def __init__(self, path: str | Path, line: int | None, field: str | None, problem: str):
        self.path, self.line, self.field, self.problem = str(path), line, field, problem
        super().__init__(_file_line_field(self.path, line, field, problem))


class TableError(InputError):
    """A trial table, or its column map, that `careful import` refuses: `problems` holds every refused row as
    one line, `file:line: column: why`; `str()` is the first of them and how many more there are."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems) or ["the table was refused"]
        more = len(self.problems) - 1
        super().__init__(self.problems[0] + (f" (and {more} more refused)" if more else ""))


class Mismatch(InputError):
    """A line that disagrees with the world or the lines before it: its number, field and problem."""

    def __init__(self, line: int, field: str, problem: str):
        super().__init__(f"{line}: {field}: {problem}")
        self.line, self.field, self.problem = line, field, problem


class StudyError(InputError):
    """A study file or participant id that cannot be used; the message is one line for the user."""


class ParticipantBusy(StudyError):
    """Another session holds this participant; `holder` says who ("careful study run (process 41 on lab-3, since ...)")."""

    def __init__(self, participant: str, holder: str):
        self.participant, self.holder = participant, holder
        super().__init__(f"participant {participant} is in another session already: {holder}; "
                         "let that one finish (or quit it) first")


class SeatUnavailable(StudyError):
    """A request's seat cannot be read: another session holds the participant (`cause` is
    `ParticipantBusy`), or the lock or the seat file cannot be made (a full disk)."""

    def __init__(self, participant: str, cause: Exception) -> None:
        super().__init__(str(cause))
        self.participant, self.cause = participant, cause


class LinksError(InputError):
    """links.csv cannot be read or written; the message is one line naming the file (and line)."""


class PlanError(InputError):
    """A plan's input that cannot be used: `field` names the option, the message says why."""

    def __init__(self, field: str, reason: str) -> None:
        super().__init__(f"{field}: {reason}")
        self.field, self.reason = field, reason


class SchedulerError(InputError):
    """A scheduler that cannot be used: the address and the reason, in one line."""


class ClusterLost(SchedulerError):
    """The cluster lost every worker, or its scheduler, mid-run: the address, what was lost, and `missing` (the
    indices of the calls not done)."""

    def __init__(self, message: str, missing: tuple[int, ...] = ()) -> None:
        super().__init__(message)
        self.missing = missing


class CalibrationError(InputError):
    """A calibration (careful check's calibration.json) that cannot be read, or was learned on another world or
    other fit options: one line naming the file (and line) and the field."""


class NotConverged(InputError):
    """Value iteration stopped at its cap before converging: its policy is not the expert asked for."""


# ---------------------------------------------------------------------- a fit that ended without a reward


class FitError(CarefulError, RuntimeError):
    """A fit that produced no reward: a stable `code` and one sentence for the user, with the
    options it names written as in `Note` (`str()` says them as `fit`'s parameters, `worded` as
    a front end's). Each subclass has a default code; a raise may give a finer one."""

    code = "fit_failed"

    def __init__(self, sentence: str, *, code: str | None = None) -> None:
        super().__init__(sentence)
        self.sentence = sentence
        if code is not None:
            self.code = code

    def __str__(self) -> str:
        return _OPTION.sub(_python_option, self.sentence)

    def __reduce__(self):  # a study report's worker sends it back: keep the code
        return _rebuilt, (type(self), self.sentence, self.code)


def _rebuilt(kind: type[FitError], sentence: str, code: str) -> FitError:
    return kind(sentence, code=code)


class BadInputError(FitError, InputError):
    """Demonstrations that cannot be fitted as given: the user's to fix (exit 2)."""

    code = "bad_input"


class InfeasibleError(BadInputError):
    """No reward satisfies the constraints: the demonstrations or the bound are at fault."""

    code = "infeasible"


# ---------------------------------------------------------------------- careful's own failures (exit 1)


class InternalError(CarefulError):
    """Careful failed on input it had accepted: a solver that gave up, a worker lost, a file deleted
    while it was written, a bug. Not the user's to fix by changing the input (exit 1)."""


class SolverError(FitError, InternalError):
    """The solver failed or gave up (exit 1)."""

    code = "solver_failed"


class LostCall(InternalError, RuntimeError):
    """A call whose worker died, and which the cluster could not rerun."""


class RecordingLost(InternalError, OSError):
    """The file being written was deleted (or its folder was): what is written now goes nowhere."""


class GameOver(InternalError, RuntimeError):
    """A move was asked for when no episode is running (a programmer's error)."""


# ---------------------------------------------------------------------- the web server's refusals


class RequestRefused(CarefulError):
    """`careful serve` refused a browser's request: the server answers it with a 4xx status and goes on."""


class SeatRefused(RequestRefused):
    """No seat for this page: `status` and a sentence for the participant."""

    def __init__(self, status: int, why: str) -> None:
        super().__init__(why)
        self.status, self.why = status, why


class KeyRefused(RequestRefused, ValueError):
    """A key event the session cannot take (an unknown key, a time that is not a number)."""


class BodyTooLarge(RequestRefused):
    """A request body over the server's limit (answered 413)."""


class BodyTooSlow(RequestRefused):
    """A request body that did not arrive in time (answered 408)."""


# ---------------------------------------------------------------------- not an error


class Stopped(CarefulError, RuntimeError):
    """The work (a fit, a study report's fits) was stopped on request before it ended (`stop_when`)."""

    def __init__(self, message: str = "the fit was stopped before it ended"):
        super().__init__(message)
