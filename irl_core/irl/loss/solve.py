"""The paper's loss IRL agent, the solver: the convex loss of `irl_core.irl.loss.model`, minimised exactly.

Hanslope & Aitchison, section "Game and Loss IRL agent"; `irl_core.irl.loss.model` states
the loss L(R_S) = sum over demonstrated s of exp(ReLU(z_s)) + lambda ||R_S||_1, its
constraints and why it is convex.

Solving it. cvxpy hands the exponential cones to an interior-point solver, and that is
fragile here: Clarabel stops with "insufficient progress" on 17 of 20 noisy instances on
the paper's world with the rival maxima written directly (14 carefulness levels make the
rows Q(s, (d, c)) nearly parallel), still on 9 of 120 across the built-in worlds with the
compact rival rows of `loss.model`, and a lexicographic second stage has no interior at all.
So `fit_loss` solves the same convex problem exactly by outer approximation with HiGHS;
`loss.model.loss_problem` (the cvxpy model) states it, cvxpy certifies it DCP, and the tests
check both give the same minimum. With r_s >= z_s and r_s >= 0 the objective sum_s exp(r_s) is
separable, one dimension per state, and each exp is replaced by tangents
w_s >= e^rho (1 + r_s - rho). Every round solves the LP (from the previous basis), adds a
tangent at each r_s where the cut is loose, and stops when the LP's value (a lower bound
on the minimum) and the loss at its solution (an upper bound) agree to a relative 1e-8.
Nothing overflows, however bad the demonstrations:

* the first LP (the tangent at 0: minimise sum ReLU(z_s)) gives a feasible point whose
  loss U0 bounds the minimum, so at any minimiser every ReLU(z_s) <= log U0: the cap
  r_s <= log U0 + 1 removes no minimiser (the 1 is far above the LP's tolerance on z);
* the LP holds w_s e^-shift, with the shift at the largest ReLU(z_s) seen, so its numbers
  stay near 1 even when the loss is e^200; losses are compared as logs.

Many rewards often minimise the loss equally (for clean demonstrations, every reward that
makes each demonstrated action the best reaches the floor L = number of demonstrated
states). To make the answer reproducible a second, lexicographic stage keeps the loss
within a relative 1e-8 of its minimum and picks the reward with the smallest weighted
||R_S||_1 (the paper's sparsity preference). Whether the minimiser is unique is then
checked directly: a fixed generic linear function of R_S is minimised and maximised over
the same optimal set; if the two differ, the result says "not unique".
"""


from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.special import logsumexp

from irl_core.irl.loss.model import LossConstraints, loss_constraints, relu_terms
from irl_core.irl.lp.highs import HighsModel, LinearProgram, linear_program
from irl_core.irl.lp.margin import check_bounds
from irl_core.irl.notes import Note
from irl_core.irl.qmap import QMap
from irl_core.irl.result import InfeasibleError, SolverError

# Relative agreement of the lower and upper bounds that ends the outer approximation, and
# HiGHS's feasibility tolerance for these LPs (its default 1e-7 would put the floor near 1e-7).
GAP_TOLERANCE = 1e-8
LP_TOLERANCE = 1e-9
# A tangent is added where exp(r_s) exceeds w_s by more than this (relative).
CUT_TOLERANCE = 1e-9
# Once the LP value has not moved for STALL_ROUNDS the LP's tolerance is the floor; a gap
# above STALL_TOLERANCE is then reported with the answer.
STALL_TOLERANCE = 1e-6
STALL_ROUNDS = 3
MAX_ROUNDS = 500
# Tangents further than this (log units) from the LP's scale are left out; a fall of the
# best loss by REBASE (log units) below the scale rebuilds the LP at the new scale.
FAR = 30.0
REBASE = 5.0
# Two optimal rewards differing by more than this (relative to rmax) make the answer not unique.
UNIQUE_TOLERANCE = 1e-4
# The loss problem always has a feasible point (`fit_loss` reports HiGHS saying otherwise).
_INFEASIBLE = "the loss problem is infeasible"


