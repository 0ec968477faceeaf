"""The printed and written summaries of an analysis: the plain-text table ``nudge analyze`` prints
(:func:`format_table`) and ``summary.md`` (:func:`format_summary`), both from
:func:`~nudgecli.report.stats_document.stats_table`'s tidy table of ``stats.json``; numbers and
p-values are formatted one way everywhere (:func:`format_value`, :func:`format_p`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.report.plans import AnalysisPlan
from nudgecli.report.stats_document import SINGLE_CONDITION_NOTE, condition_table


def format_value(value: Any) -> str:
    """A number for a table: ``-`` when missing, integers plain, else 3 significant digits."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, bool):
        return str(value)
    if float(value).is_integer() and abs(value) < 1e6:
        return str(int(value))
    if abs(value) >= 100:
        return f"{value:.1f}"
    return f"{value:.3g}"


def format_p(p: float | None) -> str:
    """A p-value for a table: ``<0.001`` below 0.001, else 3 decimals; ``-`` when missing."""
    if p is None or not math.isfinite(p):
        return "-"
    return "<0.001" if p < 0.001 else f"{p:.3f}"


def _median_iqr(median: Any, q1: Any, q3: Any) -> str:
    return f"{format_value(median)} [{format_value(q1)}, {format_value(q3)}]"


def _effect(name: str, value: Any) -> str:
    symbol = "r" if name == "rank_biserial" else "W"
    return f"{symbol}={format_value(value)}"


def _interval(difference: Any, low: Any, high: Any) -> str:
    return f"{format_value(difference)} [{format_value(low)}, {format_value(high)}]"


def _render(header: list[str], rows: list[list[str]], markdown: bool) -> str:
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
        lines += ["| " + " | ".join(row) + " |" for row in rows]
        return "\n".join(lines)
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(header, widths, strict=True)).rstrip()]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() for row in rows]
    return "\n".join(lines)


def _descriptive_rows(table: pd.DataFrame, first: str) -> list[list[str]]:
    """Rows ``first, n, median [q1, q3], mean`` of :func:`~nudgecli.report.stats_document.condition_table`'s
    table; ``first`` names the column that opens each row (``metric`` or ``condition``)."""
    return [[str(row[first]), str(int(row["n"])), _median_iqr(row["median"], row["q1"], row["q3"]),
             format_value(row["mean"])] for row in table.to_dict("records")]


def format_table(table: pd.DataFrame, conditions: Sequence[str]) -> str:
    """A plain-text table of the statistics: one row per metric x pair of conditions.

    Parameters
    ----------
    table
        :func:`~nudgecli.report.stats_document.stats_table`'s tidy table of ``stats.json``.
    conditions
        ``stats.json``'s conditions, in order.

    Columns: median [q1, q3] of both conditions, Kruskal-Wallis p, Conover p, stars, the
    participant-level p, the effect size and the median difference with its interval.
    """
    if len(conditions) == 1:
        (c,) = conditions
        rows = _descriptive_rows(condition_table(table), "metric")
        return _render(["metric", "n", f"{c} median [q1, q3]", "mean"], rows, markdown=False) + \
            "\n(one condition: descriptive statistics only, no tests)"
    two = len(conditions) == 2
    level = table["ci_level"].iloc[0] if len(table) else 0.95
    if two:
        a, b = conditions
        header = ["metric", f"{a} median [q1, q3]", f"{b} median [q1, q3]"]
    else:
        header = ["metric", "comparison", "a median [q1, q3]", "b median [q1, q3]"]
    header += ["KW p", "Conover p", "stars", "participant p", "effect", f"a-b [{level:.0%} CI]"]
    rows = []
    for r in table.to_dict("records"):
        row = [r["metric"]] + ([] if two else [f"{r['a']} vs {r['b']}"])
        row += [_median_iqr(r["median_a"], r["q1_a"], r["q3_a"]),
                _median_iqr(r["median_b"], r["q1_b"], r["q3_b"]), format_p(r["kruskal_p"]),
                format_p(r["conover_p"]), r["stars"] or "ns", format_p(r["participant_p"]),
                _effect(r["effect_size_name"], r["effect_size"]),
                _interval(r["difference"], r["ci_low"], r["ci_high"])]
        rows.append(row)
    return _render(header, rows, markdown=False)


