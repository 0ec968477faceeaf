"""Statistics per metric with the conditions as groups (any number of conditions >= 2): the
trial-level tests, and what every test shares (the settings, the order of the conditions, a
metric's values by condition).

Tidy tables in, tidy tables or plain dicts out (the style of pingouin). For each metric:

- descriptives per condition: ``n``, ``mean``, ``median``, ``q1``, ``q3`` (linear quantiles);
- Kruskal-Wallis over trials (``scipy.stats.kruskal``, tie-corrected H), as the paper;
- Conover's pairwise post-hoc test (``scikit_posthocs.posthoc_conover``) with adjusted
  (Holm by default) and unadjusted p; both evaluated on arrays with the libraries' numbers bit
  for bit (:mod:`nudgecli.report.rank_tests`), the libraries themselves (imported only then)
  where that cannot be guaranteed;
- stars ``*``, ``**``, ``***`` from the adjusted post-hoc p, only when Kruskal-Wallis is
  significant; the comparison (``<`` as the paper, ``<=`` as the study software) is a setting;
- because trials are nested in participants, a participant-level test on per-participant
  medians: Wilcoxon signed-rank (two conditions) or Friedman (more), then, with more than two
  conditions, Wilcoxon signed-rank for every pair with the same adjustment as Conover's (Holm by
  default); participants missing a condition are dropped with a note
  (:mod:`nudgecli.report.participant_tests`);
- an effect size on the participant medians: the matched-pairs rank-biserial correlation (two
  conditions, or each pair of more; positive when the first condition is larger), and with more
  than two conditions Kendall's W of the Friedman test (:mod:`nudgecli.report.participant_tests`)
  and the epsilon-squared of the trial-level Kruskal-Wallis test (here);
- a cluster-bootstrap percentile interval of the difference of the trial-level medians of each
  pair of conditions: whole participants (with all their trials) are resampled with
  replacement, ``rng = np.random.default_rng(seed)``, the same resamples for every metric
  (:mod:`nudgecli.report.cluster_bootstrap`).

:func:`nudgecli.report.stats_document.compare_conditions` puts them together into the
``stats.json`` document (DESIGN section 5).

The order of the conditions everywhere (tests, tables, figures) is :func:`order_conditions`'.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Collection, Mapping, Sequence
from typing import Any, Literal

import numpy as np
import pandas as pd

from nudgecli.model.conditions import PAPER_CONDITIONS
from nudgecli.report.comparison_options import ComparisonOptions as ComparisonOptions  # re-exported
from nudgecli.report.metric_rows import MetricRows, TidyRows, narrow_codes, rows_for
from nudgecli.report.metric_rows import compared_participants as compared_participants  # re-exported
from nudgecli.report.metric_rows import condition_positions as condition_positions  # re-exported
from nudgecli.report.metric_rows import tidy_values as tidy_values  # re-exported
from nudgecli.report.p_adjust import NATIVE_ADJUSTMENTS
from nudgecli.report.rank_tests import condition_mean_ranks, conover_exact, kruskal_exact

#: Adjustments that leave a single p-value unchanged (``multipletests`` with one test).
_IDENTITY_ON_ONE_TEST = frozenset({"bonferroni", "sidak", "holm-sidak", "holm", "simes-hochberg", "hommel",
                                   "fdr_bh", "fdr_by"})


def order_conditions(values: Sequence[Any], preferred: Sequence[str] = ()) -> list[str]:
    """The conditions present in ``values``, in the toolkit's one order of conditions.

    The paper's conditions (:data:`PAPER_CONDITIONS`) that are present come first, in the paper's
    order (so the paper's comparison is always ``disambiguation - control``); then those in
    ``preferred`` (the analysis plan's ``conditions``, then the experiment's ``study.conditions``),
    in its order; then the rest sorted by name (not by first appearance: the order, and so every
    output, must not depend on the order of a table's rows).

    Parameters
    ----------
    values
        Condition labels (any number of repeats; missing values are ignored).
    preferred
        Conditions in the wanted order (absent ones are skipped, repeats ignored).

    Returns
    -------
    list[str]
        Each present condition once.
    """
    if isinstance(values, pd.Series) and isinstance(values.dtype, pd.StringDtype):
        values = values.unique()  # strings: each distinct one once (not a Python loop over every row)
    present = sorted({str(v) for v in values if not pd.isna(v)})
    first: list[str] = []
    for c in (*PAPER_CONDITIONS, *(str(p) for p in preferred)):
        if c in present and c not in first:
            first.append(c)
    return first + [c for c in present if c not in first]


def pairs(conditions: Sequence[str]) -> list[tuple[str, str]]:
    """All pairs ``(a, b)`` of conditions, ``a`` before ``b`` in the given order."""
    return list(itertools.combinations(conditions, 2))


def python_scalar(value: Any) -> Any:
    """A numpy scalar as the Python scalar (for JSON)."""
    return value.item() if hasattr(value, "item") else value


def describe(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
             condition: str = "condition", tidy: TidyRows | None = None) -> pd.DataFrame:
    """Descriptives of one metric per condition.

    Parameters
    ----------
    tidy
        :func:`tidy_values` of ``data``, ``metric`` and ``conditions`` (or its
        :class:`~nudgecli.report.metric_rows.MetricRows`), when the caller holds it (every test of a
        metric reads the same rows: made once); ``data`` is then not read.

    Returns
    -------
    pd.DataFrame
        One row per condition (in the given order): ``condition, n, mean, median, q1, q3``;
        missing values are ignored, statistics of an empty condition are NaN.
    """
    columns = descriptive_columns(data, metric, conditions, condition=condition, tidy=tidy)
    return pd.DataFrame({"condition": list(conditions), **columns})


def descriptive_columns(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                        condition: str = "condition",
                        tidy: TidyRows | None = None) -> dict[str, np.ndarray]:
    """:func:`describe`'s columns as arrays, without its table (the ``stats.json`` entry reads them).

    The values are pandas' grouped ``size``, ``mean``, ``median`` and linear ``quantile`` (0.25,
    0.75) of the condition's values, bit for bit: the counts a ``bincount``, the means pandas' own
    (grouped in the order pandas groups the labels in), the medians and quartiles picked from one
    sort (:func:`_sorted_descriptives`).

    Returns
    -------
    dict
        ``n`` ``(k,)`` int64 (0 for a condition without values), ``mean, median, q1, q3`` ``(k,)``
        float64 (NaN there), the conditions in the given order.
    """
    rows = rows_for(data, metric, conditions, condition, None, tidy)
    k = len(conditions)
    values, positions = rows.values, rows.positions
    chosen = positions >= 0
    if not chosen.all():  # (rows of other conditions: a table given)
        values, positions = values[chosen], positions[chosen]
    columns = {"n": np.bincount(positions, minlength=k).astype(np.int64),
               **{name: np.full(k, np.nan) for name in ("mean", "median", "q1", "q3")}}
    if values.size == 0:
        return columns
    # the means are pandas' (its grouped mean is a compensated sum in the rows' order), grouped in the
    # labels' own order (:func:`condition_group_order`): the positions' order can take another path
    order = np.arange(k) if rows.group_order is None else rows.group_order
    grouped = pd.Series(values).groupby(narrow_codes(order, k)[positions])
    results = [("mean", grouped.mean())]
    if np.any((values == 0) & np.signbit(values)):  # which zero pandas' selection returns: its own
        results += [("median", grouped.median()), ("q1", grouped.quantile(0.25)),
                    ("q3", grouped.quantile(0.75))]
    else:
        columns.update(_sorted_descriptives(values, positions, k))
    position_of = np.argsort(order)  # a group's place -> its condition's position
    for name, result in results:
        columns[name][position_of[result.index.to_numpy()]] = result.to_numpy()
    return columns


def _sorted_descriptives(values: np.ndarray, positions: np.ndarray, k: int) -> dict[str, np.ndarray]:
    """pandas' grouped ``median`` and linear ``quantile`` (0.25, 0.75) of each condition's values,
    from one sort: the same values picked and combined with the same operations, so the same bits.

    pandas' median (``group_median_float64``) is the middle value, or ``(upper + lower) / 2`` of the
    two middle ones; its quantile (``group_quantile``, rows sorted by group then value) takes the
    value at ``int(q (m - 1))`` and, where ``f = q (m - 1) % 1`` is not 0, adds ``(next - value) f``.
    A value -0.0 is left to pandas (which zero a selection returns is its own).

    Returns
    -------
    dict
        ``median, q1, q3`` ``(k,)`` float64, NaN for a condition without values.
    """
    order = np.lexsort((values, positions))  # by condition, then by value
    ordered, groups = values[order], positions[order]
    starts = np.flatnonzero(np.r_[True, groups[1:] != groups[:-1]])
    sizes = np.diff(np.r_[starts, ordered.size])
    present = groups[starts]
    out = {name: np.full(k, np.nan) for name in ("median", "q1", "q3")}
    lower, upper = ordered[starts + (sizes - 1) // 2], ordered[starts + sizes // 2]
    with np.errstate(invalid="ignore", over="ignore"):  # NaN and inf as pandas' (silent) ones
        out["median"][present] = np.where(sizes % 2 == 1, lower, (upper + lower) / 2)
        for name, q in (("q1", 0.25), ("q3", 0.75)):
            where = q * (sizes - 1).astype(np.float64)
            index = starts + where.astype(np.int64)  # truncated, as pandas' cast
            fraction = where % 1
            value = ordered[index]
            following = ordered[np.minimum(index + 1, ordered.size - 1)]
            out[name][present] = np.where(fraction == 0.0, value, value + (following - value) * fraction)
    return out


def mean_rank_column(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                     compared: Collection[str] | None = None, condition: str = "condition",
                     tidy: TidyRows | None = None) -> np.ndarray:
    """Each condition's mean rank among the trials of the compared conditions, ranked together
    (:func:`~nudgecli.report.rank_tests.condition_mean_ranks`): the ranks Kruskal-Wallis and
    Conover's test compare.

    Parameters
    ----------
    compared
        The conditions ranked together (all of ``conditions`` when ``None``); the others get NaN.
    tidy
        :func:`tidy_values` of the arguments, when the caller holds it.

    Returns
    -------
    np.ndarray
        ``(k,)`` float in the conditions' order, NaN for a condition not compared or without values.
    """
    rows = rows_for(data, metric, conditions, condition, None, tidy)
    values, positions = rows.values, rows.positions
    if compared is not None:
        chosen = set(compared)
        kept = np.isin(positions, [j for j, c in enumerate(conditions) if c in chosen])
        values, positions = values[kept], positions[kept]
    return condition_mean_ranks(values, positions, len(conditions))


def kruskal_wallis(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                   condition: str = "condition", tidy: TidyRows | None = None) -> dict[str, float]:
    """Kruskal-Wallis H test over trials (tie-corrected, ``scipy.stats.kruskal``).

    Parameters
    ----------
    tidy
        :func:`tidy_values` of the arguments, when the caller holds it (as :func:`describe`).

    Returns
    -------
    dict
        ``{"statistic": H, "p": p}``; both NaN when fewer than two conditions have values or
        all values are equal.
    """
    rows = rows_for(data, metric, conditions, condition, None, tidy)
    values, positions = rows.values, rows.positions
    groups = [values[positions == j] for j in range(len(conditions))]
    groups = [g for g in groups if g.size]
    if len(groups) < 2 or np.unique(np.concatenate(groups)).size < 2:
        return {"statistic": math.nan, "p": math.nan}
    exact = kruskal_exact(groups)
    if exact is not None:
        return {"statistic": exact[0], "p": exact[1]}
    import scipy.stats

    result = scipy.stats.kruskal(*groups)
    return {"statistic": float(result.statistic), "p": float(result.pvalue)}


def adjust_p_values(p_values: Sequence[float] | np.ndarray, method: str = "holm") -> np.ndarray:
    """Adjust a family of p-values for multiple comparisons (``statsmodels``' ``multipletests``;
    Holm and Bonferroni computed here with its numbers, :mod:`nudgecli.report.p_adjust`).

    Holm's step-down method (the default, as the paper's post-hoc tests): sort the ``m`` p-values,
    multiply the ``i``-th smallest (``i = 1..m``) by ``m - i + 1``, make the sequence
    non-decreasing (running maximum) and cap it at 1 (Holm, *Scand. J. Statist.* 6, 65-70, 1979).

    Parameters
    ----------
    p_values
        ``(m,)`` unadjusted p-values; NaN marks an undefined test, which is not part of the
        family (it stays NaN and does not count in ``m``).
    method
        A ``multipletests`` method, or ``"none"`` (the p-values unchanged).

    Returns
    -------
    np.ndarray
        ``(m,)`` adjusted p-values, in the given order.
    """
    values = np.asarray(p_values, dtype=float)
    adjusted = values.copy()
    defined = np.isfinite(values)
    n_tests = int(defined.sum())
    if method in ("none", "", None) or n_tests == 0:
        return adjusted
    if n_tests == 1 and method in _IDENTITY_ON_ONE_TEST:
        return adjusted  # one test: these adjustments return p itself (and statsmodels' Holm runs
        # gc.collect() on every call, which dominated the analysis of many replications)
    native = NATIVE_ADJUSTMENTS.get(method)
    if native is not None:  # statsmodels' numbers bit for bit, without its gc.collect()
        adjusted[defined] = native(values[defined])
        return adjusted
    from statsmodels.stats.multitest import multipletests

    adjusted[defined] = multipletests(values[defined], method=method)[1]
    return adjusted


def epsilon_squared(h_statistic: float, n_observations: int) -> float:
    """The epsilon-squared effect size of a Kruskal-Wallis test: ``H / ((n^2 - 1) / (n + 1))``.

    That is ``H / (n - 1)``, in ``[0, 1]``: 0 when the groups' mean ranks are equal, larger the
    more the groups' ranks separate (two equal groups that do not overlap give about 0.75, three
    about 0.89: the maximum depends on k and the group sizes). The rank-based epsilon-squared as given by
    M. Tomczak and E. Tomczak, "The need to report effect size estimates revisited. An overview of
    some recommended measures of effect size", *Trends in Sport Sciences* 21(1), 19-25 (2014); the
    same as ``rcompanion::epsilonSquared`` (S. Mangiafico) for Kruskal-Wallis.

    Parameters
    ----------
    h_statistic
        The (tie-corrected) Kruskal-Wallis H.
    n_observations
        Values in all groups together.

    Returns
    -------
    float
        NaN for fewer than two observations or an undefined H.
    """
    if n_observations < 2 or not np.isfinite(h_statistic):
        return math.nan
    return float(h_statistic * (n_observations + 1) / (n_observations ** 2 - 1))


def conover(data: pd.DataFrame, metric: str, conditions: Sequence[str], *, p_adjust: str = "holm",
            condition: str = "condition", tidy: TidyRows | None = None) -> pd.DataFrame:
    """Conover's pairwise post-hoc test (``scikit_posthocs.posthoc_conover``).

    Parameters
    ----------
    p_adjust
        ``multipletests`` method for the adjusted p (``"none"`` for no adjustment).
    tidy
        :func:`tidy_values` of the arguments, when the caller holds it (as :func:`describe`).

    Returns
    -------
    pd.DataFrame
        One row per pair: ``a, b, p`` (adjusted), ``p_unadjusted``; NaN where a condition has
        no values, all values are equal, or there are no more values than conditions (the test's
        t statistic has ``n - k`` degrees of freedom).
    """
    rows = conover_rows(data, metric, conditions, p_adjust=p_adjust, condition=condition, tidy=tidy)
    return pd.DataFrame(rows, columns=["a", "b", "p", "p_unadjusted"])


def conover_rows(data: pd.DataFrame, metric: str, conditions: Sequence[str], *, p_adjust: str = "holm",
                 condition: str = "condition", tidy: TidyRows | None = None) -> list[dict[str, Any]]:
    """:func:`conover`'s rows as plain dicts (``a, b, p, p_unadjusted``; Python floats): what the
    ``stats.json`` document holds, without a table made and read back."""
    rows_read = rows_for(data, metric, conditions, condition, None, tidy)
    values, positions = rows_read.values, rows_read.positions
    present = [c for j, c in enumerate(conditions) if (positions == j).any()]
    rows = [{"a": a, "b": b, "p": math.nan, "p_unadjusted": math.nan} for a, b in pairs(conditions)]
    if len(present) >= 2 and np.unique(values).size >= 2 and values.size > len(present):
        groups, unadjusted = _conover_unadjusted(values, positions, conditions, rows_read)
        # what posthoc_conover(p_adjust=...) does, without ranking the data a second time
        upper = np.triu_indices(len(groups), 1)
        adjusted = unadjusted.copy()
        adjusted[upper] = adjust_p_values(adjusted[upper], p_adjust)
        adjusted.T[upper] = adjusted[upper]
        position = {group: i for i, group in enumerate(groups)}
        for row in rows:
            if row["a"] in present and row["b"] in present:
                i, j = position[row["a"]], position[row["b"]]
                row["p"], row["p_unadjusted"] = float(adjusted[i, j]), float(unadjusted[i, j])
    return rows


def _conover_unadjusted(values: np.ndarray, positions: np.ndarray, conditions: Sequence[str],
                        rows: MetricRows) -> tuple[list[Any], np.ndarray]:
    """The unadjusted Conover p-values of ``(n,)`` values in the groups ``(n,)`` positions of
    ``conditions`` (``scikit_posthocs.posthoc_conover`` with ``sort=False`` of the ``tidy`` rows they
    are): the groups in order of first appearance and their ``(k, k)`` matrix, evaluated on arrays
    where that gives the library's bits (:func:`~nudgecli.report.rank_tests.conover_exact`)."""
    exact = conover_exact(values, positions)
    if exact is not None:
        groups, matrix = exact
        return [conditions[i] for i in np.asarray(groups, dtype=np.intp).tolist()], matrix
    import scikit_posthocs

    # the tidy rows themselves (a categorical column stays one): a frame of the labels as strings
    # was 0.8 s and 0.3 GB more per metric of a 3.5 M-row table, for the same numbers
    table = scikit_posthocs.posthoc_conover(rows.table(participants=False), val_col="value",
                                            group_col="condition", sort=False)
    return [str(group) for group in table.index], table.to_numpy(dtype=float)


