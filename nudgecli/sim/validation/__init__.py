"""The paper's simulation-based validation of the disambiguation metric D(s) (end of section 3.3).

- :mod:`~nudgecli.sim.validation.readings`: the readings of the paper's paragraph (world,
  belief, lambda, expectation, match rule), side by side;
- :mod:`~nudgecli.sim.validation.world`: the validation worlds, built from the model's own
  functions;
- :mod:`~nudgecli.sim.validation.criteria`: the metric's and the ground truth's values;
- :mod:`~nudgecli.sim.validation.runner`: settings, simulations, results;
- :mod:`~nudgecli.sim.validation.output`: files and printed tables.
"""

from nudgecli.sim.validation.criteria import (
    distinct_margin,
    expected_entropy_drop,
    expected_goal_distance,
    expected_top_two_gap,
    tolerant_argmax,
    unweighted_limit,
)
from nudgecli.sim.validation.output import (
    format_readings,
    format_summary,
    prepare_out,
    queries_csv,
    readings_summary,
    save_readings,
    save_validation,
    summary_json,
)
from nudgecli.sim.validation.readings import READINGS, Reading, get_reading
from nudgecli.sim.validation.runner import (
    DEFAULT_MC_SAMPLES,
    MAX_MC_SAMPLES,
    MC_VARIANTS,
    QUERY_COLUMNS,
    ValidationResult,
    ValidationSettings,
    monte_carlo_estimates,
    query_beliefs,
    run_all_readings,
    run_validation,
)
from nudgecli.sim.validation.world import (
    ValidationWorld,
    goal_transitions,
    neighbourhoods,
    sample_study_world,
    sample_world,
    solve_goal_policies,
    study_queries,
    world_states,
)

__all__ = [
    "DEFAULT_MC_SAMPLES", "MAX_MC_SAMPLES", "MC_VARIANTS", "QUERY_COLUMNS", "READINGS", "Reading",
    "ValidationResult", "ValidationSettings", "ValidationWorld", "distinct_margin", "expected_entropy_drop",
    "expected_goal_distance", "expected_top_two_gap", "format_readings", "format_summary", "get_reading",
    "goal_transitions", "monte_carlo_estimates", "neighbourhoods", "prepare_out", "queries_csv",
    "query_beliefs", "readings_summary", "run_all_readings", "run_validation", "sample_study_world",
    "sample_world", "save_readings", "save_validation", "solve_goal_policies", "study_queries",
    "summary_json", "tolerant_argmax", "unweighted_limit", "world_states",
]
