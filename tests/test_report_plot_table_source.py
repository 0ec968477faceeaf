"""`nudge plot TABLE.csv` of a table whose analysis dropped duplicate rows draws what was analysed.

The analysis of such a table writes the rows it analysed to ``metrics.csv`` and checksums them in
``stats.json``; plotting the table itself checks the table against that record once its
duplicates are dropped again, so a table edited after its analysis is still refused.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.report import plotting

TABLE = Path(__file__).parent / "data" / "metrics_two_conditions.csv"


@pytest.fixture
def analysed_with_duplicates(tmp_path: Path) -> Path:
    """A copy of the two-condition table with two trial rows repeated at its end, analysed with
    ``--drop-duplicates`` (the analysis folder ``study-analysis/`` beside it)."""
    table = pd.read_csv(TABLE)
    doubled = pd.concat([table, table.iloc[[3, 10]]], ignore_index=True)
    source = tmp_path / "study.csv"
    doubled.to_csv(source, index=False)
    result = CliRunner().invoke(main, ["analyze", str(source), "--drop-duplicates"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "study-analysis" / "metrics.csv").is_file()
    return source


def test_plot_of_the_table_draws_the_analysed_rows(analysed_with_duplicates, monkeypatch, tmp_path):
    drawn: list[pd.DataFrame] = []
    write_figures = plotting.write_figures

    def spy(inputs: plotting.FigureInputs, plan: Any) -> list[Path]:
        drawn.append(inputs.metrics)
        return write_figures(inputs, plan)

    monkeypatch.setattr(plotting, "write_figures", spy)
    result = CliRunner().invoke(main, ["plot", str(analysed_with_duplicates), "--formats", "png",
                                       "--out", str(tmp_path / "figures")])
    assert result.exit_code == 0, result.output
    assert list((tmp_path / "figures").glob("*.png"))
    analysed = pd.read_csv(tmp_path / "study-analysis" / "metrics.csv")
    assert len(drawn) == 1 and len(drawn[0]) == len(analysed) == len(pd.read_csv(TABLE))
    key = ["participant", "condition", "trial", "completion_time"]
    pd.testing.assert_frame_equal(drawn[0][key].astype(str).reset_index(drop=True), analysed[key].astype(str))


def test_a_table_edited_after_its_analysis_is_refused(analysed_with_duplicates, tmp_path):
    edited = pd.read_csv(analysed_with_duplicates)
    edited.loc[0, "completion_time"] += 1.0
    edited.to_csv(analysed_with_duplicates, index=False)
    result = CliRunner().invoke(main, ["plot", str(analysed_with_duplicates), "--formats", "png",
                                       "--out", str(tmp_path / "figures")])
    assert result.exit_code != 0
    assert "stale or edited" in result.output and "study.csv" in result.output
