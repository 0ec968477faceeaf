"""A damaged ``batch.json`` (not JSON, not an object, no ``batch`` object) is one error line, and
``--force`` replaces the batch it damaged: the folder's tasks and tables show it is a batch's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from batch_helpers import REPLICATE, USERS_FILES, an_old_batch, nudge
from cli_helpers import files_of, one_error_line

from nudgecli.errors import RunFolderError
from nudgecli.runs.batch_folder import prepare_folder

# --- 3. a damaged batch.json ---------------------------------------------------------------------


DAMAGED = ("[]", '{"batch": 5}', "{", '{"status": "complete"}', '\x00')


@pytest.mark.parametrize("text", DAMAGED)
def test_a_damaged_manifest_is_one_error_line_and_force_replaces_the_batch(tmp_path: Path, text: str) -> None:
    folder = tmp_path / "out"
    an_old_batch(folder)
    (folder / "batch.json").write_text(text)
    for resume in (True, False):
        with pytest.raises(RunFolderError, match=r"batch\.json: damaged .*use --force"):
            prepare_folder(folder, {"kind": "replicate"}, resume=resume, force=False)
    assert (folder / "batch.json").read_text() == text  # refused: nothing touched
    assert prepare_folder(folder, {"kind": "replicate"}, resume=False, force=True) == "new"
    assert files_of(folder) == USERS_FILES


def test_a_damaged_manifest_on_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "out"
    an_old_batch(out)
    (out / "batch.json").write_text('{"batch": 5}')
    resumed = nudge(*REPLICATE, "--out", str(out), "--resume")
    assert resumed.exit_code == 1
    assert f"{out / 'batch.json'}: damaged" in one_error_line(resumed.output)
    replaced = nudge(*REPLICATE, "--out", str(out), "--force")
    assert replaced.exit_code == 0, replaced.output
    assert json.loads((out / "batch.json").read_text())["status"] == "complete"
    assert not (out / "power.csv").exists() and (out / "notes.txt").read_text() == "mine"
