"""A damaged manifest whose ``files`` entry (run file -> SHA-256) is not a mapping: one `Error:`
line naming manifest.json and the entry, as a damaged ``checksums`` entry is, with nothing written;
an absent or null entry (a manifest of an older nudge) is no damage."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import copy_run, nudge, one_error_line

from nudgecli.config import load_experiment
from nudgecli.runs.study import run_study


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished smoke run of 2 participants (copied by the tests that damage it)."""
    out = tmp_path_factory.mktemp("files-entry") / "run"
    run_study(load_experiment("smoke"), out, participants=2)
    return out


def with_files_entry(tmp_path: Path, smoke_run: Path, entry: object) -> Path:
    """A copy of the smoke run whose manifest's ``files`` is ``entry`` (deleted for ``...``)."""
    run = copy_run(smoke_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    if entry is ...:
        del manifest["files"]
    else:
        manifest["files"] = entry
    (run / "manifest.json").write_text(json.dumps(manifest))
    return run


@pytest.mark.parametrize("entry", [5, "layouts.parquet", [1, 2], ["layouts.parquet"], True])
def test_a_files_entry_that_is_no_mapping_is_one_error_line(tmp_path: Path, smoke_run: Path,
                                                            entry: object) -> None:
    run = with_files_entry(tmp_path, smoke_run, entry)
    before = sorted(tmp_path.rglob("*"))
    result = nudge("analyze", run)
    assert result.exit_code == 1, result.output
    line = one_error_line(result.output)
    assert line.startswith(f"Error: {run / 'manifest.json'}: 'files' = {json.dumps(entry)} is damaged"), line
    assert "restore the manifest" in line
    assert sorted(tmp_path.rglob("*")) == before


@pytest.mark.parametrize("entry", [..., None, {}])
def test_an_absent_or_empty_files_entry_is_no_damage(tmp_path: Path, smoke_run: Path, entry: object) -> None:
    run = with_files_entry(tmp_path, smoke_run, entry)
    result = nudge("analyze", run, "--out", tmp_path / "analysis")
    assert result.exit_code == 0, result.output


def test_a_recorded_file_that_is_gone_is_still_named(tmp_path: Path, smoke_run: Path) -> None:
    run = copy_run(smoke_run, tmp_path / "run")
    (run / "layouts.parquet").unlink()
    line = one_error_line(nudge("analyze", run).output)
    assert "layouts.parquet (missing)" in line and "--resume" in line, line
