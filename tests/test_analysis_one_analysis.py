"""An analysis folder holds one analysis: analysing again removes the outputs of the earlier
analysis that this one does not write (``questionnaire_scores.csv``, ``metrics.csv``), never an
input; a questionnaire table answering fewer conditions than the trials is analysed with a note."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from run_builders import synthetic_run

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.report.analysis import analyze
from nudgecli.report.questionnaires import read_analysed_scores

DATA = Path(__file__).parent / "data"
METRICS_CSV = DATA / "metrics_two_conditions.csv"
QUESTIONNAIRES_CSV = DATA / "questionnaires_two_conditions.csv"


def test_analysing_again_without_questionnaires_removes_the_earlier_scores(tmp_path: Path) -> None:
    table = tmp_path / "study.csv"
    shutil.copy(METRICS_CSV, table)
    folder = tmp_path / "study-analysis"
    analyze(table, questionnaires=QUESTIONNAIRES_CSV)
    assert (folder / "questionnaire_scores.csv").is_file()
    result = analyze(table)
    assert not (folder / "questionnaire_scores.csv").exists()
    assert sorted(p.name for p in folder.iterdir()) == sorted(p.name for p in result.files)
    stats = json.loads((folder / "stats.json").read_text())  # what `nudge plot` reads first
    assert read_analysed_scores(folder, stats, "stats.json") is None


def test_analysing_again_with_a_plan_that_keeps_the_table_removes_the_earlier_metrics_csv(tmp_path) -> None:
    analyze(METRICS_CSV, out=tmp_path)  # paper: successful trials' times only, so metrics.csv
    assert (tmp_path / "metrics.csv").is_file()
    analyze(METRICS_CSV, out=tmp_path, plan="study-code")  # the table as it is: no metrics.csv
    assert not (tmp_path / "metrics.csv").exists()
    stats = json.loads((tmp_path / "stats.json").read_text())
    assert stats["metrics_table"] != "metrics.csv"


def test_a_table_named_metrics_csv_analysed_in_its_own_folder_is_kept(tmp_path: Path) -> None:
    table = tmp_path / "metrics.csv"
    shutil.copy(METRICS_CSV, table)
    before = table.read_bytes()
    analyze(table, out=tmp_path, plan="study-code")  # the table as it is: metrics.csv not written
    assert table.read_bytes() == before
    result = CliRunner().invoke(main, ["analyze", str(table), "--out", str(tmp_path), "--plan", "study-code",
                                       "--force"])
    assert result.exit_code == 0, result.output
    assert table.read_bytes() == before


def test_a_run_analysed_again_without_questionnaires_loses_the_earlier_scores(tmp_path: Path) -> None:
    run = synthetic_run(tmp_path / "run", {"disambiguation": 0, "control": 20}, n_participants=3,
                        trials_per_condition=2, seed=1, max_steps=30,
                        switch_probability=lambda extra: 0.1)
    answers = pd.read_csv(QUESTIONNAIRES_CSV)  # its participants 1..3 as the run's 0..2
    answers = answers[answers["participant"].isin([1, 2, 3])].drop_duplicates(["participant", "condition"])
    answers.drop(columns="block").assign(participant=answers["participant"] - 1).to_csv(
        tmp_path / "answers.csv", index=False)  # no blocks: the run's own block order is not the table's
    analyze(run, questionnaires=tmp_path / "answers.csv")
    assert (run / "questionnaire_scores.csv").is_file()
    analyze(run)
    assert not (run / "questionnaire_scores.csv").exists() and (run / "metrics.csv").is_file()


def test_questionnaires_answering_fewer_conditions_are_analysed_with_a_note(tmp_path: Path) -> None:
    answers = pd.read_csv(QUESTIONNAIRES_CSV)
    some = tmp_path / "some.csv"
    answers[answers["condition"] == "control"].to_csv(some, index=False)
    result = analyze(METRICS_CSV, out=tmp_path / "out", questionnaires=some)
    assert [n for n in result.notes if "no answers" in n] == \
        [f"{some}: no answers in condition(s) disambiguation; the questionnaires are analysed in the "
         "conditions answered"]
    assert "tlx_raw" in [m["metric"] for m in result.stats["metrics"]]


def test_questionnaires_with_a_condition_the_trials_lack_are_refused(tmp_path: Path) -> None:
    answers = pd.read_csv(QUESTIONNAIRES_CSV)
    other = tmp_path / "other.csv"
    answers.assign(condition=answers["condition"].replace("control", "manual")).to_csv(other, index=False)
    with pytest.raises(DataError, match=r"conditions \['manual'\] are not among those of"):
        analyze(METRICS_CSV, out=tmp_path / "out", questionnaires=other)


def test_the_api_writes_a_tables_analysis_beside_it_as_docs_api_says(tmp_path: Path) -> None:
    import nudgecli

    table = tmp_path / "study.csv"
    shutil.copy(METRICS_CSV, table)
    analysis = nudgecli.analyze(table, bootstrap=100)
    assert analysis.path == tmp_path / "study-analysis" and (analysis.path / "stats.json").is_file()
    api_md = (Path(__file__).parents[1] / "docs" / "api.md").read_text(encoding="utf-8")
    assert '(`analyze("study.csv")` writes `study-analysis/`' in " ".join(api_md.split())
    assert "Without `out=` nothing is written" not in api_md  # the other commands' functions only
