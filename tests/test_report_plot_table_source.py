"""`nudge plot TABLE.csv` draws a table only as its analysis read it.

The analysis of a table records in ``stats.json`` what it did to the rows it read
(``table_read``: the table's SHA-256, its rows, whether repeated trial rows were to be dropped and
how many were) and, where it changed the table, writes the rows it analysed to ``metrics.csv``.
Plotting the table checks its bytes against that record and then draws the analysis's own rows,
so a table edited after its analysis, even by one row that exactly repeats a trial's key (which
dropping duplicates again would hide), is refused with the command that brings the analysis up to
date.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.report import plotting

# the table as the paper plan analyses it (no time for a failed trial): analysed as it is
TABLE = Path(__file__).parent / "data" / "metrics_two_conditions_paper.csv"


@pytest.fixture
def analysed_with_duplicates(tmp_path: Path) -> Path:
    """A copy of the two-condition table with two trial rows repeated at its end, analysed with
    ``--drop-duplicates`` (the analysis folder ``study-analysis/`` beside it)."""
    table = pd.read_csv(TABLE)
    doubled = pd.concat([table, table.iloc[[3, 10]]], ignore_index=True)
    source = tmp_path / "study.csv"
    doubled.to_csv(source, index=False)
    result = CliRunner().invoke(main, ["analyze", str(source), "--drop-duplicates"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "study-analysis" / "metrics.csv").is_file()
    return source


def test_plot_of_the_table_draws_the_analysed_rows(analysed_with_duplicates, monkeypatch, tmp_path):
    drawn: list[pd.DataFrame] = []
    write_figures = plotting.write_figures

    def spy(inputs: plotting.FigureInputs, plan: Any) -> list[Path]:
        drawn.append(inputs.metrics)
        return write_figures(inputs, plan)

    monkeypatch.setattr(plotting, "write_figures", spy)
    result = CliRunner().invoke(main, ["plot", str(analysed_with_duplicates), "--formats", "png",
                                       "--out", str(tmp_path / "figures")])
    assert result.exit_code == 0, result.output
    assert list((tmp_path / "figures").glob("*.png"))
    analysed = pd.read_csv(tmp_path / "study-analysis" / "metrics.csv")
    assert len(drawn) == 1 and len(drawn[0]) == len(analysed) == len(pd.read_csv(TABLE))
    key = ["participant", "condition", "trial", "completion_time"]
    pd.testing.assert_frame_equal(drawn[0][key].astype(str).reset_index(drop=True), analysed[key].astype(str))


def plot(table: Path, out: Path) -> Any:
    return CliRunner().invoke(main, ["plot", str(table), "--formats", "png", "--out", str(out)])


def test_a_table_edited_after_its_analysis_is_refused(analysed_with_duplicates, tmp_path):
    edited = pd.read_csv(analysed_with_duplicates)
    edited.loc[0, "completion_time"] += 1.0
    edited.to_csv(analysed_with_duplicates, index=False)
    result = plot(analysed_with_duplicates, tmp_path / "figures")
    assert result.exit_code != 0 and not (tmp_path / "figures").exists()
    rows = len(pd.read_csv(TABLE)) + 2
    assert result.output.count("\n") == 1 and result.output.startswith(f"Error: {analysed_with_duplicates} ")
    assert f"edited since its analysis ({rows} rows when analysed, 2 repeated trial row(s) dropped; " \
           f"{rows} rows now; its SHA-256 differs)" in result.output
    assert f"run `nudge analyze {analysed_with_duplicates} --drop-duplicates` again" in result.output


def test_a_row_repeating_a_trial_added_after_the_analysis_is_refused(analysed_with_duplicates, tmp_path):
    """The row would be dropped again as a duplicate: the figures would match the statistics, but
    the table is not the one analysed."""
    table = pd.read_csv(analysed_with_duplicates)
    pd.concat([table, table.iloc[[0]]]).to_csv(analysed_with_duplicates, index=False)
    result = plot(analysed_with_duplicates, tmp_path / "figures")
    assert result.exit_code != 0 and not (tmp_path / "figures").exists()
    rows = len(table)
    assert f"({rows} rows when analysed, 2 repeated trial row(s) dropped; {rows + 1} rows now" \
        in result.output
    assert "--drop-duplicates` again before plotting" in result.output


def test_a_repeated_row_added_to_a_table_analysed_as_it_was_names_the_flag_the_analysis_needs(tmp_path):
    # analysed without --drop-duplicates (none then); the command to run must pass the repeat now
    source = tmp_path / "study.csv"
    table = pd.read_csv(TABLE)
    table.to_csv(source, index=False)
    assert CliRunner().invoke(main, ["analyze", str(source)]).exit_code == 0
    pd.concat([table, table.iloc[[0]]]).to_csv(source, index=False)
    result = plot(source, tmp_path / "figures")
    assert result.exit_code != 0 and f"run `nudge analyze {source} --drop-duplicates` again" in result.output
    table.iloc[1:].to_csv(source, index=False)  # a row removed: the plain command does
    assert f"run `nudge analyze {source}` again" in plot(source, tmp_path / "figures").output


def stats_of(folder: Path) -> dict[str, Any]:
    return json.loads((folder / "stats.json").read_text())


@pytest.mark.parametrize("repeats, flag", [(2, True), (0, True), (0, False)])
def test_stats_json_records_what_the_analysis_did_to_the_rows_it_read(tmp_path, repeats, flag):
    table = pd.read_csv(TABLE)
    source = tmp_path / "study.csv"
    pd.concat([table, table.iloc[:repeats]]).to_csv(source, index=False)
    args = ["analyze", str(source), "--bootstrap", "100"] + (["--drop-duplicates"] if flag else [])
    assert CliRunner().invoke(main, args).exit_code == 0
    record = stats_of(tmp_path / "study-analysis")["table_read"]
    assert record == {"sha256": hashlib.sha256(source.read_bytes()).hexdigest(), "rows": len(table) + repeats,
                      "drop_duplicates": flag, "duplicates_dropped": repeats, "table": "../study.csv",
                      "plan": "paper", "questionnaires": None}
    # a table analysed as it is is drawn from itself, one whose rows were dropped from metrics.csv
    assert (tmp_path / "study-analysis" / "metrics.csv").is_file() == (repeats > 0)
    assert plot(source, tmp_path / "figures").exit_code == 0


def test_a_run_folders_analysis_records_no_table(tmp_path):
    """Only a table is read as one file of rows; a run's parts have SHA-256s of their own."""
    from run_builders import synthetic_run

    run = synthetic_run(tmp_path / "run", {"control": 0, "disambiguation": 3}, n_participants=3,
                        trials_per_condition=2, seed=1, max_steps=30, switch_probability=lambda extra: 0.2)
    result = CliRunner().invoke(main, ["analyze", str(run), "--bootstrap", "100"])
    assert result.exit_code == 0, result.output
    assert "table_read" not in stats_of(run) and "metrics_checksum" in stats_of(run)


