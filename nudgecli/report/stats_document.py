"""The ``stats.json`` document (DESIGN section 5): every metric's statistics put together
(:func:`compare_conditions`), and read back as tidy tables for the printed table, ``summary.md``,
``stats.csv`` and the replication summaries (:func:`stats_table`, :func:`condition_table`).

Each metric's entry has the same keys whatever the number of conditions (the reference run pins
them), but for the pairwise participant-level tests and epsilon-squared, which appear with three or
more. ``mean_rank`` (each condition's mean rank, the trials of the compared conditions ranked
together) and ``star_rule`` (the rule the ``stars`` follow: :func:`~nudgecli.report.stats.star_rule`)
were added after the first documents: a reader of an older document finds none.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.report.cluster_bootstrap import median_difference_intervals
from nudgecli.report.metric_rows import MetricRows, TableKeys, metric_rows, table_keys
from nudgecli.report.not_applicable import NO_EXCLUSIONS, entry_over_conditions, not_applicable_reasons
from nudgecli.report.participant_tests import participant_level_test
from nudgecli.report.stats import (
    ComparisonOptions,
    conover_rows,
    descriptive_columns,
    epsilon_squared,
    kruskal_wallis,
    mean_rank_column,
    pair_stars,
    python_scalar,
    star_rule,
)

#: The settings when none are given (a frozen dataclass: one instance serves every call).
DEFAULT_OPTIONS = ComparisonOptions()


def analyze_metric(data: pd.DataFrame, metric: str, conditions: Sequence[str],
                   options: ComparisonOptions = DEFAULT_OPTIONS, *, not_applicable: Collection[str] = (),
                   participant: str = "participant", condition: str = "condition",
                   roster: pd.DataFrame | None = None, keys: TableKeys | None = None) -> dict[str, Any]:
    """All statistics of one metric: one entry of ``stats.json``'s ``metrics`` list.

    Parameters
    ----------
    data
        Tidy table, one row per trial (or questionnaire response), with ``participant``,
        ``condition`` and the ``metric`` column (numeric or boolean; missing values ignored).
    metric
        The column to analyse.
    conditions
        The conditions to compare, in order (the first is ``a`` of the first pair).
    options
        Test settings.
    not_applicable
        The conditions the metric is not applicable to: left out of every test, effect size and
        interval (:mod:`nudgecli.report.not_applicable`), as is a condition without a value of it.
    roster
        The table whose participants are the study's, when not ``data``'s (questionnaire scores:
        the trials): the participant-level test names those of them it left out
        (:func:`~nudgecli.report.participant_tests.participant_summaries`).
    keys
        ``data``'s :class:`~nudgecli.report.metric_rows.TableKeys` of these conditions, when the
        caller holds them (:func:`compare_conditions`: found once for all the metrics).

    Returns
    -------
    dict
        ``metric, n, mean, median, q1, q3, mean_rank`` (each ``{condition: value}``; the mean
        rank among the trials of the compared conditions, ranked together as the tests rank
        them, so the sign of a pair's difference is the direction of a significant Conover
        result), ``kruskal``,
        ``conover`` (list of ``a, b, p, p_unadjusted``), ``p_adjust``, ``stars`` (list of
        ``a, b, stars``), ``participant_level``, ``effect_size``, ``ci``; with conditions left out,
        their values missing and ``not_applicable``, ``not_applicable_reasons``
        (:func:`~nudgecli.report.not_applicable.entry_over_conditions`).
    """
    # the rows every statistic of the metric reads, made once (each test would make them again)
    tidy = metric_rows(data, metric, conditions, condition, participant, keys=keys)
    columns = descriptive_columns(data, metric, conditions, condition=condition, tidy=tidy)
    descriptives = {column: dict(zip(conditions, map(python_scalar, values), strict=True))
                    for column, values in columns.items()}
    reasons = not_applicable_reasons(descriptives["n"], conditions, not_applicable)
    # ranked among the compared conditions only, as the tests rank them (NaN for the others)
    ranks = mean_rank_column(data, metric, conditions, compared=[c for c in conditions if c not in reasons],
                             condition=condition, tidy=tidy)
    descriptives["mean_rank"] = dict(zip(conditions, ranks.tolist(), strict=True))
    if not reasons:
        return _compared_entry(data, metric, conditions, descriptives, options, many=len(conditions) > 2,
                               participant=participant, condition=condition, tidy=tidy, roster=roster)
    compared = [c for c in conditions if c not in reasons]
    entry = None
    if len(compared) >= 2:  # the rows of the compared conditions: tidy_values of them
        kept = tidy.among(compared)
        entry = _compared_entry(data, metric, compared, {k: {c: v[c] for c in compared}
                                                         for k, v in descriptives.items()},
                                options, many=len(compared) > 2, participant=participant, condition=condition,
                                tidy=kept, roster=roster)
    return entry_over_conditions(entry, metric, descriptives, conditions, reasons, options)


def _compared_entry(data: pd.DataFrame, metric: str, conditions: Sequence[str],
                    descriptives: dict[str, dict[str, Any]], options: ComparisonOptions, *, many: bool,
                    participant: str, condition: str, tidy: MetricRows,
                    roster: pd.DataFrame | None = None) -> dict[str, Any]:
    """:func:`analyze_metric`'s entry of conditions that all have values (``descriptives``: theirs;
    ``many``: with epsilon-squared, as a document of more than two conditions has; ``tidy``:
    :func:`~nudgecli.report.metric_rows.metric_rows` of the metric and these conditions, with the
    participants; ``roster``: :func:`analyze_metric`'s)."""
    if len(conditions) < 2:
        return _descriptive_entry(metric, descriptives, options)
    kruskal = kruskal_wallis(data, metric, conditions, condition=condition, tidy=tidy)
    posthoc = conover_rows(data, metric, conditions, p_adjust=options.p_adjust, condition=condition,
                           tidy=tidy)
    rule = star_rule(options)
    stars = [{"a": row["a"], "b": row["b"], "stars": pair_stars(row["p"], kruskal["p"], rule)}
             for row in posthoc]
    level, effect = participant_level_test(data, metric, conditions, participant=participant,
                                           condition=condition, aggregate=options.participant_aggregate,
                                           p_adjust=options.p_adjust, tidy=tidy, roster=roster)
    if many:  # (with two, the pair's rank-biserial r says it; stats.json stays as it was)
        effect["kruskal_epsilon_squared"] = epsilon_squared(kruskal["statistic"],
                                                            sum(int(v) for v in descriptives["n"].values()))
    intervals = median_difference_intervals(
        data, metric, conditions, resamples=options.bootstrap_resamples, level=options.bootstrap_level,
        seed=options.seed, participant=participant, condition=condition, tidy=tidy)
    return {
        "metric": metric,
        **descriptives,
        "kruskal": kruskal,
        "conover": posthoc,
        "p_adjust": options.p_adjust,
        "stars": stars,
        "star_rule": rule,
        "participant_level": level,
        "effect_size": effect,
        "ci": {
            "method": "cluster bootstrap over participants, percentile interval of the difference "
                      "of trial medians (a - b)",
            "level": options.bootstrap_level,
            "resamples": options.bootstrap_resamples,
            "seed": options.seed,
            "pairs": intervals,
        },
    }


