"""``NAME=VALUE`` on a benchmark's command line, as the value a library option takes."""

from __future__ import annotations


def name_and_value(text: str) -> tuple[str, object]:
    """``NAME=VALUE`` as (name, value): true/false as a bool, else an int, else a float, else the word."""
    name, _, value = text.partition("=")
    if value.lower() in ("true", "false"):
        return name, value.lower() == "true"
    for kind in (int, float):
        try:
            return name, kind(value)
        except ValueError:
            pass
    return name, value
