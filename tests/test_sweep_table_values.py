"""A swept parameter whose values are tables or lists (``"policies.threshold.params" =
[{threshold=0.5}, ...]``, ``"study.goal_counts" = [[3, 4], ...]``) is written to ``sweep.csv``,
``replications.csv`` and ``points.csv`` as compact JSON with sorted keys, which ``json.loads``
reads back (it was the Python repr ``{'threshold': 0.5}``, neither JSON nor TOML); numbers,
strings and booleans are written as they were."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_helpers import nudge

from nudgecli.config_files import list_presets
from nudgecli.report.figures import replication as replication_figures
from nudgecli.runs import batch_kinds
from nudgecli.runs.sweep import parameter_cell

#: The custom-policy experiment at the smallest scale a sweep runs (two participants, the fewest it
#: analyses), one layout per condition.
SMALL = ["study.participants=2", "study.goal_counts=[3]", 'study.corners=["tr"]', 'study.start_modes=["x"]',
         "study.blocks_per_condition=1"]
PARAMS = "policies.threshold.params"


@pytest.mark.parametrize(("value", "cell"), [
    ({"threshold": 0.5}, '{"threshold":0.5}'),
    ({"weight": 0.2, "threshold": 0.9}, '{"threshold":0.9,"weight":0.2}'),
    ([3, 4], "[3,4]"),
    ([{"b": [1, 2], "a": "é"}], '[{"a":"é","b":[1,2]}]'),
    ({"day": dt.date(2026, 1, 2)}, '{"day":"2026-01-02"}'),
    ([np.int64(3), np.float64(0.5)], "[3,0.5]"),
    (0.5, 0.5), (3, 3), ("blend", "blend"), (True, True),
])
def test_a_cell_is_json_for_a_table_or_list_and_the_value_itself_otherwise(value: object,
                                                                           cell: object) -> None:
    written = parameter_cell(value)
    assert written == cell and type(written) is type(cell)


def test_a_sweeps_tables_write_table_values_as_json(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the tables are the point; the figure is drawn from them, and would take most of the time
    monkeypatch.setattr(replication_figures, "sweep_figure", lambda rows, names: None)
    monkeypatch.setattr(batch_kinds, "_figures", lambda folder, figures: [])
    sweep_file = tmp_path / "s.toml"
    sweep_file.write_text(f'experiment = {json.dumps(str(list_presets("experiments")["custom-policy"]))}\n'
                          f"replications = 1\nseed = 3\nset = {json.dumps(SMALL)}\n[parameters]\n"
                          f'"{PARAMS}" = [{{threshold=0.5}}, {{weight=0.2, threshold=0.9}}]\n',
                          encoding="utf-8")
    result = nudge("sweep", sweep_file, "--out", tmp_path / "out")
    assert result.exit_code == 0, result.output
    for name in ("sweep.csv", "replications.csv", "points.csv"):
        cells = pd.read_csv(tmp_path / "out" / name, dtype=str)[PARAMS]
        assert sorted(set(cells)) == ['{"threshold":0.5}', '{"threshold":0.9,"weight":0.2}'], name
        assert [json.loads(cell) for cell in sorted(set(cells))] == [{"threshold": 0.5},
                                                                     {"threshold": 0.9, "weight": 0.2}]


def test_a_design_points_values_in_a_message_are_its_set_texts() -> None:
    # a table-valued point was shown as Python's repr ({'threshold': 0.5}), which no --set reads
    from nudgecli.runs.sweep import point_overrides, point_words

    assignment = {"policies.threshold.params": {"threshold": 0.5}, "study.participants": 1}
    assert point_words(assignment) == ", ".join(point_overrides([], assignment))
    assert point_words(assignment) == "policies.threshold.params={threshold = 0.5}, study.participants=1"
