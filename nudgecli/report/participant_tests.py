"""The participant-level tests of a metric and their effect sizes (trials are nested in participants).

Each participant's trials are summarised per condition (median by default); participants missing
a condition are dropped with a note. Two conditions: Wilcoxon signed-rank and the matched-pairs
rank-biserial correlation of ``a - b``. More: Friedman and Kendall's W, then Wilcoxon signed-rank
for every pair (adjusted as the Conover p-values) with each pair's rank-biserial correlation.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
import pandas as pd

from nudgecli.report.metric_rows import MetricRows, TidyRows, rows_for
from nudgecli.report.rank_tests import average_ranks
from nudgecli.report.stats import adjust_p_values, compared_participants, pairs, python_scalar

# scipy.stats (about 0.5 s of CPU to import) is imported only where scipy's own function runs (an
# unchecked scipy release, differences that are not all finite or all zero, the Friedman test):
# importing this module, and the stats document's, costs nothing, and a two-condition analysis
# never imports it

#: ``scipy.stats.wilcoxon``'s default (``method="auto"``) runs an exact sign-flip permutation test
#: when the differences hold zeros or ties and there are at most this many of them (since scipy
#: 1.15, gh-21567; pyproject.toml requires it, and a test holds the two together on the installed one).
SIGN_FLIP_MAX_N = 13

#: The scipy releases whose ``scipy.stats.wilcoxon`` the fast paths of :func:`signed_rank_test`
#: were checked against, source and numbers; on any other release scipy's own function runs.
#: Compared in the Python sources of these releases (scipy/scipy at git revisions e29dcb65,
#: b9105ccc and 527eb7fd, as their wheels ship them): ``scipy/stats/_wilcoxon.py``
#: (``_wilcoxon_iv``: the normal approximation above 50 differences; ``_wilcoxon_statistic``:
#: ``R+``, ``R-``, ``m``, ``s``, the tie correction, ``se`` and ``z``; ``_wilcoxon_nd``: the exact
#: test without zeros or ties, the sign-flip permutation test up to 13 differences with them,
#: ``p = 2 min(sf, cdf)`` clipped; ``WilcoxonDistribution``), ``_hypotests._get_wilcoxon_distr``,
#: ``_stats_py._rankdata`` (average ranks, tie counts in sorted order), ``_get_pvalue`` and
#: ``_SimpleNormal``, ``_morestats.wilcoxon``'s defaults and ``_resampling.PermutationMethod``'s.
#: The same operations in the same order on the same values in all three: 1.15 and 1.16 call
#: numpy where 1.17 goes through the array API, keep the count of differences and the tie counts
#: as integers where 1.17 casts them to float64 (whole numbers far below 2**53: exact either way),
#: and sort in ``_rankdata`` with quicksort where 1.17 sorts stably (the average ranks and the
#: tie counts' sorted layout do not depend on it). The bit-for-bit tests of
#: :func:`signed_rank_test` against ``scipy.stats.wilcoxon`` (tests/test_report_stats.py,
#: tests/test_report_metric_once.py) passed on each of these releases (1.15.3, 1.16.3, 1.17.1).
#: 1.18.1 (Python 3.12 only; compared with 1.17.1 by the functions' sources, 2026-11-29): the same
#: arithmetic on a numpy array. ``_rankdata`` takes its float dtype from ``xp_result_type`` (float64
#: for average ranks, as before) and also returns the sorted data, the count of differences is
#: ``_count_nonmasked`` less the NaN count cast first (whole numbers, exact either way), and the
#: rest is JAX, CuPy and MArray branches and docs; the bit-for-bit tests above passed on it.
#: The fast paths run on every release of these series: a patch release that changed the
#: arithmetic would fail those tests, which run with whatever scipy is installed, rather than
#: leave every later patch release on the slow path.
CHECKED_SCIPY_VERSIONS = ("1.15", "1.16", "1.17", "1.18")


def installed_scipy_version() -> str:
    """The installed scipy's release series, ``major.minor`` of ``scipy.__version__`` (``"1.17"``)."""
    import scipy

    return ".".join(str(scipy.__version__).split(".")[:2])