def format_summary(table: pd.DataFrame, conditions: Sequence[str], plan: AnalysisPlan, source: Path,
                   n_trials: int, n_participants: int) -> str:
    """``summary.md``: the settings, then per metric a line of tests and two markdown tables.

    ``table`` is :func:`~nudgecli.report.stats_document.stats_table`'s tidy table of ``stats.json``,
    ``conditions`` its conditions in order.
    """
    settings = plan.stats
    comparison = settings.star_comparison
    thresholds = ", ".join(f"{t:g}" for t in settings.star_thresholds)
    test = "Wilcoxon signed-rank" if len(conditions) == 2 else (
        f"Friedman, then Wilcoxon signed-rank for every pair ({settings.p_adjust} adjustment)")
    effect = "matched-pairs rank-biserial r of a - b" if len(conditions) == 2 else (
        "Kendall's W (Friedman), epsilon-squared (Kruskal-Wallis), matched-pairs rank-biserial r of a - b "
        "(each pair)")
    many = "pairwise_p" in table.columns  # more than two conditions: the pairs' own participant-level tests
    seed = table["ci_seed"].iloc[0] if len(table) else plan.bootstrap.seed
    if len(conditions) == 1:
        return _descriptive_summary(table, conditions, plan, source, n_trials, n_participants)
    resamples = table["ci_resamples"].iloc[0] if len(table) else plan.bootstrap.resamples
    lines = [
        "# Analysis summary",
        "",
        f"- source: `{source}`",
        f"- plan: {plan.name}; conditions: {', '.join(conditions)}; {n_trials} trials of "
        f"{n_participants} participants",
        f"- trial level: Kruskal-Wallis, then Conover's test ({settings.p_adjust} adjustment); stars "
        f"(one per threshold {thresholds}, p {comparison} threshold) from the Conover p, only when "
        f"Kruskal-Wallis p {comparison} {settings.kruskal_alpha:g}",
        f"- participant level: {test} on per-participant {settings.participant_aggregate}s; "
        f"effect size: {effect}",
        f"- interval: {plan.bootstrap.level:.0%} cluster bootstrap over participants of the difference of "
        f"trial medians ({resamples} resamples, seed {seed})",
    ]
    descriptives = condition_table(table)
    for metric, pairs_of_metric in table.groupby("metric", sort=False):
        first = pairs_of_metric.iloc[0]
        lines += [
            "",
            f"## {metric}",
            "",
            f"Kruskal-Wallis H = {format_value(first['kruskal_statistic'])}, "
            f"p = {format_p(first['kruskal_p'])}. "
            f"Participant level ({first['participant_test']}, {int(first['n_participants'])} participants): "
            f"statistic = {format_value(first['participant_statistic'])}, "
            f"p = {format_p(first['participant_p'])}. "
            f"Effect size: {_effect(first['effect_size_name'], first['effect_size'])}"
            + (f", epsilon-squared = {format_value(first['epsilon_squared'])}." if many else "."),
        ]
        if first["participant_note"]:
            lines += ["", f"Note: {first['participant_note']}."]
        lines += ["", _render(["condition", "n", "median [q1, q3]", "mean"],
                              _descriptive_rows(descriptives[descriptives["metric"] == metric], "condition"),
                              markdown=True)]
        rows = [[f"{r['a']} - {r['b']}", format_p(r["conover_p"]), format_p(r["conover_p_unadjusted"]),
                 r["stars"] or "ns", format_value(r["difference"]),
                 f"[{format_value(r['ci_low'])}, {format_value(r['ci_high'])}]"]
                + ([format_p(r["pairwise_p"]),
                    _effect(r["pairwise_effect_size_name"], r["pairwise_effect_size"])] if many else [])
                for r in pairs_of_metric.to_dict("records")]
        header = ["comparison", f"Conover p ({first['p_adjust']})", "p unadjusted", "stars",
                  "difference of medians", f"{first['ci_level']:.0%} CI"]
        if many:
            header += [f"Wilcoxon p ({first['p_adjust']})", "effect"]
        lines += ["", _render(header, rows, markdown=True)]
    return "\n".join(lines) + "\n"


def _descriptive_summary(table: pd.DataFrame, conditions: Sequence[str], plan: AnalysisPlan, source: Path,
                         n_trials: int, n_participants: int) -> str:
    """``summary.md`` of a single condition: the descriptives per metric and a note (no tests)."""
    (condition,) = conditions
    lines = [
        "# Analysis summary",
        "",
        f"- source: `{source}`",
        f"- plan: {plan.name}; condition: {condition}; {n_trials} trials of {n_participants} participants",
        f"- note: {SINGLE_CONDITION_NOTE} (the tests compare conditions)",
        "",
        _render(["metric", "n", "median [q1, q3]", "mean"],
                _descriptive_rows(condition_table(table), "metric"), markdown=True),
    ]
    return "\n".join(lines) + "\n"
