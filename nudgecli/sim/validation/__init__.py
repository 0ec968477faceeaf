"""The paper's simulation-based validation of the disambiguation metric D(s) (end of section 3.3).

- :mod:`~nudgecli.sim.validation.readings`: the readings of the paper's paragraph (world,
  belief, lambda, expectation, match rule), side by side;
- :mod:`~nudgecli.sim.validation.world`: the validation worlds, built from the model's own
  functions;
- :mod:`~nudgecli.sim.validation.criteria`: the metric's and the ground truth's values;
- :mod:`~nudgecli.sim.validation.settings`: the settings;
- :mod:`~nudgecli.sim.validation.runner`: simulations, results;
- :mod:`~nudgecli.sim.validation.convergence`: the Monte-Carlo convergence study;
- :mod:`~nudgecli.sim.validation.output`: files and printed tables.
"""

from __future__ import annotations

import importlib
from typing import Any

# Submodules load on first use (PEP 562), so `nudge --help` and `--reading`'s choices do not
# pay for the whole validation (scipy, pandas) at start-up.
_HOME: dict[str, str] = {
    "DEFAULT_MC_SAMPLES": "settings",
    "MAX_MC_SAMPLES": "settings",
    "MC_VARIANTS": "settings",
    "QUERY_COLUMNS": "runner",
    "READINGS": "readings",
    "Reading": "readings",
    "ValidationResult": "runner",
    "ValidationSettings": "settings",
    "ValidationWorld": "world",
    "distinct_margin": "criteria",
    "expected_entropy_drop": "criteria",
    "expected_goal_distance": "criteria",
    "expected_top_two_gap": "criteria",
    "format_readings": "output",
    "format_summary": "output",
    "get_reading": "readings",
    "goal_transitions": "world",
    "monte_carlo_estimates": "convergence",
    "neighbourhoods": "world",
    "prepare_out": "output",
    "queries_csv": "output",
    "query_beliefs": "runner",
    "readings_summary": "output",
    "run_all_readings": "runner",
    "run_validation": "runner",
    "sample_study_world": "world",
    "sample_world": "world",
    "save_readings": "output",
    "save_validation": "output",
    "solve_goal_policies": "world",
    "study_queries": "world",
    "summary_json": "output",
    "tolerant_argmax": "criteria",
    "unweighted_limit": "criteria",
    "world_states": "world",
}

__all__ = sorted(_HOME)


def __getattr__(name: str) -> Any:
    """The public name ``name``, imported from its submodule on first access."""
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_HOME[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HOME))
