"""A metrics table's analysis folder holds that table's analysis, never another's.

``study.csv`` and ``study.parquet`` share the default folder ``study-analysis/``; analysing the
second there while it holds the first's analysis is refused (one ``Error:`` line naming the
folder, the table whose analysis it holds, ``--out`` and ``--force``) and leaves the first's
analysis as it was (:mod:`nudgecli.report.analysis_folders`).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import file_digests, nudge, stderr_error_line

from nudgecli.errors import RunFolderError
from nudgecli.report.analysis import analysed_metrics_path
from nudgecli.report.analysis_folders import analysed_table, analysis_folder, check_folder_is_the_tables

# the table as the paper plan analyses it (no time for a failed trial): analysed as it is
TABLE = Path(__file__).parent / "data" / "metrics_two_conditions_paper.csv"
ANALYSIS_FILES = ("stats.json", "stats.csv", "summary.md", "metrics.csv")


_nudge, _error_line = nudge, stderr_error_line


def _digests(folder: Path) -> dict[str, str]:
    return file_digests(folder, ANALYSIS_FILES)


def _study_csv(folder: Path, repeated_rows: int = 0) -> Path:
    """The two-condition table as ``study.csv`` (its first ``repeated_rows`` rows repeated at its end)."""
    table = pd.read_csv(TABLE)
    table = pd.concat([table, table.iloc[:repeated_rows]], ignore_index=True)
    table.to_csv(folder / "study.csv", index=False)
    return folder / "study.csv"


def _study_parquet(folder: Path) -> Path:
    """Other data of the same stem: the table without its last participant, as Parquet."""
    table = pd.read_csv(TABLE)
    table[table["participant"] != table["participant"].max()].to_parquet(folder / "study.parquet")
    return folder / "study.parquet"


def _metrics_table(folder: Path) -> object:
    return json.loads((folder / "stats.json").read_text(encoding="utf-8"))["metrics_table"]


@pytest.mark.parametrize("out", [False, True], ids=["default-folder", "out-names-it"])
def test_a_second_table_of_the_same_stem_is_refused_and_the_first_analysis_kept(tmp_path, out):
    csv = _study_csv(tmp_path)
    assert _nudge("analyze", csv).exit_code == 0
    folder = tmp_path / "study-analysis"
    before = _digests(folder)
    parquet = _study_parquet(tmp_path)
    line = _error_line(_nudge("analyze", parquet, *(["--out", folder] if out else [])))
    assert line.startswith(f"Error: {folder} holds the analysis of {csv}, not of {parquet}")
    assert "--out" in line and "--force" in line
    assert _digests(folder) == before and _metrics_table(folder) == "../study.csv"
    # and the table whose analysis it is still plots (QA: it was blamed for being "edited since")
    plotted = _nudge("plot", csv, "--formats", "png")
    assert plotted.exit_code == 0, plotted.output


def test_force_replaces_the_other_tables_analysis(tmp_path):
    assert _nudge("analyze", _study_csv(tmp_path)).exit_code == 0
    result = _nudge("analyze", _study_parquet(tmp_path), "--force")
    assert result.exit_code == 0, result.output
    assert _metrics_table(tmp_path / "study-analysis") == "../study.parquet"


def test_an_analysis_that_changed_the_table_is_known_by_the_bytes_it_read(tmp_path):
    """The rows are in ``metrics.csv``; ``table_read``'s SHA-256 says they were study.csv's."""
    csv = _study_csv(tmp_path, repeated_rows=2)
    assert _nudge("analyze", csv, "--drop-duplicates").exit_code == 0
    folder = tmp_path / "study-analysis"
    assert _metrics_table(folder) == "metrics.csv"
    before = _digests(folder)
    line = _error_line(_nudge("analyze", _study_parquet(tmp_path)))
    assert f"holds the analysis of {csv}," in line
    assert _digests(folder) == before


def test_the_same_table_is_analysed_again_into_its_folder_even_when_edited_since(tmp_path):
    csv = _study_csv(tmp_path, repeated_rows=2)
    _study_parquet(tmp_path)  # a sibling that shares the folder but whose analysis it is not
    assert _nudge("analyze", csv, "--drop-duplicates").exit_code == 0
    assert _nudge("analyze", csv, "--drop-duplicates", "--plan", "study-code").exit_code == 0
    _study_csv(tmp_path, repeated_rows=3)  # edited: its bytes are no longer the recorded ones
    assert _nudge("analyze", csv, "--drop-duplicates").exit_code == 0
    clean = _study_csv(tmp_path)  # analysed as it is: metrics_table names it
    assert _nudge("analyze", clean).exit_code == 0 and _nudge("analyze", clean).exit_code == 0


def _stats(folder: Path, **fields: object) -> None:
    folder.mkdir(exist_ok=True)
    (folder / "stats.json").write_text(json.dumps({"conditions": [], "metrics": [], **fields}))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_analysed_table_reads_what_stats_json_records(tmp_path):
    csv, parquet = _study_csv(tmp_path), _study_parquet(tmp_path)
    notes, other_stem = tmp_path / "study.txt", tmp_path / "study2.csv"
    notes.write_text("not a table\n")  # the folder's stem, not a table's suffix
    other_stem.write_text(csv.read_text() + "1,control,9,9,1,1.0,True\n")  # a table of another stem
    folder = tmp_path / "study-analysis"
    assert analysis_folder(csv) == analysis_folder(parquet) == folder
    assert analysed_table(folder) is None  # no stats.json yet
    _stats(folder, metrics_table="../study.parquet")
    assert analysed_table(folder) == parquet
    _stats(folder, metrics_table="../../elsewhere/t.csv")  # named, though gone: still named
    assert analysed_table(folder) == tmp_path.parent / "elsewhere" / "t.csv"
    for table in (csv, parquet):
        _stats(folder, metrics_table="metrics.csv", table_read={"sha256": _sha256(table)})
        assert analysed_table(folder) == table
    for not_beside in (notes, other_stem, tmp_path / "study-analysis" / "stats.json"):
        _stats(folder, metrics_table="metrics.csv", table_read={"sha256": _sha256(not_beside)})
        assert analysed_table(folder) is None, not_beside
    _stats(folder, metrics_table="metrics.csv")  # a run's analysis, or an older nudge's
    assert analysed_table(folder) is None
    (folder / "stats.json").write_text("{not json")
    assert analysed_table(folder) is None
    other = tmp_path / "elsewhere-analysis"  # no table of that stem beside it
    _stats(other, metrics_table="metrics.csv", table_read={"sha256": _sha256(csv)})
    assert analysed_table(other) is None


def test_check_folder_is_the_tables_accepts_the_same_file_by_another_name(tmp_path):
    csv = _study_csv(tmp_path)
    folder = tmp_path / "study-analysis"
    _stats(folder, metrics_table="../study.csv")
    check_folder_is_the_tables(csv, folder)
    check_folder_is_the_tables(tmp_path / "." / "study.csv", folder)
    (tmp_path / "study.pq").hardlink_to(csv)  # one file: its analysis is this one's
    check_folder_is_the_tables(tmp_path / "study.pq", folder)
    with pytest.raises(RunFolderError, match=r"holds the analysis of .*study\.csv, not of .*study\.parquet"):
        check_folder_is_the_tables(_study_parquet(tmp_path), folder)


def test_a_metrics_csv_left_by_an_earlier_analysis_is_not_drawn_for_the_table_named_now(tmp_path):
    """study-code's filters changed the table (metrics.csv written); the paper plan then analyses it
    as it is (stats.json names study.csv) and removes that metrics.csv, which is no part of its
    analysis: plotting the folder draws the table stats.json names, not the earlier analysis's rows."""
    table = pd.read_csv(TABLE)
    table.loc[0, "mode_switches"] = 50  # over study-code's filter of at most 10 mode switches
    csv = tmp_path / "study.csv"
    table.to_csv(csv, index=False)
    folder = tmp_path / "study-analysis"
    assert _nudge("analyze", csv, "--plan", "study-code").exit_code == 0
    assert _metrics_table(folder) == "metrics.csv"
    filtered = (folder / "metrics.csv").read_bytes()
    assert _nudge("analyze", csv, "--plan", "paper").exit_code == 0
    assert _metrics_table(folder) == "../study.csv" and not (folder / "metrics.csv").exists()
    (folder / "metrics.csv").write_bytes(filtered)  # put back by hand: still never drawn
    assert analysed_metrics_path(folder) == folder / "../study.csv"
    result = _nudge("plot", folder, "--formats", "png")
    assert result.exit_code == 0, result.output
    (folder / "stats.json").write_text(json.dumps({"metrics_table": "../gone.csv"}))
    assert analysed_metrics_path(folder) == folder / "metrics.csv"  # the checksum then refuses it
    (folder / "stats.json").write_text("{}")  # an older nudge's: metrics.csv
    assert analysed_metrics_path(folder) == folder / "metrics.csv"
