"""What a plan leaves out or leaves to its defaults: a known metric the plan's [metrics] include
leaves out is named as such with a shipped plan that includes it, a plan's definitions default to
the paper's (completion time too), and every shipped plan states its completion time."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from nudgecli.config_files import list_presets
from nudgecli.errors import DataError
from nudgecli.report import analysis as analysis_module
from nudgecli.report.plans import AnalysisPlan, MetricDefinitions, load_plan, plan_names

TWO_CONDITIONS = Path(__file__).with_name("data") / "metrics_two_conditions.csv"


def test_a_known_metric_the_plan_leaves_out_names_the_plan_and_one_that_includes_it(tmp_path: Path) -> None:
    table = Path(shutil.copy(TWO_CONDITIONS, tmp_path / "m.csv"))
    with pytest.raises(DataError) as caught:
        analysis_module.analyze(table, plan="paper", out=tmp_path / "a", metrics=["wrong_goal"])
    message = str(caught.value)
    assert message.startswith("metric 'wrong_goal' is not in plan paper's [metrics] include; "), message
    assert "--plan baselines" in message and "unknown metric" not in message
    assert all("wrong_goal" in load_plan(name).metrics.include for name in message.split("--plan ")[1:])


def test_a_plan_without_definitions_takes_the_papers_completion_time() -> None:
    # a minimal plan switched completion time to the study software's all_trials, unsaid
    paper = load_plan("paper").metrics
    assert MetricDefinitions().completion_time == "successful_trials" == paper.completion_time
    defaults = AnalysisPlan().metrics
    for definition in ("engagement", "strength", "mode_switches", "success", "completion_time"):
        assert getattr(defaults, definition) == getattr(paper, definition), definition


@pytest.mark.parametrize("name", plan_names())
def test_every_shipped_plan_states_its_completion_time(name: str) -> None:
    # the shipped results do not depend on the default: each plan says which definition it uses
    text = list_presets("analysis")[name].read_text(encoding="utf-8")
    assert "\ncompletion_time = " in text.split("[metrics]", 1)[1].split("\n[", 1)[0], name


def test_the_plans_say_the_papers_conditions_come_first() -> None:
    # the order rule is the README's: disambiguation and control first, then the plan's list
    text = list_presets("analysis")["paper"].read_text(encoding="utf-8")
    assert 'the first is "a" in every comparison' not in text
    assert "disambiguation and control come first" in text
