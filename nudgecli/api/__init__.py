"""The Python API: every command's work as a function that returns tidy frames and figures.

``nudge`` parses its options, calls these functions and prints what they return; a notebook calls
them directly (docs/api.md). Errors are :class:`~nudgecli.errors.NudgeError` exceptions whose
message is the command line's ``Error:`` line; nothing is printed, and progress goes to an optional
``progress(done, total)`` callback. The modules load pandas, matplotlib and the statistics on first
use, so ``import nudgecli`` stays as cheap as the command line's start.

- :mod:`~nudgecli.api.run`: :func:`simulate` -> :class:`Run`, :func:`experiment_config`;
- :mod:`~nudgecli.api.analysis`: :func:`analyze` -> :class:`Analysis`;
- :mod:`~nudgecli.api.figures`: :func:`plot` (one figure or panel), :func:`save_figures`;
- :mod:`~nudgecli.api.tables`: :func:`habits`, :func:`compare`;
- :mod:`~nudgecli.api.batches`: :func:`replicate`, :func:`power`, :func:`sweep` -> :class:`Batch`;
- :mod:`~nudgecli.api.fitting`: :func:`fit` (a calibration profile), :func:`fit_people` (a people file) ->
  :class:`FittedPeople`;
- :mod:`~nudgecli.api.validation`: :func:`validate` -> :class:`Validation`;
- :mod:`~nudgecli.api.population`: :func:`plot_population` -> :class:`Population`;
- :mod:`~nudgecli.api.presets`: :func:`presets`;
- :mod:`~nudgecli.api.folders`: the temporary folders of results made without ``out=``.
"""

from __future__ import annotations

from nudgecli.api.analysis import Analysis, analyze
from nudgecli.api.batches import Batch, holds_batch, power, progress_line, replicate, sweep
from nudgecli.api.figures import analyze_and_plot, plan_of, plot, save_figures
from nudgecli.api.fitting import FittedPeople, fit, fit_people
from nudgecli.api.population import Population, plot_population
from nudgecli.api.presets import presets
from nudgecli.api.run import Run, experiment_config, simulate
from nudgecli.api.tables import ComparisonResult, Habits, compare, habits, parse_matches
from nudgecli.api.validation import Validation, validate
from nudgecli.errors import NudgeError

__all__ = ["Analysis", "Batch", "ComparisonResult", "FittedPeople", "Habits", "NudgeError", "Population",
           "Run", "Validation",
           "analyze", "analyze_and_plot", "compare", "experiment_config", "fit", "fit_people", "habits",
           "holds_batch", "parse_matches", "plan_of", "plot", "plot_population", "power", "presets",
           "progress_line", "replicate", "save_figures", "simulate", "sweep", "validate"]
