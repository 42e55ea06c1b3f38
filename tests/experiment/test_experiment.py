"""`careful experiment` on reduced sizes: the summary tells the paper's story."""

import json

from careful_tui.cli import main


def test_quick_experiment_tells_the_papers_story(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no recordings/ here: stage 4 uses simulated noisy experts
    out = tmp_path / "exp"
    assert main(["experiment", "--quick", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    by_stage = {e["stage"]: e for e in summary["estimates"]}
    lp, maxent, loss = by_stage["careful lp"], by_stage["maxent baseline"], by_stage["loss, noisy"]
    # The careful LP recovers the cliff's severity; the MaxEnt baseline badly underestimates it.
    assert lp["cliff_error"] < 0.10
    assert maxent["cliff"] < 0 and maxent["cliff_error"] > 0.5
    assert maxent["goal"] > 0
    assert loss["cliff"] < loss["goal"]
    intervals = {s["world"]: s for s in summary["intervals"] if s["kind"] == "identified"}
    noisy = {s["world"]: s for s in summary["intervals"] if s["kind"] == "confidence"}
    assert set(noisy) == {"mud", "mud-simple"} and "Boltzmann episodes" in noisy["mud"]["data"]
    assert intervals["mud"]["separated"] and not intervals["mud-simple"]["separated"]
    assert intervals["mud"]["cliff"][1] < intervals["mud"]["mud"][0]
    for name in ("fig3-optimal-policy", "fig4-true-reward", "fig5-maxent", "fig6-lp",
                 "fig7-demonstrated-policy", "fig8-loss", "intervals-mud", "intervals-mud-simple"):
        assert (out / f"{name}.pdf").read_bytes().startswith(b"%PDF")
        assert (out / f"{name}.png").read_bytes().startswith(b"\x89PNG")
    # The paper's claims, judged from this run: (b) is mixed, since without carefulness maxent's confidence
    # intervals separate the cliff from the mud as well (discussed, not left bare).
    claims = {c["claim"]: c for c in summary["claims"]}
    assert sorted(claims) == ["a", "b", "c"] and claims["a"]["verdict"] == "supported"
    assert claims["b"]["verdict"] == "mixed" and "Without carefulness (mud-simple)" in claims["b"]["discussion"][0]
    report = (out / "report.md").read_text()
    assert "## The paper's claims, against this run" in report
    assert "| careful lp |" in report and "![Figure 6" in report and "(fig6-lp.png)" in report
    assert "simulated noisy experts" in report
    assert "A fitted reward is a point estimate" in report
    # Each interval figure is titled with its kind of interval.
    assert "### Identified sets on mud: every value the lp allows" in report
    assert "### Confidence intervals on mud: maxent from noisy experts" in report
    # Cliff cells at the fit's bound are counted, and such a cliff is not called recovered.
    for e in summary["estimates"]:
        assert 0 <= e["cliff_at_bound"] <= e["cliff_cells"] == 4
    caption = report.split("### Figure 8")[1].split("###")[0]
    # 10 noisy episodes leave most of the loss's cliff at -rmax (3 of 4 cells with seed 0).
    assert loss["cliff_at_bound"] >= 1
    assert f"{loss['cliff_at_bound']} of its 4 cells" in caption and "severity is recovered" not in caption


def test_experiment_refuses_a_file_as_out(tmp_path, capsys):
    target = tmp_path / "taken"
    target.write_text("")
    assert main(["experiment", "--quick", "--out", str(target)]) == 2
    assert "is a file" in capsys.readouterr().err


def test_experiment_never_overwrites_a_recording_in_its_folder(tmp_path, capsys):
    """summary.json and report.md go through the same output guard as the figures."""
    out = tmp_path / "exp"
    out.mkdir()
    recording = out / "report.md"
    assert main(["simulate", "--world", "paper", "--policy", "optimal", "--episodes", "2", "--seed", "0",
                 "--out", str(recording)]) == 0
    before = recording.read_bytes()
    assert main(["experiment", "--quick", "--out", str(out)]) == 2
    assert recording.read_bytes() == before
    assert "report.md" in capsys.readouterr().err
