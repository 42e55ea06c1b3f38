"""A count with its noun for messages ("1 episode", "2 episodes"), for the core and the terminal alike."""

from __future__ import annotations


def plural(n: int, word: str) -> str:
    """`n` and `word`, with an s unless `n` is 1: "1 level", "0 levels", "14 levels"."""
    return f"{n} {word}{'' if n == 1 else 's'}"
