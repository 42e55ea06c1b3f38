"""How the fit view looks on `mud` with intervals, in a 100x40 terminal (an SVG snapshot).

The recording is simulated with a fixed seed, and the view hides the fit's seconds, so the
picture is the same on every run. Update it after an intended change with
`pytest tests/tui/test_fit_view_snapshot.py --snapshot-update`.
"""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from careful_tui.app import make_fit_app
from careful_tui.cli import build_parser, main
from careful_tui.commands.fit import fit_from_args


@pytest.fixture(scope="module")
def mud_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("snapshot") / "mud.jsonl"
    argv = ["simulate", "--world", "mud", "--policy", "optimal", "--episodes", "100", "--seed", "0", "--out", str(path)]
    assert main(argv) == 0
    return path


def test_fit_view_on_mud_with_intervals(snap_compare, mud_file) -> None:
    args = build_parser().parse_args(["fit", str(mud_file), "--intervals"])
    demos, result = fit_from_args(args, err=Console(file=io.StringIO()))
    app = make_fit_app(args, demos, result, show_times=False)
    assert snap_compare(app, terminal_size=(100, 40))