def significance_stars(p: float, thresholds: Sequence[float] = (0.05, 0.01, 0.001),
                       comparison: Literal["<", "<="] = "<") -> str:
    """One ``*`` per threshold that ``p`` meets (``p < t`` or ``p <= t``); ``""`` for none or NaN."""
    if p is None or not np.isfinite(p):
        return ""
    meets = (lambda t: p <= t) if comparison == "<=" else (lambda t: p < t)
    return "*" * sum(1 for t in thresholds if meets(t))


def is_significant(p: float, alpha: float, comparison: Literal["<", "<="] = "<") -> bool:
    """Whether ``p`` is significant at ``alpha`` under the comparison (False for NaN)."""
    return significance_stars(p, (alpha,), comparison) == "*"


def star_rule(options: ComparisonOptions) -> dict[str, Any]:
    """The rule a metric's stars follow (its Kruskal-Wallis gate, thresholds and comparison), as
    ``stats.json`` records it beside them, so that the stars can be checked against the p-values."""
    return {"kruskal_alpha": options.kruskal_alpha, "thresholds": list(options.star_thresholds),
            "comparison": options.star_comparison}


def pair_stars(p: float, kruskal_p: float, rule: Mapping[str, Any]) -> str:
    """A pair's stars under a :func:`star_rule`: those of its (adjusted) Conover ``p``, where the
    metric's Kruskal-Wallis ``kruskal_p`` passes the gate; ``""`` otherwise."""
    comparison = rule["comparison"]
    if not is_significant(kruskal_p, float(rule["kruskal_alpha"]), comparison):
        return ""
    return significance_stars(p, [float(t) for t in rule["thresholds"]], comparison)
