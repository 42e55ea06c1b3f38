"""Without an extra a command needs, the `careful` script says what to install, in one line, not a traceback."""

import subprocess
import sys

from careful_tui.errors import missing_extra


def test_a_missing_extra_is_named_with_what_to_install(tmp_path):
    # A module named matplotlib that cannot be imported stands in for an install without the figures extra.
    (tmp_path / "matplotlib").mkdir()
    (tmp_path / "matplotlib" / "__init__.py").write_text(
        "raise ModuleNotFoundError(\"No module named 'matplotlib'\", name='matplotlib')\n")
    code = "import sys; from careful_tui.entry import main; sys.exit(main())"
    run = subprocess.run([sys.executable, "-c", code, "experiment", "--out", str(tmp_path / "x")], capture_output=True,
                         text=True, env={"PYTHONPATH": f"{tmp_path}:{'/'.join(__file__.split('/')[:-3])}",
                                         "PATH": "/usr/bin:/bin"})
    assert run.returncode == 1, run.stderr
    assert run.stderr.strip().splitlines()[-1] == (
        "careful: this needs matplotlib, which is not installed: pip install 'careful[figures]' (or 'careful[all]')")


def test_only_an_extras_module_is_turned_into_that_message():
    assert missing_extra(ModuleNotFoundError("x", name="matplotlib.pyplot")) == "figures"
    assert missing_extra(ModuleNotFoundError("x", name="starlette")) == "web"
    assert missing_extra(ModuleNotFoundError("x", name="numpy")) is None
