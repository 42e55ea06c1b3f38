"""A trial table made recordings (docs/import.md): `careful import`'s work, without a terminal.

`import_table` reads a table (`trial_table`) through a column map (`table_map`) into a world: every row
becomes a step of its participant's recording, its cell translated from the table's coordinates
(``axes``, ``origin``), its action code through ``[actions]``, its response time into ``hold_ms``
(``hold_exact`` false: a response time is not a timed key release), its level (1 without a ``level``
column). Within a participant, episodes are ordered by number (a label that is not a whole number is
numbered by its first row), and an episode's moves by ``t`` (else by the rows' order).

==============  ===========================================================================
a step          ``next_state`` from the table, else the next row's cell, else (the last
                move) where the chosen direction leads; ``slipped`` where that differs from
                where the chosen direction leads; ``reward`` and ``score`` by the world's
                rules, as `irl_core.play.game` gives them
an episode end  ``terminal`` when the last move entered a terminal cell, ``step_limit``
                when the episode has the world's ``max_steps`` moves, else ``quit``
==============  ===========================================================================

Every row is checked as the recordings' reader checks a step (`line_checks.LineChecker`: a move the world
can make, each starting where the last one ended) and every refused row is named, `file:line: column:
why`, in one `TableError`; nothing is written then. `write_imported` writes one recording per participant
with the recordings' writer, reads them all back with the recordings' reader, and only then puts them
in place under their names, so a refused table, a failed write or a kill leaves no recording behind.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, Literal, NamedTuple

from irl_core.errors import InternalError, Mismatch, OutputError, TableError
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.recordings.line_checks import LineChecker
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.table_map import ColumnMap, code_text
from irl_core.recordings.trial_table import Table, TableRow, read_table
from irl_core.recordings.writer import RecordingWriter
from irl_core.support.plural import plural
from irl_core.support.safe_files import (
    SAFE_NAME,
    SAFE_NAME_RULE,
    check_output_folder,
    rename_no_replace,
    temporary_name,
)
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.mdp import DIRECTIONS, MDP, action_index, build_mdp
from irl_core.worlds.world import WALL, Cell, Direction, World

BodyLine = Step | EpisodeEnd


class _Move(NamedTuple):
    """One accepted row, before its episode is put together."""

    line: int
    order: float
    state: Cell
    direction: Direction
    level: int | None
    hold_ms: float | None
    next_state: Cell | None
    refused: bool = False  # a refused row keeps its place: the moves on either side are not one path


@dataclass
class ImportedTable:
    """What a table became: each participant's lines (steps and episode ends, in file order), by id in the
    order of their first row."""

    path: Path
    world: World
    participants: dict[str, list[BodyLine]] = field(default_factory=dict)

    @property
    def steps(self) -> int:
        return sum(isinstance(line, Step) for lines in self.participants.values() for line in lines)

    @property
    def episodes(self) -> int:
        return sum(isinstance(line, EpisodeEnd) for lines in self.participants.values() for line in lines)

    def summary(self) -> str:
        return (f"{plural(len(self.participants), 'participant')}, {plural(self.episodes, 'episode')}, "
                f"{plural(self.steps, 'step')}")


# ---------------------------------------------------------------------------- cells


def _refused(why: str) -> TableError:
    """A cell that cannot be read: why, named with its line and column where the row is read (`_Importer.refuse`)."""
    return TableError([why])


def _whole(value: Any) -> int:
    """A whole number from a cell: 3, 3.0, "3", " 3.0 "; anything else is refused."""
    if isinstance(value, bool):
        raise _refused(f"{str(value).lower()} is not a number")
    if isinstance(value, int):
        return value
    if isinstance(value, str):
        try:
            return int(value)
        except ValueError:
            pass  # "3.0", " ", "x": as a number below
    number = _number(value)
    if number is None:
        raise _refused("empty: a whole number was expected")
    if not number.is_integer():
        raise _refused(f"{_brief(value)} is not a whole number")
    return int(number)


def _number(value: Any) -> float | None:
    """A finite number from a cell (None for an empty cell or JSON null); anything else is refused."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise _refused(f"{_brief(value)} is not a number")
    if isinstance(value, str):
        try:
            number = float(value)  # surrounding blanks allowed
        except ValueError:
            if not value.strip():
                return None
            raise _refused(f"{_brief(value)} is not a number") from None
    else:
        number = float(value)
    if not math.isfinite(number):
        raise _refused(f"{_brief(value)} is not a finite number")
    return number


