"""The one tie-tolerant argmax (nudgecli.model.ties), against hand-worked cases and brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from nudgecli.model.ties import first_argmax, tied_indices, tied_with_max, unique_argmax


def test_first_on_ties_within_the_tolerance() -> None:
    assert int(first_argmax(np.array([1.0, 3.0, 3.0, 2.0]))) == 1
    assert int(first_argmax(np.array([1.0, 3.0 - 1e-14, 3.0]))) == 1  # last-bit differences tie
    assert int(first_argmax(np.array([1.0, 2.9, 3.0]))) == 2
    # relative to max(1, |max|): at 1e6 a difference of 1e-4 is a tie, at 1 it is not
    assert int(first_argmax(np.array([1e6 - 1e-4, 1e6]))) == 0
    assert int(first_argmax(np.array([1.0 - 1e-4, 1.0]))) == 1


def test_valid_mask_and_batches() -> None:
    values = np.array([[5.0, 1.0, 5.0], [0.0, 2.0, 2.0]])
    valid = np.array([[False, True, True], [True, True, True]])
    np.testing.assert_array_equal(first_argmax(values, valid=valid), [2, 1])
    np.testing.assert_array_equal(tied_with_max(values, valid=valid),
                                  [[False, False, True], [False, True, True]])


def test_unique_argmax_names_no_index_on_a_tie() -> None:
    assert unique_argmax(np.array([0.4, 0.4, 0.2])) == -1
    assert unique_argmax(np.array([0.2, 0.5, 0.3])) == 1
    assert unique_argmax(np.array([1 / 3, 1 / 3, 1 / 3])) == -1


@given(st.lists(st.integers(-5, 5), min_size=1, max_size=8), st.randoms(use_true_random=False))
def test_matches_brute_force_and_permutes(ints: list[int], random) -> None:
    values = np.array(ints, dtype=float)
    # brute force: the lowest index holding the maximum (integers tie exactly)
    best = max(ints)
    assert int(first_argmax(values)) == ints.index(best)
    expected_unique = ints.index(best) if ints.count(best) == 1 else -1
    assert unique_argmax(values) == expected_unique
    # a rule blind to order: permuting the values permutes the tied set and the unique winner
    order = list(range(len(ints)))
    random.shuffle(order)
    permuted = values[order]
    np.testing.assert_array_equal(tied_with_max(permuted), tied_with_max(values)[order])
    if expected_unique >= 0:
        assert order[unique_argmax(permuted)] == expected_unique


def _unique_by_the_array_rule(values: np.ndarray) -> int:
    tied = tied_with_max(values)
    return int(np.argmax(tied)) if int(tied.sum()) == 1 else -1


near_ties = st.lists(st.sampled_from([0.25, 0.25 + 1e-12, 0.25 + 1e-8, 0.5, 1e9, 1e9 * (1 + 1e-10), -3.0]),
                     min_size=1, max_size=6)
anything = st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=6)


@given(st.one_of(near_ties, anything))
def test_unique_argmax_is_the_array_rule_in_plain_floats(values: list[float]) -> None:
    array = np.array(values, dtype=float)
    assert unique_argmax(array) == _unique_by_the_array_rule(array)


@given(st.one_of(near_ties, anything))
@example([-np.inf, -np.inf, 0.5 - np.inf])  # every value -inf: all tied (the threshold is -inf itself)
@example([np.inf, 1.0])  # an infinite maximum: none (inf - inf is NaN)
@example([-1.7976931348623157e308, 1.0 - 1.7976931348623157e308])  # the threshold overflows to -inf
@pytest.mark.filterwarnings("error")  # that overflow is the rule's, not a fault to warn of
def test_tied_indices_are_the_array_rules_ties_in_plain_floats(values: list[float]) -> None:
    array = np.array(values, dtype=float)
    assert tied_indices(array) == np.flatnonzero(tied_with_max(array)).tolist()


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_columns=st.integers(1, 10), rows=st.integers(1, 60),
       layout=st.sampled_from(["contiguous", "transposed", "batched"]), masked=st.booleans())
def test_rows_by_columns_are_the_rows_one_at_a_time(seed: int, n_columns: int, rows: int, layout: str,
                                                    masked: bool) -> None:
    # short last axes (the maximum taken column by column) and long ones, contiguous or not; values
    # on a coarse grid (exact ties), nudged by last bits or to either side of the tolerance, zeros of
    # both signs, infinities and NaN; every row against Python's max and the tie rule written out
    rng = np.random.default_rng(seed)
    values = rng.integers(-3, 4, size=(rows, n_columns)).astype(float)
    values += rng.choice([0.0, 1e-12, -1e-12, 0.5, -9.5e-10, -1.05e-9], size=values.shape)
    special = rng.random(values.shape)
    values[special < 0.05] = -0.0
    values[(special >= 0.05) & (special < 0.08)] = np.nan
    values[(special >= 0.08) & (special < 0.1)] = -np.inf
    valid = rng.random(values.shape) < 0.8 if masked else None
    if layout == "transposed":  # the last axis strided, as Q-values viewed action-last
        values = np.ascontiguousarray(values.T).T
    elif layout == "batched":
        values = values.reshape(1, rows, n_columns)
        valid = None if valid is None else valid.reshape(values.shape)
    tied = tied_with_max(values, valid=valid)
    first = first_argmax(values, valid=valid)
    flat_values = values.reshape(rows, n_columns)
    flat_valid = np.ones_like(flat_values, dtype=bool) if valid is None else valid.reshape(rows, n_columns)
    for r in range(rows):
        pairs = zip(flat_values[r].tolist(), flat_valid[r].tolist(), strict=True)
        row = [v if ok else -math.inf for v, ok in pairs]
        best = math.nan if any(v != v for v in row) else max(row)
        threshold = best - 1e-9 * max(1.0, abs(best))
        expected = [v >= threshold for v in row]
        assert tied.reshape(rows, n_columns)[r].tolist() == expected
        assert int(first.reshape(rows)[r]) == (expected.index(True) if any(expected) else 0)
