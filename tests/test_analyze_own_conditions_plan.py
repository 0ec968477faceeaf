"""``nudge analyze RUN`` without ``--plan`` on a run of a researcher's own conditions, whose recorded
plan (``paper``) cannot analyse them, gives the fix ``nudge run`` gives before simulating: write a
plan for these conditions and pass it with ``--plan`` (one owner: runs.study.own_plan_advice); a
plan given with ``--plan`` that does not fit keeps its own message."""

from __future__ import annotations

import json
from pathlib import Path

from cli_helpers import nudge, one_error_line
from policy_helpers import QUIET_POLICY, policy_experiment

POLICY = QUIET_POLICY

ADVICE = ('write a plan for these conditions (copy the custom-policy plan, analysis/custom-policy.toml, '
          'with conditions = ["control", "quiet"]) and pass it with --plan PLAN.toml')


def test_analyze_without_plan_names_plan_and_the_plan_file_to_write_as_run_does(tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"quiet": "mypol:Quiet"}, modules={"mypol.py": POLICY})
    refused_run = nudge("run", experiment, "--out", tmp_path / "never")
    assert refused_run.exit_code == 1 and one_error_line(refused_run.output).endswith(ADVICE)
    run = tmp_path / "R"
    assert nudge("simulate", experiment, "--out", run).exit_code == 0
    before = json.loads((run / "manifest.json").read_text())
    refused = nudge("analyze", run)
    assert refused.exit_code == 1
    line = one_error_line(refused.output)
    assert "no --plan was given" in line and line.endswith(ADVICE), line
    assert json.loads((run / "manifest.json").read_text()) == before
    given = nudge("analyze", run, "--plan", "paper")
    assert given.exit_code == 1
    assert "--plan" not in one_error_line(given.output)
