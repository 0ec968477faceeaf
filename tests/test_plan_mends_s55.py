"""Mends of analysis plans: a metric listed twice, the plan summary.md names, a table's metrics
under a plan's include, the CI level as given, and completion times under the study's success proxy."""

from __future__ import annotations

import shutil
from pathlib import Path

from cli_helpers import nudge, one_error_line

from nudgecli.config_files import list_presets

TWO_CONDITIONS = Path(__file__).with_name("data") / "metrics_two_conditions.csv"
PAPER = list_presets("analysis")["paper"]


def _paper_copy(path: Path, old: str = "", new: str = "") -> Path:
    """The paper preset, edited."""
    text = PAPER.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


def _table(tmp_path: Path) -> Path:
    return Path(shutil.copy(TWO_CONDITIONS, tmp_path / "pp.csv"))


# --- a metric listed twice -----------------------------------------------------------------------


def test_a_metric_listed_twice_in_include_is_refused_naming_the_file_and_the_metric(tmp_path):
    """It was tested twice: stats.json held it twice, replicate and power counted it twice."""
    plan = _paper_copy(tmp_path / "twice.toml", "include = [", 'include = ["completion_time", ')
    line = one_error_line(nudge("analyze", _table(tmp_path), "--plan", plan).output)
    assert line.startswith(f"Error: {plan}: metrics.include: 'completion_time' listed more than once; "
                           "list each metric once"), line
    assert not (tmp_path / "pp-analysis").exists()
