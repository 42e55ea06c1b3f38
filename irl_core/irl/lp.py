"""The paper's simple IRL agent: the rewards under which the demonstrated policy is optimal.

Ng & Russell (2000), extended by Hanslope & Aitchison to rewards R(s, a) = R_S(s) + R_A(a)
with a known action cost. The demonstrated policy pi(s) is the most frequent action at s
(ties: lowest action index). The paper writes Q^pi through (I - gamma T^pi)^-1, which needs
pi everywhere; we keep the values V as variables (SPEC section 3), so that

    V(s) >= Q(s, a)             every non-terminal s, every a      (no action beats V)
    V(s)  = Q(s, pi(s))         every demonstrated s               (pi(s) attains it)
    V(s)  = R_S(s)              every terminal cell;  V(exit) = 0
    |R_S| <= rmax,  |V| <= (rmax + max |R_A|) / (1 - gamma)

with Q(s, a) = R_S(s) + R_A(a) + gamma sum_s' P(s'|s, a) V(s') affine in x = [theta; V]
(`qmap`). When every non-terminal state is demonstrated, V = V^pi and this is exactly the
paper's LP; at a state never demonstrated it assumes only that the expert would act
optimally there. The value bound is one no genuine value function exceeds; it only closes
rays along which an unvisited state's value (bounded only from below) could grow.

Among the feasible rewards the agent maximises the paper's margin (its equation 1),

    sum over demonstrated s of [V(s) - max_{a != pi(s)} Q(s, a)]  -  lambda ||R_S||_1,

with one epigraph variable t_s >= Q(s, a) (a != pi(s)) per demonstrated state and, when
lambda > 0, u >= |theta|. Every block is assembled as one sparse matrix and the LP is
solved by HiGHS directly (`HighsLP`). bench/bench_fit.py measures the whole fit at 1.1-1.3x
the time of scipy's linprog(method="highs") on the same, pre-assembled LP, where stating
it in cvxpy costs 1.5-2.4x (over 2x on `paper-simple`); and a live HiGHS model can be
re-solved from its last basis, which is what the intervals need.
"""

from __future__ import annotations

from dataclasses import dataclass

import highspy
import numpy as np
import scipy.sparse as sp

from irl_core.irl.qmap import QMap
from irl_core.irl.result import InfeasibleError, SolverError

INFEASIBLE_MESSAGE = (
    "the demonstrations are not optimal for any reward within ±rmax; "
    "they may be noisy: try --method loss, or raise --rmax"
)


@dataclass(frozen=True, eq=False)
class LPConstraints:
    """The lp feasible set over x = [theta (k,); V (S,)].

    row_lower <= A @ x <= row_upper and lower <= x <= upper, with A (m, k + S) sparse CSR.

    Attributes:
        qmap: the Q map the rows were built from.
        policy: (S,) pi(s), the demonstrated action, or -1 where nothing was demonstrated.
    """

    qmap: QMap
    policy: np.ndarray
    A: sp.csr_matrix
    row_lower: np.ndarray
    row_upper: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    @property
    def demonstrated(self) -> np.ndarray:
        """(d,) the demonstrated states, ascending."""
        return np.flatnonzero(self.policy >= 0)

    def violation(self, x: np.ndarray) -> float:
        """The largest amount by which x breaks a constraint or a bound (0 when feasible)."""
        Ax = self.A @ x
        return float(
            max(
                np.max(self.row_lower - Ax, initial=0.0),
                np.max(Ax - self.row_upper, initial=0.0),
                np.max(self.lower - x, initial=0.0),
                np.max(x - self.upper, initial=0.0),
            )
        )


def lp_constraints(qmap: QMap, policy: np.ndarray, *, rmax: float) -> LPConstraints:
    """The lp feasible set for the demonstrated policy (S,) (-1: not demonstrated)."""
    mdp = qmap.mdp
    S, A = mdp.n_states, mdp.n_actions
    policy = np.asarray(policy, dtype=np.int64)
    shown = policy >= 0
    if np.any(shown & ~mdp.nonterminal):
        raise ValueError("a policy is given at a terminal state or the exit")

    # V(s) >= Q(s, a) at non-terminal s, except (s, pi(s)), which the equality covers.
    s_all = np.repeat(np.arange(S), A)
    a_all = np.tile(np.arange(A), S)
    keep = np.repeat(mdp.nonterminal, A) & (a_all != np.repeat(np.where(shown, policy, -1), A))
    rows_q, q0 = qmap.rows(s_all[keep], a_all[keep])
    better = rows_q - qmap.value_selector(s_all[keep])

    # V(s) = Q(s, pi(s)) at demonstrated s.
    d = np.flatnonzero(shown)
    rows_pi, q0_pi = qmap.rows(d, policy[d])
    attains = qmap.value_selector(d) - rows_pi

    matrix = sp.vstack([better, attains, qmap.E], format="csr")
    row_lower = np.concatenate([np.full(better.shape[0], -np.inf), q0_pi, qmap.e])
    row_upper = np.concatenate([-q0, q0_pi, qmap.e])
    vmax = qmap.value_bound(rmax)
    lower = np.concatenate([np.full(qmap.k, -rmax), np.full(S, -vmax)])
    upper = -lower
    return LPConstraints(qmap, policy, matrix, row_lower, row_upper, lower, upper)


