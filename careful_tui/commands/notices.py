"""The one way a command warns: "warning: ..." in yellow on stderr, and goes on.

A warning is for input the command can use but not wholly (a file left out, an option that
does nothing in this run); bad input is a `UsageError` instead (one line, exit 2).
"""

from __future__ import annotations

from rich.console import Console
from rich.text import Text

from irl_core.support.safe_text import printable


def warn(err: Console, message: str) -> None:
    """Print `message` as one warning on `err`: text, never markup (it may name a file)."""
    err.print(Text(f"warning: {printable(message, limit=400)}", style="yellow"), soft_wrap=True)


def ignored(options: list[str], applies: str) -> str:
    """The warning for options this run does not use: "--confidence and --resamples apply only
    with --intervals; ignored"."""
    names = " and ".join(options) if len(options) < 3 else ", ".join(options[:-1]) + " and " + options[-1]
    verb = "applies" if len(options) == 1 else "apply"
    return f"{names} {verb} only {applies}; ignored"
