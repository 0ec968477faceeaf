"""Kruskal-Wallis and Conover's post-hoc test on arrays: the numbers ``scipy.stats.kruskal`` and
``scikit_posthocs.posthoc_conover`` give, bit for bit, in a few hundred microseconds a metric.

Both tests rank all values together (average ranks for ties) and compare the groups' rank sums.
The libraries spend their time around that arithmetic (pandas sorting and grouping in
scikit-posthocs, the array-API and nan-policy layers in scipy); here the ranks come from one
stable ``argsort`` and the rank sums from one ``bincount``, and then the libraries' own formulas
are evaluated with the same operations on values of the same types, in the same order:

- ``scipy.stats.kruskal`` (scipy 1.17, ``scipy/stats/_stats_py.py``, ``kruskal``):
  ``H = 12 / (N (N + 1)) * sum_i R_i^2 / n_i - 3 (N + 1)``, divided by the tie correction
  ``1 - sum_t (t^3 - t) / (N^3 - N)``; ``p = chdtrc(k - 1, H)`` (its ``_SimpleChi2.sf``);
- ``scikit_posthocs.posthoc_conover`` (0.17, ``scikit_posthocs/_posthocs.py``,
  ``posthoc_conover``, called with ``sort=False``): with the tie-corrected ``H_c`` and
  ``S^2 = (sum r^2 - N (N + 1)^2 / 4) / (N - 1)`` (``N (N + 1) / 12`` without ties),
  ``t_ab = |Rbar_a - Rbar_b| / sqrt(S^2 (1/n_a + 1/n_b) (N - 1 - H_c) / (N - k))`` and
  ``p_ab = 2 stdtr(N - k, -t_ab)`` (``scipy.stats.t.sf``), the groups in order of first
  appearance.

Why the results are the same bits: ranks are half-integers, their squares quarter-integers and
the tie terms ``t^3 - t`` integers, so while ``N`` is at most :data:`MAX_EXACT_OBSERVATIONS` every
sum of them is exact in float64, whatever order or algorithm adds them (pairwise in numpy,
Kahan in pandas' groupby, sequential in ``bincount``). Everything after the sums is the
libraries' expression, operation for operation, on the same values (an array where they use
an array, a numpy or Python scalar where they do), so every IEEE-rounded step rounds the same
way; the transcendental functions are scipy.special's scalar ``chdtrc`` and ``stdtr``, the ones
scipy calls. The one vectorised power, ``t**3`` of the tie counts (numpy may evaluate it with a
SIMD ``pow`` that is not libm's), is checked against the exact integer cubes. Where one of
these guarantees does not hold (more values, a value that is not finite, a cube that is not
exact) the functions return ``None`` and the caller runs the libraries
(:func:`nudgecli.report.stats.kruskal_wallis`, :func:`nudgecli.report.stats.conover`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: The most values for which every sum of ranks, squared ranks and tie terms is exact in float64
#: (sum of t^3 - t <= N^3 < 2^53; sum of squared ranks about N^3 / 3 < 2^51, the limit for
#: quarter-integers; the rank sums far below 2^52): beyond it, the libraries' own summation order
#: would decide the last bit, and the libraries are called.
MAX_EXACT_OBSERVATIONS = 100_000


def average_ranks(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ranks ``1..N`` of the values, ties sharing the average of their ranks, and the ties' sizes.

    Parameters
    ----------
    values
        ``(N,)`` finite numbers.

    Returns
    -------
    ranks
        ``(N,)`` float, in the values' order (``scipy.stats.rankdata(values)``, exactly: each is a
        half-integer).
    tie_counts
        ``(U,)`` int, how many values share each distinct value, in increasing order of value.
    """
    order = np.argsort(values, kind="stable")
    ordered = values[order]
    starts = np.flatnonzero(np.concatenate(([True], ordered[1:] != ordered[:-1])))
    counts = np.diff(np.append(starts, values.size))
    # the run at 0-based position s with c members holds ranks s+1..s+c: their mean is exact
    run_ranks = (starts + 1) + (counts - 1) / 2.0
    ranks = np.empty(values.size, dtype=float)
    ranks[order] = np.repeat(run_ranks, counts)
    return ranks, counts


