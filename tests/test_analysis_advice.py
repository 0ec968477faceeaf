"""What ``nudge plot`` says and does about an analysis is true:

- an analysis killed mid-way (``stats.json`` removed first, written last) is named incomplete, with
  the ``nudge analyze`` command that completes it, not "no metrics yet" beside its metrics.csv;
- ``nudge plot --plan`` whose plot fails after the analysis leaves the folder's analysis as it was;
- a CIAA run's time limit is the one its manifest records, not an edited ``config.toml``'s;
- a plan built in code is recorded as no ``--plan`` (never ``custom``, which no preset is), and
  the advice says to give it again from Python; a record that names no plan invents none.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import file_digests, killed_analysis_at, nudge, one_error_line

import nudgecli.report.analysis as analysis_module
import nudgecli.report.plotting as plotting
from nudgecli.errors import WriteError
from nudgecli.report.plans import AnalysisPlan, load_plan

TABLE = Path(__file__).parent / "data" / "metrics_two_conditions.csv"
RECORDS = ("metrics.csv", "stats.json", "stats.csv", "summary.md", "manifest.json")



def test_plot_of_a_run_whose_analysis_was_killed_names_the_command_that_completes_it(
        analysed_smoke_run, tmp_path, monkeypatch):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    killed_analysis_at(monkeypatch, "summary.md", run, "--metric", "completion_time", "--bootstrap", "100")
    assert (run / "metrics.csv").is_file() and not (run / "stats.json").exists()
    line = one_error_line(nudge("plot", run, "--formats", "png", "--out", tmp_path / "figures").output)
    assert "no metrics yet" not in line and "analysis is incomplete" in line, line
    assert f"`nudge analyze {run}`" in line, line
    assert nudge("analyze", run, "--metric", "completion_time", "--bootstrap", "100").exit_code == 0
    assert (run / "stats.json").is_file()


def test_plot_of_a_tables_killed_analysis_names_the_table_to_analyse(tmp_path, monkeypatch):
    table = shutil.copy(TABLE, tmp_path / "study.csv")
    folder = tmp_path / "study-analysis"
    killed_analysis_at(monkeypatch, "summary.md", table)
    for given in (table, folder):  # the table, or its analysis folder: analyze takes the table
        line = one_error_line(nudge("plot", given, "--formats", "png").output)
        assert "analysis is incomplete" in line and f"`nudge analyze {table}`" in line, line
    # nothing there names the table
    killed_analysis_at(monkeypatch, "stats.csv", table, "--out", tmp_path / "D")
    line = one_error_line(nudge("plot", tmp_path / "D", "--formats", "png").output)
    assert f"`nudge analyze TABLE --out {tmp_path / 'D'}` (TABLE: the table analysed there" in line, line


def test_a_plot_plan_whose_plot_fails_puts_the_analysis_back(analysed_smoke_run, tmp_path, monkeypatch):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    before = file_digests(run, RECORDS)
    analysed: list[str] = []

    def fails(source: Path, *args: object, **kwargs: object) -> list[Path]:
        analysed.append(json.loads((Path(source) / "stats.json").read_text())["metrics"][0]["metric"])
        raise WriteError(f"cannot write {source}/figures: disk full")

    monkeypatch.setattr(plotting, "plot_folder", fails)
    result = nudge("plot", run, "--plan", "study-code", "--formats", "png")
    assert result.exit_code == 1 and "disk full" in one_error_line(result.output)
    assert analysed, "the plot ran after the analysis with the new plan"
    assert file_digests(run, RECORDS) == before
    assert not list(run.glob(".*.tmp")) and not (run / ".nudge.lock").exists()


def test_a_plot_plan_of_a_new_table_whose_plot_fails_leaves_no_analysis_folder(tmp_path, monkeypatch):
    table = shutil.copy(TABLE, tmp_path / "study.csv")

    def fails(*args: object, **kwargs: object) -> list[Path]:
        raise WriteError("cannot write figures: disk full")

    monkeypatch.setattr(plotting, "plot_folder", fails)
    assert nudge("plot", table, "--plan", "paper", "--formats", "png").exit_code == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.csv"]


def test_a_ciaa_runs_time_limit_is_the_one_its_manifest_records(tmp_path):
    run = tmp_path / "run"
    assert nudge("simulate", "ciaa-teleop", "--participants", "1", "--seed", "1", "--out", run).exit_code == 0
    assert nudge("analyze", run, "--metric", "completion_time", "--bootstrap", "100").exit_code == 0
    recorded = json.loads((run / "manifest.json").read_text())["config"]["study"]["time_limit_s"]
    config = (run / "config.toml").read_text()
    assert f"time_limit_s = {recorded}" in config
    (run / "config.toml").write_text(config.replace(f"time_limit_s = {recorded}", "time_limit_s = 7.0"))
    assert plotting.read_inputs(run).time_limit_s == recorded


def test_plan_argument_names_presets_and_files_and_no_plan_built_in_code(tmp_path):
    from nudgecli.report.plans import plan_argument

    plan_file = tmp_path / "mine.toml"
    shutil.copy(Path(__file__).parents[1] / "analysis" / "study-code.toml", plan_file)
    from_file = load_plan(plan_file)
    assert plan_argument(load_plan("study-code")) == "study-code"
    assert plan_argument(from_file) == str(plan_file.resolve())
    assert plan_argument(AnalysisPlan()) is None
    assert plan_argument(AnalysisPlan(name="paper")) is None  # a preset's name, not its settings
    assert plan_argument(from_file.model_copy(update={"filters": {}})) is None  # changed in code


def test_a_table_analysed_with_a_plan_built_in_code_is_advised_from_python(tmp_path):
    table = shutil.copy(TABLE, tmp_path / "study.csv")
    analysis_module.analyze(table, plan=AnalysisPlan(bootstrap={"resamples": 100}))
    stats = json.loads((tmp_path / "study-analysis" / "stats.json").read_text())
    assert stats["table_read"]["plan"] is None  # built in code: no --plan names it
    table.write_text("".join(table.read_text().splitlines(keepends=True)[:-1]))  # edited since
    line = one_error_line(nudge("plot", table, "--formats", "png").output)
    assert "--plan" not in line.split("no --plan names")[-1] and "custom" not in line, line
    assert "built in code" in line and f"`nudgecli.analyze({str(table)!r}, plan=PLAN)`" in line, line


def test_a_run_analysed_with_a_plan_built_in_code_keeps_its_default_plan(analysed_smoke_run, tmp_path):
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    del manifest["plan"]  # a run of an older nudge: the analysis records the plan it used
    (run / "manifest.json").write_text(json.dumps(manifest))
    default = analysis_module.plan_of_source(run)
    analysis_module.analyze(run, plan=AnalysisPlan(bootstrap={"resamples": 100}),
                            metrics=["completion_time"])
    assert "plan" not in json.loads((run / "manifest.json").read_text())  # never "custom"
    assert analysis_module.plan_of_source(run) == default


def test_a_record_that_names_no_plan_invents_none(tmp_path):
    table = shutil.copy(TABLE, tmp_path / "study.csv")
    assert nudge("analyze", table, "--plan", "study-code", "--bootstrap", "100").exit_code == 0
    stats_path = tmp_path / "study-analysis" / "stats.json"
    stats = json.loads(stats_path.read_text())
    del stats["table_read"]["plan"], stats["table_read"]["questionnaires"]  # an older nudge's record
    stats_path.write_text(json.dumps(stats))
    table.write_text("".join(table.read_text().splitlines(keepends=True)[:-1]))  # edited since
    line = one_error_line(nudge("plot", table, "--formats", "png").output)
    assert f"run `nudge analyze {table}` again (adding the --plan it was analysed with" in line, line
    assert "does not record it" in line, line


def test_the_advice_names_a_recorded_plan_and_no_other(tmp_path):
    from nudgecli.report.table_read import analyze_again

    folder, table = tmp_path / "study-analysis", tmp_path / "study.csv"
    assert "does not record it" in analyze_again(table, folder, False, None)  # no record at all
    named = analyze_again(table, folder, False, {"plan": "study-code"})
    assert named == f"run `nudge analyze {table} --plan study-code` again"


def test_plot_with_a_plan_built_in_code_over_questionnaire_scores_is_advised_from_python(tmp_path):
    from nudgecli.api.figures import save_figures
    from nudgecli.errors import ConfigError

    table = shutil.copy(TABLE, tmp_path / "study.csv")
    answers = shutil.copy(TABLE.with_name("questionnaires_two_conditions.csv"), tmp_path / "q.csv")
    assert nudge("analyze", table, "--questionnaires", answers, "--bootstrap", "100").exit_code == 0
    with pytest.raises(ConfigError) as refused:
        save_figures(table, plan=AnalysisPlan(bootstrap={"resamples": 100}), formats="png")
    message = str(refused.value)
    assert "--plan custom" not in message and "built in code" in message, message
    assert f"`nudgecli.analyze({str(table)!r}, plan=PLAN, questionnaires='ANSWERS.csv')`" in message, message