class HighsLP:
    """One HiGHS model, kept alive so that new costs are solved from the last basis.

    minimise cost @ z  s.t.  row_lower <= A z <= row_upper,  lower <= z <= upper.
    """

    def __init__(
        self,
        A: sp.spmatrix,
        row_lower: np.ndarray,
        row_upper: np.ndarray,
        lower: np.ndarray,
        upper: np.ndarray,
        cost: np.ndarray | None = None,
        *,
        tolerance: float | None = None,
        interior: bool = False,
    ):
        """`tolerance`: HiGHS's primal and dual feasibility tolerances (default 1e-7).
        `interior`: solve by the interior point method without crossover (no basis to warm-start
        from, but far faster on large models)."""
        A = sp.csc_matrix(A)
        A.sort_indices()
        n_row, n_col = A.shape
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = n_col, n_row
        lp.col_cost_ = np.zeros(n_col) if cost is None else np.asarray(cost, dtype=float)
        lp.col_lower_, lp.col_upper_ = _finite(lower), _finite(upper)
        lp.row_lower_, lp.row_upper_ = _finite(row_lower), _finite(row_upper)
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = A.indptr.astype(np.int32)
        lp.a_matrix_.index_ = A.indices.astype(np.int32)
        lp.a_matrix_.value_ = A.data.astype(float)
        self.n_col = n_col
        self.highs = highspy.Highs()
        self.highs.setOptionValue("output_flag", False)
        if tolerance is not None:
            self.highs.setOptionValue("primal_feasibility_tolerance", tolerance)
            self.highs.setOptionValue("dual_feasibility_tolerance", tolerance)
        if interior:
            self.highs.setOptionValue("solver", "ipm")
            self.highs.setOptionValue("run_crossover", "off")
        self.highs.passModel(lp)
        self.iterations = 0

    def add_rows(self, A: sp.spmatrix, row_lower: np.ndarray, row_upper: np.ndarray) -> None:
        """Append constraints row_lower <= A z <= row_upper; the current basis is kept."""
        A = sp.csr_matrix(A)
        A.sort_indices()
        self.highs.addRows(
            A.shape[0], _finite(row_lower), _finite(row_upper), A.nnz,
            A.indptr.astype(np.int32), A.indices.astype(np.int32), A.data.astype(float),
        )

    def minimise(self, cost: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """Solve (with new costs if given) and return (z, objective).

        Raises `InfeasibleError` when no z satisfies the constraints, `SolverError` on
        any other outcome than an optimum.
        """
        highs = self.highs
        if cost is not None:
            highs.changeColsCost(self.n_col, np.arange(self.n_col, dtype=np.int32), np.asarray(cost, dtype=float))
        status = self._run()
        if status not in _ANSWERS and not self._interior_optimum(status):
            # A warm start can occasionally fail inside HiGHS: solve from scratch, then with
            # the primal simplex, which copes with the nearly parallel tangent rows of the loss.
            highs.clearSolver()
            status = self._run()
        if status not in _ANSWERS:
            _, strategy = highs.getOptionValue("simplex_strategy")
            highs.setOptionValue("simplex_strategy", 4)
            highs.clearSolver()
            status = self._run()
            highs.setOptionValue("simplex_strategy", strategy)
        if status == highspy.HighsModelStatus.kOptimal or self._interior_optimum(status):
            return np.array(highs.getSolution().col_value), float(highs.getInfo().objective_function_value)
        # Every variable is bounded, so "unbounded or infeasible" can only mean infeasible.
        if status in (highspy.HighsModelStatus.kInfeasible, highspy.HighsModelStatus.kUnboundedOrInfeasible):
            raise InfeasibleError(INFEASIBLE_MESSAGE)
        raise SolverError(f"the LP solver HiGHS stopped without an answer ({highs.modelStatusToString(status)})")


    def _interior_optimum(self, status: highspy.HighsModelStatus) -> bool:
        """Without crossover HiGHS can report "unknown" for an interior point answer that is primal
        feasible and whose dual infeasibility is within tolerance: optimal to its tolerances."""
        info = self.highs.getInfo()
        _, tolerance = self.highs.getOptionValue("dual_feasibility_tolerance")
        feasible = int(highspy.SolutionStatus.kSolutionStatusFeasible)
        return (status == highspy.HighsModelStatus.kUnknown
                and int(info.primal_solution_status) == feasible
                and info.max_dual_infeasibility <= tolerance)

    def _run(self) -> highspy.HighsModelStatus:
        self.highs.run()
        self.iterations += max(int(self.highs.getInfo().simplex_iteration_count), 0)
        return self.highs.getModelStatus()


_ANSWERS = (
    highspy.HighsModelStatus.kOptimal,
    highspy.HighsModelStatus.kInfeasible,
    highspy.HighsModelStatus.kUnboundedOrInfeasible,
)


# A model with more rows than this is solved by HiGHS's interior point method without
# crossover: on a 64x64 world (376,000 rows) in under a minute, where simplex takes longer than
# ten; on `paper` (2,000 rows) simplex is quicker and leaves a basis to warm-start from.
INTERIOR_ROWS = 50_000


def highs_lp(
    A: sp.spmatrix,
    row_lower: np.ndarray,
    row_upper: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    cost: np.ndarray | None = None,
) -> HighsLP:
    """A live HiGHS model of the LP: simplex, or the interior point method past `INTERIOR_ROWS`."""
    return HighsLP(A, row_lower, row_upper, lower, upper, cost, interior=A.shape[0] > INTERIOR_ROWS)


def _finite(bound: np.ndarray) -> np.ndarray:
    """HiGHS writes infinity as +-inf too, but only as its own constant."""
    return np.clip(np.asarray(bound, dtype=float), -highspy.kHighsInf, highspy.kHighsInf)


@dataclass(frozen=True, eq=False)
class MarginLP:
    """The margin-maximising LP over z = [theta; V; t (d,); u (k,) if lambda > 0].

    Attributes:
        constraints: the feasible set it extends.
        A, row_lower, row_upper, lower, upper, cost: the LP in HiGHS's form (minimise cost @ z).
    """

    constraints: LPConstraints
    A: sp.csr_matrix
    row_lower: np.ndarray
    row_upper: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    cost: np.ndarray


def margin_lp(constraints: LPConstraints, *, lam: float = 0.0) -> MarginLP:
    """Add the paper's objective to the feasible set: maximise the margin minus lambda ||R_S||_1."""
    qmap = constraints.qmap
    A, n, k = qmap.mdp.n_actions, qmap.n, qmap.k
    d = constraints.demonstrated
    n_d = d.size
    n_u = k if lam > 0 else 0

    # t_s >= Q(s, a) for a != pi(s): rows Q(s, a) - t_s <= -q0.
    s_rep = np.repeat(d, A)
    a_rep = np.tile(np.arange(A), n_d)
    other = a_rep != np.repeat(constraints.policy[d], A)
    rows_q, q0 = qmap.rows(s_rep[other], a_rep[other])
    t_col = np.repeat(np.arange(n_d), A)[other]
    pick_t = sp.csr_matrix((np.ones(t_col.size), (np.arange(t_col.size), t_col)), shape=(t_col.size, n_d))
    epigraph = sp.hstack([rows_q, -pick_t, sp.csr_matrix((t_col.size, n_u))])

    blocks = [sp.hstack([constraints.A, sp.csr_matrix((constraints.A.shape[0], n_d + n_u))]), epigraph]
    row_lower = [constraints.row_lower, np.full(t_col.size, -np.inf)]
    row_upper = [constraints.row_upper, -q0]
    if n_u:
        # u >= theta and u >= -theta.
        eye = sp.identity(k, format="csr")
        zeros = sp.csr_matrix((k, n - k + n_d))
        blocks += [sp.hstack([eye, zeros, -eye]), sp.hstack([-eye, zeros, -eye])]
        row_lower += [np.full(2 * k, -np.inf)]
        row_upper += [np.zeros(2 * k)]

    cost = np.zeros(n + n_d + n_u)
    cost[qmap.k + d] = -1.0  # maximise sum V(s) ...
    cost[n : n + n_d] = 1.0  # ... - sum t_s
    cost[n + n_d :] = lam * qmap.unknowns.weight[:n_u]
    rmax = constraints.upper[:k].max(initial=0.0)
    # t_s is a Q value, so |t_s| <= vmax, the value bound (it keeps every variable bounded).
    vmax = constraints.upper[k:n].max(initial=0.0)
    lower = np.concatenate([constraints.lower, np.full(n_d, -vmax), np.zeros(n_u)])
    upper = np.concatenate([constraints.upper, np.full(n_d, vmax), np.full(n_u, rmax)])
    return MarginLP(
        constraints=constraints,
        A=sp.vstack(blocks, format="csr"),
        row_lower=np.concatenate(row_lower),
        row_upper=np.concatenate(row_upper),
        lower=lower,
        upper=upper,
        cost=cost,
    )


@dataclass(frozen=True)
class LPSolution:
    """x = [theta; V] of the margin LP's optimum, its margin sum and HiGHS's effort."""

    x: np.ndarray
    margin: float
    iterations: int


def solve_margin_lp(constraints: LPConstraints, *, lam: float = 0.0) -> LPSolution:
    """Solve the margin LP with HiGHS. Raises `InfeasibleError` or `SolverError`."""
    problem = margin_lp(constraints, lam=lam)
    solver = highs_lp(problem.A, problem.row_lower, problem.row_upper, problem.lower, problem.upper, problem.cost)
    z, _ = solver.minimise()
    n, n_d = constraints.qmap.n, constraints.demonstrated.size
    margin = float(z[constraints.qmap.k + constraints.demonstrated].sum() - z[n : n + n_d].sum())
    return LPSolution(x=z[:n], margin=margin, iterations=solver.iterations)
