"""nudge: simulate and analyse assistive shared-control studies.

The model of *Information Theoretic Intent Disambiguation via Contextual Nudges for
Assistive Shared Control*: interface-aware goal inference for a sip-and-puff driven
3-DoF robot, the disambiguation metric D(s), turn taking with linear blending, simulated
participants, the paper's metrics, statistics and figures.

The Python API (:mod:`nudgecli.api`, docs/api.md) is reached from here: ``nudgecli.simulate``,
``nudgecli.analyze``, ``nudgecli.plot``, ... load on first use (PEP 562), so ``import nudgecli``
imports none of numpy, pandas or matplotlib.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

#: Public name -> the module that defines it, imported when the name is first used.
_LAZY = {
    "simulate": "nudgecli.api.run", "Run": "nudgecli.api.run", "experiment_config": "nudgecli.api.run",
    "analyze": "nudgecli.api.analysis", "Analysis": "nudgecli.api.analysis",
    "plot": "nudgecli.api.figures", "save_figures": "nudgecli.api.figures",
    "habits": "nudgecli.api.tables", "compare": "nudgecli.api.tables",
    "replicate": "nudgecli.api.batches", "power": "nudgecli.api.batches", "sweep": "nudgecli.api.batches",
    "Batch": "nudgecli.api.batches", "NudgeError": "nudgecli.errors",
    "fit": "nudgecli.api.fitting", "fit_people": "nudgecli.api.fitting",
    "validate": "nudgecli.api.validation", "Validation": "nudgecli.api.validation",
    "plot_population": "nudgecli.api.population", "Population": "nudgecli.api.population",
    "presets": "nudgecli.api.presets",
}

__all__ = ["__version__", *_LAZY]

if TYPE_CHECKING:  # what type checkers and editors see; at run time __getattr__ imports on first use
    from nudgecli.api.analysis import Analysis as Analysis
    from nudgecli.api.analysis import analyze as analyze
    from nudgecli.api.batches import Batch as Batch
    from nudgecli.api.batches import power as power
    from nudgecli.api.batches import replicate as replicate
    from nudgecli.api.batches import sweep as sweep
    from nudgecli.api.figures import plot as plot
    from nudgecli.api.figures import save_figures as save_figures
    from nudgecli.api.fitting import fit as fit
    from nudgecli.api.fitting import fit_people as fit_people
    from nudgecli.api.population import Population as Population
    from nudgecli.api.population import plot_population as plot_population
    from nudgecli.api.presets import presets as presets
    from nudgecli.api.run import Run as Run
    from nudgecli.api.run import experiment_config as experiment_config
    from nudgecli.api.run import simulate as simulate
    from nudgecli.api.tables import compare as compare
    from nudgecli.api.tables import habits as habits
    from nudgecli.api.validation import Validation as Validation
    from nudgecli.api.validation import validate as validate
    from nudgecli.errors import NudgeError as NudgeError


def __getattr__(name: str) -> Any:
    """The API's ``name``, its module imported now (PEP 562)."""
    if name == "api":  # the package itself, as ``import nudgecli.api`` would give it
        return importlib.import_module("nudgecli.api")
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nudgecli' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # the next lookup finds it without this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY, "api"})
