"""Metrics that are "not applicable" to some conditions: which conditions, and the ``stats.json``
entry of a metric compared over the others only.

A metric is not applicable to a condition when the condition's policy makes it constant by
construction (human effort is 1 and human turns 1 without turn-taking; there is no assistance to
engage in teleoperation): such a 0/1 row is no finding, and kept in the tests it would dominate
them. The analysis takes the mapping ``metric -> conditions`` explicitly
(:func:`nudgecli.model.conditions.not_applicable_metrics` gives it for a run's conditions); a
condition without a single value of the metric is treated the same way, with the reason
:data:`NO_VALUES`, so a metrics table from real data gets it too.

Those conditions are left out of the metric's Kruskal-Wallis test, Conover's pairs (and their
Holm family), the participant-level test, the effect sizes and the intervals; a metric left with
fewer than two conditions gets no test at all. In the entry they appear as missing values
(``null`` in JSON) for every statistic of theirs, and are listed under ``not_applicable``, each
with its reason in ``not_applicable_reasons``. An entry without such conditions has neither key
(every existing ``stats.json`` stays as it was).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from typing import Any

import pandas as pd

from nudgecli.report.stats import ComparisonOptions, epsilon_squared, pairs, star_rule

#: The reason of a condition listed in the analysis' mapping.
NOT_APPLICABLE = "not applicable"
#: The reason of a condition without a value of the metric.
NO_VALUES = "no values"
#: The participant-level note of a metric applicable to fewer than two conditions.
NO_TEST_NOTE = "applicable to fewer than two conditions: no test"

#: The empty mapping: every metric applicable to every condition.
NO_EXCLUSIONS: Mapping[str, Collection[str]] = {}


def not_applicable_reasons(counts: Mapping[str, int], conditions: Sequence[str],
                           not_applicable: Collection[str] = ()) -> dict[str, str]:
    """The conditions a metric is compared without, each with its reason, in the conditions' order.

    Parameters
    ----------
    counts
        The metric's number of values per condition (``n`` of
        :func:`~nudgecli.report.stats.describe`).
    conditions
        The conditions, in order.
    not_applicable
        The conditions the analysis' mapping lists for the metric (:data:`NOT_APPLICABLE`).

    Returns
    -------
    dict[str, str]
        Condition -> :data:`NOT_APPLICABLE` or :data:`NO_VALUES` (a listed condition keeps the
        first reason); empty when every condition is compared.
    """
    listed = set(not_applicable)
    reasons = {}
    for c in conditions:
        if c in listed:
            reasons[c] = NOT_APPLICABLE
        elif not counts.get(c, 0):
            reasons[c] = NO_VALUES
    return reasons


def _spread(rows: Sequence[Mapping[str, Any]], conditions: Sequence[str],
            blank: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One row per pair of ``conditions`` (in their order): the row of ``rows`` of that pair, else
    ``blank`` (a pair with a condition not compared)."""
    known = {(r["a"], r["b"]): dict(r) for r in rows}
    return [known.get((a, b)) or {"a": a, "b": b, **blank} for a, b in pairs(conditions)]


_BLANK_CONOVER = {"p": math.nan, "p_unadjusted": math.nan}
_BLANK_STARS: dict[str, Any] = {"stars": None}
_BLANK_INTERVAL = {"difference": math.nan, "low": math.nan, "high": math.nan, "valid_resamples": 0}
_BLANK_WILCOXON = {"statistic": math.nan, "p": math.nan, "p_unadjusted": math.nan}
_BLANK_EFFECT = {"name": "none", "value": math.nan}