#: The note of a metric analysed with a single condition (nothing to compare).
SINGLE_CONDITION_NOTE = "a single condition: descriptive statistics only, no tests"


def _descriptive_entry(metric: str, descriptives: dict[str, Any],
                       options: ComparisonOptions) -> dict[str, Any]:
    """The ``stats.json`` entry of a metric with one condition: the descriptives, no test (the test
    fields keep their keys, with missing values and :data:`SINGLE_CONDITION_NOTE`)."""
    return {
        "metric": metric,
        **descriptives,
        "kruskal": {"statistic": math.nan, "p": math.nan},
        "conover": [],
        "p_adjust": options.p_adjust,
        "stars": [],
        "star_rule": star_rule(options),
        "participant_level": {"test": "none", "aggregate": options.participant_aggregate,
                              "statistic": math.nan, "p": math.nan, "n_participants": 0,
                              "dropped_participants": [], "note": SINGLE_CONDITION_NOTE},
        "effect_size": {"name": "none", "value": math.nan},
        "ci": {"method": "none", "level": options.bootstrap_level, "resamples": 0, "seed": options.seed,
               "pairs": []},
    }


def compare_conditions(data: pd.DataFrame, metrics: Sequence[str], conditions: Sequence[str],
                       options: ComparisonOptions = DEFAULT_OPTIONS, *,
                       not_applicable: Mapping[str, Collection[str]] = NO_EXCLUSIONS,
                       participant: str = "participant", condition: str = "condition",
                       roster: pd.DataFrame | None = None) -> dict[str, Any]:
    """The ``stats.json`` document: every metric's statistics.

    With a single condition every metric gets its descriptive statistics only (no test, no
    interval; the participant-level ``note`` says so). ``not_applicable`` maps a metric to the
    conditions it is not applicable to, ``roster`` the table of the study's participants when not
    ``data`` (:func:`analyze_metric`).

    Returns
    -------
    dict
        ``{"conditions": [...], "metrics": [analyze_metric(...) for each metric]}``. Values are
        plain Python (NaN stays float NaN; :func:`json_ready` turns it into ``None``).
    """
    # each row's condition and participant as integers, found once for every metric
    keys = table_keys(data, conditions, condition, participant)
    return {
        "conditions": list(conditions),
        "metrics": [analyze_metric(data, m, conditions, options, not_applicable=not_applicable.get(m, ()),
                                   participant=participant, condition=condition, roster=roster, keys=keys)
                    for m in metrics],
    }


