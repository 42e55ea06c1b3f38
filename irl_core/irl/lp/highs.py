"""One way to state a linear program, solve it with HiGHS and report what HiGHS said.

Every LP of the fitters (the lp's margin and intervals, the loss's outer approximation) is a
`LinearProgram`:

    minimise cost @ z  subject to  row_lower <= A z <= row_upper,  lower <= z <= upper,

and is solved by a live `HighsModel`, the one place a `highspy.Highs` is built. A live model
keeps its basis, so new rows (row generation), a new cost or new row bounds (the intervals'
dual) are solved from the last optimum instead of from scratch.

HiGHS's model status is read through one table, `OUTCOMES`: our word for it and whether it
is an answer, a proof of infeasibility or unboundedness, or a failure. A failure is retried
from scratch (unless it was that very solve already), then by the primal simplex, then by the
interior point method IPX with crossover; only when all of them fail does `SolverError` reach
the user. (A model built with `retry=False` raises at once: the lp fit's dual simplex, which has
a faster way on, `lp.solve_margin_lp`.) An `INTERIOR` solve (IPX without crossover, for big worlds) whose points HiGHS finds
primal and dual feasible is an answer even when HiGHS does not call it optimal, with its gap.

The solver is always named ("simplex", "ipx"): HiGHS's "ipm" means IPX in a plain install but
HiPO when `highspy-extras` is installed, which took 12x longer on a 32x32 world's fit.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import highspy
import numpy as np
import scipy.sparse as sp

from irl_core.irl.result import InfeasibleError, SolverError
from irl_core.support.stopping import Stopped, stop_check

Kind = Literal["answer", "infeasible", "unbounded", "failure"]
_Status = highspy.HighsModelStatus

# HiGHS's model status -> (our status word, what it means).
OUTCOMES: dict[highspy.HighsModelStatus, tuple[str, Kind]] = {
    _Status.kOptimal: ("optimal", "answer"),
    _Status.kInfeasible: ("infeasible", "infeasible"),
    _Status.kUnbounded: ("unbounded", "unbounded"),
    # Raised by presolve; `HighsModel.solve` settles it by solving without presolve.
    _Status.kUnboundedOrInfeasible: ("infeasible_or_unbounded", "failure"),
    _Status.kUnknown: ("unknown", "failure"),
    _Status.kIterationLimit: ("iteration_limit", "failure"),
    _Status.kTimeLimit: ("time_limit", "failure"),
    _Status.kSolveError: ("solve_error", "failure"),
    _Status.kModelError: ("model_error", "failure"),
    _Status.kLoadError: ("load_error", "failure"),
    _Status.kPresolveError: ("presolve_error", "failure"),
    _Status.kPostsolveError: ("postsolve_error", "failure"),
    _Status.kMemoryLimit: ("memory_limit", "failure"),
    _Status.kInterrupt: ("interrupted", "failure"),
    _Status.kHighsInterrupt: ("interrupted", "failure"),  # type: ignore[attr-defined]  # in highspy, not its stubs
    _Status.kNotset: ("not_solved", "failure"),
    _Status.kModelEmpty: ("optimal", "answer"),
    _Status.kObjectiveBound: ("objective_bound", "failure"),
    _Status.kObjectiveTarget: ("objective_target", "failure"),
    _Status.kSolutionLimit: ("solution_limit", "failure"),
}

DEFAULT_TOLERANCE = 1e-7

# The interior point method without crossover (`INTERIOR`), for LPs past where the simplex is
# reliable (`lp.INTERIOR_ROWS`), leaves no basis and on such LPs often no "optimal" either: on a
# 128x128 world's first round IPX said "no progress" and HiGHS "unknown", with a point primal
# feasible to 3e-8 and a dual point 0.6% from it in objective. Its point is taken as an answer
# when HiGHS finds both points feasible (within its tolerances), and `SolveReport.gap` carries
# the gap between their objectives, a bound on how far the primal's is from the optimum, on to
# the user. (Row generation needs only a feasible point in its early rounds: the gap that
# matters is the last round's. Going on to the simplex instead, as for other failures, took
# 350 s where the next rounds took 8 s each on a 64x64 world.) Both points are feasible only
# within HiGHS's tolerances, so on an ill-conditioned LP the optimum may lie a little outside
# the gap, as any answer there is good only to the conditioning (docs/benchmarks.md, "How cost grows").
# A HiGHS option's value, and a set of options by name (read-only: callers pass their constants).
OptionValue = bool | int | float | str
Options = Mapping[str, OptionValue]

INTERIOR: dict[str, OptionValue] = {"solver": "ipx", "run_crossover": "off"}


@dataclass(frozen=True)
class SolveReport:
    """What one solve ended with.

    Attributes:
        status: our word for HiGHS's model status ("optimal", "infeasible", ...).
        kind: "answer", "infeasible", "unbounded" or "failure".
        objective: cost @ z at the answer (nan without one).
        iterations: simplex and interior point iterations of this solve, retries included.
        solver: the HiGHS solver that gave the final status ("simplex", "primal simplex", "ipx").
        gap: an `INTERIOR` answer's gap to the dual objective, relative (`_interior_gap`); 0
            for a vertex (optimal within the tolerances).
    """

    status: str
    kind: Kind
    objective: float
    iterations: int
    solver: str
    gap: float = 0.0

    def check(self, infeasible_message: str) -> None:
        """Raise `InfeasibleError` (infeasible) or `SolverError` (anything but an answer)."""
        if self.kind == "infeasible":
            raise InfeasibleError(infeasible_message)
        if self.kind != "answer":
            raise SolverError(f"the LP solver HiGHS ({self.solver}) stopped without an answer ({self.status})")


@dataclass(frozen=True, eq=False)
class LinearProgram:
    """minimise cost @ z  s.t.  row_lower <= A z <= row_upper,  lower <= z <= upper.

    Attributes:
        A: (m, n) sparse CSR.
        row_lower, row_upper: (m,), -inf / inf where a side is absent.
        lower, upper: (n,)
        cost: (n,)
    """

    A: sp.csr_matrix
    row_lower: np.ndarray
    row_upper: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    cost: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns)."""
        return self.A.shape

    def violation(self, z: np.ndarray) -> float:
        """The largest amount by which z breaks a row or a bound (0 when feasible)."""
        Az = self.A @ z
        return float(
            max(
                np.max(self.row_lower - Az, initial=0.0),
                np.max(Az - self.row_upper, initial=0.0),
                np.max(self.lower - z, initial=0.0),
                np.max(z - self.upper, initial=0.0),
            )
        )


