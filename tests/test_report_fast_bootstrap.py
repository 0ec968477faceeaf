"""The cluster bootstrap's medians without replicating (``report.cluster_bootstrap``): both ways of
cutting the values into blocks give ``np.median`` of the replicated values bit for bit, and the
count product cut into slices gives the integer product exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.report import cluster_bootstrap as bootstrap_module
from nudgecli.report.cluster_bootstrap import _count_product, _one_block_per_value, _weighted_medians


def _replicated_medians(values: np.ndarray, owners: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The definition: ``np.median`` of each resample's replicated values (NaN when empty)."""
    out = []
    for row in weights:
        replicated = np.repeat(values, row[owners])
        out.append(np.median(replicated) if replicated.size else math.nan)
    return np.array(out)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 9), st.integers(0, 60), st.integers(1, 40),
       st.sampled_from(["ties", "distinct", "two"]), st.booleans(),
       st.integers(1, 9), st.integers(0, 2**32 - 1))
def test_weighted_medians_are_the_replicated_medians_bit_for_bit(participants, n, resamples, kind, per_value,
                                                                  block, seed):
    rng = np.random.default_rng(seed)
    raw = {"ties": rng.integers(0, 6, n).astype(float), "distinct": rng.normal(size=n),
           "two": rng.integers(0, 2, n).astype(float)}[kind]
    values = np.sort(raw)
    owners = rng.integers(0, participants, n)
    weights = rng.integers(0, 3, size=(resamples, participants))
    weights[0] = 0  # an empty resample
    with pytest.MonkeyPatch.context() as patch:
        # either way of cutting, small blocks, small chunks and small product slices
        patch.setattr(bootstrap_module, "_one_block_per_value", lambda *args: per_value)
        patch.setattr(bootstrap_module, "_block_size", lambda n, p: block)
        patch.setattr(bootstrap_module, "_BOOTSTRAP_CHUNK_CELLS", 50)
        fast = _weighted_medians(values, owners, weights)
    assert np.array_equal(fast, _replicated_medians(values, owners, weights), equal_nan=True)


@pytest.mark.parametrize("per_value", [True, False])
def test_weighted_medians_of_a_study_sized_metric(per_value):
    # 216 trials of 9 participants, 2000 resamples drawn as the bootstrap draws them
    rng = np.random.default_rng(11)
    values = np.sort(np.round(rng.gamma(2.0, 10.0, 216), 1))
    owners = rng.integers(0, 9, 216)
    draws = rng.integers(0, 9, size=(2000, 9))
    weights = np.bincount((np.arange(2000)[:, None] * 9 + draws).ravel(), minlength=2000 * 9).reshape(2000, 9)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(bootstrap_module, "_one_block_per_value", lambda *args: per_value)
        fast = _weighted_medians(values, owners, weights)
    assert np.array_equal(fast, _replicated_medians(values, owners, weights))


@pytest.mark.parametrize("cells", [1, 40, 10**9])
def test_count_product_is_the_integer_product_in_any_slices(monkeypatch, cells):
    rng = np.random.default_rng(5)
    weights = rng.integers(0, 4, size=(300, 7))
    cumulative = np.cumsum(rng.integers(0, 5, size=(7, 11)), axis=1).astype(np.float64)
    monkeypatch.setattr(bootstrap_module, "_ONE_THREAD_PRODUCT_CELLS", cells)
    product = _count_product(weights, cumulative)
    assert product.dtype == np.float64
    assert np.array_equal(product, (weights @ cumulative.astype(np.int64)).astype(np.float64))


def test_count_product_slices_below_the_one_thread_size(monkeypatch):
    seen = []
    real = np.matmul

    def recording(a, b, out):
        seen.append(a.shape[0] * b.shape[0] * b.shape[1])
        return real(a, b, out=out)

    monkeypatch.setattr(bootstrap_module.np, "matmul", recording)
    _count_product(np.ones((2000, 9), dtype=np.int64), np.ones((9, 193)))
    assert len(seen) > 1 and max(seen) < bootstrap_module._ONE_THREAD_PRODUCT_CELLS
    seen.clear()
    _count_product(np.ones((2000, 1000), dtype=np.int64), np.ones((1000, 196)))  # a large study: one product
    assert len(seen) == 1


def test_one_block_per_value_for_few_distinct_values_only():
    # a study's metric: 216 trials of 9 participants, blocks of 64
    assert _one_block_per_value(193, 4, 64, 9)
    assert _one_block_per_value(2, 4, 64, 9)
    # 50 000 distinct values of 1000 participants: blocks of 255
    assert not _one_block_per_value(50_000, 197, 255, 1000)
