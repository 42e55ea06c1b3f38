"""The IRL methods `fit` knows, one entry each: what every reader of a method name needs.

`FitOptions` checks a name here, `careful fit --method` offers these choices with this help,
the fit view binds each to its key and titles it with its label, `fit` runs its fitter and asks
which interval it has, and the bootstrap runs its refit. An entry names its fitter and refit as
``module:function`` and they are imported when first run, so this module imports nothing heavy and
the command line can read it before it needs numpy's solvers.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

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
            ``confidence`` (a bootstrap over episodes; maxent's timing model on a time world gives its own);
            None for a chooser, whose choice decides.
        uses_beta: it reads `FitOptions.beta` (a temperature, given or estimated).
        uses_lambda: it reads `FitOptions.lam` (the L1 penalty).
        chooser: it picks one of the others for the demonstrations given.
        fitter: its fitter, ``module:function`` (`irl_core.irl.fitting`'s, called with the Q map, the
            demonstrations and the options).
        refit: for a bootstrap interval, how one resample is refitted, ``module:function``
            (`irl_core.irl.bootstrap`'s); None for a method whose intervals are not resampled.
    """

    name: str
    key: str
    label: str
    summary: str
    interval_kind: IntervalKind | None
    uses_beta: bool
    uses_lambda: bool
    fitter: str
    refit: str | None = None
    chooser: bool = False

    def load_fitter(self) -> Callable[..., Any]:
        """The fitter, imported."""
        return _load(self.fitter)

    def load_refit(self) -> Callable[..., Any]:
        """The refit, imported; raises ValueError for a method without one."""
        if self.refit is None:
            raise ValueError(f"no bootstrap refit for method {self.name!r}: one of {', '.join(RESAMPLED)}")
        return _load(self.refit)


def _load(path: str) -> Callable[..., Any]:
    module, _, function = path.partition(":")
    return getattr(importlib.import_module(module), function)


# In the fit view's key order (tab cycles through them in this order).
METHODS: dict[str, Method] = {m.name: m for m in (
    Method("auto", "a", "", "lp for a deterministic expert whose lp is feasible, else maxent with beta "
           "estimated (a person's noisy play)", None, uses_beta=True, uses_lambda=True,
           fitter="irl_core.irl.fitting:auto_fitter", chooser=True),
    Method("lp", "l", "the simple IRL agent", "the paper's simple IRL agent", "identified",
           uses_beta=False, uses_lambda=True, fitter="irl_core.irl.fitting:lp_fitter"),
    Method("loss", "o", "the loss IRL agent", "its loss IRL agent", "confidence", uses_beta=False, uses_lambda=True,
           fitter="irl_core.irl.fitting:loss_fitter", refit="irl_core.irl.bootstrap:loss_refit"),
    Method("maxent", "m", "the MaxEnt baseline", "the maximum-entropy baseline", "confidence",
           uses_beta=True, uses_lambda=False, fitter="irl_core.irl.fitting:maxent_fitter",
           refit="irl_core.irl.bootstrap:maxent_refit"),
)}
NAMES: tuple[str, ...] = tuple(METHODS)
# The methods that fit (every one but the chooser).
FITTED: tuple[str, ...] = tuple(name for name, m in METHODS.items() if not m.chooser)
# The methods whose intervals resample episodes (a refit each).
RESAMPLED: tuple[str, ...] = tuple(name for name, m in METHODS.items() if m.refit is not None)
DEFAULT = "auto"


def method(name: str) -> Method:
    """The entry of `name`; raises ValueError naming the choices for any other."""
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise ValueError(f"method must be one of {', '.join(NAMES)}, not {name!r}") from None
