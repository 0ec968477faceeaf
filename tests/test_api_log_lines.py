"""The Python API prints nothing of its own (docs/api.md): the warning of a stale lock taken over
and of a config.toml put back on resume go to the ``log=`` callable, which ``nudge`` connects to
its stderr, where they read as before."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import copy_run, nudge

import nudgecli
from nudgecli.config import load_experiment
from nudgecli.locks import run_lock
from nudgecli.run_folder_names import LOCK
from nudgecli.runs.study import run_study


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished smoke run of 2 participants (copied by the tests that leave a lock in it)."""
    out = tmp_path_factory.mktemp("api-log") / "run"
    run_study(load_experiment("smoke"), out, participants=2)
    return out


def _stale_lock(folder: Path) -> int:
    """A lock file in ``folder`` of a process of this host that has ended; its pid."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (folder / LOCK).write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname(),
                                           "command": "nudge simulate smoke"}))
    return dead.pid


def _stale_warning(folder: Path, pid: int) -> str:
    return f"Warning: {folder}: taking over the stale lock of `nudge simulate smoke` (pid {pid} "


def test_a_stale_lock_is_told_to_log_and_nothing_is_printed(tmp_path, capsys):
    folder = tmp_path / "run"
    folder.mkdir()
    pid = _stale_lock(folder)
    lines: list[str] = []
    with run_lock(folder, log=lines.append):
        assert json.loads((folder / LOCK).read_text())["pid"] != pid
    assert len(lines) == 1 and lines[0].startswith(_stale_warning(folder, pid)), lines
    _stale_lock(folder)
    with run_lock(folder):  # no log: silent
        pass
    assert capsys.readouterr() == ("", "")


def test_analyze_tells_log_of_the_stale_lock_it_takes_over(tmp_path, smoke_run, capsys):
    run = copy_run(smoke_run, tmp_path / "run")
    pid = _stale_lock(run)
    lines: list[str] = []
    nudgecli.analyze(run, bootstrap=100, log=lines.append)
    assert [line for line in lines if line.startswith(_stale_warning(run, pid))], lines
    assert capsys.readouterr().err == ""
    assert not (run / LOCK).exists()


def test_a_resume_tells_log_of_the_stale_lock_and_the_config_toml_put_back(tmp_path, smoke_run, capsys):
    run = copy_run(smoke_run, tmp_path / "run")
    pid = _stale_lock(run)
    (run / "config.toml").unlink()
    lines: list[str] = []
    nudgecli.simulate("smoke", participants=2, out=run, resume=True, log=lines.append)
    assert [line for line in lines if line.startswith(_stale_warning(run, pid))], lines
    assert f"Warning: {run / 'config.toml'} was missing; written again from the experiment in the manifest" \
        in lines, lines
    assert capsys.readouterr().err == ""
    assert (run / "config.toml").read_text() == (smoke_run / "config.toml").read_text()


def test_nudge_still_shows_both_warnings_on_stderr(tmp_path, smoke_run):
    run = copy_run(smoke_run, tmp_path / "run")
    pid = _stale_lock(run)
    (run / "config.toml").unlink()
    result = nudge("simulate", "smoke", "--participants", "2", "--out", run, "--resume")
    assert result.exit_code == 0, result.output
    assert _stale_warning(run, pid) in result.stderr
    restored = f"{run / 'config.toml'} was missing; written again from the experiment in the manifest"
    assert f"Warning: {restored}\n" in result.stderr
    pid = _stale_lock(run)
    result = nudge("analyze", run, "--bootstrap", "100")
    assert result.exit_code == 0, result.output
    assert _stale_warning(run, pid) in result.stderr
