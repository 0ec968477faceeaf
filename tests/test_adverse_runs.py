"""Batch and run commands under adverse conditions: a full disk while the lock is written, Ctrl-C
while figures are written, a scheduler address from the environment beside an explicit --workers.

The full disk is a file object whose every write to the OS fails with ENOSPC, as a full
filesystem's does (text buffered by Python is written at flush and again at close); Ctrl-C is a
real SIGINT to a real process."""

from __future__ import annotations

import errno
import io
import json
import os
import socket
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner

from nudgecli import locks
from nudgecli.cli import main
from nudgecli.errors import WriteError
from nudgecli.run_folder_names import LOCK


class _FullDiskFile(io.FileIO):
    """A file on a full disk: opening, locking and truncating work, writing any byte fails."""

    def write(self, data: Any) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def _open_on_full_disk(path: Any, mode: str = "r", encoding: str | None = None) -> io.TextIOWrapper:
    assert mode == "a+"
    return io.TextIOWrapper(io.BufferedRandom(_FullDiskFile(path, "a+")), encoding=encoding)


def _open_descriptors() -> int:
    """How many files this process has open (Linux); -1 where that cannot be seen."""
    fds = Path("/proc/self/fd")
    return len(os.listdir(fds)) if fds.is_dir() else -1


@pytest.fixture()
def full_disk(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(locks, "open", _open_on_full_disk, raising=False)


def test_a_lock_that_cannot_be_written_names_its_file_and_leaves_none(tmp_path, monkeypatch, full_disk):
    lock_path = tmp_path / LOCK
    open_files = _open_descriptors()
    with pytest.raises(WriteError) as caught:
        locks.acquire_lock_file(lock_path, "nudge replicate")
    assert _open_descriptors() == open_files  # closed, not left to the collector
    assert str(caught.value).startswith(f"cannot write {lock_path}: {os.strerror(errno.ENOSPC)};")
    assert "free space" in str(caught.value)
    assert not lock_path.exists()  # an empty lock file would look like a damaged holder's
    monkeypatch.undo()  # space again: the failed attempt's file was closed, its flock released
    handle = locks.acquire_lock_file(lock_path, "nudge replicate")
    try:
        assert locks.read_holder(lock_path)["pid"] == os.getpid()
    finally:
        handle.close()


def test_a_batch_on_a_full_disk_says_which_file_and_keeps_the_batch(tmp_path, monkeypatch):
    out = tmp_path / "batch"
    assert CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--out", str(out)]).exit_code == 0
    before = {path: path.read_bytes() for path in out.rglob("*") if path.is_file()}
    monkeypatch.setattr(locks, "open", _open_on_full_disk, raising=False)
    result = CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--out", str(out), "--resume"])
    line = one_error_line(result.output)
    assert result.exit_code == 1
    assert line == (f"Error: cannot write {out / LOCK}: {os.strerror(errno.ENOSPC)}; check that the folder "
                    "exists, is writable and has free space")
    assert {path: path.read_bytes() for path in out.rglob("*") if path.is_file()} == before
    assert not (out / LOCK).exists()


def test_a_lock_taken_over_on_a_full_disk_leaves_no_emptied_file(tmp_path, full_disk):
    # a dead holder's lock is truncated before the new record is written: it is gone either way
    lock_path = tmp_path / LOCK
    lock_path.write_text(json.dumps({"pid": -5, "host": socket.gethostname()}), encoding="utf-8")
    with pytest.raises(WriteError):
        locks.acquire_lock_file(lock_path, None)
    assert not lock_path.exists()