def older_analysis(folder: Path) -> None:
    """``stats.json`` as a nudge before the record wrote it."""
    stats = stats_of(folder)
    del stats["table_read"]
    (folder / "stats.json").write_text(json.dumps(stats, indent=2) + "\n")


def test_an_older_analysis_of_a_table_as_it_is_is_still_drawn(tmp_path):
    source = tmp_path / "study.csv"
    source.write_bytes(TABLE.read_bytes())
    assert CliRunner().invoke(main, ["analyze", str(source), "--bootstrap", "100"]).exit_code == 0
    older_analysis(tmp_path / "study-analysis")
    assert plot(source, tmp_path / "figures").exit_code == 0
    table = pd.read_csv(source)
    table.loc[0, "completion_time"] += 1.0
    table.to_csv(source, index=False)
    assert "stale or edited" in plot(source, tmp_path / "again").output  # the checksum still decides


def test_an_older_analysis_that_may_have_dropped_repeated_rows_is_a_clear_error(analysed_with_duplicates,
                                                                               tmp_path):
    older_analysis(tmp_path / "study-analysis")
    result = plot(analysed_with_duplicates, tmp_path / "figures")
    assert result.exit_code != 0 and result.output.count("\n") == 1 and "Traceback" not in result.output
    assert "holds repeated trial rows and" in result.output and "older nudge" in result.output
    assert f"run `nudge analyze {analysed_with_duplicates} --drop-duplicates` again" in result.output


