"""A plan's filters leave the caller's metrics table as it was (the analysis works on its own table)."""

from __future__ import annotations

import pandas as pd

from nudgecli.report.plan_filters import apply_plan_filters
from nudgecli.report.plans import AnalysisPlan


def _table() -> pd.DataFrame:
    """Four trials of conditions a and b; ``condition`` a category that also names an unused c."""
    return pd.DataFrame({"participant": [1, 1, 2, 2],
                         "condition": pd.Categorical(["a", "b", "a", "b"], categories=["a", "b", "c"]),
                         "value": [1.0, 2.0, 3.0, 4.0]})


def test_no_filter_on_its_columns_leaves_the_callers_table_as_it_was() -> None:
    table = _table()
    result = apply_plan_filters(table, AnalysisPlan(filters={"other": 1.0}), ["value"], changed=False)
    assert list(result.table["condition"].cat.categories) == ["a", "b"]
    assert list(table["condition"].cat.categories) == ["a", "b", "c"]  # the caller's column untouched
    pd.testing.assert_frame_equal(table, _table())


def test_a_plain_text_condition_stays_text_in_the_callers_table() -> None:
    table = _table().assign(condition=["a", "b", "a", "b"])
    result = apply_plan_filters(table, AnalysisPlan(), ["value"], changed=False)
    assert result.table["condition"].dtype == "category"
    assert table["condition"].dtype != "category"
    assert not result.changed and result.line is None