def linear_program(
    A: sp.spmatrix,
    row_lower: np.ndarray,
    row_upper: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    cost: np.ndarray | None = None,
) -> LinearProgram:
    """A `LinearProgram`, checked: NaN or an infinite bound of the wrong sign is refused.

    Raises ValueError (a non-finite rmax, say, would otherwise reach HiGHS as a huge number).
    """
    A = sp.csr_matrix(A, dtype=float)
    m, n = A.shape
    arrays = [np.asarray(a, dtype=float) for a in (row_lower, row_upper, lower, upper)]
    cost = np.zeros(n) if cost is None else np.asarray(cost, dtype=float)
    if [a.shape for a in arrays] != [(m,), (m,), (n,), (n,)] or cost.shape != (n,):
        raise ValueError("the LP's bounds and cost do not match its matrix")
    if not np.all(np.isfinite(A.data)) or not np.all(np.isfinite(cost)):
        raise ValueError("the LP's matrix and cost must be finite")
    for low, high in (arrays[:2], arrays[2:]):
        if np.isnan(low).any() or np.isnan(high).any() or np.isposinf(low).any() or np.isneginf(high).any():
            raise ValueError("the LP's bounds must be numbers, with only -inf below and inf above")
    row_lower, row_upper, lower, upper = arrays
    return LinearProgram(A, row_lower, row_upper, lower, upper, cost)


