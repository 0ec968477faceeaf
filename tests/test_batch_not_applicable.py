"""A batch (replicate, power, sweep) decides what is not applicable by the rule ``nudge analyze``
applies (``nudgecli.model.conditions.not_applicable_metrics``), the plan's success definition
included: a replication's analysis is the ``stats.json`` ``nudge analyze --plan PLAN`` writes for
the run folder of that study. And a run records what is constant for the conditions it ran (a CIAA
run's ``world.ciaa_conditions``, not the grid's ``study.conditions`` it never runs)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.runs.batch import study_key
from nudgecli.sim.policy_registry import constant_metrics_of

NO_INFERENCE = {"assistance_engagement", "assistance_strength", "human_effort", "human_turns"}


def nudge(*args: str | Path):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_a_replications_analysis_is_what_analyze_gives_under_the_plan(tmp_path: Path) -> None:
    batch = tmp_path / "batch"
    made = nudge("replicate", "baselines", "-R", "1", "--participants", "4", "--plan", "study-code",
                 "--out", batch)
    assert made.exit_code == 0, made.output
    seeds = pd.read_csv(batch / "replications.csv")["seed"].unique()
    assert len(seeds) == 1
    config = load_experiment("baselines")
    for seed in seeds:
        run = tmp_path / f"run-{seed}"
        simulated = nudge("simulate", "baselines", "--participants", "4", "--seed", str(seed), "--out", run)
        assert simulated.exit_code == 0, simulated.output
        analysed = nudge("analyze", run, "--plan", "study-code")
        assert analysed.exit_code == 0, analysed.output
        expected = json.loads((run / "stats.json").read_text())
        document = json.loads((batch / "analyses" / f"{study_key(config, int(seed))}-n0004.json").read_text())
        assert document["conditions"] == expected["conditions"]
        assert document["metrics"] == expected["metrics"]
        success = next(e for e in document["metrics"] if e["metric"] == "success")
        # last_inferred_goal is never true without inference
        assert success.get("not_applicable") == ["teleoperation"]
    # no replication counts a pair of teleoperation's success as a difference
    rows = pd.read_csv(batch / "replications.csv")
    teleoperation = rows[(rows["metric"] == "success") & ((rows["a"] == "teleoperation") |
                                                           (rows["b"] == "teleoperation"))]
    assert len(teleoperation) == 6 and not teleoperation["trial_significant"].any()
    assert not teleoperation["participant_significant"].any()


def test_a_ciaa_run_records_the_conditions_it_ran() -> None:
    config = load_experiment("ciaa-teleop")
    assert constant_metrics_of(config) == {"no_assistance": NO_INFERENCE}


@pytest.fixture(scope="module")
def ciaa_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ciaa") / "r1"
    result = nudge("simulate", "ciaa-teleop", "--participants", "2", "--out", out)
    assert result.exit_code == 0, result.output
    return out


def test_a_ciaa_run_with_the_old_record_resumes_and_records_its_conditions(ciaa_run: Path,
                                                                          tmp_path: Path) -> None:
    # a run folder of an earlier nudge recorded the grid's study.conditions, which it never ran;
    # the record is not compared on resume (it is derived from the experiment, which is), so the
    # resume is not refused, and it writes the record of the conditions the run ran
    run = tmp_path / "r1"
    shutil.copytree(ciaa_run, run)
    manifest_path = run / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    assert manifest["constant_metrics"] == {"no_assistance": sorted(NO_INFERENCE)}
    manifest["constant_metrics"] = {"disambiguation": [], "control": []}
    manifest_path.write_text(json.dumps(manifest, indent=2))
    (run / "trials" / "part-0001.parquet").unlink()
    resumed = nudge("simulate", "ciaa-teleop", "--participants", "2", "--out", run, "--resume")
    assert resumed.exit_code == 0, resumed.output
    recorded = json.loads(manifest_path.read_text())["constant_metrics"]
    assert recorded == {"no_assistance": sorted(NO_INFERENCE)}
    assert nudge("analyze", run).exit_code == 0
