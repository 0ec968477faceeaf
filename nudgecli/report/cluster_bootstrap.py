"""The cluster-bootstrap percentile interval of the difference of two conditions' trial medians.

Whole participants (with all their trials) are resampled with replacement, so the nesting of
trials in participants is kept; ``rng = np.random.default_rng(seed)``, the same resamples for every
metric. Each resample's median is computed without replicating the trials
(:func:`_weighted_medians`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.report.metric_rows import MetricRows, TidyRows, rows_for
from nudgecli.report.stats import pairs

#: Largest number of (resample x trial) cells the bootstrap holds in memory at once.
_BOOTSTRAP_CHUNK_CELLS = 1_000_000


def _block_size(n_values: int, n_participants: int) -> int:
    """Values per block of :func:`_weighted_medians`: balances the (R x P) @ (P x B) count product
    against the (R x block) search inside one block (about ``sqrt(n P / 768)``, at least 64; the
    constant measured on 2 cores for 50 to 10 000 participants)."""
    return max(64, math.isqrt(max(1, n_values * max(1, n_participants) // 768)))


#: Relative cost, per resample, of one cell of the (R x P) @ (P x B) count product (BLAS), of one
#: cell of a pass over an (R x B) table, and of one cell of the search inside a block (a gather of
#: weights, a cumulative sum, a comparison and a count), in units of the pass; estimated from
#: timings of both ways on 2 cores (2026-11-28), 200 to 50 000 values of 9 to 1000 participants.
#: Only the speed depends on them: both ways give the same medians.
_PRODUCT_CELL, _PASS_CELL, _SEARCH_CELL = 0.1, 3.0, 24.0


def _one_block_per_value(n_distinct: int, n_blocks: int, block: int, n_participants: int) -> bool:
    """Whether :func:`_weighted_medians` makes each distinct value a block (no search inside a
    block) rather than cutting the values into ``n_blocks`` blocks of ``block``: the cheaper of
    ``U (P c_product + c_pass)`` and ``B (P c_product + c_pass) + c_search block`` a resample."""
    per_block = n_participants * _PRODUCT_CELL + _PASS_CELL
    return n_distinct * per_block <= n_blocks * per_block + _SEARCH_CELL * block


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
    ``R (P B + 2 n / B)`` instead of ``R n``. When the values take few distinct values
    (counts, booleans, rounded measurements, or a study's few hundred trials:
    :func:`_one_block_per_value`), each distinct value is a block and the block is the answer:
    cost ``R P U`` for ``U`` distinct values. Every count is an integer below 2^53, exact in
    float64, and the result is ``(low + high) / 2.0`` of the two picked values, as ``np.median``
    computes it: the same bits whichever blocks are used.

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
    n_distinct = int(np.count_nonzero(new_value))
    if _one_block_per_value(n_distinct, n_blocks, block, n_participants):
        distinct = values[new_value]
        n_blocks = n_distinct
        block_of = np.cumsum(new_value) - 1
    else:
        block_of = np.arange(n) // block
    del new_value
    counts = np.bincount(owners * n_blocks + block_of, minlength=n_participants * n_blocks)
    cumulative = np.cumsum(counts.reshape(n_participants, n_blocks), axis=1).astype(np.float64)
    del counts, block_of
    # the owners block by block; past the last value any owner: the cumulative weight there is at
    # least the block's total, above every wanted rank, so those places are never counted
    owner_blocks = np.empty((0, block), dtype=np.intp)
    if distinct is None:
        padded = np.zeros(n_blocks * block, dtype=np.intp)
        padded[:n] = owners
        owner_blocks = padded.reshape(n_blocks, block)
    chunk = max(1, _BOOTSTRAP_CHUNK_CELLS // max(block, n_blocks))
    for start in range(0, n_resamples, chunk):
        w = weights[start:start + chunk]
        ends = _count_product(w, cumulative)  # (r, B): resample size up to each block's end
        total = ends[:, -1].astype(np.int64)
        picked = [_pick(values, distinct, owner_blocks, w, ends, np.maximum(rank, 0))
                  for rank in ((total - 1) // 2, total // 2)]
        medians = (picked[0] + picked[1]) / 2.0
        result[start:start + chunk] = np.where(total > 0, medians, np.nan)
    return result


#: OpenBLAS runs a matrix product of ``M N K`` multiply-adds on one thread below ``65536 x 4`` of
#: them (``interface/gemm.c``: ``SMP_THRESHOLD_MIN`` times ``GEMM_MULTITHREAD_THRESHOLD``).
_ONE_THREAD_PRODUCT_CELLS = 65536 * 4


def _count_product(weights: np.ndarray, cumulative: np.ndarray) -> np.ndarray:
    """``weights @ cumulative`` in float64, in row slices small enough for one BLAS thread (where
    such a slice holds at least 64 rows).

    In a batch the analysis runs in the parent while the workers hold every core: a threaded
    product then waits for busy cores (about 8 ms instead of 0.1 ms for 2000 x 9 x 193, measured
    on 2 cores, 2026-11-28). Every entry is a sum of products of integers below 2^53, exact in
    float64, so how the product is cut does not change a bit.

    Parameters
    ----------
    weights
        ``(r, P)`` non-negative integer weights.
    cumulative
        ``(P, B)`` float64 cumulative counts.

    Returns
    -------
    np.ndarray
        ``(r, B)`` float64.
    """
    out = np.empty((weights.shape[0], cumulative.shape[1]))
    rows = (_ONE_THREAD_PRODUCT_CELLS - 1) // max(1, cumulative.size)
    if rows < 64:  # a large study's (P x B): one product, threaded (slices of a few rows cost more)
        rows = max(1, weights.shape[0])
    for start in range(0, weights.shape[0], rows):
        np.matmul(weights[start:start + rows].astype(np.float64), cumulative, out=out[start:start + rows])
    return out


def _pick(values: np.ndarray, distinct: np.ndarray | None, owner_blocks: np.ndarray, weights: np.ndarray,
          ends: np.ndarray, rank: np.ndarray) -> np.ndarray:
    """The element of rank ``rank[r]`` (0-based) of each resample of :func:`_weighted_medians`.

    Parameters
    ----------
    values
        ``(n,)`` sorted values.
    distinct
        ``(B,)`` the distinct values when each is a block, else None.
    owner_blocks
        ``(B, block)`` the owner of each value block by block (any owner past the last value);
        unused when ``distinct`` is given.
    weights
        ``(r, P)`` the chunk's weights.
    ends
        ``(r, B)`` each resample's size up to each block's end.
    rank
        ``(r,)`` the wanted ranks.

    Returns
    -------
    np.ndarray
        ``(r,)`` the values of those ranks.
    """
    n_blocks = ends.shape[1]
    b = np.minimum((ends <= rank[:, None]).sum(axis=1), n_blocks - 1)  # the block holding the rank
    if distinct is not None:
        return distinct[b]
    rows = np.arange(ends.shape[0])
    before = np.where(b > 0, ends[rows, np.maximum(b - 1, 0)], 0.0).astype(np.int64)
    # one gather from the flat weights (cheaper than indexing rows and columns)
    flat = np.ascontiguousarray(weights).ravel()
    gathered = flat[(rows * weights.shape[1])[:, None] + owner_blocks[b]]  # (r, block)
    within = (np.cumsum(gathered, axis=1) <= (rank - before)[:, None]).sum(axis=1)
    return values[np.minimum(b * owner_blocks.shape[1] + within, values.size - 1)]


def bootstrap_median_differences(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                                 resamples: int = 2000, level: float = 0.95, seed: int = 0,
                                 participant: str = "participant", condition: str = "condition",
                                 tidy: TidyRows | None = None) -> pd.DataFrame:
    """Cluster-bootstrap percentile intervals of ``median(a) - median(b)`` for every pair.

    The medians are over trials. Each resample draws the participants (those with a value of
    the metric) with replacement, and takes all their trials, so the nesting of trials in
    participants is kept. The draws: ``rng = np.random.default_rng(seed)``, then
    ``rng.integers(0, P, size=(resamples, P))`` (row ``r`` lists resample ``r``'s participants,
    as codes in order of first appearance in the table); each resample's median is
    ``np.median`` of its replicated trials (:func:`_weighted_medians` computes it without
    replicating). Resamples in which a condition has no trial are left out. A trial without a
    participant (a missing participant cell) belongs to no one who could be drawn: it is in no
    resample, as it is in no participant's median of the participant-level test, but in the
    observed ``difference`` (the trial medians' difference, as the descriptives). ``tidy``:
    :func:`~nudgecli.report.stats.tidy_values` of the arguments with the participants, when the
    caller holds it (``data`` is then not read).

    Returns
    -------
    pd.DataFrame
        One row per pair: ``a, b, difference`` (observed), ``low, high``, ``valid_resamples``.
    """
    rows = median_difference_intervals(data, metric, conditions, resamples=resamples, level=level, seed=seed,
                                       participant=participant, condition=condition, tidy=tidy)
    return pd.DataFrame(rows, columns=["a", "b", "difference", "low", "high", "valid_resamples"])


def median_difference_intervals(data: pd.DataFrame, metric: str, conditions: Sequence[str], *,
                                resamples: int = 2000, level: float = 0.95, seed: int = 0,
                                participant: str = "participant", condition: str = "condition",
                                tidy: TidyRows | None = None) -> list[dict[str, Any]]:
    """:func:`bootstrap_median_differences`' rows as plain dicts (Python floats and ints): what
    the ``stats.json`` document holds, without a table made and read back."""
    rows_read = rows_for(data, metric, conditions, condition, participant, tidy)
    codes, n_participants = _participants_in_order(rows_read)
    positions, all_values = rows_read.positions, rows_read.values
    drawn = codes >= 0  # a trial without a participant (code -1) is drawn with no one
    rows = []
    medians: dict[str, np.ndarray] = {}
    observed: dict[str, float] = {}
    if n_participants:
        rng = np.random.default_rng(seed)
        draws = rng.integers(0, n_participants, size=(resamples, n_participants))
        flat = (np.arange(resamples)[:, None] * n_participants + draws).ravel()
        weights = np.bincount(flat, minlength=resamples * n_participants).reshape(resamples, n_participants)
        for j, c in enumerate(conditions):
            mask = positions == j
            observed[c] = float(np.median(all_values[mask])) if mask.any() else math.nan
            mask &= drawn
            values = all_values[mask]
            owners = codes[mask]
            order = np.argsort(values)  # ties in any order: the medians are values
            medians[c] = _weighted_medians(values[order], owners[order], weights)
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
    return rows


def _participants_in_order(rows: MetricRows) -> tuple[np.ndarray, int]:
    """Each row's participant as a code in order of first appearance among the rows (what
    ``pd.factorize`` of the rows' participants gives: the bootstrap's draws name participants by
    these codes; -1 for a missing participant), and how many participants there are."""
    if rows.participant_codes is None or (rows.participant_codes < 0).any():  # categorical, missing
        codes, uniques = pd.factorize(rows.table()["participant"])
        return codes, len(uniques)
    codes = rows.participant_codes
    in_order = pd.unique(codes)  # the codes in order of first appearance (hashed: no sorted copy)
    rank = np.zeros(int(codes.max()) + 1 if codes.size else 0, dtype=np.intp)
    rank[in_order] = np.arange(in_order.size)
    return rank[codes], int(in_order.size)
