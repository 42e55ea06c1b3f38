"""The one HiGHS wrapper: its status table, its refusals and its silence on stdout."""

import _thread
import subprocess
import sys
import threading

import highspy
import numpy as np
import pytest
import scipy.sparse as sp

from bench.worlds import cliff_world
from irl_core.irl import InfeasibleError, SolverError, Stopped, fit
from irl_core.irl.lp import highs as highs_module
from irl_core.irl.lp.highs import OUTCOMES, HighsModel, linear_program
from irl_core.irl.lp.margin import lp_constraints, margin_lp
from irl_core.irl.qmap import build_qmap, build_unknowns
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts, write_rollouts
from irl_core.support.stopping import stop_when
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def one_variable(row_lower, row_upper, *, lower=-np.inf, upper=np.inf, cost=-1.0):
    """minimise cost * z subject to row_lower <= z <= row_upper (a row) and lower <= z <= upper."""
    return HighsModel(linear_program(sp.csr_matrix([[1.0]]), [row_lower], [row_upper], [lower], [upper], [cost]))


def test_every_highs_status_has_a_word_and_a_kind():
    statuses = [getattr(highspy.HighsModelStatus, name) for name in dir(highspy.HighsModelStatus) if name.startswith("k")]
    for status in statuses:
        word, kind = OUTCOMES[status]
        assert word and kind in ("answer", "infeasible", "unbounded", "failure")


def test_an_optimum_is_an_answer_with_its_objective():
    z, report = one_variable(-2.0, 3.0).solve()
    assert (report.kind, report.status) == ("answer", "optimal")
    assert z[0] == pytest.approx(3.0) and report.objective == pytest.approx(-3.0)


def test_an_unbounded_lp_is_called_unbounded_not_infeasible():
    _, report = one_variable(0.0, np.inf).solve()
    assert (report.kind, report.status) == ("unbounded", "unbounded")
    with pytest.raises(SolverError, match="unbounded"):
        report.check("never")


def test_an_infeasible_lp_raises_the_message_given():
    model = one_variable(1.0, 2.0, lower=-1.0, upper=0.0)
    _, report = model.solve()
    assert report.kind == "infeasible"
    with pytest.raises(InfeasibleError, match="no such z"):
        model.minimise(infeasible_message="no such z")


@pytest.mark.parametrize("bad", [dict(row_lower=np.nan), dict(row_upper=-np.inf), dict(lower=np.inf), dict(cost=np.inf)])
def test_nan_and_misplaced_infinities_never_reach_highs(bad):
    args = dict(row_lower=0.0, row_upper=1.0, lower=0.0, upper=1.0, cost=1.0) | bad
    with pytest.raises(ValueError):
        linear_program(sp.csr_matrix([[1.0]]), [args["row_lower"]], [args["row_upper"]], [args["lower"]],
                       [args["upper"]], [args["cost"]])


@pytest.fixture(scope="module")
def mud_demos():
    from irl_core.players.experts import demonstrations_of

    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    return demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=10, seed=0))


@pytest.mark.parametrize("method", ["lp", "loss"])
@pytest.mark.parametrize(("rmax", "lam"), [(np.inf, 0.0), (np.nan, 0.0), (1000.0, np.inf)])
def test_an_infinite_rmax_or_lambda_is_refused_before_highs(mud_demos, method, rmax, lam):
    with pytest.raises(ValueError, match="rmax|lambda"):
        fit(mud_demos, method=method, rmax=rmax, lam=lam)


def test_margin_lp_refuses_an_infinite_lambda(mud_demos):
    constraints = lp_constraints(build_qmap(mud_demos.mdp, build_unknowns(mud_demos.mdp)), mud_demos.most_frequent,
                                 rmax=1000.0)
    with pytest.raises(ValueError, match="lambda"):
        margin_lp(constraints, lam=np.inf)


def test_stdout_of_careful_fit_carries_only_its_output(tmp_path):
    # highspy prints a banner on fd 1 when a process builds its first Highs; it must not reach stdout.
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    recording = tmp_path / "mud.jsonl"
    write_rollouts(recording, mdp, rollouts(mdp, optimal_policy(mdp), episodes=5, seed=0),
                   player="expert:optimal", seed=0)
    run = subprocess.run(
        [sys.executable, "-c", "import sys; from careful_tui.cli import main; sys.exit(main())",
         "fit", "--no-view", "--intervals", str(recording)],
        capture_output=True, text=True, timeout=120, check=True,
    )
    assert "HiGHS" not in run.stdout and "licence" not in run.stdout
    library = subprocess.run(
        [sys.executable, "-c", "from irl_core.irl.lp.highs import HighsModel, linear_program; import scipy.sparse as sp; "
         "HighsModel(linear_program(sp.csr_matrix([[1.0]]), [0], [1], [0], [1], [1])).solve(); print('ok')"],
        capture_output=True, text=True, timeout=60, check=True,
    )
    assert library.stdout == "ok\n"