def condition_mean_ranks(values: np.ndarray, positions: np.ndarray, n_conditions: int) -> np.ndarray:
    """Each condition's mean rank among all the values (average ranks for ties): what
    Kruskal-Wallis and Conover's test compare, so the sign of a pair's difference is the direction
    a significant result of theirs has.

    Parameters
    ----------
    values
        ``(N,)`` finite numbers: every compared condition's values.
    positions
        ``(N,)`` int, each value's condition, ``0 <= position < n_conditions``.
    n_conditions
        ``k``, the number of conditions.

    Returns
    -------
    np.ndarray
        ``(k,)`` float, NaN for a condition without values. The rank sums are exact (half-integers
        far below 2^53 for any table that fits in memory), so each mean is the correctly rounded
        quotient whatever the order of the values.
    """
    values = np.asarray(values, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.intp)
    counts = np.bincount(positions, minlength=n_conditions)
    means = np.full(n_conditions, np.nan)
    if values.size:
        sums = np.bincount(positions, weights=average_ranks(values)[0], minlength=n_conditions)
        present = counts > 0
        means[present] = sums[present] / counts[present]
    return means


def _exact_ties(counts: np.ndarray) -> np.ndarray | None:
    """``t**3 - t`` of the tie counts as float64 (as scipy computes it), or None where the
    vectorised power is not the exact integer cube (then the sums could differ from scipy's)."""
    as_float = counts.astype(np.float64)
    cubes = _float_cubes(as_float)
    if not np.array_equal(cubes, (counts.astype(np.int64) ** 3).astype(np.float64)):
        return None
    return cubes - as_float


def _float_cubes(values: np.ndarray) -> np.ndarray:
    """``values**3`` as scipy evaluates its tie counts' cubes: numpy's vectorised power of a float
    array (its own function, so that a test can stand in for a power that misses a bit)."""
    return values**3


def _exact_possible(values: np.ndarray) -> bool:
    return values.size <= MAX_EXACT_OBSERVATIONS and bool(np.isfinite(values).all())


def kruskal_exact(groups: Sequence[np.ndarray]) -> tuple[float, float] | None:
    """Kruskal-Wallis H (tie-corrected) and its p, as ``scipy.stats.kruskal(*groups)`` gives them.

    Parameters
    ----------
    groups
        At least two ``(n_i,)`` float arrays, none empty, not all values equal.

    Returns
    -------
    tuple of float or None
        ``(H, p)``; None where the exact evaluation is not guaranteed (see the module's note):
        call scipy then.
    """
    values = np.concatenate([np.asarray(g, dtype=np.float64) for g in groups])
    if len(groups) < 2 or not _exact_possible(values):
        return None
    ranks, counts = average_ranks(values)
    ties_terms = _exact_ties(counts)
    if ties_terms is None:
        return None
    sizes = [int(np.asarray(g).size) for g in groups]
    total = sum(sizes)  # a Python int, as scipy's
    codes = np.repeat(np.arange(len(groups)), sizes)
    rank_sums = np.bincount(codes, weights=ranks, minlength=len(groups))  # exact: half-integers
    # scipy: ties = 1 - xp.sum(t**3 - t) / (totaln**3 - totaln) over a float64 array
    ties = 1 - np.sum(ties_terms) / (total**3 - total)
    # scipy: sum(xp.sum(ranked[slice])**2 / n[i] ...): numpy float64 scalars, a Python sum from 0
    ssbn = sum(rank_sums[i] ** 2 / sizes[i] for i in range(len(groups)))
    h = 12.0 / (total * (total + 1)) * ssbn - 3 * (total + 1)
    h /= ties
    from scipy.special import chdtrc  # scipy's _SimpleChi2.sf

    p = chdtrc(np.asarray(len(groups) - 1, dtype=np.float64), h)
    return float(h), float(p)


