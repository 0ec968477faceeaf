"""Mends of a review of recent changes: an analysis keeps its own copy of the plan file its
``stats.json`` records, which ``nudge plot`` draws under and checks."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import nudge, one_error_line
from plot_plan_helpers import LOOSE_PLAN, star_rule_plotted

from nudgecli.report.plans import load_plan


@pytest.fixture()
def analysed_under_a_plan_file(analysed_smoke_run: Path, tmp_path: Path) -> tuple[Path, Path, Path]:
    """A copy of the analysed smoke run, LOOSE_PLAN's file, and the run's analysis under it in D."""
    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run, ignore=shutil.ignore_patterns("figures", ".nudge.lock"))
    plan = tmp_path / "plans" / "loose.toml"
    plan.parent.mkdir()
    plan.write_text(LOOSE_PLAN)
    out = tmp_path / "D"
    assert nudge("analyze", run, "--plan", plan, "--out", out, "--bootstrap", "100").exit_code == 0
    return run, plan, out


def test_an_analysis_keeps_its_plan_file_so_moving_or_editing_the_file_changes_no_figure(
        analysed_under_a_plan_file: tuple[Path, Path, Path], tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    _, plan, out = analysed_under_a_plan_file
    stats = json.loads((out / "stats.json").read_text())
    assert stats["plan"] == "analysis_plan.toml" and len(stats["plan_sha256"]) == 64
    loose = load_plan(plan).comparison_options()
    plan.write_text(LOOSE_PLAN.replace("0.9, 0.8, 0.7", "0.5, 0.4, 0.3"))  # edited after the analysis
    assert star_rule_plotted(monkeypatch, out) == loose  # drawn under the plan of its statistics
    plan.unlink()  # moved away, and the analysis copied elsewhere: drawn as before
    moved = tmp_path / "elsewhere" / "copy-of-D"
    shutil.copytree(out, moved, ignore=shutil.ignore_patterns(".nudge.lock"))
    assert star_rule_plotted(monkeypatch, moved) == loose


@pytest.mark.parametrize("damage", ["edited", "missing"])
def test_plot_refuses_an_analysis_whose_plan_copy_is_edited_or_missing(
        analysed_under_a_plan_file: tuple[Path, Path, Path], damage: str) -> None:
    _, _, out = analysed_under_a_plan_file
    copy = out / "analysis_plan.toml"
    if damage == "edited":
        copy.write_text(LOOSE_PLAN.replace("0.9, 0.8, 0.7", "0.5, 0.4, 0.3"))
    else:
        copy.unlink()
    message = one_error_line(nudge("plot", out).output)
    assert f"({out / 'stats.json'} 'plan')" in message, message
    assert f"`nudge analyze RUN --plan PLAN --out {out} --force`" in message, message
    assert ("changed since the analysis kept it" if damage == "edited" else "cannot be read") in message


def test_a_tables_analysis_keeps_its_plan_file_too(
        analysed_under_a_plan_file: tuple[Path, Path, Path], tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    run, plan, _ = analysed_under_a_plan_file
    table = tmp_path / "study.csv"
    shutil.copy(run / "metrics.csv", table)
    assert nudge("analyze", table, "--plan", plan, "--bootstrap", "100").exit_code == 0
    loose = load_plan(plan).comparison_options()
    plan.write_text(LOOSE_PLAN.replace("0.9, 0.8, 0.7", "0.5, 0.4, 0.3"))  # edited after the analysis
    assert star_rule_plotted(monkeypatch, table) == loose  # was: the edited file's
    copy = tmp_path / "study-analysis" / "analysis_plan.toml"
    copy.write_text(plan.read_text())
    message = one_error_line(nudge("plot", table).output)
    assert f"({tmp_path / 'study-analysis' / 'stats.json'} 'table_read' 'plan')" in message, message
    assert f"run `nudge analyze {table} --plan {plan}` again before plotting" in message, message


def test_an_analysis_recording_no_plan_removes_the_plan_copy_an_earlier_one_kept(
        analysed_under_a_plan_file: tuple[Path, Path, Path]) -> None:
    run, _, out = analysed_under_a_plan_file
    again = nudge("analyze", run, "--plan", "study-code", "--out", out, "--force", "--bootstrap", "100")
    assert again.exit_code == 0, again.output
    assert json.loads((out / "stats.json").read_text())["plan"] == "study-code"  # a preset: by its name
    assert not (out / "analysis_plan.toml").exists()


def test_an_analysis_again_under_its_own_kept_plan_copy_reads_it_and_keeps_it(
        analysed_under_a_plan_file: tuple[Path, Path, Path], tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    run, plan, out = analysed_under_a_plan_file
    copy, kept = out / "analysis_plan.toml", (out / "analysis_plan.toml").read_bytes()
    again = nudge("analyze", run, "--plan", copy, "--out", out, "--force", "--bootstrap", "100")
    assert again.exit_code == 0, again.output  # was: "is this command's input (--plan) ... another --out"
    stats = json.loads((out / "stats.json").read_text())
    assert stats["plan"] == "analysis_plan.toml" and copy.read_bytes() == kept
    loose = load_plan(plan).comparison_options()
    assert star_rule_plotted(monkeypatch, out) == loose  # its SHA-256 as recorded: the copy checks
    # a run analysed in its own folder, then given its own copy: analyze and plot both take it
    assert nudge("analyze", run, "--plan", plan, "--bootstrap", "100").exit_code == 0
    own = run / "analysis_plan.toml"
    assert star_rule_plotted(monkeypatch, run, "--plan", own) == loose
    again = nudge("analyze", run, "--plan", own, "--bootstrap", "100")
    assert again.exit_code == 0, again.output
    # a table's analysis, given its own copy
    table = tmp_path / "study.csv"
    shutil.copy(run / "metrics.csv", table)
    assert nudge("analyze", table, "--plan", plan, "--bootstrap", "100").exit_code == 0
    again = nudge("analyze", table, "--plan", tmp_path / "study-analysis" / "analysis_plan.toml",
                  "--bootstrap", "100", "--force")
    assert again.exit_code == 0, again.output


def test_a_policy_module_on_sys_path_raising_as_it_is_imported_is_named_by_file_and_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from policy_helpers import QUIET_POLICY, policy_experiment

    ext = tmp_path / "ext"
    ext.mkdir()
    (ext / "extmod_s55.py").write_text(f"X = 1\nraise ValueError('x')\n{QUIET_POLICY}")
    monkeypatch.syspath_prepend(str(ext))
    experiment = policy_experiment(tmp_path / "pe", {"mine": "extmod_s55:Quiet"})
    message = one_error_line(nudge("simulate", experiment, "--out", tmp_path / "run").output)
    assert f"({ext / 'extmod_s55.py'} line 2: raise ValueError('x')); " in message, message
    assert "looked up beside the experiment file" not in message  # it was found: it raised


class _BatchMadeError(Exception):
    """Raised in place of a batch being run: its people are what the test wants."""


@pytest.mark.parametrize("kind", ["replicate", "power"])
def test_a_batch_of_a_runs_config_takes_the_people_file_it_keeps(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str) -> None:
    from people_helpers import PEOPLE_BYTES

    monkeypatch.chdir(tmp_path)
    Path("twins.csv").write_bytes(PEOPLE_BYTES)
    made = nudge("simulate", "smoke", "--participants", "1", "--people", "twins.csv", "--out", "run")
    assert made.exit_code == 0, made.output
    people: list[Any] = []

    def run_batch(batch: Any, *_: Any, **__: Any) -> None:
        people.append(batch.people)
        raise _BatchMadeError

    monkeypatch.setattr("nudgecli.runs.batch_kinds.run_batch", run_batch)
    counts = ["--participants", "12"] if kind == "replicate" else ["--participants", "6,12"]
    result = nudge(kind, "run/config.toml", "-R", "2", *counts, "--out", "batch")
    assert isinstance(result.exception, _BatchMadeError), result.output
    assert "Note: run/config.toml is the experiment of the run folder run" in result.output, result.output
    assert people[0] is not None and people[0].name == "twins.csv", people  # was: None (the population)
    (tmp_path / "run" / "people" / "twins.csv").unlink()  # its copy gone: names the file to give
    message = one_error_line(nudge(kind, "run/config.toml", "-R", "2", *counts, "--out", "lost").output)
    assert "give the file twins.csv it was simulated with (--people PATH/twins.csv)" in message, message