def sign_flip_rank_sums(d: np.ndarray) -> np.ndarray:
    """Wilcoxon's ``R+`` of every sign flip of the differences ``d``.

    Flip ``k`` negates ``d[i]`` where bit ``i`` of ``k`` is set (flip 0 is ``d``, the last ``-d``).
    ``R+`` is the sum of the average ranks of the nonzero ``|d|`` (zeros dropped, as
    ``zero_method="wilcox"`` does; NaN omitted, as ``scipy.stats.rankdata(..., nan_policy="omit")``
    omits them) over the flip's positive differences; no flip changes a magnitude, so the ranks are
    made once.

    Parameters
    ----------
    d
        ``(n,)`` paired differences.

    Returns
    -------
    np.ndarray
        ``(2^n,)``; every partial sum is a multiple of 0.5 below ``n (n + 1) / 2``, so it is exact in
        any order of addition.
    """
    ranks = np.zeros(d.size)
    ranked = (d != 0) & ~np.isnan(d)
    ranks[ranked] = average_ranks(np.abs(d[ranked]))[0]
    flips = ((np.arange(2 ** d.size)[:, None] >> np.arange(d.size)) & 1).astype(bool)  # (2^n, n)
    return np.where(np.where(flips, -d, d) > 0, ranks, 0.0).sum(axis=-1)


