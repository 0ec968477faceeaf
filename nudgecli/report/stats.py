"""Statistics per metric with the conditions as groups (any number of conditions >= 2).

Tidy tables in, tidy tables or plain dicts out (the style of pingouin). For each metric:

- descriptives per condition: ``n``, ``mean``, ``median``, ``q1``, ``q3`` (linear quantiles);
- Kruskal-Wallis over trials (``scipy.stats.kruskal``, tie-corrected H), as the paper;
- Conover's pairwise post-hoc test (``scikit_posthocs.posthoc_conover``) with adjusted
  (Holm by default) and unadjusted p;
- stars ``*``, ``**``, ``***`` from the adjusted post-hoc p, only when Kruskal-Wallis is
  significant; the comparison (``<`` as the paper, ``<=`` as the study software) is a setting;
- because trials are nested in participants, a participant-level test on per-participant
  medians: Wilcoxon signed-rank (two conditions) or Friedman (more), then, with more than two
  conditions, Wilcoxon signed-rank for every pair with the same adjustment as Conover's (Holm by
  default); participants missing a condition are dropped with a note;
- an effect size on the participant medians: the matched-pairs rank-biserial correlation (two
  conditions, or each pair of more; positive when the first condition is larger), and with more
  than two conditions Kendall's W of the Friedman test and the epsilon-squared of the trial-level
  Kruskal-Wallis test;
- a cluster-bootstrap percentile interval of the difference of the trial-level medians of each
  pair of conditions: whole participants (with all their trials) are resampled with
  replacement, ``rng = np.random.default_rng(seed)``, the same resamples for every metric.

The result of :func:`compare_conditions` is the ``stats.json`` document (DESIGN section 5). With
two conditions it holds exactly the keys it always held (the reference run pins it); the keys of
the pairwise participant-level tests and of epsilon-squared appear with three or more.

The order of the conditions everywhere (tests, tables, figures) is :func:`order_conditions`'.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd
import scikit_posthocs
import scipy.stats

#: Adjustments that leave a single p-value unchanged (``multipletests`` with one test).
_IDENTITY_ON_ONE_TEST = frozenset({"bonferroni", "sidak", "holm-sidak", "holm", "simes-hochberg", "hommel",
                                   "fdr_bh", "fdr_by"})
#: Largest number of (resample x trial) cells the bootstrap holds in memory at once.
_BOOTSTRAP_CHUNK_CELLS = 1_000_000


@dataclass(frozen=True)
class ComparisonOptions:
    """Settings of :func:`compare_conditions` (an analysis plan's ``[stats]`` and ``[bootstrap]``).

    Attributes
    ----------
    kruskal_alpha
        Significance level of the Kruskal-Wallis gate for the stars.
    p_adjust
        Adjustment of the Conover p-values (a ``statsmodels`` ``multipletests`` method, or
        ``"none"``).
    star_thresholds
        Strictly decreasing thresholds; one star per threshold met.
    star_comparison
        ``"<"`` (the paper) or ``"<="`` (the study software); also used for the gate.
    participant_aggregate
        How trials are summarised per participant and condition (``"median"`` or ``"mean"``).
    bootstrap_resamples, bootstrap_level, seed
        The cluster bootstrap.
    """

    kruskal_alpha: float = 0.05
    p_adjust: str = "holm"
    star_thresholds: tuple[float, ...] = (0.05, 0.01, 0.001)
    star_comparison: Literal["<", "<="] = "<"
    participant_aggregate: Literal["median", "mean"] = "median"
    bootstrap_resamples: int = 2000
    bootstrap_level: float = 0.95
    seed: int = 0


#: The paper's two conditions, in its order: drawn and compared first wherever they are present.
PAPER_CONDITIONS: tuple[str, ...] = ("disambiguation", "control")


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
    present = sorted({str(v) for v in values if not pd.isna(v)})
    first: list[str] = []
    for c in (*PAPER_CONDITIONS, *(str(p) for p in preferred)):
        if c in present and c not in first:
            first.append(c)
    return first + [c for c in present if c not in first]


def _numeric(series: pd.Series) -> pd.Series:
    """A float Series (bool -> 0/1, nullable types -> NaN for missing)."""
    return pd.Series(series.to_numpy(dtype=float, na_value=np.nan), index=series.index)


def _tidy(data: pd.DataFrame, metric: str, conditions: Sequence[str], condition: str,
          participant: str | None = None) -> pd.DataFrame:
    """``condition``, ``value`` (and ``participant``) rows of the given conditions with a value."""
    labels = data[condition]
    if isinstance(labels.dtype, pd.CategoricalDtype):  # fast path for large tables: no string copies
        labels = labels.cat.rename_categories([str(c) for c in labels.cat.categories])
    else:
        labels = labels.astype(str)
    columns = {"condition": labels, "value": _numeric(data[metric])}
    if participant is not None:
        columns["participant"] = data[participant]
    tidy = pd.DataFrame(columns)
    keep = (tidy["condition"].isin(conditions) & tidy["value"].notna()).to_numpy()
    if keep.all():  # the usual case: no copy of a large table
        return tidy.reset_index(drop=True)
    return tidy[keep].reset_index(drop=True)


def pairs(conditions: Sequence[str]) -> list[tuple[str, str]]:
    """All pairs ``(a, b)`` of conditions, ``a`` before ``b`` in the given order."""
    return list(itertools.combinations(conditions, 2))


def describe(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
             condition: str = "condition") -> pd.DataFrame:
    """Descriptives of one metric per condition.

    Returns
    -------
    pd.DataFrame
        One row per condition (in the given order): ``condition, n, mean, median, q1, q3``;
        missing values are ignored, statistics of an empty condition are NaN.
    """
    tidy = _tidy(data, metric, conditions, condition)
    grouped = tidy.groupby("condition", observed=True)["value"]
    table = pd.DataFrame({
        "n": grouped.size(),
        "mean": grouped.mean(),
        "median": grouped.median(),
        "q1": grouped.quantile(0.25),
        "q3": grouped.quantile(0.75),
    }).reindex(list(conditions))
    table["n"] = table["n"].fillna(0).astype(int)
    return table.rename_axis("condition").reset_index()


def kruskal_wallis(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                   condition: str = "condition") -> dict[str, float]:
    """Kruskal-Wallis H test over trials (tie-corrected, ``scipy.stats.kruskal``).

    Returns
    -------
    dict
        ``{"statistic": H, "p": p}``; both NaN when fewer than two conditions have values or
        all values are equal.
    """
    tidy = _tidy(data, metric, conditions, condition)
    groups = [tidy.loc[tidy["condition"] == c, "value"].to_numpy() for c in conditions]
    groups = [g for g in groups if g.size]
    if len(groups) < 2 or np.unique(np.concatenate(groups)).size < 2:
        return {"statistic": math.nan, "p": math.nan}
    result = scipy.stats.kruskal(*groups)
    return {"statistic": float(result.statistic), "p": float(result.pvalue)}


def adjust_p_values(p_values: Sequence[float] | np.ndarray, method: str = "holm") -> np.ndarray:
    """Adjust a family of p-values for multiple comparisons (``statsmodels``' ``multipletests``).

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
            condition: str = "condition") -> pd.DataFrame:
    """Conover's pairwise post-hoc test (``scikit_posthocs.posthoc_conover``).

    Parameters
    ----------
    p_adjust
        ``multipletests`` method for the adjusted p (``"none"`` for no adjustment).

    Returns
    -------
    pd.DataFrame
        One row per pair: ``a, b, p`` (adjusted), ``p_unadjusted``; NaN where a condition has
        no values or all values are equal.
    """
    tidy = _tidy(data, metric, conditions, condition)
    present = [c for c in conditions if (tidy["condition"] == c).any()]
    rows = [{"a": a, "b": b, "p": math.nan, "p_unadjusted": math.nan} for a, b in pairs(conditions)]
    if len(present) >= 2 and tidy["value"].nunique() >= 2:
        unadjusted = scikit_posthocs.posthoc_conover(tidy, val_col="value", group_col="condition", sort=False)
        # what posthoc_conover(p_adjust=...) does, without ranking the data a second time
        upper = np.triu_indices(len(unadjusted), 1)
        matrix = unadjusted.to_numpy(copy=True)
        matrix[upper] = adjust_p_values(matrix[upper], p_adjust)
        matrix.T[upper] = matrix[upper]
        adjusted = pd.DataFrame(matrix, index=unadjusted.index, columns=unadjusted.columns)
        for row in rows:
            if row["a"] in present and row["b"] in present:
                row["p"] = float(adjusted.loc[row["a"], row["b"]])
                row["p_unadjusted"] = float(unadjusted.loc[row["a"], row["b"]])
    return pd.DataFrame(rows, columns=["a", "b", "p", "p_unadjusted"])


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


def participant_summaries(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                          participant: str = "participant", condition: str = "condition",
                          aggregate: Literal["median", "mean"] = "median") -> tuple[pd.DataFrame, list[Any]]:
    """Per-participant medians (or means) per condition, complete participants only.

    Returns
    -------
    (pd.DataFrame, list)
        A wide table (index participant, one column per condition in the given order) of the
        participants with a value in every condition, and the participants dropped because
        they miss a condition.
    """
    tidy = _tidy(data, metric, conditions, condition, participant)
    grouped = tidy.groupby(["participant", "condition"], observed=True)["value"]
    wide = grouped.agg(aggregate).unstack("condition")
    wide = wide.reindex(columns=list(conditions))
    complete = wide.notna().all(axis=1)
    dropped = [_plain(p) for p in wide.index[~complete]]
    return wide[complete], dropped


def rank_biserial(x: np.ndarray, y: np.ndarray) -> float:
    """Matched-pairs rank-biserial correlation of ``x - y`` (Kerby's simple difference formula).

    ``r = (sum of ranks of positive differences - sum of ranks of negative differences) /
    sum of all ranks``, ranks of ``|x - y|`` with zero differences dropped (as Wilcoxon's
    ``zero_method="wilcox"``). +1 when every ``x`` exceeds its ``y``.

    Parameters
    ----------
    x, y
        ``(n,)`` paired values.

    Returns
    -------
    float
        In ``[-1, 1]``; 0 when every difference is zero, NaN for no pairs.
    """
    difference = np.asarray(x, dtype=float) - np.asarray(y, dtype=float)
    if difference.size == 0:
        return math.nan
    difference = difference[difference != 0]
    if difference.size == 0:
        return 0.0
    ranks = scipy.stats.rankdata(np.abs(difference))
    return float((ranks[difference > 0].sum() - ranks[difference < 0].sum()) / ranks.sum())


def kendalls_w(friedman_statistic: float, n_participants: int, n_conditions: int) -> float:
    """Kendall's coefficient of concordance from Friedman's chi-square: ``W = chi2 / (n (k - 1))``."""
    if n_participants < 1 or n_conditions < 2:
        return math.nan
    return float(friedman_statistic / (n_participants * (n_conditions - 1)))


#: Columns of :func:`pairwise_wilcoxon`'s table.
PAIRWISE_COLUMNS = ("a", "b", "n_participants", "statistic", "p", "p_unadjusted", "rank_biserial")


def _wilcoxon_pairs(wide: pd.DataFrame, conditions: Sequence[str], p_adjust: str) -> pd.DataFrame:
    """:func:`pairwise_wilcoxon` on a wide table of complete participants (one column per condition)."""
    rows = []
    for a, b in pairs(conditions):
        x, y = wide[a].to_numpy(dtype=float), wide[b].to_numpy(dtype=float)
        statistic = p = math.nan
        if x.size and not np.all(x == y):  # all differences zero: Wilcoxon is undefined
            result = scipy.stats.wilcoxon(x, y)
            statistic, p = float(result.statistic), float(result.pvalue)
        rows.append({"a": a, "b": b, "n_participants": int(x.size), "statistic": statistic,
                     "p_unadjusted": p, "rank_biserial": rank_biserial(x, y)})
    table = pd.DataFrame(rows, columns=[c for c in PAIRWISE_COLUMNS if c != "p"])
    table.insert(4, "p", adjust_p_values(table["p_unadjusted"].to_numpy(dtype=float), p_adjust))
    return table


def pairwise_wilcoxon(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                      participant: str = "participant", condition: str = "condition",
                      aggregate: Literal["median", "mean"] = "median",
                      p_adjust: str = "holm") -> pd.DataFrame:
    """Wilcoxon signed-rank tests of every pair of conditions on per-participant summaries.

    The post-hoc tests of the participant-level Friedman test: the participants with a value in
    every condition (the Friedman test's, listwise deletion), summarised per condition by
    ``aggregate``; for each pair ``scipy.stats.wilcoxon(a, b)`` (zero differences dropped, exact
    p for small samples), the p-values of all pairs adjusted together by ``p_adjust`` (Holm by
    default, as the Conover p-values), and the matched-pairs rank-biserial correlation of ``a - b``.

    Parameters
    ----------
    data
        Tidy table, one row per trial: ``participant``, ``condition`` and the ``metric`` column.
    metric
        The column to analyse.
    conditions
        The conditions, in order; the pairs are :func:`pairs` of them.
    p_adjust
        ``multipletests`` method (``"none"`` for no adjustment).

    Returns
    -------
    pd.DataFrame
        One row per pair, columns :data:`PAIRWISE_COLUMNS`: ``a, b, n_participants, statistic``
        (Wilcoxon's W), ``p`` (adjusted), ``p_unadjusted``, ``rank_biserial``. Statistic and p are
        NaN where every participant's difference is zero (that pair is left out of the adjustment).
    """
    wide, _ = participant_summaries(data, metric, conditions, participant=participant,
                                    condition=condition, aggregate=aggregate)
    return _wilcoxon_pairs(wide, conditions, p_adjust)


def participant_level_test(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                           participant: str = "participant", condition: str = "condition",
                           aggregate: Literal["median", "mean"] = "median", p_adjust: str = "holm",
                           ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The paired test on per-participant summaries and its effect size.

    Two conditions: Wilcoxon signed-rank (``scipy.stats.wilcoxon``, defaults: zero differences
    dropped, exact p for small samples) and the matched-pairs rank-biserial correlation of
    ``a - b``. More: Friedman (``scipy.stats.friedmanchisquare``) and Kendall's W, then
    :func:`pairwise_wilcoxon` (adjusted by ``p_adjust``) with each pair's rank-biserial correlation.

    Returns
    -------
    (dict, dict)
        ``participant_level``: ``test, aggregate, statistic, p, n_participants,
        dropped_participants, note`` (and with more than two conditions ``pairwise_test``,
        ``p_adjust`` and ``pairs``: a list of ``a, b, statistic, p, p_unadjusted``);
        ``effect_size``: ``name, value`` (and ``a, b`` for two conditions; ``pairs``, a list of
        ``a, b, name, value``, for more).
    """
    wide, dropped = participant_summaries(data, metric, conditions, participant=participant,
                                          condition=condition, aggregate=aggregate)
    notes = []
    if dropped:
        notes.append(f"{len(dropped)} participant(s) without a value in every condition dropped: "
                     f"{', '.join(map(str, dropped))}")
    n = len(wide)
    statistic = p = effect = math.nan
    two = len(conditions) == 2
    if two:
        a, b = wide[conditions[0]].to_numpy(), wide[conditions[1]].to_numpy()
        effect = rank_biserial(a, b)
        if n == 0:
            notes.append("no participant has values in both conditions")
        elif np.all(a == b):
            notes.append("every participant's difference is zero; the test is undefined")
        else:
            result = scipy.stats.wilcoxon(a, b)
            statistic, p = float(result.statistic), float(result.pvalue)
    else:
        if n < 2:
            notes.append("fewer than two participants have values in every condition")
        else:
            with warnings.catch_warnings(), np.errstate(invalid="ignore", divide="ignore"):
                warnings.simplefilter("ignore", RuntimeWarning)
                result = scipy.stats.friedmanchisquare(*(wide[c].to_numpy() for c in conditions))
            statistic, p = float(result.statistic), float(result.pvalue)
            if not np.isfinite(statistic):
                notes.append("every participant ranks the conditions equally; the test is undefined")
            effect = kendalls_w(statistic, n, len(conditions))
    level = {
        "test": "wilcoxon" if two else "friedman",
        "aggregate": aggregate,
        "statistic": statistic,
        "p": p,
        "n_participants": n,
        "dropped_participants": dropped,
        "note": "; ".join(notes) if notes else None,
    }
    if two:
        effect_size = {"name": "rank_biserial", "value": effect, "a": conditions[0], "b": conditions[1]}
        return level, effect_size
    effect_size = {"name": "kendall_w", "value": effect}
    if len(conditions) > 2:
        posthoc = _wilcoxon_pairs(wide, conditions, p_adjust)
        level.update({
            "pairwise_test": "wilcoxon",
            "p_adjust": p_adjust,
            "pairs": [{"a": r["a"], "b": r["b"], "statistic": r["statistic"], "p": r["p"],
                       "p_unadjusted": r["p_unadjusted"]} for r in posthoc.to_dict("records")],
        })
        effect_size["pairs"] = [{"a": r["a"], "b": r["b"], "name": "rank_biserial",
                                 "value": r["rank_biserial"]} for r in posthoc.to_dict("records")]
    return level, effect_size


def _block_size(n_values: int, n_participants: int) -> int:
    """Values per block of :func:`_weighted_medians`: balances the (R x P) @ (P x B) count product
    against the (R x block) search inside one block (about ``sqrt(n P / 768)``, at least 64; the
    constant measured on 2 cores for 50 to 10 000 participants)."""
    return max(64, math.isqrt(max(1, n_values * max(1, n_participants) // 768)))


def _weighted_medians(values: np.ndarray, owners: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Medians of ``values`` replicated ``weights[r, owners]`` times, for every resample ``r``.

    Definition: resample ``r`` is the multiset holding each value ``weights[r, owner]`` times
    (participant ``p`` drawn ``k`` times brings all its values ``k`` times); its median is its
    element of rank ``(N - 1) // 2`` when ``N`` is odd and the mean of the elements of ranks
    ``N // 2 - 1`` and ``N // 2`` when even (``np.median`` of the replicated values; ``N`` the
    resample's size).

    Computed without replicating: the sorted values are cut into blocks; a matrix product of
    the weights with each participant's cumulative count per block gives every resample's
    cumulative size at each block end, which locates the block holding each wanted rank; a
    cumulative sum of the weights inside that block locates the element. Cost about
    ``R (P B + 2 n / B)`` instead of ``R n``. When the values take fewer distinct values than
    there would be blocks (counts, booleans, rounded measurements), each distinct value is a
    block and the block is the answer: cost ``R P U`` for ``U`` distinct values.

    Parameters
    ----------
    values
        ``(n,)`` sorted values.
    owners
        ``(n,)`` participant index (0 .. P - 1) of each value.
    weights
        ``(R, P)`` how many times each participant is in resample ``r`` (non-negative integers).

    Returns
    -------
    np.ndarray
        ``(R,)`` the medians; NaN where the resample holds no value.
    """
    n_resamples, n_participants = weights.shape
    result = np.full(n_resamples, np.nan)
    n = values.size
    if n == 0:
        return result
    block = min(n, _block_size(n, n_participants))
    n_blocks = -(-n // block)
    new_value = np.r_[True, values[1:] != values[:-1]]
    distinct: np.ndarray | None = None
    if np.count_nonzero(new_value) <= n_blocks:  # one block per distinct value
        distinct = values[new_value]
        n_blocks = distinct.size
        block_of = np.cumsum(new_value) - 1
    else:
        block_of = np.arange(n) // block
    del new_value
    counts = np.bincount(owners * n_blocks + block_of, minlength=n_participants * n_blocks)
    cumulative = np.cumsum(counts.reshape(n_participants, n_blocks), axis=1).astype(np.float64)
    del counts, block_of
    chunk = max(1, _BOOTSTRAP_CHUNK_CELLS // max(block, n_blocks))
    offsets = np.arange(block)
    for start in range(0, n_resamples, chunk):
        w = weights[start:start + chunk]
        rows = np.arange(w.shape[0])
        ends = w.astype(np.float64) @ cumulative  # (r, B): resample size up to each block's end
        total = ends[:, -1].astype(np.int64)
        picked = []
        for rank in ((total - 1) // 2, total // 2):
            rank = np.maximum(rank, 0)
            b = np.minimum((ends <= rank[:, None]).sum(axis=1), n_blocks - 1)
            if distinct is not None:
                picked.append(distinct[b])
                continue
            before = np.where(b > 0, ends[rows, np.maximum(b - 1, 0)], 0.0).astype(np.int64)
            index = b[:, None] * block + offsets[None, :]  # (r, block) positions in the block
            inside = index < n
            gathered = np.where(inside, w[rows[:, None], owners[np.minimum(index, n - 1)]], 0)
            within = (np.cumsum(gathered, axis=1) <= (rank - before)[:, None]).sum(axis=1)
            picked.append(values[np.minimum(b * block + within, n - 1)])
        medians = (picked[0] + picked[1]) / 2.0
        result[start:start + chunk] = np.where(total > 0, medians, np.nan)
    return result


def bootstrap_median_differences(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                                 resamples: int = 2000, level: float = 0.95, seed: int = 0,
                                 participant: str = "participant",
                                 condition: str = "condition") -> pd.DataFrame:
    """Cluster-bootstrap percentile intervals of ``median(a) - median(b)`` for every pair.

    The medians are over trials. Each resample draws the participants (those with a value of
    the metric) with replacement, and takes all their trials, so the nesting of trials in
    participants is kept. The draws: ``rng = np.random.default_rng(seed)``, then
    ``rng.integers(0, P, size=(resamples, P))`` (row ``r`` lists resample ``r``'s participants,
    as codes in order of first appearance in the table); each resample's median is
    ``np.median`` of its replicated trials (:func:`_weighted_medians` computes it without
    replicating). Resamples in which a condition has no trial are left out.

    Returns
    -------
    pd.DataFrame
        One row per pair: ``a, b, difference`` (observed), ``low, high``, ``valid_resamples``.
    """
    tidy = _tidy(data, metric, conditions, condition, participant)
    codes, uniques = pd.factorize(tidy["participant"])
    n_participants = len(uniques)
    rows = []
    medians: dict[str, np.ndarray] = {}
    observed: dict[str, float] = {}
    if n_participants:
        rng = np.random.default_rng(seed)
        draws = rng.integers(0, n_participants, size=(resamples, n_participants))
        flat = (np.arange(resamples)[:, None] * n_participants + draws).ravel()
        weights = np.bincount(flat, minlength=resamples * n_participants).reshape(resamples, n_participants)
        for c in conditions:
            mask = (tidy["condition"] == c).to_numpy()
            values = tidy["value"].to_numpy()[mask]
            owners = codes[mask]
            order = np.argsort(values)  # ties in any order: the medians are values
            medians[c] = _weighted_medians(values[order], owners[order], weights)
            observed[c] = float(np.median(values)) if values.size else math.nan
    tail = (1.0 - level) / 2.0
    for a, b in pairs(conditions):
        low = high = difference = math.nan
        valid = 0
        if n_participants:
            differences = medians[a] - medians[b]
            differences = differences[np.isfinite(differences)]
            valid = int(differences.size)
            difference = observed[a] - observed[b]
            if valid:
                low, high = (float(q) for q in np.quantile(differences, [tail, 1.0 - tail]))
        rows.append({"a": a, "b": b, "difference": difference, "low": low, "high": high,
                     "valid_resamples": valid})
    return pd.DataFrame(rows, columns=["a", "b", "difference", "low", "high", "valid_resamples"])


def analyze_metric(data: pd.DataFrame, metric: str, conditions: Sequence[str],
                   options: ComparisonOptions = ComparisonOptions(), *,
                   participant: str = "participant", condition: str = "condition") -> dict[str, Any]:
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

    Returns
    -------
    dict
        ``metric, n, mean, median, q1, q3`` (each ``{condition: value}``), ``kruskal``,
        ``conover`` (list of ``a, b, p, p_unadjusted``), ``p_adjust``, ``stars`` (list of
        ``a, b, stars``), ``participant_level``, ``effect_size``, ``ci``.
    """
    table = describe(data, metric, conditions, condition=condition).set_index("condition")
    descriptives = {column: {c: _plain(table.loc[c, column]) for c in conditions}
                    for column in ("n", "mean", "median", "q1", "q3")}
    if len(conditions) < 2:
        return _descriptive_entry(metric, descriptives, options)
    kruskal = kruskal_wallis(data, metric, conditions, condition=condition)
    posthoc = conover(data, metric, conditions, p_adjust=options.p_adjust, condition=condition)
    significant = is_significant(kruskal["p"], options.kruskal_alpha, options.star_comparison)
    stars = [{"a": row.a, "b": row.b,
              "stars": significance_stars(row.p, options.star_thresholds, options.star_comparison)
              if significant else ""} for row in posthoc.itertuples()]
    level, effect = participant_level_test(data, metric, conditions, participant=participant,
                                           condition=condition, aggregate=options.participant_aggregate,
                                           p_adjust=options.p_adjust)
    if len(conditions) > 2:  # (with two, the pair's rank-biserial r says it; stats.json stays as it was)
        effect["kruskal_epsilon_squared"] = epsilon_squared(kruskal["statistic"],
                                                            sum(int(v) for v in descriptives["n"].values()))
    intervals = bootstrap_median_differences(
        data, metric, conditions, resamples=options.bootstrap_resamples, level=options.bootstrap_level,
        seed=options.seed, participant=participant, condition=condition)
    return {
        "metric": metric,
        **descriptives,
        "kruskal": kruskal,
        "conover": posthoc.to_dict("records"),
        "p_adjust": options.p_adjust,
        "stars": stars,
        "participant_level": level,
        "effect_size": effect,
        "ci": {
            "method": "cluster bootstrap over participants, percentile interval of the difference "
                      "of trial medians (a - b)",
            "level": options.bootstrap_level,
            "resamples": options.bootstrap_resamples,
            "seed": options.seed,
            "pairs": intervals.to_dict("records"),
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
        "participant_level": {"test": "none", "aggregate": options.participant_aggregate,
                              "statistic": math.nan, "p": math.nan, "n_participants": 0,
                              "dropped_participants": [], "note": SINGLE_CONDITION_NOTE},
        "effect_size": {"name": "none", "value": math.nan},
        "ci": {"method": "none", "level": options.bootstrap_level, "resamples": 0, "seed": options.seed,
               "pairs": []},
    }


def compare_conditions(data: pd.DataFrame, metrics: Sequence[str], conditions: Sequence[str],
                       options: ComparisonOptions = ComparisonOptions(), *,
                       participant: str = "participant", condition: str = "condition") -> dict[str, Any]:
    """The ``stats.json`` document: every metric's statistics.

    With a single condition every metric gets its descriptive statistics only (no test, no
    interval; the participant-level ``note`` says so).

    Returns
    -------
    dict
        ``{"conditions": [...], "metrics": [analyze_metric(...) for each metric]}``. Values are
        plain Python (NaN stays float NaN; :func:`json_ready` turns it into ``None``).
    """
    return {
        "conditions": list(conditions),
        "metrics": [analyze_metric(data, m, conditions, options, participant=participant,
                                   condition=condition) for m in metrics],
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


def stats_table(stats: dict[str, Any]) -> pd.DataFrame:
    """``stats.json`` as a tidy table: one row per metric x pair of conditions.

    The one reader of ``stats.json``'s ``metrics`` for the formatters (the printed table,
    ``summary.md``, ``stats.csv``) and the replication summaries: they take this table.

    Returns
    -------
    pd.DataFrame
        Columns :data:`STATS_CSV_COLUMNS`, then ``mean_a, mean_b, participant_note, ci_seed,
        ci_resamples``, then with more than two conditions :data:`K_CONDITION_CSV_COLUMNS` (the
        ``participant_*`` and ``effect_size*`` columns stay the omnibus Friedman test and Kendall's
        W; ``pairwise_*`` are the pair's Wilcoxon test and rank-biserial r). With a single
        condition, one row per metric with ``b`` ``None`` and only ``metric, a, b, n_a, median_a,
        q1_a, q3_a, participant_test, ci_level, mean_a, participant_note, ci_seed, ci_resamples``.
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
                **extra,
                **(_pairwise_columns(entry, a, b) if many else {}),
            })
    return pd.DataFrame(rows)


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


def _plain(value: Any) -> Any:
    """A numpy scalar as the Python scalar (for JSON)."""
    return value.item() if hasattr(value, "item") else value


def json_ready(value: Any) -> Any:
    """A copy of ``value`` with numpy scalars made plain and NaN/inf made ``None`` (JSON null)."""
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    value = _plain(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
