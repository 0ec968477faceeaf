"""A step log's text columns as object arrays, each distinct value converted once: the same values
(and types) as converting the whole column."""

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.report.metrics import _text_objects

CONVERSIONS = {"as is": lambda labels: labels, "as text": lambda labels: labels.astype(str),
               "missing as empty": lambda labels: labels.fillna("").astype(str)}


LABELS = ["human", "autonomy", "", "nudge|handover_to_human", None]


@settings(max_examples=60, deadline=None)
@given(values=st.lists(st.sampled_from(LABELS), max_size=30),
       dtype=st.sampled_from(["str", "object"]), conversion=st.sampled_from(sorted(CONVERSIONS)))
def test_text_objects_are_the_whole_columns_conversion(values, dtype, conversion):
    column = pd.Series(values, dtype=dtype)
    convert = CONVERSIONS[conversion]
    expected = convert(column).to_numpy(dtype=object).tolist()
    got = _text_objects(column, convert)
    assert got.dtype == object and got.shape == (len(values),)
    for a, b in zip(got.tolist(), expected, strict=True):
        assert type(a) is type(b)
        assert a == b or (a != a and b != b) or (a is b)  # NaN and pd.NA: the same kind of missing
    assert np.array_equal(pd.isna(got), pd.isna(np.array(expected, dtype=object)))
