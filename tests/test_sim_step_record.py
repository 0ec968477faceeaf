"""A step log's coded columns (sim/step_record.py): the distinct codes without a sort are
``np.unique``'s, and every code's value is the value of its code."""

from __future__ import annotations

from collections.abc import Collection

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


def hand_rows() -> list[tuple]:
    """Three raw steps (:data:`step_record.ROW_FIELDS`), one command an array as hindsight's are."""
    belief = np.array([0.5, 0.25, 0.25])
    return [
        (0, "human", 1.5, 2.0, 0.0, 0, 7, 2, -0.25, 2, (0.1, 0.0, -0.2), (0.0, 0.0, 0.0), 0.0, -1, belief,
         1.04, ("trial_start",)),
        (1, "human", 1.6, 2.0, 0.1, 0, 7, 2, -0.3, 4, np.array([0.2, 0.0, 0.0]), (0.05, 0.0, 0.0), 0.5, 1,
         belief, 1.04, ()),
        (2, "robot", 1.7, 2.5, 0.2, 1, 9, -1, 0.0, -1, (0.0, 0.0, 0.0), (0.0, 0.3, 0.0), 1.0, 1, belief, 0.9,
         ["goal_reached", "trial_end"]),
    ]


@pytest.mark.parametrize("names", [step_record.STEP_COLUMNS, ("x", "event", "u_a_y"), {"phi_m", "belief"},
                                   ()])
def test_a_recording_keeps_the_wanted_fields_of_its_rows_value_for_value(names: Collection[str]) -> None:
    rows = hand_rows()
    recording = step_record.StepRecording.of_rows(rows, 3, 1, 0.1, lambda state: (0, 0, 0), names)
    kept = {"step"} | {field for name in names for field in step_record._COLUMN_FIELDS[name]}
    assert list(recording.fields) == [field for field in step_record.ROW_FIELDS if field in kept]
    by_field = dict(zip(step_record.ROW_FIELDS, zip(*rows, strict=True), strict=True))
    for field, values in recording.fields.items():
        if field == "events":  # each step's event cell
            assert values == ("trial_start", "", "goal_reached|trial_end")
        elif field in ("u_h", "u_a"):  # (3N,) each command's components in turn
            assert values.dtype == np.float64
            assert values.tolist() == [float(v) for command in by_field[field] for v in command]
        elif field in ("turn", "belief"):
            assert values == by_field[field]
        else:
            assert isinstance(values, np.ndarray) and values.dtype == step_record._FIELD_DTYPES[field]
            assert values.tolist() == list(by_field[field])
    assert len(recording) == 3
    empty = step_record.StepRecording.of_rows([], 3, 1, 0.1, lambda state: (0, 0, 0), names)
    assert len(empty) == 0 and list(empty.fields) == list(recording.fields)
