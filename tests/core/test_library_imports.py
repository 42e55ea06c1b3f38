"""`import irl_core` is the library: its public API, none of it from an extra (TUI, figures, export, cluster)."""

import subprocess
import sys

import irl_core

EXTRAS = ("textual", "rich", "matplotlib", "minari", "PIL", "h5py", "dask", "distributed")


def test_every_public_name_resolves_and_is_documented():
    for name in irl_core.__all__:
        value = getattr(irl_core, name)
        assert value is not None and name in dir(irl_core)
        if callable(value):
            assert (value.__doc__ or "").strip(), f"irl_core.{name} has no docstring for the API reference"


def test_an_unknown_name_is_an_attribute_error():
    try:
        irl_core.no_such_name  # noqa: B018
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:
        raise AssertionError("irl_core.no_such_name resolved")


def test_the_whole_api_needs_nothing_from_an_extra():
    # A fresh process, so modules the test session imported do not count; every name is resolved.
    code = (
        "import sys, irl_core\n"
        "[getattr(irl_core, name) for name in irl_core.__all__]\n"
        f"print(sorted(m for m in {EXTRAS!r} if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_importing_the_package_alone_loads_no_solver():
    # careful play imports irl_core's world and game modules; the package must not drag the fit stack along.
    code = "import sys, irl_core.worlds.world\nprint(sorted(m for m in ('cvxpy', 'highspy', 'gymnasium') if m in sys.modules))\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