def test_a_malformed_record_or_a_lost_metrics_csv_is_a_clear_error(analysed_with_duplicates, tmp_path):
    folder = tmp_path / "study-analysis"
    (folder / "metrics.csv").unlink()
    result = plot(analysed_with_duplicates, tmp_path / "figures")
    assert result.exit_code != 0 and "metrics.csv is gone" in result.output
    stats = stats_of(folder)
    stats["table_read"]["rows"] = "many"
    (folder / "stats.json").write_text(json.dumps(stats))
    result = plot(analysed_with_duplicates, tmp_path / "figures")
    assert result.exit_code != 0 and "`table_read` is malformed" in result.output
    assert "Traceback" not in result.output


def test_the_command_to_run_names_an_analysis_folder_of_its_own(tmp_path):
    from nudgecli.report.table_read import analyze_command

    table = tmp_path / "study.csv"
    assert analyze_command(table, tmp_path / "study-analysis", False) == f"nudge analyze {table}"
    assert analyze_command(table, tmp_path, True) == \
        f"nudge analyze {table} --out {tmp_path} --force --drop-duplicates"


def test_a_parquet_tables_record_is_the_sha256_of_its_bytes_and_an_edit_is_refused(tmp_path):
    """A Parquet file is binary: its record must be the hash of the bytes, not of any text made of
    them, and rewriting one value (another file of the same shape) is refused like a CSV edit."""
    source = tmp_path / "study.parquet"
    table = pd.read_csv(TABLE)
    table.to_parquet(source, index=False)
    assert CliRunner().invoke(main, ["analyze", str(source), "--bootstrap", "100"]).exit_code == 0
    record = stats_of(tmp_path / "study-analysis")["table_read"]
    assert record["sha256"] == hashlib.sha256(source.read_bytes()).hexdigest()
    assert record["rows"] == len(table) and record["duplicates_dropped"] == 0
    assert plot(source, tmp_path / "figures").exit_code == 0
    table.loc[0, "completion_time"] += 1.0
    table.to_parquet(source, index=False)
    result = plot(source, tmp_path / "again")
    assert result.exit_code != 0 and not (tmp_path / "again").exists()
    assert f"({len(table)} rows when analysed; {len(table)} rows now; its SHA-256 differs)" in result.output


def test_plot_plan_of_an_analysis_written_elsewhere_finds_the_changed_table(analysed_with_duplicates,
                                                                            tmp_path):
    # the analysis changed the table (repeated rows dropped) and lives away from it: its record
    # names the table, so --plan can analyse it again (it looked beside the folder only)
    folder = tmp_path / "analyses" / "first"
    args = ["analyze", str(analysed_with_duplicates), "--drop-duplicates", "--out", str(folder)]
    assert CliRunner().invoke(main, args).exit_code == 0
    assert stats_of(folder)["table_read"]["table"] == "../../study.csv"
    result = CliRunner().invoke(main, ["plot", str(folder), "--plan", "paper", "--formats", "png"])
    assert result.exit_code == 0, result.output
    analysed_with_duplicates.write_text(analysed_with_duplicates.read_text() + "\n")  # edited since
    result = CliRunner().invoke(main, ["plot", str(folder), "--plan", "paper", "--formats", "png"])
    assert result.exit_code == 1 and "that table is not there (moved, or edited since)" in result.output