def _new_highs() -> highspy.Highs:
    """A silent `highspy.Highs`.

    highspy 1.16 writes its banner ("Running HiGHS ...") to file descriptor 1 when the first
    Highs of a process is built, before any option can be set. `careful fit --no-view` owes its
    stdout to its own output (it may be piped into a file), so the first one is built with
    fd 1 pointed at /dev/null.
    """
    global _banner_shown
    if _banner_shown:
        highs = highspy.Highs()
    else:
        sys.stdout.flush()
        saved = os.dup(1)
        try:
            with open(os.devnull, "w") as null:
                os.dup2(null.fileno(), 1)
                highs = highspy.Highs()
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        _banner_shown = True
    highs.setOptionValue("output_flag", False)
    return highs


_banner_shown = False


class HighsModel:
    """A live HiGHS model of a `LinearProgram`, solved by the dual simplex unless told otherwise.

    `tolerance` sets HiGHS's primal and dual feasibility tolerances (default 1e-7); `options`
    are further HiGHS options, kept for every solve; `scratch` are those of a retry from
    scratch; `warm_limit` (seconds) gives up a solve from a basis that takes longer, as a failure.
    Without `retry` a failed solve is not retried (`_ATTEMPTS`): for a caller with a better way on.
    """

    def __init__(self, problem: LinearProgram, *, tolerance: float = DEFAULT_TOLERANCE,
                 options: Options | None = None, warm_limit: float | None = None,
                 scratch: Options | None = None, retry: bool = True):
        A = sp.csc_matrix(problem.A)
        A.sort_indices()
        n_row, n_col = A.shape
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = n_col, n_row
        lp.col_cost_ = problem.cost
        lp.col_lower_, lp.col_upper_ = _highs_bound(problem.lower), _highs_bound(problem.upper)
        lp.row_lower_, lp.row_upper_ = _highs_bound(problem.row_lower), _highs_bound(problem.row_upper)
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = A.indptr.astype(np.int32)
        lp.a_matrix_.index_ = A.indices.astype(np.int32)
        lp.a_matrix_.value_ = A.data.astype(float)
        self.n_col, self.n_row = n_col, n_row
        self.highs = _new_highs()
        self.highs.setOptionValue("primal_feasibility_tolerance", tolerance)
        self.highs.setOptionValue("dual_feasibility_tolerance", tolerance)
        self.options = {"solver": "simplex", "simplex_strategy": 1, "run_crossover": "on", **(options or {})}
        self._set(self.options)
        self.highs.passModel(lp)
        self.warm_limit = warm_limit
        self.scratch = scratch or {}
        self.retry = retry
        self.iterations = 0
        self.solves = 0
        self.last: SolveReport | None = None

    def add_rows(self, A: sp.spmatrix, row_lower: np.ndarray, row_upper: np.ndarray) -> None:
        """Append rows row_lower <= A z <= row_upper; the current basis is kept."""
        A = sp.csr_matrix(A)
        A.sort_indices()
        self.highs.addRows(
            A.shape[0], _highs_bound(row_lower), _highs_bound(row_upper), A.nnz,
            A.indptr.astype(np.int32), A.indices.astype(np.int32), A.data.astype(float),
        )
        self.n_row += A.shape[0]

    def set_cost(self, cost: np.ndarray) -> None:
        self.highs.changeColsCost(self.n_col, np.arange(self.n_col, dtype=np.int32), np.asarray(cost, dtype=float))

    def set_basis(self, columns: np.ndarray, rows: np.ndarray) -> None:
        """Start the next solve from a basis: (n_col,) and (n_row,) codes 0 basic, -1 nonbasic at
        the lower bound, +1 nonbasic at the upper bound. Raises ValueError if HiGHS refuses it."""
        status = {0: highspy.HighsBasisStatus.kBasic, -1: highspy.HighsBasisStatus.kLower,
                  1: highspy.HighsBasisStatus.kUpper}
        basis = highspy.HighsBasis()
        basis.col_status = [status[int(c)] for c in columns]
        basis.row_status = [status[int(r)] for r in rows]
        if self.highs.setBasis(basis) != highspy.HighsStatus.kOk:
            raise ValueError("HiGHS refused the basis")

    @property
    def report(self) -> SolveReport:
        """The last solve's report; asking before any solve is a programming error."""
        if self.last is None:
            raise RuntimeError("the model has not been solved yet")
        return self.last

    def solve(self, options: Options | None = None) -> tuple[np.ndarray, SolveReport]:
        """Solve from the current basis, with `options` for this solve only (the first attempt);
        on a failure retry as the module says. Never raises."""
        highs = self.highs
        iterations = 0
        first = {**self.options, **(options or {})}
        interior = all(first.get(option) == value for option, value in INTERIOR.items())
        gap = 0.0
        start = highs.getBasis()
        # A solve from a basis is given up after warm_limit seconds (numerical trouble), then retried.
        # (HiGHS's time limit is on its clock since the model was built.)
        warm_limit = self.warm_limit or 0.0
        warm = {"time_limit": highs.getRunTime() + warm_limit} if warm_limit and start.valid else {}
        # The other simplex: primal after the dual (or HiGHS's choice), dual after the primal.
        other = 1 if first.get("simplex_strategy") == 4 else 4
        for solver, setup in _ATTEMPTS if self.retry else _ATTEMPTS[:1]:
            if solver == "as set":
                self._set({**first, **warm})
            elif solver == "other simplex":
                if not start.valid or first.get("solver") != "simplex":
                    continue
                if warm:
                    warm["time_limit"] = highs.getRunTime() + warm_limit
                self._set({**self.options, **setup, **warm, "simplex_strategy": other})
                highs.setBasis(start)
            else:
                if solver == "from scratch" and not start.valid and _same_solve(first, {**self.options, **self.scratch}):
                    # The failed attempt was this very solve, and HiGHS is deterministic: on a
                    # 128x128 world's first round the retry retraced the 1,170 s failure
                    # iteration for iteration.
                    continue
                highs.clearSolver()
                self._set({**self.options, **self.scratch, **setup, "time_limit": float("inf")})
            _run(highs)
            info = highs.getInfo()
            iterations += max(int(info.simplex_iteration_count), 0) + max(int(info.ipm_iteration_count), 0)
            status = highs.getModelStatus()
            if status == _Status.kUnboundedOrInfeasible and highs.getOptionValue("presolve")[1] != "off":
                # Presolve cannot tell which: the simplex without it can.
                highs.setOptionValue("presolve", "off")
                _run(highs)
                highs.setOptionValue("presolve", self.options.get("presolve", "choose"))
                status = highs.getModelStatus()
            word, kind = OUTCOMES.get(status, ("unknown", "failure"))
            if interior and solver == "as set" and kind in ("answer", "failure"):
                found = _interior_gap(highs)
                if found is not None:
                    word, kind, gap = word if kind == "answer" else "optimal_inaccurate", "answer", found
            if kind != "failure":
                break
        self._set({**self.options, "time_limit": float("inf")})
        self.iterations += iterations
        self.solves += 1
        objective = float(highs.getInfo().objective_function_value) if kind == "answer" else float("nan")
        if solver in ("as set", "from scratch", "other simplex"):
            solver = {"as set": str(first["solver"]), "from scratch": f"{self.options['solver']} from scratch",
                      "other simplex": f"{'dual' if other == 1 else 'primal'} simplex from the same basis"}[solver]
        report = self.last = SolveReport(word, kind, objective, iterations, solver, gap)
        return np.array(highs.getSolution().col_value), report

    def _set(self, options: Options) -> None:
        for option, value in options.items():
            self.highs.setOptionValue(option, value)

    def minimise(self, cost: np.ndarray | None = None, *, infeasible_message: str,
                 options: Options | None = None) -> tuple[np.ndarray, float]:
        """Solve (with a new cost if given, and `options` for this solve only) and return (z, cost @ z).

        Raises `InfeasibleError` with `infeasible_message`, or `SolverError` on anything but an answer.
        """
        if cost is not None:
            self.set_cost(cost)
        z, report = self.solve(options)
        report.check(infeasible_message)
        return z, report.objective


