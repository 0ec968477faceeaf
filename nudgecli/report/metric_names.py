"""The names of the per-trial metrics, in the metrics table's order.

Apart from :mod:`nudgecli.report.metrics` so that reading a plan (:mod:`nudgecli.report.plans`, which
a batch does before its workers start) does not load pandas.
"""

from __future__ import annotations

# The metrics of nudgecli.report.metrics.trial_metrics, in the metrics table's column order; the
# model owns the names (the simulation checks the metrics a policy declares constant against them).
from nudgecli.model.conditions import METRIC_NAMES as METRIC_NAMES

#: The metrics that are a trial's true-or-false verdict (stored as booleans, analysed as 0/1): a
#: maximum keeps all of one's values or leaves out every true one, never a few outliers.
TRUE_FALSE_METRICS = frozenset({"success", "wrong_goal"})
#: The metrics that are never negative (fractions, counts, seconds, verdicts: every one of
#: :data:`METRIC_NAMES`; a signed metric added there is left out here): a negative maximum
#: leaves out every value.
NON_NEGATIVE_METRICS = frozenset(METRIC_NAMES)

__all__ = ["METRIC_NAMES", "NON_NEGATIVE_METRICS", "TRUE_FALSE_METRICS"]