@dataclass(frozen=True, eq=False)
class _LossLP:
    """The outer approximation's LP over v = [y; r (d); w (d); u (k)].

    r_s >= z_s, r_s >= 0 (so r_s >= ReLU(z_s)); w_s >= exp(r_s) through tangents added
    later; u >= |theta|.
    """

    constraints: LossConstraints
    program: LinearProgram

    @property
    def y(self) -> slice:
        return slice(0, self.constraints.program.shape[1])

    @property
    def x(self) -> slice:
        return slice(0, self.constraints.qmap.n)

    @property
    def r(self) -> slice:
        return slice(self.y.stop, self.y.stop + self.constraints.demonstrated.size)

    @property
    def w(self) -> slice:
        return slice(self.r.stop, self.r.stop + self.constraints.demonstrated.size)

    @property
    def u(self) -> slice:
        return slice(self.w.stop, self.w.stop + self.constraints.qmap.k)

    @property
    def size(self) -> int:
        return self.u.stop


def _loss_lp(constraints: LossConstraints) -> _LossLP:
    c = constraints
    lp = c.program
    n_y, d, k = lp.shape[1], c.demonstrated.size, c.qmap.k
    size = n_y + 2 * d + k
    eye_k = sp.identity(k, format="csr")

    def place(block: sp.spmatrix, at: int) -> sp.csr_matrix:
        block = sp.csr_matrix(block)
        return sp.hstack(
            [sp.csr_matrix((block.shape[0], at)), block, sp.csr_matrix((block.shape[0], size - at - block.shape[1]))],
            format="csr",
        )

    A = sp.vstack(
        [
            place(lp.A, 0),
            place(c.Z, 0) - place(sp.identity(d), n_y),  # z_s - r_s <= -z0
            place(eye_k, 0) - place(eye_k, size - k),  # theta - u <= 0
            -place(eye_k, 0) - place(eye_k, size - k),  # -theta - u <= 0
        ],
        format="csr",
    )
    return _LossLP(
        constraints=c,
        program=linear_program(
            A,
            np.concatenate([lp.row_lower, np.full(d + 2 * k, -np.inf)]),
            np.concatenate([lp.row_upper, -c.z0, np.zeros(2 * k)]),
            np.concatenate([lp.lower, np.zeros(2 * d + k)]),
            np.concatenate([lp.upper, np.full(2 * d, np.inf), lp.upper[:k]]),
        ),
    )


@dataclass(frozen=True)
class LossSolution:
    """The loss agent's answer.

    Attributes:
        x: [theta; V] of the reported minimiser (smallest ||R_S||_1 among the minimisers).
        loss: L at x (lambda term included).
        lower_bound: a certified lower bound on the minimum.
        unique: whether the minimiser is unique (up to UNIQUE_TOLERANCE); None if unchecked.
        gap: the relative gap HiGHS's tolerance left between the bounds (normally below 1e-8).
        rounds: LP solves used.
        notes: what the user should know (`Note`).
    """

    x: np.ndarray
    loss: float
    lower_bound: float
    unique: bool | None
    gap: float
    rounds: int
    notes: list[Note] = field(default_factory=list)


