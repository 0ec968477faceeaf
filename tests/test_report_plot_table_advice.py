"""The ``nudge analyze`` command ``nudge plot TABLE`` prints for a table edited after its analysis
repeats what that analysis used: its plan and its questionnaires file (``stats.json``'s
``table_read`` records both, as seen from the analysis folder), so that following the advice
literally restores the same analysis and the plot then draws it."""

from __future__ import annotations

import json
import re
import shlex
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main

DATA = Path(__file__).parent / "data"
PLAN_FILE = Path(__file__).parents[1] / "analysis" / "study-code.toml"


def invoke(*args: str) -> object:
    return CliRunner().invoke(main, list(args))


def plan_line(folder: Path) -> str:
    lines = [line for line in (folder / "summary.md").read_text().splitlines() if line.startswith("- plan:")]
    assert len(lines) == 1
    return lines[0].split(";")[0]


def edit(table: Path) -> None:
    lines = table.read_text().splitlines(keepends=True)
    table.write_text("".join(lines[:-1]))  # the last trial row removed


def advice(output: str) -> list[str]:
    """The command of the one Error line, as words (``nudge`` left out)."""
    assert output.count("\n") == 1 and output.startswith("Error: "), output
    found = re.search(r"run `(nudge analyze [^`]+)` again before plotting", output)
    assert found, output
    return shlex.split(found.group(1))[1:]


@pytest.fixture
def study(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """study.csv and q.csv in the working folder ``tmp_path``, a plan file in ``plans/``."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(DATA / "metrics_two_conditions.csv", tmp_path / "study.csv")
    shutil.copy(DATA / "questionnaires_two_conditions.csv", tmp_path / "q.csv")
    (tmp_path / "plans").mkdir()
    shutil.copy(PLAN_FILE, tmp_path / "plans" / "mine.toml")
    return tmp_path


@pytest.mark.parametrize("analysed_with", [
    ["--plan", "study-code"],
    ["--plan", "study-code", "--questionnaires", "q.csv"],
    ["--plan", "plans/mine.toml", "--questionnaires", "q.csv", "--out", ".", "--force"],  # the table's folder
])
def test_following_the_printed_advice_restores_the_same_analysis(study, analysed_with):
    result = invoke("analyze", "study.csv", *analysed_with)
    assert result.exit_code == 0, result.output
    folder = study if "--out" in analysed_with else study / "study-analysis"
    before = plan_line(folder)
    # a plan file is named by its file as seen from the analysis folder, a preset by its name
    assert before == "- plan: " + ("plans/mine.toml" if "plans/mine.toml" in analysed_with else "study-code")
    edit(study / "study.csv")

    refused = invoke("plot", "study.csv", "--formats", "png")
    assert refused.exit_code != 0
    command = advice(refused.output)
    assert command[:2] == ["analyze", "study.csv"]
    assert ("--questionnaires" in command) == ("--questionnaires" in analysed_with)
    assert ("--out" in command) == ("--out" in analysed_with)

    again = invoke(*command)  # the advice, literally
    assert again.exit_code == 0, again.output
    assert plan_line(folder) == before
    assert (folder / "questionnaire_scores.csv").is_file() == ("--questionnaires" in analysed_with)
    plotted = invoke("plot", "study.csv", "--formats", "png")
    assert plotted.exit_code == 0, plotted.output


def test_the_advice_names_files_as_seen_from_where_plot_runs(study, monkeypatch):
    analysed = invoke("analyze", "study.csv", "--plan", "plans/mine.toml", "--questionnaires", "q.csv")
    assert analysed.exit_code == 0
    record = json.loads((study / "study-analysis" / "stats.json").read_text())["table_read"]
    # seen from the analysis folder: no machine's path in the document
    assert (record["plan"], record["questionnaires"]) == ("../plans/mine.toml", "../q.csv")
    edit(study / "study.csv")
    monkeypatch.chdir(study / "plans")
    command = advice(invoke("plot", "../study.csv").output)
    assert command == ["analyze", "../study.csv", "--plan", "../plans/mine.toml",
                       "--questionnaires", "../q.csv"]
    assert invoke(*command).exit_code == 0
    assert invoke("plot", "../study.csv", "--formats", "png").exit_code == 0


def test_the_default_plan_is_not_named_and_an_older_record_is_read(study):
    from nudgecli.report.table_read import analyze_command

    assert invoke("analyze", "study.csv").exit_code == 0
    stats_path = study / "study-analysis" / "stats.json"
    stats = json.loads(stats_path.read_text())
    assert stats["table_read"]["plan"] == "paper" and stats["table_read"]["questionnaires"] is None
    folder = Path("study-analysis")
    assert analyze_command(Path("study.csv"), folder, False, stats["table_read"]) == "nudge analyze study.csv"
    # a record of a nudge before these keys: the command names neither, the plot reads it
    del stats["table_read"]["plan"], stats["table_read"]["questionnaires"]
    stats_path.write_text(json.dumps(stats))
    assert invoke("plot", "study.csv", "--formats", "png").exit_code == 0
    stats["table_read"]["plan"] = 3
    stats_path.write_text(json.dumps(stats))
    result = invoke("plot", "study.csv", "--formats", "png")
    assert result.exit_code != 0 and "`table_read` is malformed" in result.output


def test_a_plan_file_in_the_analysis_folder_is_never_taken_for_a_preset(tmp_path):
    from nudgecli.report.table_read import analysed_inputs, analyze_command

    folder = tmp_path / "out"
    plan, questionnaires = analysed_inputs(folder, str(folder / "paper"), None)
    assert plan == "./paper" and questionnaires is None
    command = analyze_command(tmp_path / "t.csv", folder, False, {"plan": plan})
    assert command.endswith(f"--plan {folder / 'paper'}")
