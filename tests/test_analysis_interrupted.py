"""An analysis killed while it writes its files: ``nudge plot`` never draws a ``stats.json`` beside
the files of another analysis (stats.json goes first and comes last)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

import nudgecli.report.analysis as analysis_module

REFERENCE = Path(__file__).resolve().parents[1] / "results" / "paper" / "metrics.csv"


def _table(tmp_path: Path) -> Path:
    table = tmp_path / "study.csv"
    shutil.copy(REFERENCE, table)
    return table


def _killed_at(monkeypatch: pytest.MonkeyPatch, name: str, *args: str | Path) -> None:
    """``nudge analyze ARGS`` stopped as it is about to write ``name`` (the files before it written,
    those after it not: what a kill -9 leaves, the temporaries aside)."""
    original = analysis_module.write_text_atomic

    def write(path: str | Path, text: str) -> None:
        if Path(path).name == name:
            raise KeyboardInterrupt
        original(path, text)

    monkeypatch.setattr(analysis_module, "write_text_atomic", write)
    try:
        assert nudge("analyze", *args).exit_code != 0
    finally:
        monkeypatch.setattr(analysis_module, "write_text_atomic", original)


@pytest.mark.parametrize("name", ["stats.csv", "summary.md"])
def test_plot_refuses_an_analysis_killed_while_it_replaced_another(tmp_path, monkeypatch, name):
    table = _table(tmp_path)
    assert nudge("analyze", table).exit_code == 0
    _killed_at(monkeypatch, name, table, "--metric", "completion_time")  # another analysis, cut short
    result = nudge("plot", table, "--formats", "png", "--out", tmp_path / "figures")
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert f"nudge analyze {table}" in line, line
    assert nudge("analyze", table, "--metric", "completion_time").exit_code == 0  # no --force needed
    summary = (tmp_path / "study-analysis" / "summary.md").read_text(encoding="utf-8")
    assert "completion_time" in summary and "human_effort" not in summary
    assert nudge("plot", table, "--formats", "png", "--out", tmp_path / "figures").exit_code == 0
