"""A run folder is read on no trust and its advice works: a damaged part without a recorded
SHA-256, a file manager's copy of a part, a run of another nudge version, a linked part folder."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli import __version__


def _damaged_in_its_metadata(part: Path) -> None:
    """Flip a byte of the pandas metadata in the footer: the footer parses, the table does not."""
    data = bytearray(part.read_bytes())
    at = data.rfind(b'"columns"')  # pandas' JSON, read only when the table is
    assert at > 0
    data[at + 10] ^= 0x5A
    part.write_bytes(bytes(data))


def test_a_damaged_part_with_no_recorded_checksum_is_one_error_naming_it(analysed_smoke_run: Path,
                                                                         tmp_path: Path) -> None:
    parts = tmp_path / "parts"
    for kind in ("trials", "steps"):
        shutil.copytree(analysed_smoke_run / kind, parts / kind)
    _damaged_in_its_metadata(parts / "trials" / "part-0000.parquet")
    line = one_error_line(nudge("analyze", parts).output)
    assert "trials/part-0000.parquet is not a readable Parquet file" in line
    assert "--resume" not in line and "--force" in line  # nothing resumes a folder of parts alone

    # a manifest of an older nudge records no SHA-256: the same one line, not a traceback
    run = tmp_path / "older"
    shutil.copytree(analysed_smoke_run, run)
    manifest = json.loads((run / "manifest.json").read_text())
    manifest.pop("checksums")
    manifest.pop("files", None)
    (run / "manifest.json").write_text(json.dumps(manifest))
    _damaged_in_its_metadata(run / "trials" / "part-0000.parquet")
    line = one_error_line(nudge("analyze", run, "--out", tmp_path / "analysis").output)
    assert "trials/part-0000.parquet is not a readable Parquet file" in line


def test_one_rule_reads_a_participant_from_a_part_name(tmp_path: Path) -> None:
    from nudgecli.run_folder_names import numbered_parts, stray_part_files

    for name in ("part-0003.parquet", "part-00012.parquet", "part-0001 (copy).parquet", "part-x.parquet"):
        (tmp_path / name).write_bytes(b"")
    found = {3: tmp_path / "part-0003.parquet", 12: tmp_path / "part-00012.parquet"}
    assert numbered_parts(tmp_path) == found
    assert [p.name for p in stray_part_files(tmp_path)] == ["part-0001 (copy).parquet", "part-x.parquet"]


def test_a_copy_of_a_part_is_left_out_with_a_note(analysed_smoke_run: Path, tmp_path: Path) -> None:
    parts = tmp_path / "parts"
    for kind in ("trials", "steps"):
        shutil.copytree(analysed_smoke_run / kind, parts / kind)
        shutil.copy(parts / kind / "part-0001.parquet", parts / kind / "part-0001 (copy).parquet")
    result = nudge("analyze", parts, "--bootstrap", "100")
    assert result.exit_code == 0, result.output
    assert "left out trials/part-0001 (copy).parquet" in result.output

    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run)
    shutil.copy(run / "trials" / "part-0001.parquet", run / "trials" / "part-0001 (copy).parquet")
    result = nudge("simulate", "smoke", "--participants", "2", "--seed", "5", "--out", run, "--resume")
    assert result.exit_code == 0, result.output
    assert "Traceback" not in result.output


def _of_version(run: Path, version: str) -> None:
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["versions"]["nudgecli"] = version
    (run / "manifest.json").write_text(json.dumps(manifest))


def test_a_run_of_another_version_is_not_advised_a_resume_that_is_refused(analysed_smoke_run: Path,
                                                                          tmp_path: Path) -> None:
    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run)
    _of_version(run, "0.0.9")
    (run / "steps" / "part-0001.parquet").unlink()
    analysed = one_error_line(nudge("analyze", run).output)
    resumed = one_error_line(nudge("simulate", "smoke", "--participants", "2", "--seed", "5", "--out", run,
                                   "--resume").output)
    for line in (analysed, resumed):
        assert f"nudgecli 0.0.9 (this is {__version__}" in line, line
        assert "install nudgecli==0.0.9" in line
        assert "--seed 5 --participants 2 --force`" in line  # what works with this version
    assert "resume it with its own" not in resumed


def test_another_versions_run_that_stopped_is_told_both_versions(analysed_smoke_run: Path,
                                                                 tmp_path: Path) -> None:
    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run)
    _of_version(run, "0.0.9")
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["status"] = "failed"
    (run / "manifest.json").write_text(json.dumps(manifest))
    line = one_error_line(nudge("analyze", run).output)
    assert "to finish it, install nudgecli==0.0.9" in line and "--force`" in line


def test_force_never_follows_a_linked_part_folder(analysed_smoke_run: Path, tmp_path: Path) -> None:
    other = tmp_path / "other"
    shutil.copytree(analysed_smoke_run, other)
    before = {p.name: p.read_bytes() for p in (other / "steps").iterdir()}
    linked = tmp_path / "linked"
    linked.mkdir()
    (linked / "steps").symlink_to(other / "steps", target_is_directory=True)
    line = one_error_line(nudge("simulate", "smoke", "--participants", "1", "--seed", "9", "--out", linked,
                                "--force").output)
    assert f"{linked / 'steps'} is a symbolic link" in line
    assert {p.name: p.read_bytes() for p in (other / "steps").iterdir()} == before
    assert (linked / "steps").is_symlink()


@pytest.mark.parametrize("name", ["manifest.json", "calibration"])
def test_a_linked_run_file_or_folder_is_refused(tmp_path: Path, name: str) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    run = tmp_path / "run"
    run.mkdir()
    (run / name).symlink_to(elsewhere)
    line = one_error_line(nudge("simulate", "smoke", "--participants", "1", "--out", run, "--force").output)
    assert "is a symbolic link" in line and name in line


def test_another_versions_run_missing_its_layouts_is_told_both_versions(analysed_smoke_run: Path,
                                                                        tmp_path: Path) -> None:
    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run)
    _of_version(run, "0.0.9")
    (run / "layouts.parquet").unlink()
    line = one_error_line(nudge("analyze", run).output)
    assert "to restore it, install nudgecli==0.0.9" in line and "--seed 5 --participants 2 --force`" in line


def test_a_part_lacking_a_column_is_advised_a_simulation_that_is_not_refused(analysed_smoke_run: Path,
                                                                             tmp_path: Path) -> None:
    import pandas as pd

    parts = tmp_path / "parts"
    for kind in ("trials", "steps"):
        shutil.copytree(analysed_smoke_run / kind, parts / kind)
    part = parts / "trials" / "part-0000.parquet"
    pd.read_parquet(part).drop(columns=["success"]).to_parquet(part, index=False)
    line = one_error_line(nudge("analyze", parts).output)
    assert "lacks the column(s) success" in line
    assert line.endswith(f"`nudge simulate EXPERIMENT --out {parts} --force`")  # --force: it holds parts


def test_a_damaged_page_header_is_one_error_line(analysed_smoke_run: Path, tmp_path: Path) -> None:
    parts = tmp_path / "parts"
    for kind in ("trials", "steps"):
        shutil.copytree(analysed_smoke_run / kind, parts / kind)
    part = parts / "trials" / "part-0001.parquet"
    data = bytearray(part.read_bytes())
    data[4:12] = b"\xff" * 8  # the first page's header, just after the magic bytes
    part.write_bytes(bytes(data))
    line = one_error_line(nudge("analyze", parts).output)  # pyarrow's message spans lines
    assert "trials/part-0001.parquet is not a readable Parquet file" in line
