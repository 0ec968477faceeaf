"""belief_matrix stacks a run's belief arrays at once: the same (T, G) matrix as reading every
cell on its own (lists, JSON text, arrays of other types or lengths, missing cells)."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.errors import DataError
from nudgecli.report.trial_steps import belief_matrix

FLOATS = st.floats(min_value=0.0, max_value=1.0, allow_nan=False, width=64)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 5).flatmap(lambda g: st.lists(st.lists(FLOATS, min_size=g, max_size=g), min_size=1,
                                                    max_size=20)),
       st.sampled_from([None, "own", "other"]))
def test_stacked_arrays_are_the_matrix_of_the_cells_read_one_by_one(rows, goals):
    n_goals = None if goals is None else len(rows[0]) + (goals == "other")
    arrays = pd.DataFrame({"belief": [np.array(row, dtype=np.float64) for row in rows]})
    lists = pd.DataFrame({"belief": rows})  # read cell by cell
    if goals == "other":
        with pytest.raises(DataError, match="belief vectors of length"):
            belief_matrix(arrays, n_goals)
        with pytest.raises(DataError, match="belief vectors of length"):
            belief_matrix(lists, n_goals)
        return
    stacked = belief_matrix(arrays, n_goals)
    assert stacked.dtype == np.float64 and stacked.shape == (len(rows), len(rows[0]))
    np.testing.assert_array_equal(stacked, belief_matrix(lists, n_goals))


def test_cells_of_other_kinds_are_read_one_by_one():
    steps = pd.DataFrame({"belief": [np.array([0.5, 0.5]), "[0.25, 0.75]", None, np.array([1, 0]),
                                     np.array([], dtype=float)]})
    expected = [[0.5, 0.5], [0.25, 0.75], [np.nan, np.nan], [1.0, 0.0], [np.nan, np.nan]]
    np.testing.assert_array_equal(belief_matrix(steps), expected)