# The solver attempts, in order: the model's own simplex from the current basis, the other
# simplex (primal or dual) from that basis, the model's simplex from scratch (after
# clearSolver), the primal simplex, which copes with the nearly parallel tangent rows of the
# loss, and IPX with crossover. Where a basis is nearly singular (a 64x64 world's interval LPs)
# one simplex fails where the other answers from the same basis, so each is tried before a
# restart (`bench.bench_scaling --stages intervals_cells`).
_ATTEMPTS: tuple[tuple[str, Options], ...] = (
    ("as set", {}),
    ("other simplex", {"simplex_dual_edge_weight_strategy": -1, "simplex_primal_edge_weight_strategy": -1}),
    ("from scratch", {}),
    ("primal simplex", {"solver": "simplex", "simplex_strategy": 4}),
    ("ipx", {"solver": "ipx", "run_crossover": "on"}),
)


def _run(highs: highspy.Highs) -> None:
    """`highs.run()`, stopped within an iteration by Ctrl+C on the main thread (which then raises
    KeyboardInterrupt) or by the thread's `stopping.stop_when` check (which then raises
    `Stopped`; on the main thread too, where a bootstrap pool's worker refits by loss).

    Python runs a signal's handler only between its own bytecodes, so during HiGHS's `run` it
    saw a Ctrl+C only once the solve was over: 20 minutes on a 128x128 world's first round.
    The solve now carries a simplex and IPX callback: Python code, in which the handler runs,
    and which asks HiGHS to stop. (Running HiGHS in highspy's solver thread instead made a
    16x16 fit with its intervals 1.4x slower; the callback costs 1.02x.)
    """
    check = stop_check()
    if threading.current_thread() is not threading.main_thread():
        if check is None:
            highs.run()
            return
        _run_with_stop(highs, check)
        if check():
            raise Stopped()
        return
    asked = check or (lambda: False)
    interrupted = False

    def on_ctrl_c(signum, frame) -> None:
        nonlocal interrupted
        interrupted = True

    previous = signal.signal(signal.SIGINT, on_ctrl_c)
    try:
        _run_with_stop(highs, lambda: interrupted or asked())
    finally:
        signal.signal(signal.SIGINT, previous)
    if interrupted:
        raise KeyboardInterrupt
    if asked():
        raise Stopped()


