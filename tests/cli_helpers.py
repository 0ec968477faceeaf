"""Helpers shared by the command-line tests (imported as ``from cli_helpers import ...``; pytest
puts this folder on the path, as for ``live_helpers``)."""

from __future__ import annotations

import contextlib
import csv
import hashlib
import shutil
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from nudgecli.cli import main


def one_error_line(output: str) -> str:
    """The output's single ``Error: ...`` line; fails if there is anything else or a traceback."""
    lines = [line for line in output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: "), output
    assert "Traceback" not in output
    return lines[0]


def nudge(*args: str | Path) -> Result:
    """``nudge ARGS`` in this process (paths given as they are)."""
    return CliRunner().invoke(main, [str(a) for a in args])


def nudge_interrupted(monkeypatch: object, *args: str | Path) -> Result:
    """``nudge *args`` of a batch, Ctrl-C'd as it records its second part (its first one written):
    the interrupted command's result (exit 130, the resume command on its output)."""
    from nudgecli.runs.batch_folder import PartRecord

    original = PartRecord.write
    calls: list[int] = []

    def interrupted(self: PartRecord, *parts: object) -> None:
        if calls:
            raise KeyboardInterrupt
        calls.append(1)
        original(self, *parts)  # type: ignore[arg-type]

    monkeypatch.setattr(PartRecord, "write", interrupted)  # type: ignore[attr-defined]
    try:
        return nudge(*args)
    finally:
        monkeypatch.setattr(PartRecord, "write", original)  # type: ignore[attr-defined]


def stderr_error_line(result: Result) -> str:
    """The single ``Error: ...`` line a failed command wrote on stderr (exit 1)."""
    assert result.exit_code == 1, (result.output, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.stderr
    return lines[0]


def file_digests(folder: Path, names: Iterable[str]) -> dict[str, str]:
    """The SHA-256 of each of the files ``names`` in ``folder`` that exists."""
    return {name: hashlib.sha256((folder / name).read_bytes()).hexdigest()
            for name in names if (folder / name).is_file()}


def wait_for(predicate: Callable[[], object], timeout: float = 60.0) -> None:
    """Poll ``predicate`` every 5 ms until it is true; fail after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, "timed out waiting for the child process"
        time.sleep(0.005)


def copy_run(source: Path, target: Path) -> Path:
    """A copy of the run folder ``source`` at ``target`` (for tests that damage a run)."""
    shutil.copytree(source, target)
    return target


def files_of(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` but the lock (relative path -> bytes)."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != ".nudge.lock"}


def killed_analysis_at(monkeypatch: pytest.MonkeyPatch, name: str, *args: str | Path) -> None:
    """``nudge analyze ARGS`` stopped as it is about to write ``name`` (the files before it written,
    those after it not: what a kill -9 leaves, the temporaries aside)."""
    import nudgecli.report.analysis as analysis_module

    original = analysis_module.write_text_atomic

    def write(path: str | Path, text: str) -> None:
        if Path(path).name == name:
            raise KeyboardInterrupt
        original(path, text)

    monkeypatch.setattr(analysis_module, "write_text_atomic", write)
    try:
        assert nudge("analyze", *args).exit_code != 0
    finally:
        monkeypatch.setattr(analysis_module, "write_text_atomic", original)


def write_csv_rows(path: Path, rows: list[dict[str, str]]) -> Path:
    """``rows`` written to ``path`` as a CSV file, the first row's keys as the header."""
    with path.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return path


@contextlib.contextmanager
def dies_at_unlink(monkeypatch: pytest.MonkeyPatch, doomed: Path) -> Iterator[None]:
    """Within the block, a command dies (``KeyboardInterrupt``, as a kill: nothing after it runs) as
    it removes ``doomed``; every other file is removed as usual."""
    unlink = Path.unlink

    def killed(path: Path, missing_ok: bool = False) -> None:
        if path == doomed:
            raise KeyboardInterrupt
        unlink(path, missing_ok=missing_ok)

    with monkeypatch.context() as patch:
        patch.setattr(Path, "unlink", killed)
        yield

