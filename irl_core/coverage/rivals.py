"""The rival players of `careful check`: the person-like players of `irl_core.players.person_like` (those of
`careful simulate --policy`), each a player no model of the fit contains, who plays the world's own rewards."""

from __future__ import annotations

from irl_core.errors import UsageError
from irl_core.players.person_like import KINDS, LEVEL_KINDS, TIME_KINDS
from irl_core.worlds.world import World

# Rivals checked when --players is not given: the three hands on a world with levels; on a time world
# its two players who hold for a time.
DEFAULT_LEVEL_RIVALS = ("loose", "timed", "hasty")
DEFAULT_TIME_RIVALS = ("timing", "steady")


def rival_choices(world: World) -> tuple[str, ...]:
    """The person-like players that can play `world`: on a time world every one but ``timed`` (which times a
    level world's windows); elsewhere every one but those who hold for a time (``timing``, ``steady``)."""
    if world.care == "time":
        return tuple(kind for kind in KINDS if kind != "timed")
    return LEVEL_KINDS


def default_rivals(world: World) -> tuple[str, ...]:
    return DEFAULT_TIME_RIVALS if world.care == "time" else DEFAULT_LEVEL_RIVALS


def parse_rivals(text: str) -> tuple[str, ...]:
    """``loose,timed`` as names of person-like players (in order, once each; empty items skipped).

    Raises `UsageError` naming the first unknown name and listing the players."""
    names = tuple(dict.fromkeys(name.strip() for name in text.split(",") if name.strip()))
    for name in names:
        if name not in KINDS:
            raise UsageError(f"--players: {name!r} is not a player; the players are {', '.join(KINDS)}")
    return names


def rivals_for(names: tuple[str, ...], world: World) -> tuple[str, ...]:
    """`names` when every one can play `world`, else `UsageError` naming it and this world's choices."""
    allowed = rival_choices(world)
    for name in names:
        if name not in allowed:
            why = ("holds for a time and needs a time world" if name in TIME_KINDS else
                   "times a level world's windows")
            raise UsageError(f"--players: {name} {why}; on {world.name!r} the players are {', '.join(allowed)}")
    return names