#: The columns of ``stats.csv``, in order (a subset of :func:`stats_table`'s; a table of a single
#: condition has only those of them that it holds).
STATS_CSV_COLUMNS = (
    "metric", "a", "b", "n_a", "n_b", "median_a", "median_b", "q1_a", "q3_a", "q1_b", "q3_b",
    "kruskal_statistic", "kruskal_p", "conover_p", "conover_p_unadjusted", "p_adjust", "stars",
    "participant_test", "participant_statistic", "participant_p", "n_participants",
    "effect_size_name", "effect_size", "difference", "ci_low", "ci_high", "ci_level",
)
#: The columns ``stats.csv`` adds after :data:`STATS_CSV_COLUMNS` when more than two conditions are
#: compared: the pair's participant-level post-hoc test and effect size (with two conditions the
#: participant-level test is the pair's), and the epsilon-squared of Kruskal-Wallis.
K_CONDITION_CSV_COLUMNS = (
    "pairwise_test", "pairwise_statistic", "pairwise_p", "pairwise_p_unadjusted",
    "pairwise_effect_size_name", "pairwise_effect_size", "epsilon_squared",
)


#: The columns of a pair's row that are the metric's omnibus tests (of every compared condition),
#: not the pair's own: missing for a pair holding a condition the tests left out.
_OMNIBUS_COLUMNS = ("kruskal_statistic", "kruskal_p", "participant_statistic", "participant_p", "effect_size")


def stats_table(stats: dict[str, Any]) -> pd.DataFrame:
    """``stats.json`` as a tidy table: one row per metric x pair of conditions.

    The one reader of ``stats.json``'s ``metrics`` for the formatters (the printed table,
    ``summary.md``, ``stats.csv``) and the replication summaries: they take this table.

    Returns
    -------
    pd.DataFrame
        Columns :data:`STATS_CSV_COLUMNS`, then ``mean_a, mean_b, mean_rank_a, mean_rank_b,
        participant_note, ci_seed, ci_resamples`` (the mean ranks ``None`` in a document written
        before they were recorded), then with more than two conditions
        :data:`K_CONDITION_CSV_COLUMNS` (the
        ``participant_*`` and ``effect_size*`` columns stay the omnibus Friedman test and Kendall's
        W; ``pairwise_*`` are the pair's Wilcoxon test and rank-biserial r). With a single
        condition, one row per metric with ``b`` ``None`` and only ``metric, a, b, n_a, median_a,
        q1_a, q3_a, participant_test, ci_level, mean_a, participant_note, ci_seed, ci_resamples``.
        A condition left out of a metric (:mod:`nudgecli.report.not_applicable`) has its cells
        missing (``n_a``/``n_b`` then nullable integers), as has every test of a pair holding it.
    """
    rows = []
    many = len(stats["conditions"]) > 2
    for entry in stats["metrics"]:
        ci, level = entry["ci"], entry["participant_level"]
        extra = {"participant_note": level.get("note") or "", "ci_seed": ci.get("seed"),
                 "ci_resamples": ci.get("resamples")}
        if len(stats["conditions"]) == 1:  # descriptives only
            (a,) = stats["conditions"]
            rows.append({"metric": entry["metric"], "a": a, "b": None, "n_a": entry["n"][a],
                         "median_a": entry["median"][a], "q1_a": entry["q1"][a], "q3_a": entry["q3"][a],
                         "participant_test": "none", "ci_level": ci["level"], "mean_a": entry["mean"][a],
                         **extra})
            continue
        posthoc = {(r["a"], r["b"]): r for r in entry["conover"]}
        ranks = entry.get("mean_rank", {})  # a document of an older nudge has none
        stars = {(r["a"], r["b"]): r["stars"] for r in entry["stars"]}
        for interval in ci["pairs"]:
            a, b = interval["a"], interval["b"]
            rows.append({
                "metric": entry["metric"], "a": a, "b": b,
                "n_a": entry["n"][a], "n_b": entry["n"][b],
                "median_a": entry["median"][a], "median_b": entry["median"][b],
                "q1_a": entry["q1"][a], "q3_a": entry["q3"][a],
                "q1_b": entry["q1"][b], "q3_b": entry["q3"][b],
                "kruskal_statistic": entry["kruskal"]["statistic"], "kruskal_p": entry["kruskal"]["p"],
                "conover_p": posthoc[a, b]["p"], "conover_p_unadjusted": posthoc[a, b]["p_unadjusted"],
                "p_adjust": entry["p_adjust"], "stars": stars[a, b],
                "participant_test": level["test"],
                "participant_statistic": level["statistic"],
                "participant_p": level["p"],
                "n_participants": level["n_participants"],
                "effect_size_name": entry["effect_size"]["name"],
                "effect_size": entry["effect_size"]["value"],
                "difference": interval["difference"], "ci_low": interval["low"],
                "ci_high": interval["high"], "ci_level": ci["level"],
                "mean_a": entry["mean"][a], "mean_b": entry["mean"][b],
                "mean_rank_a": ranks.get(a), "mean_rank_b": ranks.get(b),
                **extra,
                **(_pairwise_columns(entry, a, b) if many else {}),
            })
    table = pd.DataFrame(rows)
    if "n_b" in table:
        # a pair holding a condition left out of the metric: the omnibus tests compared the others
        left_out = table["n_a"].isna() | table["n_b"].isna()
        table.loc[left_out, [c for c in _OMNIBUS_COLUMNS if c in table]] = None
    for column in ("n_a", "n_b"):  # a count missing for a condition left out stays a count
        if column in table and table[column].isna().any():
            table[column] = table[column].astype("Int64")
    return table


