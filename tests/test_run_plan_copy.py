"""A run keeps the plan file it was run with (``--plan pl/myplan.toml``): a copy in the run folder,
its SHA-256 in the manifest, as a batch keeps its ``plan.toml``. The file typed may be edited or
moved later without changing ``nudge analyze RUN``; an edited copy is refused naming the manifest's
``plan`` and ``--plan``, which overrides it. Presets stay names."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

import nudgecli

PLAN = """name = "myplan"
conditions = ["disambiguation", "control"]

[metrics]
include = ["completion_time", "human_turns"]

[bootstrap]
resamples = 100
"""


@pytest.fixture(scope="module")
def planned_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A one-participant smoke run simulated with a plan file, which was then edited and moved away.
    Do not modify: tests change a copy."""
    root = tmp_path_factory.mktemp("planned")
    plan = root / "pl" / "myplan.toml"
    plan.parent.mkdir()
    plan.write_text(PLAN)
    run = root / "rp"
    nudgecli.simulate("smoke", participants=1, out=run, plan=str(plan))
    plan.write_text("not = [a plan")  # edited: not even TOML
    plan.rename(plan.with_name("moved.toml"))
    return run


def _copy(run: Path, to: Path) -> Path:
    shutil.copytree(run, to, ignore=shutil.ignore_patterns(".nudge.lock"))
    return to


def _manifest(run: Path) -> dict:
    return json.loads((run / "manifest.json").read_text())


def test_the_run_keeps_a_copy_of_its_plan_file_with_its_sha256(planned_run):
    manifest = _manifest(planned_run)
    assert manifest["plan"] == "plan.toml"
    assert (planned_run / "plan.toml").read_text() == PLAN
    assert manifest["plan_sha256"] == hashlib.sha256(PLAN.encode()).hexdigest()


def test_the_plan_file_edited_and_moved_changes_nothing(planned_run, tmp_path):
    run = _copy(planned_run, tmp_path / "rp")
    result = nudge("analyze", run)
    assert result.exit_code == 0, result.output
    stats = json.loads((run / "stats.json").read_text())
    assert [entry["metric"] for entry in stats["metrics"]] == ["completion_time", "human_turns"]


def test_an_edited_copy_is_refused_naming_the_manifest_and_plan_overrides_it(planned_run, tmp_path):
    run = _copy(planned_run, tmp_path / "rp")
    with (run / "plan.toml").open("a") as copy:
        copy.write("# edited\n")
    line = one_error_line(nudge("analyze", run).output)
    assert line.startswith(f"Error: {run / 'plan.toml'}: changed since the run kept it")
    assert f"{run / 'manifest.json'} 'plan'" in line and "--plan PLAN" in line
    assert not (run / "stats.json").exists()
    assert nudge("analyze", run, "--plan", "paper", "--bootstrap", "100").exit_code == 0


@pytest.mark.parametrize("recorded", ["bogus", "gone/myplan.toml"])
def test_a_recorded_plan_that_does_not_load_names_the_manifest(analysed_smoke_run, tmp_path, recorded):
    run = _copy(analysed_smoke_run, tmp_path / "run")
    manifest = _manifest(run)
    manifest["plan"] = recorded  # an older nudge's path, moved since; or a name edited in
    (run / "manifest.json").write_text(json.dumps(manifest))
    result = nudge("analyze", run)
    assert result.exit_code == 1
    line = one_error_line(result.output)
    assert line.startswith(f"Error: {run / 'manifest.json'} 'plan' = \"{recorded}\": ")
    assert "--plan PLAN, which overrides" in line


def test_a_preset_stays_a_name(tmp_path):
    run = tmp_path / "run"
    nudgecli.simulate("smoke", participants=1, out=run, plan="paper")
    assert _manifest(run)["plan"] == "paper" and "plan_sha256" not in _manifest(run)
    assert not (run / "plan.toml").exists()


def test_force_removes_the_old_runs_plan_copy(planned_run, tmp_path):
    run = _copy(planned_run, tmp_path / "rp")
    nudgecli.simulate("smoke", participants=1, out=run, force=True)
    assert _manifest(run)["plan"] == "paper"  # smoke's default plan
    assert not (run / "plan.toml").exists()  # the old run's plan would stand beside the new run


def test_a_start_killed_after_its_plan_copy_is_only_a_start(planned_run, tmp_path):
    from nudgecli.run_folder_state import only_a_start

    run = tmp_path / "start"
    run.mkdir()
    for name in ("config.toml", "plan.toml", "layouts.parquet"):
        shutil.copy(planned_run / name, run / name)
    assert only_a_start(run)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("resume", [False, True])
def test_the_runs_own_plan_copy_as_plan_is_refused_before_the_run_is_touched(planned_run, tmp_path, resume):
    run = _copy(planned_run, tmp_path / "rp")
    before = _snapshot(run)
    result = nudge("run", "smoke", "--participants", "1", "--out", run, "--plan", run / "plan.toml",
                   "--resume" if resume else "--force")
    line = one_error_line(result.output)
    assert f"{run / 'plan.toml'} is this command's input (--plan {run / 'plan.toml'})" in line
    assert "an output never replaces a file the command read" in line and "elsewhere as --plan" in line
    assert _snapshot(run) == before  # --force deleted nothing; the old run is whole


def test_the_api_refuses_the_runs_plan_copy_as_plan_too(planned_run, tmp_path):
    run = _copy(planned_run, tmp_path / "rp")
    before = _snapshot(run)
    with pytest.raises(nudgecli.NudgeError, match="is this command's input"):
        nudgecli.simulate("smoke", participants=1, out=run, plan=str(run / "plan.toml"), force=True)
    assert _snapshot(run) == before


def test_plan_takes_a_path(tmp_path):
    plan = tmp_path / "myplan.toml"
    plan.write_text(PLAN)
    run = tmp_path / "run"
    nudgecli.simulate("smoke", participants=1, out=run, plan=plan)  # a pathlib.Path, as for out=
    assert _manifest(run)["plan"] == "plan.toml" and (run / "plan.toml").read_text() == PLAN


@pytest.mark.parametrize("batch", [lambda plan: nudgecli.replicate("smoke", 1, participants=2, plan=plan),
                                   lambda plan: nudgecli.power("smoke", [2], 1, plan=plan)])
def test_a_batch_takes_a_plan_path_and_names_it(tmp_path, batch):
    plan = tmp_path / "bad.toml"
    plan.write_text('name = "myplan"\nconditions = ["nope", "control"]\n')
    with pytest.raises(nudgecli.NudgeError) as raised:  # refused before any study is simulated
        batch(plan)
    assert str(raised.value).startswith(f"{plan}: conditions names 'nope'"), raised.value
