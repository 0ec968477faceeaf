"""The one tie-tolerant argmax (nudgecli.model.ties), against hand-worked cases and brute force."""

from __future__ import annotations

import numpy as np
from hypothesis import example, given
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
def test_tied_indices_are_the_array_rules_ties_in_plain_floats(values: list[float]) -> None:
    array = np.array(values, dtype=float)
    assert tied_indices(array) == np.flatnonzero(tied_with_max(array)).tolist()