def _label(value: Any) -> str:
    """A participant's or an episode's name from a cell: text, or a whole number written as one."""
    if isinstance(value, bool) or value is None or not isinstance(value, int | float | str):
        raise _refused(f"{_brief(value)} is not a name")
    text = code_text(value)
    if not text:
        raise _refused("empty")
    return text


def _brief(value: Any) -> str:
    text = value if isinstance(value, str) else repr(value)
    return repr(printable(text, limit=VALUE_LIMIT)) if isinstance(value, str) else printable(text, limit=VALUE_LIMIT)


def _coordinates(value: Any) -> tuple[str, tuple[int, ...]]:
    """One cell column's value as ("pair", (a, b)) (``a,b``, ``[a, b]``, ``(a, b)``, a JSON list) or ("index", (i,))."""
    if isinstance(value, list | tuple):
        if len(value) != 2:
            raise _refused(f"{_brief(value)} is not a cell: give two coordinates")
        return "pair", (_whole(value[0]), _whole(value[1]))
    if isinstance(value, str):
        text = value.strip().removeprefix("[").removesuffix("]").removeprefix("(").removesuffix(")")
        if "," in text:
            parts = text.split(",")
            if len(parts) != 2:
                raise _refused(f"{_brief(value)} is not a cell: give row,col, [row, col] or a cell index")
            try:
                return "pair", (_whole(parts[0]), _whole(parts[1]))
            except TableError:
                raise _refused(f"{_brief(value)} is not a cell: its coordinates are not whole numbers") from None
    return "index", (_whole(value),)


FORMS = {"pair": "two coordinates", "index": "a cell index", "columns": "two columns"}


class _CellReader:
    """Cells of the table's coordinate system (the map's ``axes`` and ``origin``) as careful's (row, col)."""

    def __init__(self, world: World, column_map: ColumnMap) -> None:
        self.world, self.map = world, column_map
        self.form: str | None = None  # the first cell's form: every cell of the table must share it
        self.form_line = 0

    def same_form(self, parsed: tuple[str, Cell], line: int) -> Cell:
        """The cell of `parse`'s answer, if it is given the way the table's first cell was."""
        form, cell = parsed
        if self.form is None:
            self.form, self.form_line = form, line
        elif form != self.form and {form, self.form} != {"columns", "pair"}:
            raise _refused(f"{FORMS[form]}, but line {self.form_line} gave {FORMS[self.form]}: one coordinate "
                           "system per table")
        return cell

    def parse(self, raw: Any) -> tuple[str, Cell]:
        """A cell column's value (or a pair of columns' values, as a tuple) as its form and careful's (row, col)."""
        values: tuple[int, ...]
        if isinstance(raw, tuple):
            form, values = "columns", (_whole(raw[0]), _whole(raw[1]))
        else:
            form, values = _coordinates(raw)
        return form, self._cell(values, form)

    def _cell(self, values: tuple[int, ...], form: str) -> Cell:
        world = self.world
        if form == "index":
            if not 0 <= values[0] < world.rows * world.cols:
                raise _refused(f"cell index {values[0]} is outside the {world.rows}x{world.cols} grid "
                               f"(0 to {world.rows * world.cols - 1})")
            r, c = divmod(values[0], world.cols)
        else:
            r, c = values if self.map.axes == "rowcol" else (values[1], values[0])
        if not (0 <= r < world.rows and 0 <= c < world.cols):
            raise _refused(f"{self._shown(values)} is outside the {world.rows}x{world.cols} grid")
        if self.map.origin == "bottom-left":
            r = world.rows - 1 - r
        if world.grid[r][c] == WALL:
            raise _refused(f"{self._shown(values)} is [{r}, {c}] in careful's rows and columns, a wall")
        return r, c

    def _shown(self, values: tuple[int, ...]) -> str:
        if len(values) == 1:
            return f"cell index {values[0]}"
        names = ("x", "y") if self.map.axes == "xy" else ("row", "col")
        return f"{names[0]} {values[0]}, {names[1]} {values[1]}"


