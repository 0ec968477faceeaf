"""A ``.nudge.lock`` that is not a lock record (not JSON, or JSON but no object: a damaged or
hand-edited file) is taken over with the documented warning, as a stale lock is
(docs/reliability.md); an empty one, as ``open`` leaves it before its record is written, silently."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from cli_helpers import nudge

from nudgecli.locks import run_lock
from nudgecli.run_folder_names import LOCK


@pytest.mark.parametrize("content", ["not json {", "\0\0\0\0", "[1, 2]", '"text"', "7"])
def test_a_lock_that_is_not_a_record_is_taken_over_with_a_warning(tmp_path: Path, content: str) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / LOCK).write_text(content)
    lines: list[str] = []
    with run_lock(folder, log=lines.append):
        assert json.loads((folder / LOCK).read_text())["pid"] == os.getpid()
    assert len(lines) == 1 and lines[0].startswith(f"Warning: {folder}: taking over the stale lock"), lines
    assert not (folder / LOCK).exists()


def test_an_empty_lock_is_taken_over_silently(tmp_path: Path) -> None:
    (tmp_path / LOCK).write_text("")
    lines: list[str] = []
    with run_lock(tmp_path, log=lines.append):
        pass
    assert lines == []


def test_the_command_prints_the_warning_of_a_lock_that_is_not_json(tmp_path: Path) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / LOCK).write_text("garbage\n")
    result = nudge("simulate", "smoke", "--participants", "2", "--out", out)
    assert result.exit_code == 0, result.output
    assert f"Warning: {out}: taking over the stale lock" in result.stderr
    assert not (out / LOCK).exists()