def _run_with_stop(highs: highspy.Highs, check: Callable[[], bool]) -> None:
    """`highs.run()` with HiGHS asked to stop at its next simplex or IPX iteration once `check()`."""

    def stop_if_asked(event) -> None:
        if check():
            event.interrupt()

    highs.cbSimplexInterrupt += stop_if_asked
    highs.cbIpmInterrupt += stop_if_asked
    try:
        highs.run()
    finally:
        highs.cbSimplexInterrupt -= stop_if_asked
        highs.cbIpmInterrupt -= stop_if_asked


def _interior_gap(highs: highspy.Highs) -> float | None:
    """The gap between an `INTERIOR` solve's objective p and its dual objective d, relative to
    |p| (or 1), which by weak duality holds the optimum when both points are feasible; None when
    HiGHS does not find both feasible (the point is then no answer).

    HiGHS gives e = |p - d| / (1 + |p| + |d|); as |d| <= |p| + |p - d|, the gap
    |p - d| <= e (1 + 2|p|) / (1 - e).
    """
    info = highs.getInfo()
    feasible = highspy.SolutionStatus.kSolutionStatusFeasible
    e = float(info.primal_dual_objective_error)  # type: ignore[attr-defined]  # in highspy, not its stubs
    if info.primal_solution_status != feasible or info.dual_solution_status != feasible or not 0 <= e < 1:
        return None
    p = abs(float(info.objective_function_value))
    return e * (1 + 2 * p) / (1 - e) / max(p, 1.0)


def _same_solve(a: Options, b: Options) -> bool:
    """Whether two option sets describe the same solve (time limits aside)."""
    return {k: v for k, v in a.items() if k != "time_limit"} == {k: v for k, v in b.items() if k != "time_limit"}


def _highs_bound(bound: np.ndarray) -> np.ndarray:
    """HiGHS writes infinity as its own constant."""
    return np.clip(np.asarray(bound, dtype=float), -highspy.kHighsInf, highspy.kHighsInf)