def wilcoxon_null_probabilities(n: int) -> np.ndarray:
    """``(n (n + 1) / 2 + 1,)`` the null distribution of ``R+`` for ``n`` differences without zeros or
    ties: ``P(R+ = r)``, ``r = 0 ... n (n + 1) / 2``.

    ``R+ = sum_k k B_k`` with independent fair ``B_k``: each rank ``k`` in turn halves the
    distribution so far and adds it again shifted by ``k`` (the recursion of scipy's
    ``scipy.stats._hypotests._get_wilcoxon_distr``, which :func:`signed_rank_test` matches: every
    value is a count over ``2^n`` with the count below ``2^53``, so each sum is exact).
    """
    probabilities = np.ones(1)
    for rank in range(1, n + 1):
        half = probabilities * 0.5
        probabilities = np.zeros(rank * (rank + 1) // 2 + 1)
        probabilities[:half.size] = half
        probabilities[rank:] += half
    return probabilities


def signed_rank_test(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``scipy.stats.wilcoxon(x, y)``'s statistic and p-value, computed here on arrays.

    With zeros or ties among at most :data:`SIGN_FLIP_MAX_N` differences, scipy's default runs an
    exact permutation test (all ``2^n`` sign flips) with a statistic it evaluates one flip at a time
    (60-70 ms a call); here ``R+`` of all flips is one array operation
    (:func:`_sign_flip_signed_rank_test`): the same null distribution and comparisons, so the same
    p-value. Without zeros or ties among at most :data:`EXACT_MAX_N` differences, scipy's exact test
    (:func:`_exact_signed_rank_test`), and for the rest its normal approximation
    (:func:`_normal_signed_rank_test`). None of them imports ``scipy.stats``. Differences that are
    not all finite, or all zero, go to ``scipy.stats.wilcoxon`` itself, and so does everything on a
    scipy release series whose source was not checked (:data:`CHECKED_SCIPY_VERSIONS`).

    Parameters
    ----------
    x, y
        ``(n,)`` paired samples.

    Returns
    -------
    (float, float)
        ``min(R+, R-)`` and the two-sided p-value, bit for bit what ``scipy.stats.wilcoxon`` returns
        (a test holds the two together).
    """
    if installed_scipy_version() not in CHECKED_SCIPY_VERSIONS:  # its arithmetic may differ
        return _scipy_signed_rank_test(x, y)
    d = np.asarray(x, dtype=float) - np.asarray(y, dtype=float)
    nonzero = np.abs(d[d != 0])
    has_zeros_or_ties = nonzero.size < d.size or np.unique(nonzero).size < nonzero.size
    if nonzero.size > 0 and d.size <= SIGN_FLIP_MAX_N and has_zeros_or_ties and not np.isnan(d).any():
        return _sign_flip_signed_rank_test(d)
    if 0 < d.size <= EXACT_MAX_N and not has_zeros_or_ties and np.isfinite(d).all():
        return _exact_signed_rank_test(d)
    if nonzero.size > 0 and (d.size > EXACT_MAX_N or has_zeros_or_ties) and np.isfinite(d).all():
        return _normal_signed_rank_test(d)  # (n > 13 here when there are zeros or ties)
    return _scipy_signed_rank_test(x, y)


def _scipy_signed_rank_test(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``scipy.stats.wilcoxon(x, y)`` itself (about 0.5 s of CPU to import scipy.stats the first time)."""
    import scipy.stats

    result = scipy.stats.wilcoxon(x, y)
    return float(result.statistic), float(result.pvalue)


#: The relative tolerance of ``scipy.stats.permutation_test``'s comparisons with the observed
#: statistic: 100 machine epsilons of float64 (``_resampling.permutation_test``'s ``eps``).
PERMUTATION_TOLERANCE = float(np.finfo(np.float64).eps) * 100


def _sign_flip_signed_rank_test(d: np.ndarray) -> tuple[float, float]:
    """``scipy.stats.wilcoxon``'s exact sign-flip test of differences with zeros or ties (at most
    :data:`SIGN_FLIP_MAX_N` of them).

    What scipy computes (:data:`CHECKED_SCIPY_VERSIONS`; ``_wilcoxon_nd``'s
    ``PermutationMethod()`` and ``_resampling.permutation_test`` with ``permutation_type="samples"``
    on one sample): the null distribution is ``R+`` of every one of the ``2^n`` sign flips of
    ``d`` (a multiset: its order does not matter to the counts below); with ``gamma = |100 eps
    R+(d)|``, ``less`` and ``greater`` are the counts of flips with ``R+ <= R+(d) + gamma`` and
    ``R+ >= R+(d) - gamma`` over ``2^n``, and ``p = 2 min(less, greater)`` clipped to ``[0, 1]``.
    The null distribution is :func:`sign_flip_rank_sums`, whose first flip is ``d`` itself and
    last ``-d`` (``R-``). A test holds it to ``scipy.stats.wilcoxon`` bit for bit.

    Parameters
    ----------
    d
        ``(n,)`` differences without NaN, not all zero, ``n <=`` :data:`SIGN_FLIP_MAX_N`.

    Returns
    -------
    (float, float)
        ``min(R+, R-)`` and the p-value.
    """
    null = sign_flip_rank_sums(d)
    observed, r_minus = float(null[0]), float(null[-1])
    gamma = abs(PERMUTATION_TOLERANCE * observed)
    total = float(null.size)
    less = np.count_nonzero(null <= observed + gamma) / total
    greater = np.count_nonzero(null >= observed - gamma) / total
    return min(observed, r_minus), float(np.clip(min(less, greater) * 2, 0.0, 1.0))


#: ``scipy.stats.wilcoxon``'s default runs its exact test (the null distribution of ``R+``) when
#: the differences hold neither zeros nor ties and there are at most this many of them.
EXACT_MAX_N = 50


def _exact_signed_rank_test(d: np.ndarray) -> tuple[float, float]:
    """``scipy.stats.wilcoxon``'s exact two-sided test of differences without zeros or ties.

    What scipy computes (:data:`CHECKED_SCIPY_VERSIONS`; ``scipy/stats/_wilcoxon.py``,
    ``_wilcoxon_nd`` with ``method="exact"`` and ``WilcoxonDistribution``), operation for operation:
    ``R+`` and ``R-``, sums of the integer ranks of ``|d|`` (exact); the null probabilities of
    ``R+`` (:func:`wilcoxon_null_probabilities`, scipy's ``_get_wilcoxon_distr(n)``); ``sf(k)``
    the sum of those from ``k`` up and ``cdf(k)`` of those up to ``k`` (each ``1 -`` the other
    side's sum when ``k`` exceeds the mean ``n (n + 1) / 4``), summed by numpy over the same
    slices; ``p = 2 min(sf, cdf)`` clipped to ``[0, 1]``. A test holds it to
    ``scipy.stats.wilcoxon`` bit for bit.

    Parameters
    ----------
    d
        ``(n,)`` finite differences, none zero, no two of equal magnitude, ``1 <= n <=``
        :data:`EXACT_MAX_N`.

    Returns
    -------
    (float, float)
        ``min(R+, R-)`` and the p-value.
    """
    ranks, _ = average_ranks(np.abs(d))  # 1..n: integers, every sum below exact
    r_plus, r_minus = float(np.sum(ranks[d > 0])), float(np.sum(ranks[d < 0]))
    n = int(d.size)
    probabilities = wilcoxon_null_probabilities(n)
    mean = n * (n + 1) / 4
    k = int(r_plus)  # an integer: scipy's floor (for sf) and ceil (for cdf) of it are k itself
    sf = probabilities[k:].sum() if k <= mean else 1 - probabilities[:k].sum()
    cdf = probabilities[:k + 1].sum() if k <= mean else 1 - probabilities[k + 1:].sum()
    p = np.clip(2 * np.minimum(sf, cdf), 0, 1)
    return min(r_plus, r_minus), float(p)


def _normal_signed_rank_test(d: np.ndarray) -> tuple[float, float]:
    """``scipy.stats.wilcoxon``'s two-sided normal approximation (no continuity correction), for
    more than :data:`EXACT_MAX_N` differences or zeros or ties among more than
    :data:`SIGN_FLIP_MAX_N`.

    What scipy computes (:data:`CHECKED_SCIPY_VERSIONS`; ``scipy/stats/_wilcoxon.py``,
    ``_wilcoxon_statistic`` and ``_wilcoxon_nd`` with ``zero_method="wilcox"``;
    ``_stats_py._rankdata`` and ``_get_pvalue``), operation for operation on values of the same
    types: zeros dropped (scipy ranks them last, as NaN, and adds nothing of them), ``R+``, ``R-``
    sums of the average ranks (half-integers: exact); ``m = c (c + 1) 0.25`` and ``s = c (c + 1) (2
    c + 1)`` of the ``c`` nonzero differences; the tie counts laid out as scipy lays them (each
    run's size at the run's first place in sorted order, zeros elsewhere, one per dropped zero after
    them), ``T = sum(t**3 - t)`` over that same array (numpy's power and pairwise sum on the same
    layout, so the same bits); ``se = sqrt((s - T / 2) / 24)``, ``z = (R+ - m) / se``, ``p = 2
    ndtr(-|z|)``. A test holds it to ``scipy.stats.wilcoxon`` bit for bit.

    Parameters
    ----------
    d
        ``(n,)`` finite differences, not all zero.

    Returns
    -------
    (float, float)
        ``min(R+, R-)`` and the p-value.
    """
    from scipy.special import ndtr  # scipy's _SimpleNormal.sf(x) is ndtr(-x)

    nonzero = d[d != 0]
    count = np.float64(nonzero.size)
    ranks, tie_counts = average_ranks(np.abs(nonzero))
    r_plus, r_minus = np.sum(ranks[nonzero > 0]), np.sum(ranks[nonzero < 0])
    ties = np.zeros(d.size)  # scipy's layout: runs of the sorted |d| first, the dropped zeros last
    ties[np.r_[0, np.cumsum(tie_counts)[:-1]]] = tie_counts
    ties[nonzero.size:] = 1.0
    mean = count * (count + 1.) * 0.25
    spread = count * (count + 1.) * (2. * count + 1.)
    se = np.sqrt((spread - np.sum(ties**3 - ties) / 2) / 24)
    z = (r_plus - mean) / se
    return float(min(r_plus, r_minus)), float(2 * ndtr(-np.abs(z)))


def participant_summaries(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                          participant: str = "participant", condition: str = "condition",
                          aggregate: Literal["median", "mean"] = "median",
                          tidy: TidyRows | None = None,
                          roster: pd.DataFrame | None = None) -> tuple[pd.DataFrame, list[Any]]:
    """Per-participant medians (or means) per condition, complete participants only.

    Parameters
    ----------
    tidy
        :func:`~nudgecli.report.stats.tidy_values` of the arguments with the participants (or its
        :class:`~nudgecli.report.metric_rows.MetricRows`), when the caller holds it (every test of
        a metric reads the same rows); ``data`` is then read for its participants only
        (:func:`~nudgecli.report.stats.compared_participants`).
    roster
        The table whose participants (of these conditions) are the study's, when not ``data``'s:
        the trials, for questionnaire scores a participant may not have answered at all.

    Returns
    -------
    (pd.DataFrame, list)
        A wide table (index participant, one column per condition in the given order) of the
        participants with a value in every condition, and the participants dropped because
        they miss a condition: every participant of ``data``'s rows of these conditions without
        a value in one of them (its rows there missing, or their values all blank), sorted.
    """
    rows = rows_for(data, metric, conditions, condition, participant, tidy)
    table, who, complete, dropped = _complete(rows, aggregate, data, roster, condition, participant)
    wide = pd.DataFrame(table[complete], index=_labels(rows, who)[complete],
                        columns=pd.Index(list(conditions), name="condition"))
    return wide, dropped


def _complete(rows: MetricRows, aggregate: str, data: pd.DataFrame, roster: pd.DataFrame | None,
              condition: str, participant: str) -> tuple[np.ndarray, np.ndarray | pd.Index, np.ndarray, list]:
    """:func:`_summaries` of the rows, which of them are complete (``(P,)`` bool: a value in every
    condition) and the participants dropped (:func:`_dropped`)."""
    table, who = _summaries(rows, aggregate)
    complete = ~np.isnan(table).any(axis=1)
    dropped = _dropped(rows, who, complete, data if roster is None else roster, condition, participant,
                       roster is not None)
    return table, who, complete, dropped


def _summaries(rows: MetricRows, aggregate: str) -> tuple[np.ndarray, np.ndarray | pd.Index]:
    """``(P, k)`` each participant's summary per condition (NaN where it has no value there), the
    participants sorted, and who they are: their codes (:attr:`MetricRows.participant_codes`'),
    or their labels where pandas grouped them (means: pandas' compensated sums; categorical
    participants; no rows; a value -0.0)."""
    medians = _median_array(rows) if aggregate == "median" else None
    if medians is not None:
        return medians
    grouped = rows.table().groupby(["participant", "condition"], observed=True)["value"]
    wide = grouped.agg(aggregate).unstack("condition").reindex(columns=list(rows.conditions))
    return wide.to_numpy(dtype=float), wide.index


def _labels(rows: MetricRows, who: np.ndarray | pd.Index) -> pd.Index:
    """The participants ``who`` (:func:`_summaries`') as labels."""
    if isinstance(who, pd.Index):
        return who
    assert rows.participant_labels is not None
    return pd.Index(rows.participant_labels.take(who), name="participant")


def _dropped(rows: MetricRows, who: np.ndarray | pd.Index, complete: np.ndarray, table: pd.DataFrame,
             condition: str, participant: str, roster: bool) -> list[Any]:
    """The participants of ``table``'s rows of the conditions that are not among the complete
    ones (``who[complete]``), sorted as ``pd.Index.difference`` sorts them; without a roster and
    with codes, the usual "none dropped" is found on the codes alone."""
    # from the table's participants, not the rows': one without any value of a condition has no
    # row of it, and is dropped as surely as one missing the condition's rows
    everyone_codes = None if roster or isinstance(who, pd.Index) else rows.everyone()
    if everyone_codes is not None and np.isin(everyone_codes, who[complete]).all():
        return []
    everyone = compared_participants(table, rows.conditions, condition, participant)
    return [python_scalar(p) for p in everyone.difference(_labels(rows, who)[complete])]


def _median_array(rows: MetricRows) -> tuple[np.ndarray, np.ndarray] | None:
    """Per-participant medians per condition from one sort, as pandas' grouping gives them.

    pandas' grouped median (``group_median_float64``) takes the group's middle value, or
    ``(upper + lower) / 2`` of its two middle values; here the rows are sorted by group and value
    (``np.lexsort``) and the same values are picked, and added and halved the same way: the same
    bits. The participants are sorted as the grouping sorts them (their codes are those of
    ``pd.factorize(sort=True)``).

    Returns
    -------
    (np.ndarray, np.ndarray) or None
        ``(P, k)`` medians, NaN where a participant has no value of a condition, and the ``(P,)``
        sorted codes of the participants with a value. None for participants without codes
        (categorical), no rows, or a value -0.0 (the caller groups with pandas then).
    """
    values, codes = rows.values, rows.participant_codes
    # pandas' selection may return either zero of a group holding -0.0 and 0.0: let it choose
    if codes is None or values.size == 0 or np.any((values == 0) & np.signbit(values)):
        return None
    k = len(rows.conditions)
    positions = rows.positions
    keep = (codes >= 0) & (positions >= 0)  # a missing participant: left out, as pandas' grouping
    if not keep.all():  # (the usual rows need no copy)
        values, codes, positions = values[keep], codes[keep], positions[keep]
    # the participants with a value, sorted, and each row's place among them (as np.unique's
    # inverse, from a count per participant: no sorted copy of a large table's codes)
    present = np.bincount(codes) > 0 if codes.size else np.zeros(0, dtype=bool)
    who = np.flatnonzero(present)
    place = np.cumsum(present) - 1
    keys = place[codes] * k + positions
    order = np.lexsort((values, keys))  # by group, then by value
    ordered, ordered_keys = values[order], keys[order]
    starts = np.flatnonzero(np.r_[True, ordered_keys[1:] != ordered_keys[:-1]])
    sizes = np.diff(np.r_[starts, ordered.size])
    lower, upper = ordered[starts + (sizes - 1) // 2], ordered[starts + sizes // 2]
    with np.errstate(invalid="ignore", over="ignore"):  # NaN and inf as pandas' (silent) median
        medians = np.where(sizes % 2 == 1, lower, (upper + lower) / 2)
    table = np.full((who.size, k), np.nan)
    group_keys = ordered_keys[starts]
    table[group_keys // k, group_keys % k] = medians
    return table, who


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
    if np.isnan(difference).any():  # (scipy.stats.rankdata propagates NaN: so does r)
        return math.nan
    # scipy.stats.rankdata's average ranks: half-integers, so every sum below is exact
    ranks, _ = average_ranks(np.abs(difference))
    return float((ranks[difference > 0].sum() - ranks[difference < 0].sum()) / ranks.sum())


def kendalls_w(friedman_statistic: float, n_participants: int, n_conditions: int) -> float:
    """Kendall's coefficient of concordance from Friedman's chi-square: ``W = chi2 / (n (k - 1))``."""
    if n_participants < 1 or n_conditions < 2:
        return math.nan
    return float(friedman_statistic / (n_participants * (n_conditions - 1)))


#: Columns of :func:`pairwise_wilcoxon`'s table.
PAIRWISE_COLUMNS = ("a", "b", "n_participants", "statistic", "p", "p_unadjusted", "rank_biserial")


def _wilcoxon_pair_rows(columns: Sequence[np.ndarray], conditions: Sequence[str],
                        p_adjust: str) -> list[dict[str, Any]]:
    """:func:`pairwise_wilcoxon`'s rows as plain dicts (keys :data:`PAIRWISE_COLUMNS`, Python
    scalars) of the complete participants' summaries, ``columns[j]`` those of ``conditions[j]``:
    what the stats document holds, without a table made and read back."""
    rows = []
    column = dict(zip(conditions, columns, strict=True))
    for a, b in pairs(conditions):
        x, y = column[a], column[b]
        statistic = p = math.nan
        if x.size and not np.all(x == y):  # all differences zero: Wilcoxon is undefined
            statistic, p = signed_rank_test(x, y)
        rows.append({"a": a, "b": b, "n_participants": int(x.size), "statistic": statistic,
                     "p_unadjusted": p, "rank_biserial": rank_biserial(x, y)})
    adjusted = adjust_p_values(np.array([r["p_unadjusted"] for r in rows], dtype=float), p_adjust)
    return [{**{k: r[k] for k in ("a", "b", "n_participants", "statistic")}, "p": float(p),
             "p_unadjusted": r["p_unadjusted"], "rank_biserial": r["rank_biserial"]}
            for r, p in zip(rows, adjusted, strict=True)]


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
        The conditions, in order; the pairs are :func:`~nudgecli.report.stats.pairs` of them.
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
    columns = [wide[c].to_numpy(dtype=float) for c in conditions]
    return pd.DataFrame(_wilcoxon_pair_rows(columns, conditions, p_adjust), columns=list(PAIRWISE_COLUMNS))


def participant_level_test(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                           participant: str = "participant", condition: str = "condition",
                           aggregate: Literal["median", "mean"] = "median", p_adjust: str = "holm",
                           tidy: TidyRows | None = None,
                           roster: pd.DataFrame | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """The paired test on per-participant summaries and its effect size.

    Two conditions: Wilcoxon signed-rank (``scipy.stats.wilcoxon``, defaults: zero differences
    dropped, exact p for small samples) and the matched-pairs rank-biserial correlation of
    ``a - b``. More: Friedman (``scipy.stats.friedmanchisquare``) and Kendall's W, then
    :func:`pairwise_wilcoxon` (adjusted by ``p_adjust``) with each pair's rank-biserial correlation.
    ``tidy``, ``roster``: as :func:`participant_summaries`'.

    Returns
    -------
    (dict, dict)
        ``participant_level``: ``test, aggregate, statistic, p, n_participants,
        dropped_participants, note`` (and with more than two conditions ``pairwise_test``,
        ``p_adjust`` and ``pairs``: a list of ``a, b, statistic, p, p_unadjusted``);
        ``effect_size``: ``name, value`` (and ``a, b`` for two conditions; ``pairs``, a list of
        ``a, b, name, value``, for more).
    """
    rows = rows_for(data, metric, conditions, condition, participant, tidy)
    table, _, complete, dropped = _complete(rows, aggregate, data, roster, condition, participant)
    # each condition's column of the complete participants (contiguous, as a table's column was)
    columns = [np.ascontiguousarray(column) for column in table[complete].T]
    notes = []
    if dropped:
        notes.append(f"{len(dropped)} participant(s) without a value in every condition dropped: "
                     f"{', '.join(map(str, dropped))}")
    n = int(np.count_nonzero(complete))
    statistic = p = effect = math.nan
    two = len(conditions) == 2
    if two:
        a, b = columns
        effect = rank_biserial(a, b)
        if n == 0:
            notes.append("no participant has values in both conditions")
        elif np.all(a == b):
            notes.append("every participant's difference is zero; the test is undefined")
        else:
            statistic, p = signed_rank_test(a, b)
    else:
        if n < 2:
            notes.append("fewer than two participants have values in every condition")
        else:
            import scipy.stats

            with warnings.catch_warnings(), np.errstate(invalid="ignore", divide="ignore"):
                warnings.simplefilter("ignore", RuntimeWarning)
                result = scipy.stats.friedmanchisquare(*columns)
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
        posthoc = _wilcoxon_pair_rows(columns, conditions, p_adjust)
        level.update({
            "pairwise_test": "wilcoxon",
            "p_adjust": p_adjust,
            "pairs": [{"a": r["a"], "b": r["b"], "statistic": r["statistic"], "p": r["p"],
                       "p_unadjusted": r["p_unadjusted"]} for r in posthoc],
        })
        effect_size["pairs"] = [{"a": r["a"], "b": r["b"], "name": "rank_biserial",
                                 "value": r["rank_biserial"]} for r in posthoc]
    return level, effect_size
