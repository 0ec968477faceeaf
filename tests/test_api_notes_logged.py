"""A notebook sees what the command line sees: the ``Note:`` lines ``nudge analyze``, ``nudge run``
and ``nudge compare`` print on stderr go to the functions' ``log=``, worded by one owner, and a
DataFrame analysed without ``out=`` is named as what it is."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import nudge

import nudgecli
from nudgecli import api
from nudgecli.api import analysis as api_analysis


def _study() -> pd.DataFrame:
    """Three participants in two conditions, and P04 in one only: the participant-level test drops
    P04, and the success column makes completion_time's definition a note."""
    rows = []
    for number, person in enumerate(("P01", "P02", "P03", "P04")):
        for condition in ("control", "disambiguation") if person != "P04" else ("control",):
            for trial in (1, 2):
                slower = 5 if condition == "control" else 0
                rows.append({"participant": person, "condition": condition, "trial": trial,
                             "completion_time": 30.0 + 3 * number + trial + slower, "success": 1})
    return pd.DataFrame(rows)


@pytest.fixture
def study_csv(tmp_path: Path) -> Path:
    path = tmp_path / "study.csv"
    _study().to_csv(path, index=False)
    return path


def _dropped(lines: list[str]) -> bool:
    return any(line.startswith("Note: ") and "dropped: P04" in line for line in lines)


def test_analyze_of_a_table_sends_its_notes_to_log(study_csv: Path) -> None:
    logs: list[str] = []
    analysis = nudgecli.analyze(study_csv, log=logs.append, bootstrap=100)
    assert analysis.notes and logs == [api_analysis.note_line(note) for note in analysis.notes]
    assert _dropped(logs)


def test_analyze_of_a_dataframe_sends_its_notes_to_log_naming_the_frame() -> None:
    logs: list[str] = []
    with nudgecli.analyze(_study(), log=logs.append, bootstrap=100) as analysis:
        assert logs == [api_analysis.note_line(note) for note in analysis.notes] and _dropped(logs)
        # the table is this call's temporary copy: a note names what was given, as an error does
        assert not any(str(analysis.path) in line for line in logs)
        assert any(line.startswith(f"Note: {api_analysis.FRAME_NAME}: completion_time") for line in logs)


def test_summary_of_a_dataframe_without_out_names_no_file() -> None:
    with nudgecli.analyze(_study(), bootstrap=100) as analysis:
        summary = analysis.summary()
        assert f"- source: {api_analysis.FRAME_SOURCE}\n" in summary
        assert api_analysis.DATAFRAME_TABLE not in summary
        assert (analysis.path / "summary.md").read_text(encoding="utf-8") == summary


def test_summary_of_a_dataframe_with_out_names_its_table(tmp_path: Path) -> None:
    analysis = nudgecli.analyze(_study(), bootstrap=100, out=tmp_path / "analysis")
    assert f"- source: `{api_analysis.DATAFRAME_TABLE}`" in analysis.summary()  # it stays there


def test_nudge_analyze_prints_each_note_once(study_csv: Path) -> None:
    result = nudge("analyze", study_csv, "--bootstrap", "100")
    assert result.exit_code == 0, result.output
    analysis_notes = nudgecli.analyze(study_csv, bootstrap=100, force=True).notes
    printed = [line for line in result.output.splitlines() if line.startswith("Note: ")]
    assert printed == [api_analysis.note_line(note) for note in analysis_notes]


def test_compare_sends_its_notes_to_log_and_the_command_prints_them_once(study_csv: Path) -> None:
    logs: list[str] = []
    comparison = nudgecli.compare(study_csv, study_csv, resamples=0, log=logs.append)
    assert comparison.notes and logs == [api_analysis.note_line(note) for note in comparison.notes]
    result = nudge("compare", study_csv, study_csv, "--resamples", "0")
    assert result.exit_code == 0, result.output
    assert [line for line in result.output.splitlines() if line.startswith("Note: ")] == logs


def test_analyze_and_plot_sends_the_analysis_notes_to_log(analysed_smoke_run: Path, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    # nudge run's second half; the figures are not what is checked here
    monkeypatch.setattr("nudgecli.report.plotting.plot_folder", lambda *args, **kwargs: [])
    run = Path(shutil.copytree(analysed_smoke_run, tmp_path / "run"))
    logs: list[str] = []
    analysis, _ = api.analyze_and_plot(run, log=logs.append)
    assert analysis.notes
    assert [line for line in logs if line.startswith("Note: ")] == \
        [api_analysis.note_line(note) for note in analysis.notes]


def test_fit_people_sends_its_note_lines_to_log(tmp_path: Path) -> None:
    table = tmp_path / "habits.csv"  # one participant with one habit: the rest is the population's
    table.write_text("scope,participant,habit,n,median,q25,q75\n"
                     "participant,0,first_command_latency,8,2.65,2.6,2.9\n")
    logs: list[str] = []
    people = nudgecli.fit_people(table, log=logs.append)
    assert logs and logs == people.note_lines() and all(line.startswith("Note: person 0 ") for line in logs)
    made = nudge("fit-people", table, "--out", tmp_path / "people.csv")
    assert made.exit_code == 0, made.output
    assert [line for line in made.stderr.splitlines() if line.startswith("Note: ")] == logs


def test_validate_sends_its_notes_to_log(monkeypatch: pytest.MonkeyPatch) -> None:
    # the notes are on the options; the validation itself is not what is checked here
    monkeypatch.setattr("nudgecli.sim.validation.run_all_readings", lambda settings, names, progress: [])
    logs: list[str] = []
    checked = nudgecli.validate(simulations=1, min_goals=3, max_goals=3, states=72, mc_queries=0,
                                all_readings=True, log=logs.append)
    assert checked.notes and logs == [api_analysis.note_line(note) for note in checked.notes]
    monkeypatch.setattr("nudgecli.api.validation.Validation.text", lambda self: "the table")
    result = nudge("validate", "--simulations", "1", "--min-goals", "3", "--max-goals", "3", "--mc-queries",
                   "0", "--all-readings", "--states", "72")
    assert result.exit_code == 0, result.output
    assert [line for line in result.stderr.splitlines() if line.startswith("Note: ")] == logs
