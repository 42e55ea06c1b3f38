"""An option a run does not use is named on stderr ("warning: ... ignored"), never dropped in silence;
one that can only be a mistake (--beta auto with a method without a temperature) is refused."""

import io
from pathlib import Path

import pytest
from rich.console import Console

import careful_tui.commands.play as play_command
from careful_tui.cli import build_parser, main
from careful_tui.commands.fit import fit_from_args

SAMPLE = Path(__file__).parents[2] / "recordings" / "samples" / "sample-expert-paper.jsonl"  # an optimal expert: auto picks lp


def careful(capsys, *argv) -> tuple[int, str]:
    code = main([str(arg) for arg in argv])
    return code, capsys.readouterr().err


def warnings_in(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith("warning:")]


@pytest.mark.parametrize(("beta", "policy", "wanted"), [
    (["--beta", "3"], "optimal", ["warning: --beta applies only to --policy boltzmann; ignored"]),
    (["--beta", "3"], "boltzmann", []),
    ([], "optimal", []),
])
def test_simulate_names_a_beta_the_optimal_expert_does_not_use(capsys, tmp_path, beta, policy, wanted):
    out = tmp_path / "e.jsonl"
    code, err = careful(capsys, "simulate", "--world", "mud", "--policy", policy, *beta, "--episodes", "2",
                        "--seed", "0", "--out", out)
    assert code == 0 and out.exists()
    assert warnings_in(err) == wanted


def test_simulate_boltzmann_keeps_its_default_beta_of_one(capsys, tmp_path):
    out = tmp_path / "e.jsonl"
    assert careful(capsys, "simulate", "--world", "mud", "--policy", "boltzmann", "--episodes", "1", "--seed", "0",
                   "--out", out)[0] == 0
    assert '"player": "expert:boltzmann(beta=1)"' in out.read_text()


@pytest.mark.parametrize(("argv", "wanted"), [
    (["--confidence", "0.9", "--resamples", "50"], "--confidence and --resamples apply only with --intervals; ignored"),
    (["--seed", "7"], "--seed applies only with --intervals; ignored"),
    (["--method", "lp", "--intervals", "--resamples", "50"],
     "--resamples applies only to loss's and maxent's intervals, which resample episodes (lp's is every value "
     "the demonstrations allow); ignored"),
    (["--method", "lp", "--beta", "2"], "--beta applies only to maxent; ignored"),
    (["--beta", "2"], "--beta applies only to maxent (method auto chose lp); ignored"),
    (["--method", "maxent", "--lambda", "1"], "--lambda applies only to lp and loss; ignored"),
])
def test_the_printout_names_each_option_its_fit_ignores_and_goes_on(capsys, argv, wanted):
    code, err = careful(capsys, "fit", SAMPLE, "--no-view", *argv)
    assert code == 0, err
    assert warnings_in(err) == [f"warning: {wanted}"]


@pytest.mark.parametrize("argv", [
    [], ["--seed", "0", "--resamples", "200", "--lambda", "0"],  # defaults given: ignoring them changes nothing
    ["--intervals", "--method", "maxent", "--beta", "2", "--confidence", "0.9"],
    ["--method", "lp", "--lambda", "1"],
])
def test_options_the_fit_uses_get_no_warning(capsys, argv):
    code, err = careful(capsys, "fit", SAMPLE, "--no-view", *argv)
    assert code == 0, err
    assert warnings_in(err) == []


def test_the_fit_view_warns_of_nothing_as_its_keys_can_use_every_option():
    args = build_parser().parse_args(["fit", str(SAMPLE), "--method", "lp", "--beta", "2", "--confidence", "0.9"])
    err = io.StringIO()
    fit_from_args(args, err=Console(file=err))
    assert "warning" not in err.getvalue()


def test_beta_auto_with_loss_is_refused_as_with_lp(capsys):
    code, err = careful(capsys, "fit", SAMPLE, "--no-view", "--method", "loss", "--beta", "auto")
    assert code == 2
    assert err.strip() == "careful fit: --beta auto needs --method maxent or auto: loss has no temperature to estimate"


@pytest.mark.parametrize(("argv", "wanted"), [
    (["--input", "tap"], "warning: --calibrate applies only to --input hold; ignored"),
    (["--world", "paper-simple"],
     "warning: --calibrate applies only to a world of several levels ('paper-simple' has one); ignored"),
    ([], None),
])
def test_play_names_a_calibration_that_would_time_nothing(capsys, monkeypatch, tmp_path, argv, wanted):
    made = {}

    class Opened(Exception):
        """The game would open now."""

    def make_play_app(world, **options):
        made.update(options)
        raise Opened

    monkeypatch.setattr(play_command, "require_terminal", lambda command: None)
    monkeypatch.setattr(play_command, "make_play_app", make_play_app)
    args = build_parser().parse_args(["play", "--calibrate", "--out", str(tmp_path), *argv])
    with pytest.raises(Opened):
        play_command.run_play(args)
    assert made["calibrate"] is (wanted is None)
    assert warnings_in(capsys.readouterr().err) == ([wanted] if wanted else [])
