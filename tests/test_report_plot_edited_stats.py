"""`nudge plot` draws only the p-values its metrics give: a stats.json whose p-values (and the stars
drawn from them) were edited by hand is refused, not drawn."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

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
    assert errors[0] == (f"Error: {stats_path}: the p-values of completion_time are not those of its metrics "
                         "(the file was edited); run `nudge analyze` on the source again before plotting")
