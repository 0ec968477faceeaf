"""An analysis killed while it writes its files: ``nudge plot`` never draws a ``stats.json`` beside
the files of another analysis (stats.json goes first and comes last), and ``nudge analyze`` run
again into the same folder finishes it without ``--force``, removing the temporaries the killed
one left (named as :func:`nudgecli.store.atomic_path` names them)."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest
from cli_helpers import files_of, killed_analysis_at, nudge, one_error_line

from nudgecli.store import temporary_prefix

REFERENCE = Path(__file__).resolve().parents[1] / "results" / "paper" / "metrics.csv"


def _table(tmp_path: Path) -> Path:
    table = tmp_path / "study.csv"
    shutil.copy(REFERENCE, table)
    return table



def _temporary(folder: Path, of: str) -> Path:
    """A temporary of ``folder/of`` as a writer killed mid-write leaves it."""
    fd, name = tempfile.mkstemp(prefix=temporary_prefix(folder / of), suffix=".tmp", dir=folder)
    os.close(fd)
    return Path(name)


@pytest.mark.parametrize("name", ["stats.csv", "summary.md"])
def test_plot_refuses_an_analysis_killed_while_it_replaced_another(tmp_path, monkeypatch, name):
    table = _table(tmp_path)
    assert nudge("analyze", table).exit_code == 0
    killed_analysis_at(monkeypatch, name, table, "--metric", "completion_time")  # another analysis, cut short
    result = nudge("plot", table, "--formats", "png", "--out", tmp_path / "figures")
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert f"nudge analyze {table}" in line, line
    assert nudge("analyze", table, "--metric", "completion_time").exit_code == 0  # no --force needed
    summary = (tmp_path / "study-analysis" / "summary.md").read_text(encoding="utf-8")
    assert "completion_time" in summary and "human_effort" not in summary
    assert nudge("plot", table, "--formats", "png", "--out", tmp_path / "figures").exit_code == 0


def test_analyze_again_into_an_out_folder_a_killed_analysis_left(tmp_path, monkeypatch):
    table, out = _table(tmp_path), tmp_path / "D"
    killed_analysis_at(monkeypatch, "summary.md", table, "--out", out)
    left = [_temporary(out, "stats.json"), _temporary(out, "summary.md")]
    assert (out / "stats.csv").is_file() and not (out / "stats.json").exists()
    result = nudge("analyze", table, "--out", out)
    assert result.exit_code == 0, result.output
    assert not any(path.exists() for path in left)
    assert not list(out.glob(".*.tmp")) and (out / "stats.json").is_file()


def test_analyze_again_removes_the_temporaries_of_the_default_folder(tmp_path):
    table = _table(tmp_path)
    assert nudge("analyze", table).exit_code == 0
    folder = tmp_path / "study-analysis"
    left = _temporary(folder, "stats.csv")
    assert nudge("analyze", table).exit_code == 0
    assert not left.exists() and not list(folder.glob(".*.tmp"))


@pytest.mark.parametrize("held", ["complete analysis", "temporary of another file"])
def test_an_out_folder_holding_more_than_a_killed_analysis_still_needs_force(tmp_path, held):
    table, out = _table(tmp_path), tmp_path / "D"
    if held == "complete analysis":
        assert nudge("analyze", table, "--out", out).exit_code == 0  # finished: not replaced unasked
    else:
        out.mkdir()
        _temporary(out, "notes.txt")
    before = files_of(out)
    line = one_error_line(nudge("analyze", table, "--out", out).output)
    assert line.startswith(f"Error: {out}: exists and is not empty") and "--force" in line
    assert files_of(out) == before