def _pairwise_columns(entry: dict[str, Any], a: str, b: str) -> dict[str, Any]:
    """:data:`K_CONDITION_CSV_COLUMNS` of one pair of a ``stats.json`` entry of three or more conditions."""
    level, effect = entry["participant_level"], entry["effect_size"]
    test: dict[str, Any] = next((r for r in level.get("pairs") or [] if (r["a"], r["b"]) == (a, b)), {})
    size: dict[str, Any] = next((r for r in effect.get("pairs") or [] if (r["a"], r["b"]) == (a, b)), {})
    return {
        "pairwise_test": level.get("pairwise_test", "none"),
        "pairwise_statistic": test.get("statistic", math.nan),
        "pairwise_p": test.get("p", math.nan),
        "pairwise_p_unadjusted": test.get("p_unadjusted", math.nan),
        "pairwise_effect_size_name": size.get("name", "none"),
        "pairwise_effect_size": size.get("value", math.nan),
        "epsilon_squared": effect.get("kruskal_epsilon_squared", math.nan),
    }


def condition_table(table: pd.DataFrame) -> pd.DataFrame:
    """The descriptives of :func:`stats_table`'s table per metric x condition.

    Parameters
    ----------
    table
        :func:`stats_table`'s table.

    Returns
    -------
    pd.DataFrame
        ``metric, condition, n, median, q1, q3, mean``: one row per metric and condition, metrics
        in the table's order, conditions in order of first appearance (the ``stats.json`` order:
        every condition is ``a`` or ``b`` of some pair, and the pairs follow that order).
    """
    columns = ["metric", "condition", "n", "median", "q1", "q3", "mean"]
    sides = []
    for side in ("a", "b"):
        if f"n_{side}" not in table:
            continue
        part = table[["metric", side, f"n_{side}", f"median_{side}", f"q1_{side}", f"q3_{side}",
                      f"mean_{side}"]].copy()
        part.columns = columns
        part["_row"], part["_side"] = np.arange(len(table)), side
        sides.append(part)
    if not sides:
        return pd.DataFrame(columns=columns)
    stacked = pd.concat(sides).sort_values(["_row", "_side"], kind="stable")
    stacked = stacked.drop_duplicates(["metric", "condition"])
    return stacked[columns].reset_index(drop=True)


def stats_csv(table: pd.DataFrame) -> str:
    """``stats.csv``: :func:`stats_table`'s table, columns :data:`STATS_CSV_COLUMNS` then (more than
    two conditions) :data:`K_CONDITION_CSV_COLUMNS` only."""
    columns = (*STATS_CSV_COLUMNS, *K_CONDITION_CSV_COLUMNS)
    return table[[c for c in columns if c in table.columns]].to_csv(index=False)

def json_ready(value: Any) -> Any:
    """A copy of ``value`` with numpy scalars made plain and NaN/inf made ``None`` (JSON null)."""
    kind = type(value)
    if kind is float:  # the plain types first: most of a document's values
        return value if math.isfinite(value) else None
    if kind is str or kind is int or kind is bool or value is None:
        return value
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    value = python_scalar(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
