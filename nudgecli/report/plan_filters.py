"""A plan's ``[filters]`` applied to the metrics analysed, and the line that says what they left out.

A filter sets a metric to missing where it exceeds the plan's maximum
(:func:`nudgecli.report.metrics.apply_filters`, the one rule); the trial stays in its other
metrics. The values each filter removed are counted per metric, and one line says so, as the
other values the analysis leaves out are said (a ``Note:`` on stderr and a line of
``summary.md``, :func:`nudgecli.report.summary.format_summary`'s ``filters``): a study-code plan
that drops 12 of 48 trials' ``mode_switches`` does not do it unseen.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import pandas as pd

from nudgecli.report.metrics import apply_filters
from nudgecli.report.plans import AnalysisPlan

#: The end of every line that says what filters left out: a filter removes a value, not a trial.
STAYS = "each trial stays in its other metrics"


@dataclass(frozen=True)
class FilteredMetrics:
    """A metrics table after a plan's filters (:func:`apply_plan_filters`).

    Attributes
    ----------
    table
        The table, each filtered metric missing where it exceeded its maximum; ``condition`` as
        categories, only those the table holds (an unused category is no condition of the analysis).
    changed
        Whether the table now differs from the source (it did already, or a filter removed a value).
    line
        What the filters left out of the analysed metrics, one line (``None``: nothing).
    """

    table: pd.DataFrame
    changed: bool
    line: str | None


def apply_plan_filters(table: pd.DataFrame, plan: AnalysisPlan, analysed: Sequence[str],
                       changed: bool) -> FilteredMetrics:
    """Apply ``plan``'s filters to ``table`` and say what they left out of the ``analysed`` metrics.

    Parameters
    ----------
    table
        The metrics, one row per trial.
    plan
        The analysis plan (its ``filters``: metric -> maximum).
    analysed
        The metrics analysed: only the values they lost are counted in ``line``.
    changed
        Whether ``table`` already differs from the source.

    Returns
    -------
    FilteredMetrics
        A new table; ``table`` itself is left as it was. When no filter names one of its columns
        the new table shares ``table``'s metric columns (a shallow copy, not a copy of a large table).
    """
    if any(name in table.columns for name in plan.filters):
        filtered = apply_filters(table, plan.filters)
        changed = changed or not filtered.equals(table)
    else:  # a shallow copy: the condition column below is replaced in it, not in the caller's table
        filtered = table.copy(deep=False)
    if filtered["condition"].dtype != "category":
        filtered["condition"] = filtered["condition"].astype(str).astype("category")
    else:  # a DataFrame's categorical condition may name conditions no trial holds
        filtered["condition"] = filtered["condition"].cat.remove_unused_categories()
    return FilteredMetrics(filtered, changed, _left_out_line(table, filtered, plan, analysed))


def filter_counts(table: pd.DataFrame, filtered: pd.DataFrame, plan: AnalysisPlan,
                  analysed: Sequence[str]) -> list[dict[str, Any]]:
    """What ``plan``'s filters removed from the ``analysed`` metrics of ``table`` (``filtered``: the
    table after them), one ``{"metric", "removed", "values", "maximum"}`` per metric that lost a
    value (``values``: the metric's values present before the filter); empty when none did."""
    counts: list[dict[str, Any]] = []
    for name, maximum in plan.filters.items():
        if name not in analysed or name not in table.columns:
            continue
        present = table[name].notna()
        removed = int((present & filtered[name].isna()).sum())
        if removed:
            counts.append({"metric": name, "removed": removed, "values": int(present.sum()),
                           "maximum": float(maximum)})
    return counts


def _left_out_line(table: pd.DataFrame, filtered: pd.DataFrame, plan: AnalysisPlan,
                   analysed: Sequence[str]) -> str | None:
    """``plan X's [filters] left out N of M <metric> values (above MAX), ...``, or ``None`` when the
    filters removed none of the analysed metrics' values."""
    counts = [f"{c['removed']} of {c['values']} {c['metric']} values (above {c['maximum']:g})"
              for c in filter_counts(table, filtered, plan, analysed)]
    if not counts:
        return None
    return f"plan {plan.label}'s [filters] left out {', '.join(counts)}; {STAYS}"


def replications_left_out_line(documents: Sequence[Mapping[str, Any]], label: str) -> str | None:
    """What a plan's filters left out over a batch's replications, one clause per metric:
    ``plan X's [filters] left out mode_switches values (above 10) in N of R replications (K of M
    values)``; ``None`` when they removed none. Each document is a replication's stats document,
    whose ``filters`` are its :func:`filter_counts` (absent where nothing was removed)."""
    metrics: dict[str, list[Mapping[str, Any]]] = {}
    for document in documents:
        for count in document.get("filters", ()):
            metrics.setdefault(count["metric"], []).append(count)
    if not metrics:
        return None
    clauses = [f"{name} values (above {counts[0]['maximum']:g}) in {len(counts)} of {len(documents)} "
               f"replications ({sum(c['removed'] for c in counts)} of {sum(c['values'] for c in counts)} "
               "values)" for name, counts in metrics.items()]
    return f"plan {label}'s [filters] left out {', '.join(clauses)}; {STAYS}"
