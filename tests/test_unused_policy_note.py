"""A ``[policies.NAME]`` section that no condition of the run names is told in one Note line (it is
neither imported nor checked), not left out in silence; the run goes on."""

from __future__ import annotations

import shutil
from pathlib import Path

from click.testing import CliRunner

from nudgecli.cli import main

EXPERIMENTS = Path(__file__).resolve().parents[1] / "experiments"


def test_a_policy_no_condition_runs_is_one_note(tmp_path: Path) -> None:
    shutil.copy(EXPERIMENTS / "custom-policy.toml", tmp_path / "exp.toml")
    shutil.copytree(EXPERIMENTS / "policies", tmp_path / "policies")
    result = CliRunner().invoke(main, ["simulate", str(tmp_path / "exp.toml"), "--participants", "2",
                                       "--out", str(tmp_path / "run"),
                                       "--set", 'study.conditions=["disambiguation", "control"]'])
    assert result.exit_code == 0, result.output
    notes = [line for line in result.output.splitlines() if "[policies.threshold]" in line]
    assert notes == ["Note: [policies.threshold] (policies.threshold:ThresholdAssist) is not in "
                     "study.conditions, so not run (nor imported or checked); list it in study.conditions "
                     "to run it"], result.output


def test_a_policy_a_condition_runs_is_no_note(tmp_path: Path) -> None:
    shutil.copy(EXPERIMENTS / "custom-policy.toml", tmp_path / "exp.toml")
    shutil.copytree(EXPERIMENTS / "policies", tmp_path / "policies")
    result = CliRunner().invoke(main, ["simulate", str(tmp_path / "exp.toml"), "--participants", "2",
                                       "--out", str(tmp_path / "run")])
    assert result.exit_code == 0, result.output
    assert "[policies.threshold]" not in result.output
