"""`nudge plot` draws only the p-values its metrics give and the stars those give under the rule
recorded beside them: a stats.json whose p-values or stars were edited by hand is refused, not
drawn."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from nudgecli.cli import main

REFERENCE = Path(__file__).resolve().parents[1] / "results" / "paper" / "metrics.csv"


def _analysed(tmp_path: Path) -> Path:
    table = tmp_path / "study.csv"
    shutil.copy(REFERENCE, table)
    result = CliRunner().invoke(main, ["analyze", str(table)])
    assert result.exit_code == 0, result.output
    return table


def test_plot_refuses_p_values_and_stars_edited_by_hand(tmp_path):
    table = _analysed(tmp_path)
    stats_path = tmp_path / "study-analysis" / "stats.json"
    assert CliRunner().invoke(main, ["plot", str(table), "--formats", "png"]).exit_code == 0
    stats = json.loads(stats_path.read_text(encoding="utf-8"))
    entry = next(e for e in stats["metrics"] if e["metric"] == "completion_time")
    entry["kruskal"]["p"] = 1e-6  # two groups with p = 1 drawn with ***
    for row in entry["conover"]:
        row["p"] = row["p_unadjusted"] = 1e-6
    for row in entry["stars"]:
        row["stars"] = "***"
    stats_path.write_text(json.dumps(stats, indent=2), encoding="utf-8")
    result = CliRunner().invoke(main, ["plot", str(table), "--formats", "png"])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1, result.output
    assert errors[0] == _refusal(stats_path, "completion_time")


def _refusal(stats_path: Path, metric: str) -> str:
    return (f"Error: {stats_path}: the p-values or stars of {metric} are not those of its metrics (the "
            "file was edited); run `nudge analyze` on the source again before plotting")


def _starred(entry: dict[str, Any]) -> None:
    for row in entry["stars"]:
        row["stars"] = "***"  # p-values left as they are


def _rule_loosened(entry: dict[str, Any]) -> None:
    entry["star_rule"]["comparison"] = "<>"


def _unstarred(entry: dict[str, Any]) -> None:
    for row in entry["stars"]:
        row["stars"] = ""


@pytest.mark.parametrize(("metric", "edit"), [
    ("completion_time", _starred),  # not significant in the reference run: stars added
    ("human_effort", _unstarred),  # significant there: its stars taken away
    ("human_effort", _rule_loosened),
])
def test_plot_refuses_stars_edited_alone(tmp_path: Path, metric: str,
                                         edit: Callable[[dict[str, Any]], None]) -> None:
    table = _analysed(tmp_path)
    stats_path = tmp_path / "study-analysis" / "stats.json"
    stats = json.loads(stats_path.read_text(encoding="utf-8"))
    entry = next(e for e in stats["metrics"] if e["metric"] == metric)
    before = [row["stars"] for row in entry["stars"]]
    edit(entry)
    stats_path.write_text(json.dumps(stats, indent=2), encoding="utf-8")
    result = CliRunner().invoke(main, ["plot", str(table), "--formats", "png"])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and errors == [_refusal(stats_path, metric)], (before, result.output)


def test_a_document_without_a_star_rule_is_plotted_as_before(tmp_path: Path) -> None:
    """An older nudge's stats.json records no rule: its p-values are checked, its stars drawn as
    recorded."""
    table = _analysed(tmp_path)
    stats_path = tmp_path / "study-analysis" / "stats.json"
    stats = json.loads(stats_path.read_text(encoding="utf-8"))
    for entry in stats["metrics"]:
        entry.pop("star_rule")
    stats_path.write_text(json.dumps(stats, indent=2), encoding="utf-8")
    result = CliRunner().invoke(main, ["plot", str(table), "--formats", "png"])
    assert result.exit_code == 0, result.output


def test_a_cut_off_metrics_csv_of_a_run_is_named_with_the_analysis_that_writes_it_again(tmp_path):
    runner = CliRunner()
    run = tmp_path / "run"
    result = runner.invoke(main, ["simulate", "paper", "--participants", "2", "--set",
                                  "study.blocks_per_condition=1", "--out", str(run)])
    assert result.exit_code == 0, result.output
    assert runner.invoke(main, ["analyze", str(run)]).exit_code == 0
    metrics = run / "metrics.csv"
    metrics.write_bytes(metrics.read_bytes()[:-40])  # the last row cut short
    result = runner.invoke(main, ["plot", str(run)])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1, result.output
    assert "looks cut off" in errors[0] and errors[0].endswith(f"write it again with `nudge analyze {run}`")
    assert "complete that line" not in errors[0], errors[0]
    assert runner.invoke(main, ["analyze", str(run)]).exit_code == 0
    assert runner.invoke(main, ["plot", str(run)]).exit_code == 0
