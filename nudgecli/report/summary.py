"""The printed and written summaries of an analysis: the plain-text table ``nudge analyze`` prints
(:func:`format_table`) and ``summary.md`` (:func:`format_summary`), both from
:func:`~nudgecli.report.stats_document.stats_table`'s tidy table of ``stats.json``; numbers and
p-values are formatted one way everywhere (:func:`format_value`, :func:`format_p`): a printed
p-value is never on the other side of a plan's threshold than the p its stars were given for.

A condition a metric is not applicable to (:mod:`nudgecli.report.not_applicable`) shows
:data:`NOT_APPLICABLE_CELL` in its cells and in those of its pairs. ``summary.md`` shows the pairs
of four or more conditions by letters, or those of a reference condition
(:mod:`nudgecli.report.pair_display`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from decimal import Decimal
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.report.letters import compact_letter_display
from nudgecli.report.not_applicable import is_not_applicable
from nudgecli.report.pair_display import PairDisplay, of_reference, pair_display
from nudgecli.report.plans import AnalysisPlan
from nudgecli.report.stats_document import SINGLE_CONDITION_NOTE, condition_table

#: What a table shows for a condition a metric is not applicable to, and for its pairs.
NOT_APPLICABLE_CELL = "n/a"


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


def format_level(level: float) -> str:
    """A confidence level as a percentage, exactly as the plan gives it: ``95%``, ``97.5%``,
    ``99.9%`` (rounding to whole percent printed 0.975 as ``98%`` and 0.999 as ``100%``)."""
    text = format(Decimal(repr(float(level))) * 100, "f")
    return (text.rstrip("0").rstrip(".") if "." in text else text) + "%"


#: The thresholds a p-value printed without a plan keeps its side of: the star thresholds of every
#: shipped plan, whose Kruskal-Wallis alpha is 0.05 as well.
P_THRESHOLDS: tuple[float, ...] = (0.05, 0.01, 0.001)
#: Below this a p-value prints as ``<0.001`` (``p < 0.001`` in a sentence).
P_FLOOR = 0.001
#: Decimals of a p-value far from every threshold.
P_DECIMALS = 3


def plan_p_thresholds(plan: AnalysisPlan) -> tuple[float, ...]:
    """The thresholds a plan's p-values are judged against: its star thresholds, then its
    Kruskal-Wallis alpha (the gate of the stars)."""
    return (*plan.stats.star_thresholds, plan.stats.kruskal_alpha)


def _same_side(text: str, p: float, threshold: float) -> bool:
    """Whether the printed ``text`` lies on the same side of ``threshold`` as ``p`` (or on it
    exactly when ``p`` is): then it meets ``p < t`` and ``p <= t`` exactly when ``p`` does.

    The threshold is read as written in the plan (its shortest repr, e.g. ``0.05``), the decimal a
    reader compares the printed value with; ``p`` is compared as the stars compare it (as floats).
    """
    printed = Decimal(text) - Decimal(repr(float(threshold)))
    exact = (p > threshold) - (p < threshold)
    return (printed > 0) - (printed < 0) == exact


def format_p(p: float | None, thresholds: Sequence[float] = P_THRESHOLDS) -> str:
    """A p-value for a table: ``<0.001`` below 0.001, ``-`` when missing, else 3 decimals or as
    many more as keep it on its side of every threshold.

    Rounding alone would print p = 0.009976 as ``0.010`` beside ``**`` (p < .01), and p = 0.0104
    as ``0.010``, which under the study code's ``p <= .01`` reads as two stars while it has one.
    So the value is printed to 3 decimals, or to the fewest more for which the rounded value is
    below, on or above each threshold exactly as ``p`` is (``0.00998``, ``0.0104``): correctly
    rounded, and right under ``<`` and ``<=`` alike. Rounding toward zero instead would hold only
    for ``<`` (``0.0104`` -> ``0.010`` again reads as meeting ``<= .01``) and prints 0.009976 as
    ``0.009``. A p on a float next to a threshold takes all its digits (at most its repr's).

    Parameters
    ----------
    p
        The p-value (``None`` or NaN: missing).
    thresholds
        The plan's star thresholds and Kruskal-Wallis alpha (:func:`plan_p_thresholds`); those
        below :data:`P_FLOOR` say nothing ``<0.001`` could contradict.

    Returns
    -------
    str
        ``-``, ``<0.001``, or the decimal (``0.012``, ``0.00998``).
    """
    if p is None or not math.isfinite(p):
        return "-"
    p = float(p)  # a numpy float's repr names its type
    if p < P_FLOOR:
        return "<0.001"
    # repr(p) ends the search: no float other than t has its shortest repr on or across t's
    decimals = len(repr(p).partition(".")[2])
    for places in range(P_DECIMALS, max(decimals, P_DECIMALS) + 1):
        text = f"{p:.{places}f}"
        if all(_same_side(text, p, t) for t in thresholds):
            return text
    return repr(p)


def _p_clause(p: float | None, thresholds: Sequence[float]) -> str:
    """A p-value in a sentence: ``p = 0.012``, ``p < 0.001``."""
    text = format_p(p, thresholds)
    return "p < 0.001" if text == "<0.001" else f"p = {text}"


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
    table; ``first`` names the column that opens each row (``metric`` or ``condition``); a
    condition left out of the metric shows :data:`NOT_APPLICABLE_CELL`."""
    rows = []
    for row in table.to_dict("records"):
        if is_not_applicable(row["n"]):
            rows.append([str(row[first])] + [NOT_APPLICABLE_CELL] * 3)
        else:
            rows.append([str(row[first]), str(int(row["n"])),
                         _median_iqr(row["median"], row["q1"], row["q3"]), format_value(row["mean"])])
    return rows


def _left_out(row: Mapping[str, Any]) -> bool:
    """Whether a pair row of the tidy table holds a condition left out of its metric."""
    return is_not_applicable(row["n_a"]) or is_not_applicable(row["n_b"])


def _side(row: Mapping[str, Any], side: str) -> str:
    """``median [q1, q3]`` of one side of a pair row, or :data:`NOT_APPLICABLE_CELL`."""
    if is_not_applicable(row[f"n_{side}"]):
        return NOT_APPLICABLE_CELL
    return _median_iqr(row[f"median_{side}"], row[f"q1_{side}"], row[f"q3_{side}"])


def _p_adjust(table: pd.DataFrame) -> str:
    """The adjustment of the pairs' p values (the plan's ``p_adjust``) named in a column header."""
    return str(table["p_adjust"].iloc[0]) if "p_adjust" in table.columns and len(table) else "adjusted"


def _participant_cells(r: Mapping[str, Any], two: bool, thresholds: Sequence[float]) -> list[str]:
    """A pair's participant-level p and effect size: with two conditions the test of the pair
    (``participant_p``), with more the pair's own Wilcoxon test (``pairwise_p``)."""
    if two:
        return [format_p(r["participant_p"], thresholds), _effect(r["effect_size_name"], r["effect_size"])]
    return [format_p(r["pairwise_p"], thresholds),
            _effect(r["pairwise_effect_size_name"], r["pairwise_effect_size"])]


def format_table(table: pd.DataFrame, conditions: Sequence[str], reference: str | None = None, *,
                 thresholds: Sequence[float] = P_THRESHOLDS) -> str:
    """A plain-text table of the statistics: one row per metric x pair of conditions.

    Parameters
    ----------
    table
        :func:`~nudgecli.report.stats_document.stats_table`'s tidy table of ``stats.json``.
    conditions
        ``stats.json``'s conditions, in order.
    reference
        Only the pairs of this condition (``--reference``; three or more conditions), as
        ``summary.md`` and the figures show them; ``stats.csv`` keeps every pair.
    thresholds
        The analysis plan's (:func:`plan_p_thresholds`): each p keeps its side of them (:func:`format_p`).

    Columns: median [q1, q3] of both conditions, Kruskal-Wallis p, Conover p, stars, the pair's
    participant-level p and effect size (two conditions: the Wilcoxon test of the pair; more: the
    pair's adjusted Wilcoxon p and rank-biserial r, as ``summary.md`` shows them, not the Friedman
    p and Kendall's W of all conditions) and the median difference with its interval. A pair
    holding a condition left out of the metric shows :data:`NOT_APPLICABLE_CELL` for that
    condition and for the pair's own statistics.
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
    # two conditions: the participant-level test is the pair's own; more: the pair's Wilcoxon test
    # (as summary.md shows it), not the omnibus Friedman p and Kendall's W, which no pair owns
    participant = "participant p" if two else f"Wilcoxon p ({_p_adjust(table)})"
    header += ["KW p", "Conover p", "stars", participant, "effect", f"a-b [{format_level(level)} CI]"]
    rows = []
    for r in table.to_dict("records"):
        if reference is not None and not two and not of_reference(reference, r["a"], r["b"]):
            continue
        row = [r["metric"]] + ([] if two else [f"{r['a']} vs {r['b']}"])
        if _left_out(r):
            # the participant-level test and its effect are the pair's own, at any number of conditions
            own = NOT_APPLICABLE_CELL
            row += [_side(r, "a"), _side(r, "b"), format_p(r["kruskal_p"], thresholds)] + [own] * 5
        else:
            row += [_median_iqr(r["median_a"], r["q1_a"], r["q3_a"]),
                    _median_iqr(r["median_b"], r["q1_b"], r["q3_b"]), format_p(r["kruskal_p"], thresholds),
                    format_p(r["conover_p"], thresholds), r["stars"] or "ns",
                    *_participant_cells(r, two, thresholds),
                    _interval(r["difference"], r["ci_low"], r["ci_high"])]
        rows.append(row)
    return _render(header, rows, markdown=False)


def format_summary(table: pd.DataFrame, conditions: Sequence[str], plan: AnalysisPlan, source: Path,
                   n_trials: int, n_participants: int, *, reference: str | None = None,
                   not_applicable: Mapping[str, Mapping[str, str]] | None = None,
                   definitions: str | None = None, filters: str | None = None,
                   blanks: str | None = None, plan_name: str | None = None) -> str:
    """``summary.md``: the settings, then per metric a line of tests and two markdown tables.

    ``table`` is :func:`~nudgecli.report.stats_document.stats_table`'s tidy table of ``stats.json``,
    ``conditions`` its conditions in order. The pairs (:func:`~nudgecli.report.pair_display.pair_display`):
    up to three conditions every pair; four or more a letter per condition in the table of
    descriptives instead (:func:`~nudgecli.report.letters.compact_letter_display` of the pairs
    with stars); with ``reference`` only that condition's pairs. ``not_applicable``: metric ->
    condition -> why it was left out (``stats.json``'s ``not_applicable_reasons``). ``source`` is
    the analysed run folder or table as seen from the folder ``summary.md`` is written to (``.``:
    that folder itself). ``definitions``: for a table, which of the plan's metric definitions were
    applied and which are the table's own
    (:func:`~nudgecli.report.table_definitions.apply_plan_definitions`), a line after the plan's;
    ``filters``: the values the plan's filters left out
    (:func:`~nudgecli.report.plan_filters.apply_plan_filters`), a line after that; ``blanks``: a
    table's blank cells of the analysed metrics, which every statistic leaves out
    (:func:`~nudgecli.report.table_definitions.blank_values_line`), a line after the definitions.
    ``plan_name``: how the ``- plan:`` line names the plan (a plan file as seen from the folder
    ``summary.md`` is written to: :func:`~nudgecli.report.plan_metrics.summary_plan_name`); default
    its :attr:`~nudgecli.report.plans.AnalysisPlan.label`, a preset's name or the file's path, never
    the file's ``name`` key, which a copied preset keeps.
    """
    plan_name = plan.label if plan_name is None else plan_name
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
        return _descriptive_summary(table, conditions, plan_name, source, n_trials, n_participants,
                                    (definitions, blanks, filters))
    resamples = table["ci_resamples"].iloc[0] if len(table) else plan.bootstrap.resamples
    display = pair_display(len(conditions), reference)
    lines = [
        "# Analysis summary",
        "",
        f"- source: `{source}`",
        f"- plan: {plan_name}; conditions: {', '.join(conditions)}; {n_trials} trials of "
        f"{n_participants} participants",
        *([f"- definitions: {definitions}"] if definitions else []),
        *([f"- {blanks}"] if blanks else []),
        *([f"- filters: {filters}"] if filters else []),
        f"- trial level: Kruskal-Wallis, then Conover's test ({settings.p_adjust} adjustment); stars "
        f"(one per threshold {thresholds}, p {comparison} threshold) from the Conover p, only when "
        f"Kruskal-Wallis p {comparison} {settings.kruskal_alpha:g}",
        f"- participant level: {test} on per-participant {settings.participant_aggregate}s; "
        f"effect size: {effect}",
        f"- interval: {format_level(plan.bootstrap.level)} cluster bootstrap over participants of the "
        f"difference of trial medians ({resamples} resamples, seed {seed})",
    ]
    if display == "letters":
        lines.append("- pairs: a compact letter display per metric (Piepho 2004): conditions that share a "
                     "letter do not differ, a pair with a star does; every pair is in stats.csv")
    elif display == "reference" and len(conditions) > 2:
        lines.append(f"- pairs: those of {reference} (--reference); every pair is in stats.csv")
    descriptives = condition_table(table)
    for metric, pairs_of_metric in table.groupby("metric", sort=False):
        reasons = (not_applicable or {}).get(str(metric), {})
        lines += _metric_section(str(metric), pairs_of_metric, descriptives[descriptives["metric"] == metric],
                                 many, display, reference, reasons, plan_p_thresholds(plan))
    return "\n".join(lines) + "\n"


def _metric_section(metric: str, pairs_of_metric: pd.DataFrame, own: pd.DataFrame, many: bool,
                    display: PairDisplay, reference: str | None, reasons: Mapping[str, str],
                    thresholds: Sequence[float]) -> list[str]:
    """One metric's lines of ``summary.md``: its tests, the conditions left out of them, its
    descriptives (with letters) and its pairs (``own``: its rows of the condition table;
    ``thresholds``: the plan's, :func:`plan_p_thresholds`)."""
    first = pairs_of_metric.iloc[0]
    compared = [str(r["condition"]) for r in own.to_dict("records") if not is_not_applicable(r["n"])]
    lines = ["", f"## {metric}", ""]
    if len(compared) < 2:
        lines.append("No test: fewer than two conditions left to compare.")
    else:
        lines.append(
            f"Kruskal-Wallis H = {format_value(first['kruskal_statistic'])}, "
            f"{_p_clause(first['kruskal_p'], thresholds)}. "
            f"Participant level ({first['participant_test']}, {int(first['n_participants'])} "
            "participants): "
            f"statistic = {format_value(first['participant_statistic'])}, "
            f"{_p_clause(first['participant_p'], thresholds)}. "
            f"Effect size: {_effect(first['effect_size_name'], first['effect_size'])}"
            + (f", epsilon-squared = {format_value(first['epsilon_squared'])}." if many else "."))
    left_out = [str(r["condition"]) for r in own.to_dict("records") if is_not_applicable(r["n"])]
    if left_out:
        lines += ["", "Left out of the tests: " + ", ".join(
            f"{c} ({reasons.get(c, NOT_APPLICABLE_CELL)})" for c in left_out) + "."]
    if first["participant_note"] and len(compared) >= 2:
        lines += ["", f"Note: {first['participant_note']}."]
    descriptive_header = ["condition", "n", "median [q1, q3]", "mean"]
    descriptive_rows = _descriptive_rows(own, "condition")
    if display == "letters":
        letters = _letters(pairs_of_metric, compared)
        descriptive_header.append("letters")
        descriptive_rows = [[*row, letters.get(row[0], NOT_APPLICABLE_CELL)] for row in descriptive_rows]
    lines += ["", _render(descriptive_header, descriptive_rows, markdown=True)]
    if display == "letters":
        return lines
    shown = pairs_of_metric.to_dict("records")
    if display == "reference" and reference is not None:
        shown = [r for r in shown if of_reference(reference, r["a"], r["b"])]
    header = ["comparison", f"Conover p ({first['p_adjust']})", "p unadjusted", "stars",
              "difference of medians", f"{format_level(first['ci_level'])} CI"]
    if many:
        header += [f"Wilcoxon p ({first['p_adjust']})", "effect"]
    return [*lines, "", _render(header, [_pair_cells(r, many, thresholds) for r in shown], markdown=True)]


def _pair_cells(r: Mapping[str, Any], many: bool, thresholds: Sequence[float]) -> list[str]:
    """One pair's row of ``summary.md``'s comparisons (:data:`NOT_APPLICABLE_CELL` for a pair
    holding a condition left out)."""
    if _left_out(r):
        return [f"{r['a']} - {r['b']}"] + [NOT_APPLICABLE_CELL] * (7 if many else 5)
    return ([f"{r['a']} - {r['b']}", format_p(r["conover_p"], thresholds),
             format_p(r["conover_p_unadjusted"], thresholds),
             r["stars"] or "ns", format_value(r["difference"]),
             f"[{format_value(r['ci_low'])}, {format_value(r['ci_high'])}]"]
            + ([format_p(r["pairwise_p"], thresholds),
                _effect(r["pairwise_effect_size_name"], r["pairwise_effect_size"])] if many else []))


def _letters(pairs_of_metric: pd.DataFrame, compared: Sequence[str]) -> dict[str, str]:
    """The compact letter display of one metric's compared conditions: a pair differs where it has stars."""
    present = set(compared)
    different = [(r["a"], r["b"]) for r in pairs_of_metric.to_dict("records")
                 if r["a"] in present and r["b"] in present and r["stars"]]
    return compact_letter_display(compared, different)


def _descriptive_summary(table: pd.DataFrame, conditions: Sequence[str], plan_name: str, source: Path,
                         n_trials: int, n_participants: int,
                         left_out: tuple[str | None, str | None, str | None] = (None, None, None)) -> str:
    """``summary.md`` of a single condition: the descriptives per metric and a note (no tests);
    ``plan_name``: how the plan is named; ``left_out``: :func:`format_summary`'s ``definitions``,
    ``blanks`` and ``filters`` lines."""
    (condition,) = conditions
    definitions, blanks, filters = left_out
    lines = [
        "# Analysis summary",
        "",
        f"- source: `{source}`",
        f"- plan: {plan_name}; condition: {condition}; {n_trials} trials of {n_participants} participants",
        *([f"- definitions: {definitions}"] if definitions else []),
        *([f"- {blanks}"] if blanks else []),
        *([f"- filters: {filters}"] if filters else []),
        f"- note: {SINGLE_CONDITION_NOTE} (the tests compare conditions)",
        "",
        _render(["metric", "n", "median [q1, q3]", "mean"],
                _descriptive_rows(condition_table(table), "metric"), markdown=True),
    ]
    return "\n".join(lines) + "\n"
