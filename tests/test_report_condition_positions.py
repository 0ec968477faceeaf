"""condition_positions: ``positions == j`` is ``labels == conditions[j]``, for a categorical column
(its codes mapped through its categories) and for plain labels alike."""

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.report.stats import condition_positions

NAMES = ["control", "disambiguation", "blend", "x", "10"]


@settings(max_examples=60, deadline=None)
@given(labels=st.lists(st.sampled_from([*NAMES, None]), max_size=40),
       conditions=st.lists(st.sampled_from(NAMES), min_size=1, max_size=4, unique=True),
       categorical=st.booleans(), extra_category=st.booleans())
def test_positions_are_the_label_comparisons(labels, conditions, categorical, extra_category):
    values = np.array(labels, dtype=object)
    if categorical:
        categories = sorted({v for v in labels if v is not None} | ({"unused"} if extra_category else set()))
        series = pd.Series(pd.Categorical(values, categories=categories))
    else:
        series = pd.Series(values, dtype=object)
    positions = condition_positions(series, conditions)
    assert positions.shape == (len(labels),)
    for j, name in enumerate(conditions):
        np.testing.assert_array_equal(positions == j, values == name)
    np.testing.assert_array_equal(positions == -1, ~np.isin(values, np.array(conditions, dtype=object)))
