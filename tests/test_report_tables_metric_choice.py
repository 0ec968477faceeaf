"""With ``--metric``, only the chosen metric columns of a table must be numeric: a text column
(``notes``) the analysis was not asked for is ignored by ``analyze``, ``plot`` and ``compare``,
as the error without ``--metric`` advises; a chosen text column is still refused."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.report.tables import validate_metrics_table

TABLE = Path(__file__).parent / "data" / "metrics_two_conditions.csv"


def with_notes(folder: Path) -> Path:
    """TABLE with a text column ``notes`` after its metrics."""
    table = pd.read_csv(TABLE)
    table.insert(5, "notes", ["slow start" if i % 3 else "ok" for i in range(len(table))])
    table.to_csv(folder / "extra.csv", index=False)
    return folder / "extra.csv"


def invoke(args: list[str], code: int = 0) -> str:
    result = CliRunner().invoke(main, args)
    assert result.exit_code == code, result.output
    if code:
        assert result.stderr.startswith("Error: ") and result.stderr.count("\n") == 1, result.stderr
        return result.stderr
    return result.stdout


def test_validation_requires_only_the_chosen_columns_to_be_numeric() -> None:
    table = pd.DataFrame({"participant": [1, 1, 2, 2], "condition": ["a", "b", "a", "b"],
                          "notes": ["x", "y", "z", "w"], "m": [1.0, 2.0, 3.0, 4.0],
                          "flag": [True, None, False, True]})
    with pytest.raises(DataError, match=r"'notes' is not numeric \(row 2 holds 'x'.*pick the metrics with "
                                        r"--metric"):
        validate_metrics_table(table.copy(), "t.csv")
    assert validate_metrics_table(table, "t.csv", chosen=["m"]) == ["m", "flag"]  # numeric ones still metrics
    assert table["flag"].dtype == "boolean"  # True/False with a blank converted as before
    with pytest.raises(DataError, match=r"'notes' is not numeric.*leave it out of --metric"):
        validate_metrics_table(table, "t.csv", chosen=["m", "notes"])


def test_analyze_and_plot_a_table_with_a_text_column_given_metric(tmp_path: Path) -> None:
    extra = with_notes(tmp_path)
    assert "'notes' is not numeric" in invoke(["analyze", str(extra)], code=1)
    invoke(["analyze", str(extra), "--metric", "mode_switches", "--metric", "success"])
    stats = json.loads((tmp_path / "extra-analysis" / "stats.json").read_text())
    # the same statistics as the table without the text column
    plain = tmp_path / "plain" / "study.csv"
    plain.parent.mkdir()
    plain.write_bytes(TABLE.read_bytes())
    invoke(["analyze", str(plain), "--metric", "mode_switches", "--metric", "success"])
    expected = json.loads((tmp_path / "plain" / "study-analysis" / "stats.json").read_text())
    assert [m["metric"] for m in stats["metrics"]] == ["mode_switches", "success"]
    assert stats["metrics"] == expected["metrics"]
    assert "extra-analysis/figures/metrics.png" in invoke(["plot", str(extra)]).replace("\\", "/")
    assert "metrics.png" in invoke(["plot", str(tmp_path / "extra-analysis"), "--force"])  # its folder


def test_a_chosen_text_column_or_a_misspelt_metric_is_refused(tmp_path: Path) -> None:
    extra = with_notes(tmp_path)
    message = invoke(["analyze", str(extra), "--metric", "notes"], code=1)
    assert "'notes' is not numeric" in message and "leave it out of --metric" in message
    message = invoke(["analyze", str(extra), "--metric", "mode_switchs"], code=1)
    assert "did you mean 'mode_switches'" in message and "notes" not in message  # not a metric
    assert not (tmp_path / "extra-analysis").exists()


def test_compare_ignores_a_text_column_not_chosen(tmp_path: Path) -> None:
    extra = with_notes(tmp_path)
    args = ["--metric", "completion_time", "--resamples", "100", "--format", "csv"]
    assert "'notes' is not numeric" in invoke(["compare", str(TABLE), str(extra), "--resamples", "0"], code=1)
    expected = invoke(["compare", str(TABLE), str(TABLE), *args])
    assert invoke(["compare", str(TABLE), str(extra), *args]) == expected  # the real table's notes
    assert invoke(["compare", str(extra), str(TABLE), *args]) == expected  # the simulated table's
