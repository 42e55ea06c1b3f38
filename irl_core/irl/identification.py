"""What the recordings can pin, decided before a fit estimates: the rewards' units (docs/answers.md).

Play shows only beta times the rewards unless something of known size trades against them. Three things
do: a care cost that differs between the choices a player makes (levels that cost more the more careful
they are; holding a key, which costs per second), a reward the user knows (``--known G=100``), and a
temperature the user gives to a soft-optimal fit (``--beta 0.1``: beta times the rewards is what play shows,
so a given beta leaves the rewards themselves; note ``units_from_beta``).
Where neither is there (the moves cost nothing, or every level costs the same, or holding costs nothing
on a time world) any positive multiple of the rewards explains the recordings as well, so the fit holds a
reference reward at 1 (the goal, else the first terminal symbol) and every other reward is read relative
to it: ``"reward_unit": "relative to G"`` in the JSON, note ``scale_not_identified``.

A cost every move pays alike is no exception: it trades against the rewards only through how long
episodes last, which says little (a soft-optimal fit in points on such a world read the goal at 1-17
against 100, with narrow intervals). Its size relative to the reference is then one more unknown
(``move``), since in points it would put the other rewards in points too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from irl_core.errors import BadInputError
from irl_core.irl.choices import RewardCells
from irl_core.worlds.world import GROUND, World

# The label and symbol of the unknown that stands for a move's cost where the rewards are relative (`Scale.move`).
MOVE = "move"
# The reference reward's value when nothing else fixes the units: the other rewards are its multiples.
REFERENCE_VALUE = 1.0


@dataclass(frozen=True)
class Scale:
    """How a fit's rewards get their units.

    Attributes:
        held: (symbol, value) pairs whose cells are held at that value, not fitted: the rewards the user
            gave (`FitOptions.known`), or the reference when nothing fixes the units.
        unfixed_why: why the world fixes no units (a clause), or None where its care cost does.
        reference: the symbol every reward is read relative to (held at `REFERENCE_VALUE`) when nothing
            else fixes the units, else None.
        beta: the temperature the user gave a soft-optimal fit, where it is what fixes the units, else None.
        move: every move costs the same nonzero amount, in points, while the rewards are relative to the
            reference: the fit takes a move's cost as one more unknown (`irl_core.irl.qmap.MOVE`).
    """

    held: tuple[tuple[str, float], ...] = ()
    unfixed_why: str | None = None
    reference: str | None = None
    beta: float | None = None
    move: bool = False

    @property
    def unit(self) -> str:
        """``points``, or ``relative to G`` (the reference's symbol)."""
        return f"relative to {self.reference}" if self.reference is not None else "points"

    @property
    def identified(self) -> bool:
        """Something fixes the units: the world's care cost, or a reward the user gave."""
        return self.unfixed_why is None or self.beta is not None or (bool(self.held) and self.reference is None)


def units_unfixed_why(world: World) -> str | None:
    """Why nothing in `world` fixes the rewards' units (a clause for a note), or None where its care cost does."""
    if world.care == "time":
        return None if world.cost_per_second > 0 else "holding costs nothing (cost_per_second 0)"
    costs = set(world.level_costs)
    if len(costs) > 1:
        return None
    if costs == {0.0}:
        return "the moves cost nothing"
    return "every move costs the same, with one carefulness level" if world.levels == 1 else \
        "every level costs the same"


def reference_symbol(world: World) -> str | None:
    """The reward others are read relative to: the goal ``G``, else the first terminal symbol in the layout."""
    present = [symbol for symbol in dict.fromkeys(world.layout.replace("\n", "")) if symbol in world.terminal]
    if "G" in present:
        return "G"
    return present[0] if present else None


def decide_scale(world: World, known: tuple[tuple[str, float], ...], *, reward_cells: RewardCells,
                 rmax: float, given_beta: float | None = None) -> Scale:
    """The fit's `Scale` for `world` with the user's `known` rewards (symbol, value) and the temperature
    `given_beta` the user fixed for a soft-optimal fit (None where none was given or the method has none).

    Raises `BadInputError` (code ``bad_known``) for a known symbol the layout lacks, one that is not fitted
    (ground under ``reward_cells="special"``), one given twice, or a value that is not a finite number within
    ±rmax."""
    symbols = set(world.layout.replace("\n", ""))
    seen: set[str] = set()
    for symbol, value in known:
        if symbol not in symbols:
            raise BadInputError(f"{{known}} names {symbol!r}, which the world {world.name!r} does not have "
                                f"(its cells: {', '.join(sorted(symbols))})", code="bad_known")
        if symbol == GROUND and reward_cells == "special":
            raise BadInputError(f"{{known}} names ground ({symbol!r}), which {{reward_cells=special}} holds at 0 "
                                "already", code="bad_known")
        if symbol in seen:
            raise BadInputError(f"{{known}} gives {symbol!r} twice", code="bad_known")
        if not (isinstance(value, int | float) and math.isfinite(value) and abs(value) <= rmax):
            raise BadInputError(f"{{known}} gives {symbol!r} the value {value!r}: a number within ±rmax "
                                f"({rmax:g}) is needed", code="bad_known")
        seen.add(symbol)
    why = units_unfixed_why(world)
    if known or why is None:
        return Scale(held=tuple((s, float(v)) for s, v in known), unfixed_why=why)
    if given_beta is not None:
        return Scale(unfixed_why=why, beta=given_beta)
    reference = reference_symbol(world)
    if reference is None:
        return Scale(held=(), unfixed_why=why)
    moves_cost = world.care != "time" and any(world.level_costs)
    return Scale(held=((reference, REFERENCE_VALUE),), unfixed_why=why, reference=reference, move=moves_cost)
