"""The names of the per-trial metrics, in the metrics table's order.

Apart from :mod:`nudgecli.report.metrics` so that reading a plan (:mod:`nudgecli.report.plans`, which
a batch does before its workers start) does not load pandas.
"""

from __future__ import annotations

#: The metrics of :func:`nudgecli.report.metrics.trial_metrics`, in the metrics table's column order.
METRIC_NAMES = (
    "assistance_engagement",
    "assistance_strength",
    "mode_switches",
    "human_effort",
    "completion_time",
    "human_turns",
    "success",
    "first_input_latency",
    "active_input_fraction",
    "wrong_goal",
)

__all__ = ["METRIC_NAMES"]
