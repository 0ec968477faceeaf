"""A ``batch.json`` marked ``replacing`` (a ``--force`` killed while it removed the old batch) holds
no batch: the people file the old batch recorded is neither checked against a resume nor named by
the resume command, and the Ctrl-C hint of a ``--force`` interrupted during the removal says that
nothing was computed yet (the command, run again, starts afresh)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from batch_helpers import REPLICATE
from cli_helpers import nudge
from people_helpers import people_typed_here

from nudgecli.api.resuming import people_to_resume
from nudgecli.runs import batch_folder
from nudgecli.runs.batch_folder import recorded_people
from nudgecli.runs.batch_kinds import _people_fields

#: The old batch's people file record, as batch.json describes it.
OLD_PEOPLE = {"file": "p1.csv", "sha256": "ab", "people": 2}


def _replacing(folder: Path) -> Path:
    """What a ``--force`` killed as it removed a ``--people p1.csv`` batch leaves: ``batch.json``
    marked ``replacing`` and the old batch's people copy, not removed yet."""
    (folder / "people").mkdir(parents=True)
    (folder / "people" / "p1.csv").write_text("person\n0\n")
    (folder / "batch.json").write_text(json.dumps({"batch": {"kind": "replicate", "people": OLD_PEOPLE},
                                                   "status": "replacing"}))
    return folder


def test_a_replacing_record_describes_no_batch_and_no_people(tmp_path: Path) -> None:
    folder = _replacing(tmp_path / "F")
    assert recorded_people(folder) == (False, None)  # was: (True, the old batch's people)
    # a resume without --people is not refused for the old batch's (was: "simulated with --people")
    assert _people_fields(None, folder, True, "replicate") == ({}, None)
    # the resume command names the people typed, not the old batch's copy (was: F/people/p1.csv)
    assert people_to_resume(folder, "p2.csv") == "p2.csv"


def test_the_ctrl_c_hint_of_a_force_interrupted_while_removing_says_nothing_was_computed(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    people_typed_here(tmp_path, monkeypatch, "p2.csv")
    folder = _replacing(tmp_path / "F")

    def interrupted(_: Path) -> None:
        raise KeyboardInterrupt  # Ctrl-C while the old batch's outputs are removed

    monkeypatch.setattr(batch_folder, "remove_outputs", interrupted)
    result = nudge(*REPLICATE, "--people", "p2.csv", "--out", folder, "--force")
    assert result.exit_code == 130, result.output
    (line,) = [x for x in result.output.splitlines() if x.startswith("Interrupted")]
    # was: "F keeps its finished tasks; resume with: nudge replicate ... --people F/people/p1.csv"
    assert "nothing was computed yet; run the command again" in line, line
    assert "p1.csv" not in result.output
