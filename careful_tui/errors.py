"""What a command tells the shell: exit codes, and what to say of a missing extra or terminal.

Commands raise `UsageError` (`irl_core.errors`, with every other error of careful) and return the
exit codes; `careful_tui.cli` turns any `InputError` (a `UsageError` is one) into one line on stderr
and exit 2. Commands import this module, never `cli`, so imports run one way.
"""

from __future__ import annotations

import sys

from irl_core.errors import UsageError

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


def require_terminal(command: str) -> None:
    """Raise `UsageError` unless standard input and output are a terminal (for the screens)."""
    if not (sys.stdin.isatty() and sys.stdout.isatty()):
        raise UsageError(f"careful {command} needs an interactive terminal")


# The extra that installs each optional top-level module (pyproject.toml's optional-dependencies).
EXTRA_OF = {"matplotlib": "figures", "minari": "export", "PIL": "export", "h5py": "export",
            "starlette": "web", "uvicorn": "web", "distributed": "cluster"}


def missing_extra(exc: ModuleNotFoundError) -> str | None:
    """The extra whose module `exc` did not find, or None when it is not an extra's."""
    return EXTRA_OF.get((exc.name or "").partition(".")[0])


def missing_extra_line(exc: ModuleNotFoundError, extra: str) -> str:
    """The one line that says which extra to install."""
    return (f"careful: this needs {exc.name}, which is not installed: pip install 'careful[{extra}]' "
            "(or 'careful[all]')")
