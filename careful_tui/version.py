"""The installed version of careful, for `--version` and the headers of recordings."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version


def app_version() -> str:
    try:
        return version("careful")
    except PackageNotFoundError:
        return "0+unknown"
