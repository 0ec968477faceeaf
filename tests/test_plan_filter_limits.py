"""A plan's ``[filters]`` maximum that can only empty a metric (or keep it whole) is refused when the
plan is read: a filter on a true-or-false metric (``success``, ``wrong_goal``) and a negative
maximum of a metric that is never negative. Such a plan was applied (``success = 0.5`` left out
every success) and the analysis went on with a note and no test of the metric."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.config_files import list_presets
from nudgecli.errors import ConfigError
from nudgecli.report.plans import AnalysisPlan, load_plan

TWO_CONDITIONS = Path(__file__).with_name("data") / "metrics_two_conditions.csv"
PAPER = list_presets("analysis")["paper"]


def _paper_copy(path: Path, filters: str) -> Path:
    """The paper preset (no filters of its own) with ``filters`` as its ``[filters]`` table."""
    text = PAPER.read_text(encoding="utf-8")
    path.write_text(text.replace("[filters]", f"[filters]\n{filters}", 1), encoding="utf-8")
    return path


@pytest.mark.parametrize(("filters", "message"), [
    ("success = 0.5", "success = 0.5: success is true or false, so a maximum keeps every value or leaves "
                      "out every true one; remove the filter"),
    ("wrong_goal = 0", "wrong_goal = 0: wrong_goal is true or false, so a maximum keeps every value or "
                       "leaves out every true one; remove the filter"),
    ("mode_switches = -1", "mode_switches = -1: mode_switches is never negative, so a negative maximum "
                           "leaves out every value; give a maximum of 0 or more"),
    ("completion_time = -0.5", "completion_time = -0.5: completion_time is never negative, so a negative "
                               "maximum leaves out every value; give a maximum of 0 or more"),
])
def test_a_filter_that_can_only_empty_a_metric_is_refused_naming_the_file_and_key(
        tmp_path: Path, filters: str, message: str) -> None:
    plan = _paper_copy(tmp_path / "p.toml", filters)
    with pytest.raises(ConfigError) as caught:
        load_plan(plan)
    assert str(caught.value) == f"{plan}: filters: {message}"
    key, maximum = filters.split(" = ")
    with pytest.raises(ValueError, match=r"remove the filter|give a maximum of 0 or more"):  # in code too
        AnalysisPlan(filters={key: float(maximum)})


def test_analyze_refuses_such_a_plan_in_one_error_line_before_any_work(tmp_path: Path) -> None:
    plan = _paper_copy(tmp_path / "p.toml", "success = 0.5")
    table = Path(shutil.copy(TWO_CONDITIONS, tmp_path / "pp.csv"))
    result = nudge("analyze", table, "--plan", plan, "--bootstrap", "100")
    assert result.exit_code != 0
    assert one_error_line(result.output).startswith(f"Error: {plan}: filters: success = 0.5: success is "
                                                    "true or false"), result.output
    assert not (tmp_path / "pp-analysis").exists()


def test_a_maximum_of_zero_and_a_negative_maximum_of_another_column_are_kept() -> None:
    # 0 keeps a count's zeros (the trials without a mode switch); a table's own column may be signed
    plan = AnalysisPlan(filters={"mode_switches": 0, "human_turns": 0.0, "score_change": -2})
    assert plan.filters == {"mode_switches": 0, "human_turns": 0, "score_change": -2}
