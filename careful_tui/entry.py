"""The `careful` console script: the command line, or one line saying which extra to install.

`pip install careful` is the library alone; the command line needs the `tui` extra (Rich and
Textual), and some commands another (`figures`, `export`). Without it, the import of the command
line would end in a traceback; this says what to install instead. Nothing here imports Rich.
"""

from __future__ import annotations

import sys

# The extra that installs each optional top-level module (pyproject.toml's optional-dependencies).
EXTRA_OF = {"textual": "tui", "rich": "tui", "matplotlib": "figures", "minari": "export", "PIL": "export",
            "h5py": "export"}
EXIT_FAILURE = 1


def missing_extra(exc: ModuleNotFoundError) -> str | None:
    """The extra whose module `exc` did not find, or None when it is not an extra's."""
    return EXTRA_OF.get((exc.name or "").partition(".")[0])


def main() -> int:
    try:
        from careful_tui.cli import main as command_line
    except ModuleNotFoundError as exc:
        extra = missing_extra(exc)
        if extra is None:
            raise
        print(f"careful: the command line needs {exc.name}, which is not installed: "
              f"pip install 'careful[{extra}]' (or 'careful[all]')", file=sys.stderr)
        return EXIT_FAILURE
    return command_line()
