"""The IRL methods `fit` knows, one entry each: what every reader of a method name needs.

`FitOptions` checks a name here, `careful fit --method` offers these choices with this help,
the fit view binds each to its key and titles it with its label, and `fit` asks which interval
a method's fit has. Each entry's implementation is its fitter in `irl_core.irl.fitting` (`FITTERS`)
and, for a resampled interval, its refit in `irl_core.irl.bootstrap` (`REFITS`); both modules
check at import that every entry has one. This module imports nothing heavy, so the command line
can read it before it needs numpy's solvers.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Literal

IntervalKind = Literal["identified", "confidence"]


@dataclass(frozen=True)
class Method:
    """One method.

    Attributes:
        name: what `FitOptions.method`, ``--method`` and the fit JSON call it.
        key: the fit view's key for it.
        label: what the paper calls it, for the fit view's title ("" for a chooser).
        summary: what it does, in a few words (the command line's help).
        interval_kind: its intervals: ``identified`` (every value the demonstrations allow) or
            ``confidence`` (a bootstrap over episodes); None for a chooser, whose choice decides.
        uses_beta: it reads `FitOptions.beta` (a temperature, given or estimated).
        uses_lambda: it reads `FitOptions.lam` (the L1 penalty).
        chooser: it picks one of the others for the demonstrations given.
    """

    name: str
    key: str
    label: str
    summary: str
    interval_kind: IntervalKind | None
    uses_beta: bool
    uses_lambda: bool
    chooser: bool = False


# In the fit view's key order (tab cycles through them in this order).
METHODS: dict[str, Method] = {m.name: m for m in (
    Method("auto", "a", "", "lp for a deterministic expert whose lp is feasible, else maxent with beta "
           "estimated (a person's noisy play)", None, uses_beta=True, uses_lambda=True, chooser=True),
    Method("lp", "l", "the simple IRL agent", "the paper's simple IRL agent", "identified",
           uses_beta=False, uses_lambda=True),
    Method("loss", "o", "the loss IRL agent", "its loss IRL agent", "confidence", uses_beta=False, uses_lambda=True),
    Method("maxent", "m", "the MaxEnt baseline", "the maximum-entropy baseline", "confidence",
           uses_beta=True, uses_lambda=False),
)}
NAMES: tuple[str, ...] = tuple(METHODS)
# The methods that fit (every one but the chooser).
FITTED: tuple[str, ...] = tuple(name for name, m in METHODS.items() if not m.chooser)
DEFAULT = "auto"


def method(name: str) -> Method:
    """The entry of `name`; raises ValueError naming the choices for any other."""
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise ValueError(f"method must be one of {', '.join(NAMES)}, not {name!r}") from None


def check_covers(table: Mapping[str, object], names: Iterable[str], what: str) -> None:
    """Raise at import when an implementation table (`what`) has no entry for one of `names`, or extra ones."""
    names = tuple(names)
    missing, extra = set(names) - set(table), set(table) - set(names)
    if missing or extra:
        raise RuntimeError(f"{what} must hold exactly {sorted(names)}: missing {sorted(missing)}, extra {sorted(extra)}")
