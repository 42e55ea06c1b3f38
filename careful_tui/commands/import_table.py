"""`careful import TABLE --world W --map MAP --out DIR` (docs/import.md): another lab's trial table as recordings.

The work is `irl_core.recordings.importing`'s; this prints what it refused, every row on its own line
(`file:line: column: why`, exit 2, nothing written), or a summary of what it wrote.
"""

from __future__ import annotations

import argparse

from rich.console import Console
from rich.text import Text

from careful_tui.errors import EXIT_BAD_INPUT, EXIT_OK
from careful_tui.version import app_version
from irl_core.errors import TableError
from irl_core.recordings.importing import import_table, write_imported
from irl_core.recordings.table_map import load_map
from irl_core.support.safe_text import one_line, printable
from irl_core.worlds.world import load_world


def run_import(args: argparse.Namespace) -> int:
    err = Console(stderr=True, highlight=False)
    world = load_world(args.world)
    try:
        imported = import_table(args.table, world, load_map(args.map))
    except TableError as exc:
        for problem in exc.problems:
            err.print(Text.assemble(("careful import: ", "bold red"), one_line(problem)), soft_wrap=True)
        if len(exc.problems) > 1:
            err.print(Text(f"careful import: {len(exc.problems):,} problems; nothing was written"), soft_wrap=True)
        return EXIT_BAD_INPUT
    paths = write_imported(imported, args.out, app_version=app_version())
    names = ", ".join(path.name for path in paths[:3]) + (f" and {len(paths) - 3} more" if len(paths) > 3 else "")
    err.print(Text(f"imported {imported.summary()} from {printable(str(args.table), limit=160)} into "
                   f"{printable(str(args.out), limit=160)}: {printable(names, limit=300)}"), soft_wrap=True)
    return EXIT_OK
