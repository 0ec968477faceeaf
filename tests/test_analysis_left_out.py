"""What ``nudge analyze`` leaves out is said, and what it prints is what it writes: a plan's filters
counted in a note, a boolean column's culprit cell named, ``--format csv`` as ``stats.csv``, a
DataFrame's unused condition category no condition."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

import nudgecli
from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.report.analysis import analyze

METRICS_CSV = Path(__file__).parent / "data" / "metrics_two_conditions.csv"


def _table() -> pd.DataFrame:
    return pd.read_csv(METRICS_CSV)


def test_the_values_a_plans_filters_remove_are_counted_in_a_note_and_the_summary(tmp_path: Path) -> None:
    table = _table()
    table.loc[::4, "mode_switches"] = 15  # study-code keeps at most 10 mode switches
    source = tmp_path / "filtered.csv"
    table.to_csv(source, index=False)
    result = analyze(source, plan="study-code", out=tmp_path / "out", metrics=["mode_switches"],
                     bootstrap=100)
    line = ("plan study-code's [filters] left out 12 of 48 mode_switches values (above 10); each trial "
            "stays in its other metrics")
    assert f"{source}: {line}" in result.notes
    assert f"- filters: {line}\n" in result.summary
    assert result.metrics["mode_switches"].notna().sum() == 36
    unfiltered = analyze(METRICS_CSV, plan="study-code", out=tmp_path / "plain", metrics=["mode_switches"],
                         bootstrap=100)  # nothing above a maximum: nothing to say
    assert not any("[filters]" in note for note in unfiltered.notes)
    assert "- filters:" not in unfiltered.summary


def test_a_boolean_columns_error_names_the_cell_that_is_not_true_or_false(tmp_path: Path) -> None:
    table = _table()
    table["success"] = table["success"].astype(str)
    table.loc[10, "success"] = "yes"  # line 12 of the file
    source = tmp_path / "yes.csv"
    table.to_csv(source, index=False)
    with pytest.raises(DataError, match=r"'success' is not numeric \(row 12 holds 'yes'\);"):
        analyze(source, out=tmp_path / "out")


def test_format_csv_prints_exactly_stats_csv(tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["analyze", str(METRICS_CSV), "--out", str(out), "--format", "csv",
                                       "--metric", "mode_switches", "--bootstrap", "100"])
    assert result.exit_code == 0, result.output
    assert result.stdout == (out / "stats.csv").read_text(encoding="utf-8")


def test_an_unused_category_of_a_dataframes_condition_is_no_condition(tmp_path: Path) -> None:
    table = _table()
    table["condition"] = pd.Categorical(table["condition"], categories=["disambiguation", "control", "blend"])
    analysis = nudgecli.analyze(table, out=tmp_path / "out", metrics=["mode_switches"], bootstrap=100)
    assert analysis.conditions == ["disambiguation", "control"]
    assert analysis.pairs[["a", "b"]].values.tolist() == [["disambiguation", "control"]]
