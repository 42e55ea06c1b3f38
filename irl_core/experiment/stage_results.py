"""What the experiment's stages found, as numbers: a fit's cliff and goal against the truth (`Estimate`),
and the cliff's and mud's intervals in one world (`Separation`). `irl_core.experiment.run` produces them,
`irl_core.experiment.claims` judges the paper's claims from them.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Estimate:
    """A fit's cliff and goal against the truth (means over the cells of each symbol).

    `cliff_at_bound` of the `cliff_cells` sit at the fit's bound -`rmax`, which set them, not the
    data; `cliff_inside` is the mean of the others (None when there are none).
    """

    stage: str
    method: str
    data: str
    cliff: float
    goal: float
    true_cliff: float
    true_goal: float
    seconds: float
    cliff_cells: int = 0
    cliff_at_bound: int = 0
    cliff_inside: float | None = None
    rmax: float | None = None

    @property
    def cliff_error(self) -> float:
        """Relative error of the cliff estimate, |est - true| / |true|."""
        return abs(self.cliff - self.true_cliff) / abs(self.true_cliff)

    @property
    def goal_error(self) -> float:
        return abs(self.goal - self.true_goal) / abs(self.true_goal)


@dataclass(frozen=True)
class Separation:
    """Intervals of the cliff and mud cells in one world, and whether they are disjoint.

    `kind` is ``identified`` (lp: every value the demonstrations allow) or ``confidence``
    (a bootstrap confidence interval); `data` says what was fitted.
    """

    world: str
    cliff: tuple[float, float]
    mud: tuple[float, float]
    seconds: float
    kind: str = "identified"
    data: str = ""
    rmax: float | None = None  # the fit's bound |R_S| <= rmax: an end there is the bound's, not the data's
    careful: bool = True  # the world has more than one level of carefulness

    @property
    def separated(self) -> bool:
        return self.cliff[1] < self.mud[0] or self.mud[1] < self.cliff[0]

    @property
    def cliff_width(self) -> float:
        return self.cliff[1] - self.cliff[0]

    @property
    def mud_width(self) -> float:
        return self.mud[1] - self.mud[0]

