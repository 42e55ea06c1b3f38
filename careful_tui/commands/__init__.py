"""One module per `careful` command: `run_<command>(args)` reads the parsed arguments, does the
work through `irl_core`, builds an app (`careful_tui.app`) or prints with `careful_tui.render`,
and returns an exit code from `careful_tui.errors`, raising its `UsageError` for bad input.

May import: `irl_core`, `careful_tui.render`, `careful_tui.app` and below. Never `careful_tui.cli`.
"""
