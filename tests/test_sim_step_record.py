"""A step log's coded columns (sim/step_record.py): the distinct codes without a sort are
``np.unique``'s, and every code's value is the value of its code."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.sim import step_record
from nudgecli.sim.step_record import mapped_codes


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), size=st.integers(0, 5000), low=st.integers(-3000, 3000),
       span=st.integers(1, 30000), dtype=st.sampled_from([np.int64, np.int32, np.uint16]))
def test_the_distinct_codes_are_np_uniques(seed: int, size: int, low: int, span: int, dtype: type) -> None:
    # spans short and long beside the number of codes: the table over the range, or the sort
    if np.dtype(dtype).kind == "u":
        low = abs(low)
    codes = np.random.default_rng(seed).integers(low, low + span, size=size).astype(dtype)
    distinct, position = step_record._distinct_codes(codes)
    expected_distinct, expected_position = np.unique(codes, return_inverse=True)
    assert distinct.dtype == expected_distinct.dtype and distinct.tolist() == expected_distinct.tolist()
    assert position.shape == (size,) and position.tolist() == expected_position.reshape(-1).tolist()


@pytest.mark.parametrize("size", [5, 3000])
def test_each_code_gets_its_value_asked_once_in_increasing_order(size: int) -> None:
    codes = np.random.default_rng(7).choice([-1, 0, 2, 5, 6], size=size)
    asked: list[int] = []

    def label(code: int) -> str:
        asked.append(code)
        return f"code {code}"

    values = mapped_codes(codes, label)
    assert values.tolist() == [f"code {code}" for code in codes.tolist()]
    assert asked == sorted(set(codes.tolist()))
    pairs = mapped_codes(codes, lambda code: (code, 2 * code), np.int64)
    assert pairs.dtype == np.int64 and pairs.tolist() == [[code, 2 * code] for code in codes.tolist()]