class _OuterApproximation:
    """The loss LP with tangent cuts, one HiGHS model for as long as its scale holds.

    The LP holds w'_s = w_s e^-shift, where shift is the largest ReLU(z_s) at a recent
    solution, so its numbers stay near 1 however large the loss (a demonstration that walks
    into a wall at the highest level can make it e^200). A tangent at a point rho more than
    FAR from the shift only bounds a term below e^-FAR of the largest and is left out; when
    the largest term falls REBASE below the shift, the LP is rebuilt at the new shift with
    every tangent so far.
    """

    def __init__(self, problem: _LossLP, *, lam: float):
        self.problem, self.lam, self.rounds = problem, lam, 0
        self.shift, self.cap = 0.0, np.inf
        self.log_level: float | None = None
        self.excess = 0.0  # the largest gap any stage had to accept when the LP stopped improving
        # HiGHS's tolerances are absolute: with huge bounds (values near vmax) ask for less.
        vmax = float(np.max(np.abs(problem.program.upper[problem.x]), initial=1.0))
        self.tolerance = min(max(LP_TOLERANCE, 1e-14 * vmax), 1e-7)
        d = problem.constraints.demonstrated.size
        self.points = (np.arange(d), np.zeros(d))  # every tangent so far: (positions, rho)
        self._build()

    def _build(self) -> None:
        p = self.problem
        lp = p.program
        upper = lp.upper.copy()
        upper[p.r] = self.cap
        capped = LinearProgram(lp.A, lp.row_lower, lp.row_upper, lp.lower, upper, lp.cost)
        self.solver = HighsModel(capped, tolerance=self.tolerance)
        self._add_tangents(*self.points)
        if self.log_level is not None:
            self._add_level_row(self.log_level)

    def _add_tangents(self, states: np.ndarray, rho: np.ndarray) -> None:
        """w'_s >= e^(rho - shift) (1 + r_s - rho), each row scaled so its largest coefficient is 1."""
        near = np.abs(rho - self.shift) <= FAR
        states, rho = states[near], rho[near]
        if states.size == 0:
            return
        slope = np.exp(rho - self.shift)
        scale = 1.0 / np.maximum(slope, 1.0)
        r, w = self.problem.r, self.problem.w
        rows = sp.csr_matrix(
            (
                np.column_stack([slope * scale, -scale]).ravel(),
                (np.repeat(np.arange(states.size), 2), np.column_stack([r.start + states, w.start + states]).ravel()),
            ),
            shape=(states.size, self.problem.size),
        )
        self.solver.add_rows(rows, np.full(states.size, -np.inf), slope * scale * (rho - 1.0))

    def loss_cost(self) -> np.ndarray:
        """The loss objective in the LP's units: sum w'_s + lambda e^-shift ||R_S||_1."""
        cost = np.zeros(self.problem.size)
        cost[self.problem.w] = 1.0
        cost[self.problem.u] = self.lam * np.exp(-self.shift) * self.problem.constraints.qmap.unknowns.weight
        return cost

    def _add_level_row(self, log_level: float) -> None:
        self.solver.add_rows(
            sp.csr_matrix(self.loss_cost()), np.array([-np.inf]), np.array([np.exp(log_level - self.shift)])
        )

    def relu(self, v: np.ndarray) -> np.ndarray:
        """(d,) ReLU(z_s) at the LP point v, from the exact rival maxima."""
        c = self.problem.constraints
        return np.maximum(relu_terms(c.qmap, c.frequencies, v[self.problem.x]), 0.0)

    def log_loss(self, v: np.ndarray) -> float:
        """log(L(R_S) + lambda ||R_S||_1) at the LP point v, without overflow."""
        c = self.problem.constraints
        log_l = float(logsumexp(self.relu(v)))
        penalty = self.lam * float(c.qmap.unknowns.weight @ np.abs(v[: c.qmap.k]))
        return float(np.logaddexp(log_l, np.log(penalty))) if penalty > 0 else log_l

    def rescale(self, v: np.ndarray, *, cap: float | None = None) -> None:
        """Rebuild the LP with the shift at the largest term's exponent at v (and, if given, the cap on r).

        The largest term then has w' = 1 and the LP's absolute tolerances stay relative.
        With a new cap, every state also gets tangents every half unit from the shift - FAR
        (or 0) to the cap: each tangent only binds above rho - 1, so without them the first
        rounds would creep down one unit at a time.
        """
        self.shift = float(self.relu(v).max())
        if cap is not None:
            self.cap = cap
            grid = np.arange(self.cap, max(self.shift - FAR, 0.0) - 0.5, -0.5)
            d = self.problem.constraints.demonstrated.size
            self.points = (
                np.concatenate([self.points[0], np.repeat(np.arange(d), grid.size)]),
                np.concatenate([self.points[1], np.tile(grid, d)]),
            )
        self._build()

    def restrict(self, log_level: float) -> None:
        """From now on keep the loss below e^log_level (the lexicographic stages)."""
        self.log_level = log_level
        self._add_level_row(log_level)

    def minimise(self, cost: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """Minimise cost @ v (the loss itself if None), adding tangents; (v, log of a lower bound).

        For the loss: until the LP value, a lower bound on the minimum, is within
        GAP_TOLERANCE (relative) of the true loss at its solution. Under a level: until the
        solution's true loss is within GAP_TOLERANCE of the level. The lower bound is only
        meaningful for the loss.
        """
        r, w = self.problem.r, self.problem.w
        gap = max(GAP_TOLERANCE, 10 * self.tolerance)
        best, stale = -np.inf, 0
        # Any cost but the loss's is minimised under a level (`restrict`), the stage's bound.
        level = self.log_level if cost is not None else None
        if cost is not None and level is None:
            raise ValueError("minimise(cost) needs a level: call restrict() first")
        for _ in range(MAX_ROUNDS):
            v, value = self.solver.minimise(self.loss_cost() if cost is None else cost, infeasible_message=_INFEASIBLE)
            self.rounds += 1
            log_loss = self.log_loss(v)
            log_bound = np.log(value) + self.shift if value > 0 else -np.inf
            excess = log_loss - (log_bound if level is None else level)
            relevant = v[r] >= self.shift - FAR
            loose = np.flatnonzero(relevant & (np.exp(v[r] - self.shift) > v[w] * (1 + CUT_TOLERANCE)))
            if excess <= gap or loose.size == 0:
                return v, log_bound
            # The LP value only rises as tangents are added; once it stops, the LP's tolerance is the floor.
            if value > best + 1e-12 * max(abs(value), 1.0):
                best, stale = value, 0
            else:
                stale += 1
            if stale >= STALL_ROUNDS:
                self.excess = max(self.excess, excess)
                return v, log_bound
            self.points = (np.concatenate([self.points[0], loose]), np.concatenate([self.points[1], v[r][loose]]))
            if cost is None and self.shift - float(self.relu(v).max()) > REBASE:
                self.rescale(v)
                best, stale = -np.inf, 0
            else:
                self._add_tangents(loose, v[r][loose])
        raise SolverError(f"the loss did not converge in {MAX_ROUNDS} rounds of tangent cuts")


def fit_loss(qmap: QMap, frequencies: np.ndarray, *, rmax: float, lam: float = 0.0) -> LossSolution:
    """Minimise the loss exactly, then pick the smallest-||R_S||_1 minimiser and test uniqueness."""
    check_bounds(rmax=rmax, lam=lam)
    constraints = loss_constraints(qmap, frequencies, rmax=rmax)
    if constraints.demonstrated.size == 0:
        raise ValueError("the loss needs at least one demonstrated state")
    try:
        return _minimise_loss(qmap, constraints, rmax=rmax, lam=lam)
    except InfeasibleError:
        # Some V is always feasible (play pi where demonstrated, optimally elsewhere): a numerical failure.
        raise SolverError("HiGHS reported the loss problem infeasible, which it cannot be; please report this") from None


def _minimise_loss(qmap: QMap, constraints: LossConstraints, *, rmax: float, lam: float) -> LossSolution:
    problem = _loss_lp(constraints)
    outer = _OuterApproximation(problem, lam=lam)
    k = qmap.k

    # The tangent at 0 alone (minimise sum ReLU(z_s)): a feasible point whose loss U0 bounds
    # the minimum. Rescale to it and cap r at log U0 + 1 (a margin far above the LP's tolerance).
    first = outer.solver.minimise(outer.loss_cost(), infeasible_message=_INFEASIBLE)[0]
    outer.rescale(first, cap=outer.log_loss(first) + 1.0)
    optimum, log_lower_bound = outer.minimise()

    # The optimal set: loss <= level. Lexicographic stage: the smallest weighted ||R_S||_1 in it.
    outer.restrict(outer.log_loss(optimum) + GAP_TOLERANCE)
    l1 = np.zeros(problem.size)
    l1[problem.u] = qmap.unknowns.weight
    chosen, _ = outer.minimise(l1)

    # Uniqueness: the range of a fixed generic linear function of theta over the optimal set.
    generic = np.zeros(problem.size)
    generic[:k] = 1.0 + (np.arange(k) * 0.6180339887498949) % 1.0
    notes: list[Note] = []
    try:
        low, _ = outer.minimise(generic)
        high, _ = outer.minimise(-generic)
    except SolverError:
        unique = None
        notes.append(Note("uniqueness_unchecked", "the minimiser shown has the smallest ||R_S||_1; whether others "
                                                  "exist could not be checked"))
    else:
        unique = float(np.max(np.abs(high[:k] - low[:k]), initial=0.0)) <= UNIQUE_TOLERANCE * max(rmax, 1.0)
    if unique is False:
        notes.append(Note("not_unique", "not unique: many rewards minimise the loss equally; shown is the one with "
                                        "the smallest ||R_S||_1"))
    if outer.excess > STALL_TOLERANCE:
        notes.append(Note("inaccurate", f"inaccurate: the loss is pinned down only to a relative {outer.excess:.0e} "
                                        "(a very large {rmax}?)"))
    with np.errstate(over="ignore"):
        loss, lower_bound = np.exp(outer.log_loss(chosen)), np.exp(log_lower_bound)
    return LossSolution(
        x=chosen[problem.x],
        loss=float(loss),
        lower_bound=float(lower_bound),
        unique=unique,
        gap=float(outer.excess),
        rounds=outer.rounds,
        notes=notes,
    )