def test_an_lp_the_simplex_cannot_finish_is_answered_by_ipx_with_the_same_optimum(mud_demos):
    constraints = lp_constraints(build_qmap(mud_demos.mdp, build_unknowns(mud_demos.mdp)), mud_demos.most_frequent,
                                 rmax=1000.0)
    problem = margin_lp(constraints).full()
    # No simplex iterations allowed: the simplex attempts all stop at their limit, IPX does not.
    _, report = HighsModel(problem, options={"simplex_iteration_limit": 0}).solve()
    _, reference = HighsModel(problem).solve()
    assert (report.kind, report.solver) == ("answer", "ipx")
    assert report.objective == pytest.approx(reference.objective, rel=1e-7)


def cliff16_margin_model() -> HighsModel:
    """A fresh model of a 16x16 world's whole margin LP (20 optimal episodes): long enough to stop."""
    mdp = build_mdp(cliff_world(16, 16))
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    constraints = lp_constraints(build_qmap(mdp, build_unknowns(mdp)), demos.most_frequent, rmax=1000.0)
    return HighsModel(margin_lp(constraints).full())


def test_ctrl_c_stops_a_solve_at_once_and_is_not_retried():
    # Ctrl+C used to reach Python only when HiGHS returned (20 minutes on a 128x128 world's first
    # round). Here it comes (from the solver thread, deterministically) at the 5th simplex
    # callback of a 16x16 world's margin LP.
    model = cliff16_margin_model()
    seen = []

    def ctrl_c_at_the_fifth(event):
        seen.append(event.data_out.simplex_iteration_count)
        if len(seen) == 5:
            _thread.interrupt_main()

    model.highs.cbSimplexInterrupt += ctrl_c_at_the_fifth
    with pytest.raises(KeyboardInterrupt):
        model.solve()
    assert not model.highs.is_solver_running()
    assert model.highs.getModelStatus() == highspy.HighsModelStatus.kInterrupt  # stopped, not retried


def test_a_solve_on_another_thread_stops_when_asked_and_raises_stopped():
    # The fit view's worker: closing the view must not leave HiGHS running for minutes.
    model = cliff16_margin_model()
    asked, outcome = [], []

    def stop_at_the_fifth() -> bool:
        asked.append(True)
        return len(asked) >= 5

    def fitting_thread():
        try:
            with stop_when(stop_at_the_fifth):
                model.solve()
        except Stopped as exc:
            outcome.append(exc)

    thread = threading.Thread(target=fitting_thread)
    thread.start()
    thread.join(30)
    assert outcome and model.highs.getModelStatus() == highspy.HighsModelStatus.kInterrupt
    assert model.solves == 0  # not retried, not counted as answered


def test_a_solve_on_the_main_thread_stops_when_asked_too():
    # A bootstrap pool's worker refits (by loss, on HiGHS) on its process's main thread, where
    # Ctrl+C has its own route: the stop check must still be heard there.
    model = cliff16_margin_model()
    asked = []
    with stop_when(lambda: asked.append(True) or len(asked) >= 5), pytest.raises(Stopped):
        model.solve()
    assert model.highs.getModelStatus() == highspy.HighsModelStatus.kInterrupt
    assert model.solves == 0


def test_a_failed_solve_from_no_basis_is_not_repeated_from_scratch(mud_demos, monkeypatch):
    # HiGHS is deterministic: a 128x128 world's first round failed after 1,170 s, and the retry
    # from scratch with the same settings retraced it iteration for iteration.
    constraints = lp_constraints(build_qmap(mud_demos.mdp, build_unknowns(mud_demos.mdp)), mud_demos.most_frequent,
                                 rmax=1000.0)
    model = HighsModel(margin_lp(constraints).full(), options={"simplex_iteration_limit": 0})
    runs = []
    run = highs_module._run
    monkeypatch.setattr(highs_module, "_run", lambda highs: runs.append(highs.getOptionValue("solver")[1]) or run(highs))
    _, report = model.solve()
    # The dual simplex, the primal simplex, then IPX: no second identical dual simplex.
    assert runs == ["simplex", "simplex", "ipx"] and report.solver == "ipx"


def test_a_solve_from_a_basis_that_runs_out_of_time_is_retried_from_scratch_with_the_same_optimum(mud_demos):
    # A 64x64 world's interval LPs met nearly singular bases on which the warm simplex ran for
    # minutes: a warm solve is given up after `warm_limit` seconds (here at once) and retried.
    constraints = lp_constraints(build_qmap(mud_demos.mdp, build_unknowns(mud_demos.mdp)), mud_demos.most_frequent,
                                 rmax=1000.0)
    problem = margin_lp(constraints).full()
    cost = np.zeros(problem.shape[1])
    cost[0] = -1.0  # the largest first reward: not where the margin's optimum put it
    answers = []
    for warm_limit in (1e-12, None):
        model = HighsModel(problem, warm_limit=warm_limit)
        assert model.solve()[1].solver == "simplex"  # no basis yet: no limit
        model.set_cost(cost)
        answers.append(model.solve()[1])
    assert answers[0].solver == "simplex from scratch" and answers[1].solver == "simplex"
    assert answers[0].objective == pytest.approx(answers[1].objective, rel=1e-9)


def test_options_for_one_solve_are_set_back_afterwards():
    model = one_variable(-2.0, 3.0)
    _, report = model.solve({"simplex_strategy": 4})
    assert report.kind == "answer" and model.highs.getOptionValue("simplex_strategy")[1] == 1