def _participant_level(entry: Mapping[str, Any] | None, conditions: Sequence[str], compared: Sequence[str],
                       options: ComparisonOptions) -> tuple[dict[str, Any], dict[str, Any]]:
    """The entry's ``participant_level`` and ``effect_size`` over every condition: with more than
    two, the pairwise lists hold every pair (the omitted ones blank); two compared conditions of
    such a document get their Wilcoxon test and r as their pair's."""
    many = len(conditions) > 2
    if entry is None:
        level: dict[str, Any] = {"test": "none", "aggregate": options.participant_aggregate,
                                 "statistic": math.nan, "p": math.nan, "n_participants": 0,
                                 "dropped_participants": [], "note": NO_TEST_NOTE}
        effect: dict[str, Any] = {"name": "none", "value": math.nan}
        if many:
            level.update(pairwise_test="none", p_adjust=options.p_adjust, pairs=_spread([], conditions,
                                                                                         _BLANK_WILCOXON))
            effect.update(pairs=_spread([], conditions, _BLANK_EFFECT), kruskal_epsilon_squared=math.nan)
        return level, effect
    level, effect = dict(entry["participant_level"]), dict(entry["effect_size"])
    if not many:
        return level, effect
    if "pairs" not in level:  # two compared conditions: their Wilcoxon test is their pair's
        a, b = compared
        level.update(pairwise_test=level["test"], p_adjust=options.p_adjust,
                     pairs=[{"a": a, "b": b, "statistic": level["statistic"], "p": level["p"],
                             "p_unadjusted": level["p"]}])
        effect["pairs"] = [{"a": a, "b": b, "name": effect["name"], "value": effect["value"]}]
    level["pairs"] = _spread(level["pairs"], conditions, _BLANK_WILCOXON)
    effect["pairs"] = _spread(effect["pairs"], conditions, _BLANK_EFFECT)
    return level, effect


def entry_over_conditions(entry: Mapping[str, Any] | None, metric: str,
                          descriptives: Mapping[str, Mapping[str, Any]], conditions: Sequence[str],
                          reasons: Mapping[str, str], options: ComparisonOptions) -> dict[str, Any]:
    """The ``stats.json`` entry of a metric over every condition, from its entry over the compared
    conditions only.

    Parameters
    ----------
    entry
        :func:`~nudgecli.report.stats_document.analyze_metric`'s entry of the compared conditions
        (at least two), or ``None`` when fewer than two are compared (no test at all).
    metric
        The metric's name.
    descriptives
        ``n, mean, median, q1, q3`` -> condition -> value, of every condition.
    conditions
        Every condition of the document, in order.
    reasons
        The conditions left out, with their reasons (:func:`not_applicable_reasons`).
    options
        The test settings.

    Returns
    -------
    dict
        The entry's usual keys, the left-out conditions' descriptives ``None`` and every statistic
        of a pair holding one missing (stars ``None``), then ``not_applicable`` (the conditions, in
        order) and ``not_applicable_reasons``.
    """
    compared = [c for c in conditions if c not in reasons]
    level, effect = _participant_level(entry, conditions, compared, options)
    if entry is not None and len(conditions) > 2 and "kruskal_epsilon_squared" not in effect:
        n_values = sum(int(descriptives["n"][c]) for c in compared)
        effect["kruskal_epsilon_squared"] = epsilon_squared(entry["kruskal"]["statistic"], n_values)
    if entry is None:
        ci: dict[str, Any] = {"method": "none", "level": options.bootstrap_level, "resamples": 0,
                              "seed": options.seed, "pairs": []}
    else:
        ci = dict(entry["ci"])
    ci["pairs"] = _spread(ci["pairs"], conditions, _BLANK_INTERVAL)
    return {
        "metric": metric,
        **{column: {c: None if c in reasons else values[c] for c in conditions}
           for column, values in descriptives.items()},
        "kruskal": dict(entry["kruskal"]) if entry is not None else {"statistic": math.nan, "p": math.nan},
        "conover": _spread(entry["conover"] if entry is not None else [], conditions, _BLANK_CONOVER),
        "p_adjust": options.p_adjust,
        "stars": _spread(entry["stars"] if entry is not None else [], conditions, _BLANK_STARS),
        "star_rule": star_rule(options),
        "participant_level": level,
        "effect_size": effect,
        "ci": ci,
        "not_applicable": [c for c in conditions if c in reasons],
        "not_applicable_reasons": {c: reasons[c] for c in conditions if c in reasons},
    }


def not_applicable_of(entry: Mapping[str, Any] | None) -> list[str]:
    """The conditions a ``stats.json`` entry lists as not applicable (none for an older entry)."""
    return [str(c) for c in (entry or {}).get("not_applicable") or []]


def is_not_applicable(value: Any) -> bool:
    """Whether a tidy table's descriptive cell marks a condition left out (``n`` missing)."""
    return value is None or (isinstance(value, float) and math.isnan(value)) or value is pd.NA


__all__ = ["NOT_APPLICABLE", "NO_EXCLUSIONS", "NO_TEST_NOTE", "NO_VALUES", "entry_over_conditions",
           "is_not_applicable", "not_applicable_of", "not_applicable_reasons"]