# ---------------------------------------------------------------------------- rows


class _Importer:
    """The table's rows read into moves by participant and episode, every refused row noted."""

    def __init__(self, table: Table, world: World, column_map: ColumnMap) -> None:
        self.table, self.world, self.map = table, world, column_map
        self.mdp: MDP = build_mdp(world)
        # The world's arrays as lists: read once per row, where numpy's scalar indexing would cost more than the rest.
        self._neighbour = self.mdp.neighbour.tolist()
        self._nonterminal = self.mdp.nonterminal.tolist()
        self._reward = self.mdp.reward_matrix().tolist()
        self.problems: list[tuple[int, str]] = []  # (line, the problem's line of text)
        self.cells = _CellReader(world, column_map)
        self.direction_of = column_map.direction_of
        self._fields = self._field_readers()
        # participant -> episode label -> moves, both in the order of their first row
        self.moves: dict[str, dict[str, list[_Move]]] = {}

    def refuse(self, line: int, column: str, why: str) -> None:
        self.problems.append((line, f"{printable(str(self.table.path), limit=200)}:{line}: "
                                    f"{printable(column, limit=VALUE_LIMIT)}: {why}"))

    def column_problems(self) -> None:
        """A map naming a column the table lacks, or a column the world cannot use: said once, at the header."""
        lacking = [(key, name) for key, name in self.map.columns() if name not in self.table.columns]
        known = ", ".join(printable(name, limit=40) for name in self.table.columns[:20])
        for key, name in lacking:
            self.refuse(self.table.header_line, name, f"the map's {key} names this column, which the table does not "
                        f"have (its columns: {known})")
        if self.world.care == "time":
            if self.map.level is not None:
                self.refuse(self.table.header_line, self.map.level, "a time world has no levels: its care is the "
                            "response time (remove level from the map)")
            if self.map.rt is None:
                self.refuse(self.table.header_line, "rt_ms", "a time world's move is a hold: the map must name the "
                            "response time's column (rt_ms or rt_s)")

    def read_rows(self) -> None:
        for order, row in enumerate(self.table.rows):
            self.read_row(row, order)

    def read_row(self, row: TableRow, order: int) -> None:
        values: dict[str, Any] = {}
        refused = False
        cells = row.cells
        for key, column, names, reader in self._fields:
            try:
                try:
                    raw = cells[names[0]] if len(names) == 1 else (cells[names[0]], cells[names[1]])
                except KeyError:
                    missing = next(name for name in names if name not in cells)
                    raise _refused(f"missing: the row has no {printable(missing, limit=VALUE_LIMIT)!r}") from None
                value = reader(raw)
                values[key] = self.cells.same_form(value, row.line) if key in ("state", "next_state") else value
            except TableError as exc:
                self.refuse(row.line, _joined(column), exc.problems[0])
                refused = True
        if refused and not {"participant", "episode"} <= values.keys():
            return
        episodes = self.moves.setdefault(values["participant"], {})
        episodes.setdefault(values["episode"], []).append(_Move(
            row.line, values.get("t", order), values.get("state", (0, 0)), values.get("action", "up"),
            values.get("level"), values.get("rt"), values.get("next_state"), refused))

    def _field_readers(self) -> list[tuple[str, str | tuple[str, str], tuple[str, ...], Callable[[Any], Any]]]:
        """(key, column, its names, reader) for every column the map names, in the order rows are read; a reader
        takes the cell's value (a pair of columns' values as a tuple)."""
        cell_map = self.map
        readers: list[tuple[str, str | tuple[str, str] | None, Callable[[Any], Any]]] = [
            ("participant", cell_map.participant, _remembered(self._participant)),
            ("episode", cell_map.episode, _remembered(_label)), ("t", cell_map.t, _remembered(self._order)),
            ("state", cell_map.state, _remembered(self.cells.parse)),
            ("next_state", cell_map.next_state, _remembered(self.cells.parse)),
            ("action", cell_map.action, _remembered(self._action)), ("level", cell_map.level, _remembered(self._level)),
            ("rt", cell_map.rt, self._rt),
        ]
        return [(key, column, _names(column), reader) for key, column, reader in readers if column is not None]

    def _participant(self, raw: Any) -> str:
        participant = _label(raw)
        if not SAFE_NAME.fullmatch(participant):
            raise _refused(f"participant id {printable(participant, limit=VALUE_LIMIT)!r} cannot name a recording's "
                           f"file: use {SAFE_NAME_RULE}")
        return participant

    @staticmethod
    def _order(value: Any) -> float:
        number = _number(value)
        if number is None:
            raise _refused("empty: the move's place in its episode was expected")
        return number

    def _action(self, raw: Any) -> Direction:
        code = code_text(raw) if raw is not None else ""
        if code not in self.direction_of:
            codes = ", ".join(f"{printable(c, limit=20)!r}" for c in self.direction_of)
            raise _refused(f"{printable(code, limit=VALUE_LIMIT)!r} is not an action code of the map's [actions] "
                           f"({codes})")
        return self.direction_of[code]

    def _level(self, raw: Any) -> int:
        level = _whole(raw)
        if not 1 <= level <= self.world.levels:
            raise _refused(f"level {level} is not one of the world's levels 1 to {self.world.levels}")
        return level

    def _rt(self, raw: Any) -> float | None:
        number = _number(raw)
        if number is None:
            if self.world.care == "time":
                raise _refused("empty, but a time world's move is a hold: every row needs its time")
            return None
        if number < 0:
            raise _refused(f"{_brief(raw)} is negative: a response time is 0 or more")
        hold = round(number * self.map.rt_scale, 1)
        return min(hold, self.world.max_hold_ms) if self.world.care == "time" else hold

    # ------------------------------------------------------------------------ episodes

    def recordings(self) -> dict[str, list[BodyLine]]:
        """Each participant's lines; the moves' problems are noted as they are found."""
        out: dict[str, list[BodyLine]] = {}
        for participant, episodes in self.moves.items():
            numbers = _episode_numbers(list(episodes))
            lines: list[BodyLine] = []
            for label in sorted(episodes, key=lambda label: numbers[label]):
                lines.extend(self._episode(numbers[label], episodes[label]))
            out[participant] = lines
        return out

    def _episode(self, number: int, moves: list[_Move]) -> list[BodyLine]:
        mdp, world = self.mdp, self.world
        if self.map.t is not None:
            moves = sorted(moves, key=lambda move: move.order)
            for before, move in zip(moves, moves[1:]):
                if move.order == before.order:
                    self.refuse(move.line, self.map.t, f"{move.order:g} is line {before.line}'s too: each move of "
                                f"episode {number} has its own place")
        lines: list[BodyLine] = []
        checker, start = LineChecker(mdp), 0
        score = world.initial_score
        for i, move in enumerate(moves):
            if move.refused:
                checker, start = LineChecker(mdp), i + 1
                continue
            if i >= world.max_steps:
                self.refuse(move.line, self.map.t or _joined(self.map.state), f"move {i + 1} of episode {number}, "
                            f"past the world's max_steps ({world.max_steps}): the episode ended at its step limit")
                continue
            s = mdp.state_of[move.state]
            intended = mdp.cells[self._neighbour[s][DIRECTIONS.index(move.direction)]] if self._nonterminal[s] \
                else move.state
            following = moves[i + 1].state if i + 1 < len(moves) and not moves[i + 1].refused else None
            next_state = move.next_state or following or intended
            step = self._step(number, i - start, move, s, next_state, intended, score)
            try:
                checker.step(step, move.line)
            except Mismatch as exc:
                self._mismatch(exc, move, moves[i + 1] if move.next_state is None and following else None)
                checker, start = LineChecker(mdp), i + 1
                continue
            score = step.score
            lines.append(step)  # its t is i while no move was refused (else nothing is written)
        if not lines or len(lines) != min(len(moves), world.max_steps):
            return lines
        last = mdp.state_of[lines[-1].next_state]  # type: ignore[union-attr]
        outcome: Literal["terminal", "quit", "step_limit"]
        if mdp.terminal[last]:
            score += float(mdp.R_S[last])
            outcome, symbol = "terminal", str(mdp.symbols[last])
        else:
            outcome, symbol = ("step_limit" if len(lines) >= world.max_steps else "quit"), None
        lines.append(EpisodeEnd(episode=number, outcome=outcome, terminal_symbol=symbol, steps=len(lines),
                                return_=score - world.initial_score, score=score))
        return lines

    def _step(self, number: int, t: int, move: _Move, s: int, next_state: Cell, intended: Cell, score: float) -> Step:
        world, mdp = self.world, self.mdp
        if world.care == "time":
            hold = move.hold_ms if move.hold_ms is not None else 0.0
            gain = float(mdp.R_S[s] - world.hold_cost(hold))
            level, bin_ = None, int(world.bin_of(hold))
        else:
            level, bin_ = move.level or 1, None
            gain = self._reward[s][action_index(move.direction, level, world.levels)]
        return Step(
            episode=number, t=t, state=move.state, direction=move.direction, carefulness=level,
            hold_ms=move.hold_ms, hold_exact=False, bin=bin_, next_state=next_state,
            slipped=next_state != intended, reward=gain, score=score + gain, realised=None,
        )

    def _mismatch(self, exc: Mismatch, move: _Move, following: _Move | None) -> None:
        """A move the reader would refuse, named by the table's column (a next cell read from the following
        row is that row's fault: its cell is not where this move can go)."""
        if exc.field == "next_state" and following is not None:
            self.refuse(following.line, _joined(self.map.state), f"[{following.state[0]}, {following.state[1]}] is "
                        f"not one move from line {move.line}'s [{move.state[0]}, {move.state[1]}] going "
                        f"{move.direction}: the world cannot make that move")
            return
        column = {"state": self.map.state, "next_state": self.map.next_state, "carefulness": self.map.level,
                  "t": self.map.t, "hold_ms": self.map.rt, "bin": self.map.rt, "episode": self.map.episode}.get(exc.field)
        self.refuse(move.line, _joined(column) if column else exc.field, exc.problem)


