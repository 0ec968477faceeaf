"""A ``--force`` killed while it removes the batch it replaces: ``batch.json`` is marked
``replacing`` before anything goes, so the folder never shows an old table beside a record that says
``complete``, and any command into it (the same ``--force``, ``--resume``, the plain command) finishes
the removal and starts its batch afresh. A refused resume names a command even where the folder's
experiment copy is gone."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from batch_helpers import USERS_FILES, an_old_batch
from cli_helpers import files_of

from nudgecli.runs import batch_folder
from nudgecli.runs.batch_folder import BATCH_TABLES, prepare_folder
from nudgecli.runs.batch_resume import resume_advice


class KilledError(Exception):
    """Stands for the SIGKILL that stops a ``--force`` halfway through its removal."""


def _killed_halfway(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make the replacement's removal stop once the old batch's parts are gone, its tables not yet."""
    def parts_then_killed(folder: Path) -> None:
        for name in ("tasks", "analyses"):
            shutil.rmtree(folder / name)
        raise KilledError

    monkeypatch.setattr(batch_folder, "remove_outputs", parts_then_killed)


def test_a_killed_force_leaves_no_old_table_beside_a_complete_record(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "out"
    an_old_batch(folder)
    _killed_halfway(monkeypatch)
    with pytest.raises(KilledError):
        prepare_folder(folder, {"kind": "replicate"}, resume=False, force=True)
    assert (folder / "summary.csv").exists()  # the state the kill left: old tables, parts gone
    # was: "complete", so the old tables read as the finished batch's, its parts gone
    assert json.loads((folder / "batch.json").read_text())["status"] == "replacing"


@pytest.mark.parametrize(("resume", "force"), [(True, False), (False, False), (False, True)])
def test_a_folder_a_force_was_replacing_starts_afresh_on_any_command(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch,
                                                                    resume: bool, force: bool) -> None:
    folder = tmp_path / "out"
    an_old_batch(folder)
    with monkeypatch.context() as patched:
        _killed_halfway(patched)
        with pytest.raises(KilledError):
            prepare_folder(folder, {"kind": "replicate"}, resume=False, force=True)
    # was refused: "holds a different batch ... resume it with the same settings, or use --force"
    assert prepare_folder(folder, {"kind": "replicate", "seed": 9}, resume=resume, force=force) == "new"
    assert files_of(folder) == USERS_FILES
    assert not any((folder / f"{stem}.csv").exists() for stem in BATCH_TABLES)


def test_a_refused_resume_names_a_command_where_the_experiment_copy_is_gone(tmp_path: Path) -> None:
    recorded = {"kind": "replicate", "replications": 3, "seed": 5,
                "points": [{"index": 0, "participants": [2], "parameters": {}}]}
    advice = resume_advice(tmp_path, {"batch": recorded, "inputs": {}})
    # was "": "resume it with the same settings, or use --force", no command
    assert "nudge replicate EXPERIMENT" in advice and "--replications 3 --seed 5" in advice
    assert "--resume" in advice and "the folder keeps no copy" in advice
