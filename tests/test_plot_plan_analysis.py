"""``nudge plot SOURCE --plan PLAN`` analyses SOURCE first, and only once the plot's choices are checked.

- A plot refused for its ``--trial`` or its ``--out`` leaves the existing analysis as it was
  (QA: ``--trial 9:9`` had already rewritten ``metrics.csv``, ``stats.json``, ``stats.csv`` and
  ``summary.md`` with the new plan's analysis before failing).
- A table's analysis folder given as SOURCE is analysed again from the table its ``stats.json``
  names, into that folder, with the ``--drop-duplicates`` it was analysed with.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from cli_helpers import file_digests, nudge, stderr_error_line

from nudgecli.config import load_experiment
from nudgecli.report.analysis import analyze
from nudgecli.runs.study import run_study

# the table as the paper plan analyses it (no time for a failed trial): analysed as it is
TABLE = Path(__file__).parent / "data" / "metrics_two_conditions_paper.csv"
RECORDS = ("metrics.csv", "stats.json", "stats.csv", "summary.md", "manifest.json")


@pytest.fixture(scope="module")
def analysed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The smoke study analysed with the paper plan. Do not modify: tests work on copies."""
    run = run_study(load_experiment("smoke"), tmp_path_factory.mktemp("smoke") / "run")
    analyze(run.path, plan="paper")
    return run.path


_nudge, _error_line = nudge, stderr_error_line


def _digests(folder: Path) -> dict[str, str]:
    return file_digests(folder, RECORDS)


def _stats(folder: Path) -> dict[str, Any]:
    stats = json.loads((folder / "stats.json").read_text(encoding="utf-8"))
    stats.pop("metrics_table")  # the table as seen from the folder: differs between folders
    return dict(stats)


@pytest.mark.parametrize(("choice", "message"), [
    (["--trial", "9:9"], "--trial 9:9: no such trial"),
    (["--trial", "0:99"], "--trial 0:99: no such trial"),
    (["--out", "NONEMPTY"], "exists and is not empty"),
], ids=["unknown-participant", "unknown-trial", "out-not-empty"])
def test_a_plot_refused_for_its_choices_leaves_the_analysis_as_it_was(analysed_run, tmp_path, choice,
                                                                      message):
    run = shutil.copytree(analysed_run, tmp_path / "run")
    before = _digests(run)
    assert set(before) == set(RECORDS)
    (tmp_path / "NONEMPTY").mkdir()
    (tmp_path / "NONEMPTY" / "notes.txt").write_text("mine\n")
    args = [str(tmp_path / a) if a == "NONEMPTY" else a for a in choice]
    line = _error_line(_nudge("plot", run, "--plan", "study-code", "--formats", "png", *args))
    assert message in line
    assert _digests(run) == before and not (run / "figures").exists()


def test_a_plot_with_a_known_trial_still_analyses_with_the_plan(analysed_run, tmp_path):
    run = shutil.copytree(analysed_run, tmp_path / "run")
    before = _digests(run)
    result = _nudge("plot", run, "--plan", "study-code", "--formats", "png", "--trial", "1:7")
    assert result.exit_code == 0, result.output
    assert _digests(run)["stats.json"] != before["stats.json"]
    assert "plan: study-code" in (run / "summary.md").read_text(encoding="utf-8")


def _table(folder: Path, name: str = "t.csv", repeated_rows: int = 0) -> Path:
    table = pd.read_csv(TABLE)
    pd.concat([table, table.iloc[:repeated_rows]], ignore_index=True).to_csv(folder / name, index=False)
    return folder / name


@pytest.mark.parametrize(("repeated_rows", "out"), [(0, None), (2, None), (0, "mine")],
                         ids=["analysed-as-it-is", "duplicates-dropped", "out-of-its-own"])
def test_plot_of_a_tables_analysis_folder_with_plan_analyses_the_table_into_it(tmp_path, repeated_rows, out):
    table = _table(tmp_path, repeated_rows=repeated_rows)
    flags = ["--drop-duplicates"] if repeated_rows else []
    folder = tmp_path / (out or "t-analysis")
    assert _nudge("analyze", table, *flags, *(["--out", folder] if out else [])).exit_code == 0
    result = _nudge("plot", folder, "--plan", "study-code", "--formats", "png")
    assert result.exit_code == 0, result.output
    assert list((folder / "figures").glob("*.png"))
    # the same as analysing the table with that plan (and the flag it was analysed with) directly
    expected = _nudge("analyze", table, "--plan", "study-code", "--out", tmp_path / "direct", *flags)
    assert expected.exit_code == 0, expected.output
    assert _stats(folder) == _stats(tmp_path / "direct")
    assert "plan: study-code" in (folder / "summary.md").read_text(encoding="utf-8")


def test_plot_plan_of_an_analysis_folder_whose_table_is_gone_is_one_error_line(tmp_path):
    table = _table(tmp_path, repeated_rows=2)
    assert _nudge("analyze", table, "--drop-duplicates").exit_code == 0
    folder = tmp_path / "t-analysis"
    _table(tmp_path, repeated_rows=3)  # edited: no table beside the folder has the bytes analysed
    before = _digests(folder)
    line = _error_line(_nudge("plot", folder, "--plan", "study-code", "--formats", "png"))
    assert line.startswith(f"Error: {folder}: --plan analyses the metrics table") and "not there" in line
    assert f"nudge analyze TABLE --plan PLAN --out {folder}" in line
    assert _digests(folder) == before and not (folder / "figures").exists()


def test_plot_plan_of_a_runs_analysis_written_elsewhere_names_what_to_give(analysed_run, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    analyze(analysed_run, plan="paper", out=elsewhere)
    before = _digests(elsewhere)
    line = _error_line(_nudge("plot", elsewhere, "--plan", "study-code", "--formats", "png"))
    assert "names no metrics table" in line and "the run folder or the metrics table itself" in line
    assert _digests(elsewhere) == before
