"""The `careful` console script: the command line, or one line saying which extra to install.

`pip install careful` plays (Textual and Rich are in the base dependencies); some commands need an
extra (`figures`, `export`, `web`, `cluster`). A module that an extra installs and is missing would end
in a traceback; this says what to install instead (`careful_tui.cli` does the same for each command).
"""

from __future__ import annotations

import sys

from careful_tui.errors import EXIT_FAILURE, missing_extra, missing_extra_line


def main() -> int:
    try:
        from careful_tui.cli import main as command_line
    except ModuleNotFoundError as exc:
        extra = missing_extra(exc)
        if extra is None:
            raise
        print(missing_extra_line(exc, extra), file=sys.stderr)
        return EXIT_FAILURE
    return command_line()
