"""The step log's event cells (``nudgecli.steplog``): counting an event per row."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from hypothesis import given
from hypothesis import strategies as st

from nudgecli.steplog import (
    EVENT_SEPARATOR,
    STEP_COLUMNS,
    STEP_NUMERIC_DTYPES,
    count_event,
    has_event,
    join_events,
    step_arrays,
    steps_frame,
)

NAMES = ("mode_switch_human", "nudge", "trial_start", "mode_switch")


def brute_force_count(cell: object, name: str) -> int:
    """The count read the long way: split the one cell, strip each token, compare."""
    if not isinstance(cell, str):
        return 0
    return sum(1 for token in cell.split(EVENT_SEPARATOR) if token.strip() == name)


cells = st.one_of(
    st.lists(st.sampled_from((*NAMES, "", " nudge ")), max_size=4).map(join_events),
    st.none(), st.just(math.nan), st.integers(-3, 3))


@given(st.lists(cells, max_size=40), st.sampled_from(NAMES), st.booleans())
def test_count_event_counts_each_row_as_a_brute_force_split_does(values: list[object], name: str,
                                                                 shuffled_index: bool) -> None:
    index = pd.Index(np.arange(len(values))[::-1] * 3) if shuffled_index else None
    series = pd.Series(values, dtype=object, index=index)
    counts = count_event(series, name)
    assert counts.index.equals(series.index)
    assert counts.tolist() == [brute_force_count(v, name) for v in values]
    assert counts.dtype == np.int64
    assert has_event(series, name).tolist() == [brute_force_count(v, name) > 0 for v in values]


def test_count_event_keeps_rows_that_share_an_index_label_apart() -> None:
    # metrics concatenate trials' steps: a repeated label must not merge two rows' counts
    series = pd.Series(["nudge", "nudge|nudge", ""], index=[0, 0, 1], dtype=object)
    assert count_event(series, "nudge").tolist() == [1, 2, 0]


def test_count_event_reads_a_plain_iterable() -> None:
    counts = count_event(iter(["nudge", None, "trial_start|nudge"]), "nudge")
    assert counts.tolist() == [1, 0, 1] and counts.index.equals(pd.RangeIndex(3))


def test_steps_frame_is_the_frame_pandas_infers_from_the_columns() -> None:
    # a step log's columns as the protocol builds them (sim/step_record.py): Python ints, floats,
    # strings and belief lists, typed here independently of STEP_NUMERIC_DTYPES
    ints = {"participant": [3] * 4, "trial": [7] * 4, "step": [0, 1, 2, 3], "cell_x": [1, 1, 2, 2],
            "cell_y": [0, 0, 0, 1], "heading": [0, 0, 1, 1], "inferred_goal": [-1, -1, 2, 2]}
    floats = {name: [0.0, 0.1, -0.25, 1.5] for name in (
        "t", "x", "y", "theta", "pressure", "u_h_x", "u_h_y", "u_h_theta", "u_a_x", "u_a_y", "u_a_theta",
        "alpha", "entropy")}
    text = {"turn": ["human"] * 4, "mode": ["x", "y", "theta", "x"], "phi_i": ["", "Soft Puff", "", ""],
            "phi_m": ["", "Soft Puff", "Soft-Hard Puff Deadband", ""],
            "event": ["trial_start", "", "", "nudge"],
            "belief": [[0.5, 0.5], [0.6, 0.4], [0.7, 0.3], [0.75, 0.25]]}
    columns = {name: {**ints, **floats, **text}[name] for name in STEP_COLUMNS}
    frame = steps_frame(columns)
    pd.testing.assert_frame_equal(frame, pd.DataFrame(columns), check_exact=True)
    assert set(STEP_NUMERIC_DTYPES) == set(ints) | set(floats)
    # the numpy-only half (a worker's): typed arrays for numbers, the text and belief lists as they are
    arrays = step_arrays(columns)
    assert list(arrays) == list(columns)
    for name in ints:
        assert arrays[name].dtype == np.int64 and arrays[name].tolist() == ints[name]
    for name in floats:
        assert arrays[name].dtype == np.float64 and arrays[name].tolist() == floats[name]
    assert all(arrays[name] is columns[name] for name in text)
    # the frame of those arrays is the same frame, and arrays of their dtype are not copied again
    pd.testing.assert_frame_equal(steps_frame(arrays), frame, check_exact=True)
    assert all(again is arrays[name] for name, again in step_arrays(arrays).items())
