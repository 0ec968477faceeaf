"""Undefined values over replications: a pooled value or sensitivity input never stands on fewer
or other seeds than it says (docs/batches.md)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from nudgecli.report.replication import point_outputs, summarise


def _rows(differences: list[list[float]]) -> pd.DataFrame:
    """Rows of one metric and pair: ``differences[point][replication]``."""
    records = []
    for point, values in enumerate(differences):
        for replication, value in enumerate(values):
            records.append({"point": point, "replication": replication, "seed": replication,
                            "participants": 4, "metric": "completion_time", "a": "x", "b": "y",
                            "trial_significant": False, "trial_direction": 0,
                            "participant_significant": False, "participant_direction": 0,
                            "kruskal_p": 0.5, "conover_p": value * 0 + 0.5, "participant_p": 0.5,
                            "effect_size_name": "rank_biserial", "effect_size": value, "difference": value})
    return pd.DataFrame(records)


def test_the_sensitivity_input_uses_only_replications_defined_at_every_point() -> None:
    # replication 0 is undefined at point 1: every point's Y is replication 1's and 2's mean
    rows = _rows([[10.0, 2.0, 4.0], [math.nan, 6.0, 8.0], [1.0, 3.0, 5.0]])
    outputs = point_outputs(rows)
    assert outputs["y"].tolist() == [3.0, 7.0, 4.0]
    assert outputs["replications"].tolist() == [2, 2, 2]


def test_the_sensitivity_input_is_undefined_where_no_replication_is_defined_everywhere() -> None:
    outputs = point_outputs(_rows([[math.nan, 2.0], [1.0, math.nan]]))
    assert outputs["y"].isna().all() and outputs["replications"].tolist() == [0, 0]


def test_a_pooled_value_is_undefined_where_some_replication_is() -> None:
    summary = summarise(_rows([[10.0, 2.0, 4.0], [math.nan, 6.0, 8.0]])).set_index("point")
    assert summary.loc[0, "difference"] == 16 / 3 and summary.loc[0, "replications"] == 3
    assert summary.loc[1, "replications"] == 3
    for column in ("difference", "difference_low", "difference_high", "effect_size", "median_conover_p"):
        assert np.isnan(summary.loc[1, column]), column
    assert summary.loc[1, "median_kruskal_p"] == 0.5