def conover_exact(values: np.ndarray, labels: np.ndarray) -> tuple[list[object], np.ndarray] | None:
    """Conover's unadjusted pairwise p-values, as ``scikit_posthocs.posthoc_conover(frame,
    val_col=..., group_col=..., sort=False)`` gives them.

    Parameters
    ----------
    values
        ``(N,)`` float, without missing values.
    labels
        ``(N,)`` the group of each value.

    Returns
    -------
    tuple or None
        The groups in order of first appearance (the library's row and column order) and the
        ``(k, k)`` symmetric matrix of p-values with ones on the diagonal; None where the exact
        evaluation is not guaranteed (see the module's note): call scikit-posthocs then.
    """
    values = np.asarray(values, dtype=np.float64)
    if not _exact_possible(values):
        return None
    present, first, codes = np.unique(labels, return_index=True, return_inverse=True)
    appearance = np.argsort(first, kind="stable")
    position = np.empty_like(appearance)
    position[appearance] = np.arange(appearance.size)
    codes = position[np.ravel(codes)]  # group codes in order of first appearance
    groups = [present[i] for i in appearance]
    n = int(values.size)
    k = len(groups)
    if k < 2 or n <= k:  # the t statistic has n - k degrees of freedom
        return None
    ranks, counts = average_ranks(values)
    group_lens = np.bincount(codes, minlength=k).astype(np.int64)
    rank_sums = np.bincount(codes, weights=ranks, minlength=k)  # exact, as pandas' Kahan sums
    rank_means = rank_sums / group_lens
    tie_sum = int(np.sum(counts.astype(np.int64) ** 3 - counts))  # integers, as pandas' value_counts
    x_ties = np.min([1.0, 1.0 - tie_sum / (n**3.0 - n)])
    h = (12.0 / (n * (n + 1.0))) * np.sum(rank_sums**2 / group_lens) - 3.0 * (n + 1.0)
    h_cor = h / x_ties
    if x_ties == 1:
        s2 = n * (n + 1.0) / 12.0
    else:
        squares = float(np.sum(ranks**2.0))  # exact: quarter-integers below 2^51
        s2 = (1.0 / (n - 1.0)) * (squares - (n * (((n + 1.0) ** 2.0) / 4.0)))
    upper = np.triu_indices(k, 1)
    diff = np.abs(rank_means[upper[0]] - rank_means[upper[1]])
    b = 1.0 / group_lens[upper[0]] + 1.0 / group_lens[upper[1]]
    d = (n - 1.0 - h_cor) / (n - k)
    with np.errstate(invalid="ignore", divide="ignore"):  # an undefined t is NaN there too
        t_values = diff / np.sqrt(s2 * b * d)
    from scipy.special import stdtr  # scipy.stats.t.sf(x, df) is stdtr(df, -x)

    matrix = np.zeros((k, k))
    matrix[upper] = 2.0 * _t_sf(np.abs(t_values), float(n - k), stdtr)
    lower = np.tril_indices(k, -1)
    matrix[lower] = np.transpose(matrix)[lower]
    np.fill_diagonal(matrix, 1)
    return groups, matrix


def _t_sf(x: np.ndarray, df: float, stdtr: object) -> np.ndarray:
    """``scipy.stats.t.sf(x, df)`` for ``x >= 0``: ``stdtr(df, -x)`` inside the support, 0 at
    ``+inf`` and NaN for NaN (what ``rv_continuous.sf`` places there)."""
    out = np.zeros(x.shape)
    finite = np.isfinite(x)
    out[np.isnan(x)] = np.nan
    out[finite] = stdtr(df, -x[finite])  # type: ignore[operator]
    return out
