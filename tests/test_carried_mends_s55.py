"""Mends of four carried defects: ``nudge plot`` of an analysis written away from its run uses the
plan that analysis used; a dask run's Python resume call names its scheduler; a policy module that
raises as it is imported is named by file and line; ``nudge validate --all-readings --mc-queries
100`` says the value is not used."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import nudge, one_error_line
from plot_plan_helpers import LOOSE_PLAN, star_rule_plotted
from policy_helpers import QUIET_POLICY, policy_experiment

from nudgecli.report.plans import load_plan


@pytest.fixture()
def run_and_plan(analysed_smoke_run: Path, tmp_path: Path) -> tuple[Path, Path]:
    """A copy of the analysed smoke run (under the paper plan, which it records), and LOOSE_PLAN's file."""
    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run, ignore=shutil.ignore_patterns("figures", ".nudge.lock"))
    plan = tmp_path / "loose.toml"
    plan.write_text(LOOSE_PLAN)
    return run, plan


def test_plot_of_an_analysis_written_away_from_its_run_uses_its_plan(
        run_and_plan: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    run, plan = run_and_plan
    out = tmp_path / "elsewhere"
    assert nudge("analyze", run, "--plan", plan, "--out", out, "--bootstrap", "100").exit_code == 0
    assert star_rule_plotted(monkeypatch, out) == load_plan(plan).comparison_options()  # was the paper's
    # stats.json names the analysis's own copy of the plan file, which moves with it
    assert json.loads((out / "stats.json").read_text())["plan"] == "analysis_plan.toml"
    assert (out / "analysis_plan.toml").read_text() == LOOSE_PLAN


def test_a_runs_analysis_under_another_plan_than_its_own_records_it_and_only_then(
        run_and_plan: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch) -> None:
    run, _ = run_and_plan
    before = (run / "stats.json").read_bytes()
    assert nudge("analyze", run, "--bootstrap", "100").exit_code == 0  # its recorded plan, paper
    assert (run / "stats.json").read_bytes() == before  # nothing added: results/paper stays as it is
    assert nudge("analyze", run, "--plan", "study-code", "--bootstrap", "100").exit_code == 0
    assert json.loads((run / "stats.json").read_text())["plan"] == "study-code"
    assert json.loads((run / "manifest.json").read_text())["plan"] == "paper"
    assert star_rule_plotted(monkeypatch, run) == load_plan("study-code").comparison_options()


def test_plot_of_a_table_analysed_with_a_plan_file_uses_that_plan(
        run_and_plan: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    run, plan = run_and_plan
    table = tmp_path / "study.csv"
    shutil.copy(run / "metrics.csv", table)
    assert nudge("analyze", table, "--plan", plan, "--bootstrap", "100").exit_code == 0
    assert star_rule_plotted(monkeypatch, table) == load_plan(plan).comparison_options()


def test_the_python_resume_call_of_a_dask_run_names_its_scheduler() -> None:
    from nudgecli.sim.policy_files import SOURCES_KEY, script_resume_call

    manifest: dict[str, Any] = {SOURCES_KEY: {"__main__:Mine": "0" * 64}, "executor": "dask"}
    call = script_resume_call(manifest, "R/config.toml", "R", 5, 2, None)
    assert call is not None and "out='R', seed=5, participants=2, scheduler='ADDRESS', resume=True)" in call
    local = script_resume_call({**manifest, "executor": "processes"}, "R/config.toml", "R", 5, 2, None)
    assert local is not None and "scheduler" not in local


@pytest.mark.parametrize(("line", "error"), [
    ("raise ValueError('x')", "ValueError: x"),
    ("W = undefined_weight + 1", "NameError: name 'undefined_weight' is not defined"),
])
def test_a_policy_module_raising_as_it_is_imported_is_named_by_file_and_line(
        tmp_path: Path, line: str, error: str) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "policies.mine:Quiet"},
                                   modules={"policies/mine.py": f"X = 1\n{line}\n{QUIET_POLICY}"})
    message = one_error_line(nudge("simulate", experiment, "--out", tmp_path / "run").output)
    assert message.startswith(f"Error: condition 'mine' (policy policies.mine:Quiet): cannot import module "
                              f"'policies.mine': {error} (policies/mine.py line 2: {line}); "), message
    assert "looked up beside the experiment file" not in message  # it was found: it raised
    assert not (tmp_path / "run").exists()


def test_validate_says_an_explicit_mc_queries_beside_all_readings_is_not_used(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from nudgecli.api.validation import validate

    monkeypatch.setattr("nudgecli.sim.validation.run_all_readings", lambda settings, names, progress: [])
    given = validate(simulations=2, min_goals=3, max_goals=3, states=72, mc_queries=100, all_readings=True)
    assert any(note.startswith("--mc-queries 100 is not used with --all-readings") for note in given.notes)
    left_out = validate(simulations=2, min_goals=3, max_goals=3, states=72, all_readings=True)
    assert not any("--mc-queries" in note for note in left_out.notes)
    # the command passes on whether the option was given, not the default's value
    passed: list[object] = []

    def validated(**options: Any) -> None:
        passed.append(options["mc_queries"])
        raise SystemExit(0)  # the option's value is what is checked, not the validation

    monkeypatch.setattr("nudgecli.api.validation.validate", validated)
    nudge("validate", "--all-readings")
    nudge("validate", "--all-readings", "--mc-queries", "100")
    assert passed == [None, 100]
