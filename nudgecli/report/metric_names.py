"""The names of the per-trial metrics, in the metrics table's order.

Apart from :mod:`nudgecli.report.metrics` so that reading a plan (:mod:`nudgecli.report.plans`, which
a batch does before its workers start) does not load pandas.
"""

from __future__ import annotations

# The metrics of nudgecli.report.metrics.trial_metrics, in the metrics table's column order; the
# model owns the names (the simulation checks the metrics a policy declares constant against them).
from nudgecli.model.conditions import METRIC_NAMES as METRIC_NAMES

__all__ = ["METRIC_NAMES"]