# A column's values `_remembered` at most: a trial table repeats its ids, codes and cells, rarely more of them.
REMEMBERED = 1 << 16


def _remembered(read: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """`read`, its answer (or its refusal) kept for each text value (or pair of them) it has read: a table's
    participants, episodes, codes and cells repeat on row after row. Values of other types (JSON's numbers, whose
    1, 1.0 and true would share a key) are read each time."""
    known: dict[Any, tuple[bool, Any]] = {}

    def reader(raw: Any) -> Any:
        text = type(raw) is str or (type(raw) is tuple and all(type(value) is str for value in raw))
        if not text:
            return read(raw)
        answer = known.get(raw)
        if answer is None:
            try:
                answer = (True, read(raw))
            except TableError as exc:
                answer = (False, exc.problems[0])
            if len(known) < REMEMBERED:
                known[raw] = answer
        if not answer[0]:
            raise _refused(answer[1])
        return answer[1]

    return reader


def _names(column: str | tuple[str, str]) -> tuple[str, ...]:
    return column if isinstance(column, tuple) else (column,)


def _joined(column: str | tuple[str, str]) -> str:
    return ",".join(_names(column))


def _episode_numbers(labels: list[str]) -> dict[str, int]:
    """Episode numbers: the labels themselves when every one is a whole number 0 or more, else 0, 1, 2, ...
    in the order of each label's first row."""
    try:
        numbers = {label: _whole(label) for label in labels}
    except TableError:
        numbers = {}
    if numbers and all(number >= 0 for number in numbers.values()) and len(set(numbers.values())) == len(numbers):
        return numbers
    return {label: i for i, label in enumerate(labels)}


def import_table(table: str | Path, world: World, column_map: ColumnMap) -> ImportedTable:
    """Read `table` through `column_map` into recordings of `world` (the module docstring says how).

    Raises:
        TableError: every refused row (file, line, column and why, one line each), or the file itself.
    """
    read = read_table(table)
    importer = _Importer(read, world, column_map)
    importer.column_problems()
    if not importer.problems:
        importer.read_rows()
        participants = importer.recordings()
    if importer.problems:
        raise TableError([text for _, text in sorted(importer.problems, key=lambda problem: problem[0])])
    if not participants:
        raise TableError([f"{printable(str(read.path), limit=200)}: the table has no rows"])
    return ImportedTable(read.path, world, participants)


# ---------------------------------------------------------------------------- writing


def recording_path(out: Path, participant: str) -> Path:
    """Where `careful import` writes a participant's recording: ``DIR/<participant>.jsonl``."""
    return out / f"{participant}.jsonl"


def write_imported(imported: ImportedTable, out: str | Path, *, app_version: str = "") -> list[Path]:
    """Write one recording per participant into the folder `out` (made if missing); returns their paths.

    Each is written under a hidden temporary name with `RecordingWriter`; then all are read back with the
    recordings' reader (`Demonstrations.read`) and renamed into place only if they read as written.

    Raises:
        OutputError: `out` is not a folder, or a participant's recording exists there (nothing is replaced,
            nothing written), or a file cannot be written (nothing is left).
        InternalError: the reader does not read back what was written (a bug; nothing is left).
    """
    out = check_output_folder(out, option="--out")
    targets = {participant: recording_path(out, participant) for participant in imported.participants}
    existing = [path for path in targets.values() if os.path.lexists(path)]
    if existing:
        raise OutputError(f"--out {printable(str(existing[0]), limit=160)}: exists already"
                          f"{f' (and {len(existing) - 1} more)' if len(existing) > 1 else ''}; import never "
                          "overwrites a recording: choose another folder")
    made = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"--out {printable(str(out), limit=160)}: cannot make the folder ({exc.strerror or exc})") from None
    created = datetime.now().astimezone()
    built: dict[Path, Path] = {}
    placed: list[Path] = []
    done = False
    try:
        for participant, lines in imported.participants.items():
            header = SessionHeader(world=imported.world, player=participant, created=created, seed=None,
                                   input={"mode": "import", "table": imported.path.name}, app_version=app_version)
            temporary = temporary_name(targets[participant])
            built[temporary] = targets[participant]
            with RecordingWriter(temporary, header, sync_episodes=False) as writer:
                for start in range(0, len(lines), 5000):
                    writer.write_many(lines[start : start + 5000])
        back = Demonstrations.read(list(built))
        if back.steps != imported.steps or back.files != len(built):
            raise InternalError(f"the recordings read back hold {plural(back.steps, 'step')}, not the "
                                f"{plural(imported.steps, 'step')} written")
        for temporary, target in built.items():
            rename_no_replace(temporary, target)
            placed.append(target)
        done = True
    except FileExistsError as exc:
        _remove(placed)
        raise OutputError(f"--out {printable(str(exc.filename), limit=160)}: was written by someone else meanwhile; "
                          "import never overwrites a recording: nothing was imported") from None
    except OSError as exc:
        _remove(placed)
        raise OutputError(f"--out {printable(str(out), limit=160)}: cannot write the recordings "
                          f"({exc.strerror or exc}); nothing was imported") from None
    except BaseException:
        _remove(placed)
        raise
    finally:
        _remove(list(built))
        if made and not done:
            with contextlib.suppress(OSError):
                out.rmdir()  # the folder this import made, left empty by a failure
    return placed


def _remove(paths: list[Path]) -> None:
    for path in paths:
        try:
            os.unlink(path)
        except FileNotFoundError:
            pass
