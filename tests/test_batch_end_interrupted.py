"""A batch's ``batch.json`` says ``complete`` only once every table and figure is written: a Ctrl-C
or a failure while they are made leaves it ``interrupted``, and the printed resume command writes
them, equal byte for byte to an uninterrupted batch's."""

from __future__ import annotations

from pathlib import Path

import pytest
from batch_ends_helpers import command, reference, resume_command, status, tables
from cli_helpers import nudge

from nudgecli.runs import batch_kinds


@pytest.mark.parametrize("kind", ["replicate", "power", "sweep"])
def test_a_ctrl_c_while_the_tables_are_written_leaves_the_batch_interrupted_and_its_resume_writes_them(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str) -> None:
    expected = reference(kind, tmp_path)
    out = tmp_path / "batch"

    def interrupted(folder: Path, figures: dict[str, object]) -> list[Path]:
        raise KeyboardInterrupt  # its tables written, its figures not

    with monkeypatch.context() as patched:
        patched.setattr(batch_kinds, "_figures", interrupted)
        stopped = nudge(*command(kind, out), "--out", out)
    assert stopped.exit_code == 130, stopped.output
    assert status(out) == "interrupted", "a batch without its figures read as complete"
    assert not list((out / "figures").glob("*.png"))
    resumed = nudge(*resume_command(stopped.output))
    assert resumed.exit_code == 0, resumed.output
    assert status(out) == "complete"
    assert tables(out) == expected


def test_a_failure_while_the_tables_are_made_leaves_the_batch_interrupted(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    expected = reference("replicate", tmp_path)
    out = tmp_path / "batch"

    def failing(folder: Path, tables: dict[str, object]) -> list[Path]:
        raise OSError(28, "No space left on device")

    with monkeypatch.context() as patched:
        patched.setattr(batch_kinds, "_write_tables", failing)
        with pytest.raises(OSError):
            batch_kinds.replicate("smoke", 2, out, seed=9, participants=2)
    assert status(out) == "interrupted"
    batch_kinds.replicate("smoke", 2, out, seed=9, participants=2, resume=True)
    assert status(out) == "complete"
    assert tables(out) == expected
