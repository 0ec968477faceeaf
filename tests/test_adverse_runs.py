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
import signal
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import one_error_line, wait_for
from click.testing import CliRunner

from nudgecli import locks
from nudgecli.cli import main
from nudgecli.cores import available_cores
from nudgecli.errors import WriteError
from nudgecli.run_folder_names import LOCK
from nudgecli.runs import study as study_module


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


# --- Ctrl-C while figures are written ------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[1]
#: ``nudge run smoke`` through the program's entry point, its figures' writers slowed (each
#: ``savefig`` first leaves a file named by its pid in MARKS, then sleeps) or, with ``at-fork``,
#: Ctrl-C sent to the whole process group the moment the first figure writer is forked, from
#: the parent's own after-fork hook (where the interpreter cannot raise it).
_RUN_SCRIPT = """
import os, signal, sys, time
from pathlib import Path
from matplotlib.figure import Figure
from nudgecli import cli
from nudgecli.report import figures

out, marks, mode = sys.argv[1:4]
armed = []
writing = figures.save_figures

def save_figures(*args, **kwargs):
    armed.append(True)
    return writing(*args, **kwargs)

def ctrl_c_at_first_fork():
    if armed and armed.pop():
        os.killpg(0, signal.SIGINT)

savefig = Figure.savefig

def slow_savefig(self, *args, **kwargs):
    Path(marks, str(os.getpid())).touch()
    time.sleep(60)
    return savefig(self, *args, **kwargs)

figures.save_figures = save_figures
if mode == "at-fork":
    os.register_at_fork(after_in_parent=ctrl_c_at_first_fork)
else:
    Figure.savefig = slow_savefig
sys.argv = ["nudge", "run", "smoke", "--participants", "2", "--out", out]
cli.entry_point()
"""

needs_forked_writers = pytest.mark.skipif(available_cores() < 2 or not hasattr(os, "fork"),
                                          reason="figures are forked only with two cores")


def _run_interrupted(tmp_path: Path, mode: str) -> tuple[int, str, set[int]]:
    """Exit status and stderr of the script's ``nudge run`` after Ctrl-C, and the writers' pids."""
    marks = tmp_path / "marks"
    marks.mkdir()
    # a session of its own: Ctrl-C in a terminal reaches the whole process group, children included
    proc = subprocess.Popen([sys.executable, "-c", _RUN_SCRIPT, str(tmp_path / "run"), str(marks), mode],
                            env={**os.environ, "PYTHONPATH": str(ROOT)}, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        if mode == "while-writing":
            wait_for(lambda: len(list(marks.iterdir())) >= 2 or proc.poll() is not None, timeout=120)
            os.killpg(proc.pid, signal.SIGINT)
        stderr = proc.communicate(timeout=120)[1]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    return proc.returncode, stderr, {int(mark.name) for mark in marks.iterdir()}


def _ended(pid: int) -> bool:
    """Whether process ``pid`` has ended (gone, or a zombie waiting to be reaped)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] in ("Z", "X")
    except (FileNotFoundError, ProcessLookupError):
        return True


@needs_forked_writers
@pytest.mark.parametrize("mode", ["while-writing", "at-fork"])
def test_ctrl_c_while_figures_are_written_exits_130_with_the_resume_hint(tmp_path, mode):
    code, stderr, writers = _run_interrupted(tmp_path, mode)
    assert code == 130, stderr
    out = tmp_path / "run"
    assert (f"Interrupted: {out} keeps its 2 finished participant(s); resume with: nudge simulate smoke "
            f"--out {out} --participants 2 --resume") in stderr
    # the writers ignore Ctrl-C (the parent ends them): no child's traceback, no line but the hint's
    assert "Traceback" not in stderr and "Process nudge-figures" not in stderr, stderr
    assert "Aborted" not in stderr and "Exception ignored" not in stderr, stderr
    if mode == "while-writing":
        assert len(writers) >= 2 and os.getpid() not in writers
        wait_for(lambda: all(_ended(pid) for pid in writers), timeout=30)


# --- DASK_SCHEDULER_ADDRESS beside --workers ---------------------------------------------------


@pytest.fixture()
def nothing_listening(monkeypatch: pytest.MonkeyPatch) -> str:
    """A local address where no process listens; the shipped wait for a scheduler, shortened."""
    monkeypatch.setattr(study_module, "SCHEDULER_TIMEOUT_S", 1.5)
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    return f"tcp://127.0.0.1:{port}"


def _run_with_environment_scheduler(address: str, args: list[str]) -> Any:
    return CliRunner(env={"DASK_SCHEDULER_ADDRESS": address}).invoke(main, args)


@pytest.mark.parametrize("command", [["replicate", "smoke", "-R", "1"], ["simulate", "smoke"]])
def test_an_explicit_workers_wins_over_the_scheduler_of_the_environment(tmp_path, nothing_listening, command):
    out = tmp_path / "out"
    result = _run_with_environment_scheduler(
        nothing_listening, [*command, "--participants", "2", "--workers", "2", "--out", str(out)])
    assert result.exit_code == 0, result.output
    record = out / ("batch.json" if command[0] == "replicate" else "manifest.json")
    assert json.loads(record.read_text())["executor"] == "processes:2"
    assert ("Note: --workers given: running on local workers, not on the dask scheduler "
            f"DASK_SCHEDULER_ADDRESS names ({nothing_listening})") in result.output


@pytest.mark.parametrize("command", [["replicate", "smoke", "-R", "1"], ["power", "smoke", "-R", "1"],
                                     ["simulate", "smoke"]])
def test_an_unreachable_scheduler_of_the_environment_is_named_as_the_variable(tmp_path, nothing_listening,
                                                                              command):
    out = tmp_path / "out"
    args = [*command, "--participants", "2", "--out", str(out)]
    line = one_error_line(_run_with_environment_scheduler(nothing_listening, args).output)
    assert line.startswith(f"Error: DASK_SCHEDULER_ADDRESS={nothing_listening} (from the environment): "
                           "cannot connect")
    assert line.endswith("or unset DASK_SCHEDULER_ADDRESS (or give --workers N) to run on local workers")
    assert "--scheduler" not in line
    assert not out.exists()


def test_a_scheduler_on_the_command_line_still_wins_over_workers(tmp_path, nothing_listening):
    out = tmp_path / "out"
    result = _run_with_environment_scheduler(
        "tcp://127.0.0.1:1", ["replicate", "smoke", "-R", "1", "--participants", "2", "--workers", "2",
                              "--scheduler", nothing_listening, "--out", str(out)])
    line = one_error_line(result.output)
    assert result.exit_code == 1
    assert line.startswith(f"Error: --scheduler {nothing_listening}: cannot connect")
    assert not out.exists()
