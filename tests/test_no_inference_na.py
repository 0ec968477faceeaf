"""A condition without goal inference (teleoperation, the CIAA study's ``no_assistance``): the
metrics only an assisting, inferring policy gives are not applicable, and so is success where the
plan defines it by the inferred goal (the study software's proxy, never true without inference)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.model.conditions import not_applicable_metrics
from nudgecli.report.path_figures import measures_figure

NO_INFERENCE = {"assistance_engagement", "assistance_strength", "human_effort", "human_turns"}


def test_a_condition_the_recorded_table_lacks_has_its_built_in_policys_constants() -> None:
    # a CIAA run recorded its experiment's study.conditions (the paper's pair), not no_assistance
    table = not_applicable_metrics(["no_assistance"], {"disambiguation": [], "control": []})
    assert {m for m, conditions in table.items() if "no_assistance" in conditions} == NO_INFERENCE
    # what a run records for its conditions is kept
    assert not_applicable_metrics(["no_assistance"], {"no_assistance": []}) == {}


@pytest.mark.parametrize(("success", "expected"), [
    ("last_inferred_goal", ("teleoperation",)),  # hindsight infers: its success applies
    ("reached_goal", None),
])
def test_inferred_goal_success_is_not_applicable_without_inference(success: str,
                                                                    expected: tuple[str, ...] | None) -> None:
    table = not_applicable_metrics(["disambiguation", "teleoperation", "hindsight"], success=success)
    assert table.get("success") == expected


@pytest.fixture(scope="module")
def ciaa_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ciaa") / "r1"
    result = CliRunner().invoke(main, ["simulate", "ciaa-teleop", "--participants", "2", "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_study_code_analysis_of_a_ciaa_run_says_n_a(ciaa_run: Path, tmp_path: Path) -> None:
    run = tmp_path / "r1p"
    shutil.copytree(ciaa_run, run)
    result = CliRunner().invoke(main, ["analyze", str(run), "--plan", "study-code"])
    assert result.exit_code == 0, result.output
    stats = json.loads((run / "stats.json").read_text())
    left_out = {e["metric"] for e in stats["metrics"] if e.get("not_applicable") == ["no_assistance"]}
    assert left_out == NO_INFERENCE | {"success"}
    success_row = next(line for line in result.output.splitlines() if line.startswith("success "))
    assert "n/a" in success_row, result.output
    title = measures_figure(pd.read_csv(run / "metrics.csv"), stats)._suptitle
    assert title is not None and title.get_text() == "Success rate: no_assistance n/a"
    # the run's own plan still reports the simulator's success
    reached = CliRunner().invoke(main, ["analyze", str(run), "--plan", "ciaa-teleop", "--force"])
    assert reached.exit_code == 0, reached.output
    stats = json.loads((run / "stats.json").read_text())
    assert not any(e.get("not_applicable") for e in stats["metrics"])
