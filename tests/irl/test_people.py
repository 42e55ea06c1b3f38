"""The people player model: exact gradients against central differences, and maxent as its special case."""

from __future__ import annotations

import numpy as np
import pytest

from irl_core.irl import maxent
from irl_core.irl.choices import PLAYER_MODELS, Player, player_model
from irl_core.irl.people.likelihood import level_kernel, log_likelihood
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import World

SMALL = World(name="small", layout="...\n.U.\nCUG\n", levels=4, rewards={"C": -50.0, "G": 10.0, "U": -3.0})


def _counts(mdp, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    counts[mdp.nonterminal] = rng.integers(0, 4, size=(int(mdp.nonterminal.sum()), mdp.n_actions))
    return counts


@pytest.mark.parametrize("bias", [0.0, -1.3])
@pytest.mark.parametrize("name", list(PLAYER_MODELS))
def test_every_gradient_agrees_with_central_differences(name, bias):
    """Also with a hand that under-holds (a bias known from calibration trials): the gradient is the same formula."""
    mdp = build_mdp(SMALL)
    model = player_model(name)
    counts = _counts(mdp, 1)
    R_S = mdp.R_S + np.random.default_rng(2).normal(0, 2, mdp.n_states)
    R_S[mdp.exit_state] = 0.0
    player = Player(beta=0.7, sigma=0.8, lapse=0.1, bias=bias)
    got = log_likelihood(mdp, counts, R_S, model=model, player=player)

    def ll(R=R_S, p=player) -> float:
        return log_likelihood(mdp, counts, R, model=model, player=p, gradient=False).value

    h = 1e-5
    for s in range(mdp.n_states - 1):
        step = np.zeros(mdp.n_states)
        step[s] = h
        assert got.R_S[s] == pytest.approx((ll(R_S + step) - ll(R_S - step)) / (2 * h), rel=1e-5, abs=1e-6)
    scaled = [Player(0.7 * np.exp(e), 0.8, 0.1, bias) for e in (h, -h)]
    assert got.log_beta == pytest.approx((ll(p=scaled[0]) - ll(p=scaled[1])) / (2 * h), rel=1e-5, abs=1e-6)
    if model.hand:
        wider = [Player(0.7, 0.8 * np.exp(e), 0.1, bias) for e in (h, -h)]
        assert got.log_sigma == pytest.approx((ll(p=wider[0]) - ll(p=wider[1])) / (2 * h), rel=1e-5, abs=1e-6)
        assert got.log_sigma != 0.0
    if model.lapses:
        more = [Player(0.7, 0.8, 0.1 + e, bias) for e in (h, -h)]
        assert got.lapse == pytest.approx((ll(p=more[0]) - ll(p=more[1])) / (2 * h), rel=1e-5, abs=1e-6)


def test_the_boltzmann_player_is_maxent_exactly():
    mdp = build_mdp(SMALL)
    counts = _counts(mdp, 3)
    R_S = mdp.R_S.copy()
    ours = log_likelihood(mdp, counts, R_S, model=player_model("boltzmann"), player=Player(0.4, 2.0, 0.2))
    theirs, grad, _ = maxent.log_likelihood(mdp, counts, R_S, beta=0.4)
    assert ours.value == pytest.approx(theirs, rel=1e-10)
    np.testing.assert_allclose(ours.R_S, grad, rtol=1e-8, atol=1e-10)


def test_a_hand_of_no_noise_and_no_lapses_is_the_ends_model():
    mdp = build_mdp(SMALL)
    counts = _counts(mdp, 4)
    ends = log_likelihood(mdp, counts, mdp.R_S, model=player_model("ends"), player=Player(0.5))
    person = log_likelihood(mdp, counts, mdp.R_S, model=player_model("person"), player=Player(0.5, 0.05, 0.0))
    assert person.value == pytest.approx(ends.value, rel=1e-9)


def test_with_ends_a_terminal_cell_is_worth_its_reward_and_nothing_after():
    mdp = build_mdp(SMALL)
    got = log_likelihood(mdp, _counts(mdp, 5), mdp.R_S, model=player_model("ends"), player=Player(1.0))
    terminal = np.flatnonzero(mdp.terminal)
    np.testing.assert_allclose(got.plan.V[terminal], mdp.R_S[terminal], atol=1e-9)
    assert got.plan.V[mdp.exit_state] == pytest.approx(0.0, abs=1e-9)


def test_the_level_kernel_is_a_distribution_centred_on_the_intended_level():
    K, _ = level_kernel(14, 1.5)
    np.testing.assert_allclose(K.sum(axis=1), 1.0)
    assert (K.argmax(axis=1) == np.arange(14)).all()
    np.testing.assert_allclose(level_kernel(14, 0.05)[0], np.eye(14), atol=1e-80)


def test_an_unknown_player_model_is_refused_by_name():
    with pytest.raises(ValueError, match="player_model must be one of"):
        player_model("robot")


def test_the_people_package_is_reached_through_its_face():
    # Its public names import from the package; code outside it never imports its modules.
    import ast
    from pathlib import Path

    import irl_core.irl.people as people

    assert all(hasattr(people, name) for name in people.__all__)
    root = Path(people.__file__).resolve().parents[3]
    reaching_in = []
    for path in [*root.joinpath("irl_core").rglob("*.py"), *root.joinpath("careful_tui").rglob("*.py"),
                 *root.joinpath("bench").rglob("*.py")]:
        if "people" in path.relative_to(root).parts[:3] and path.parent.name == "people":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("irl_core.irl.people."):
                reaching_in.append(f"{path.relative_to(root)}: {node.module}")
    assert reaching_in == []


def test_a_warm_start_moves_the_values_to_first_order_and_changes_no_answer():
    # `Likelihood.warm` starts the next evaluation's soft values where a first-order step in the rewards puts them:
    # the answer is the same fixed point as from a cold start, and the step is first order (its error shrinks with
    # the square of the rewards' change), found with the factors the gradient left. Small worlds have none.
    from bench.worlds import cliff_world
    from irl_core.irl.people.likelihood import WARM_STEP_STATES

    small = build_mdp(cliff_world(3, 4))
    assert log_likelihood(small, _counts(small, 1), small.R_S * 0.05, model=PLAYER_MODELS["person"],
                          player=Player(1.3, 0.6, 0.03)).warm is None
    mdp = build_mdp(cliff_world(12, 14))
    assert mdp.n_states > WARM_STEP_STATES
    counts = _counts(mdp, 1)
    model, player = PLAYER_MODELS["person"], Player(1.3, 0.6, 0.03)
    R_S = np.where(mdp.nonterminal, 0.0, mdp.R_S) * 0.05
    first = log_likelihood(mdp, counts, R_S, model=model, player=player)
    change = np.random.default_rng(0).normal(size=mdp.n_states)
    errors = []
    for step in (1e-2, 1e-3):
        moved = R_S + step * change
        cold = log_likelihood(mdp, counts, moved, model=model, player=player)
        warm = log_likelihood(mdp, counts, moved, model=model, player=player, warm=first.warm)
        np.testing.assert_allclose(warm.value, cold.value, rtol=1e-12)
        np.testing.assert_allclose(warm.R_S, cold.R_S, rtol=1e-8, atol=1e-10)
        predicted = first.warm.values_for(player.beta * mdp.reward_matrix(moved))
        errors.append(np.abs(predicted - cold.plan.V).max())
        assert errors[-1] < 0.1 * np.abs(first.plan.V - cold.plan.V).max()  # far nearer than the last values
    assert errors[1] < 0.03 * errors[0]  # a tenth of the step, a hundredth of the error
