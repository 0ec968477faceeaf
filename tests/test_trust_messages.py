"""Nothing taken on trust (issue 38), the misleading messages: ``compare``'s conditions, a plan's
conditions, SIGTERM and a lost dask worker, each through the command line where a user meets it."""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import wait_for
from click.testing import CliRunner

from nudgecli.cli import main

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
NUDGE = [sys.executable, "-m", "nudgecli.cli"]


def invoke(args: list[str]):
    return CliRunner().invoke(main, args)


# --- SIGTERM -------------------------------------------------------------------------------------


@pytest.mark.parametrize("workers", ["1", "2"])
def test_sigterm_marks_the_run_interrupted_releases_the_lock_and_exits_143(tmp_path, workers):
    """200 participants take far longer than the wait for the manifest: the signal lands mid-run,
    with two workers often while a worker is being forked (a handler's exception lost there)."""
    out = tmp_path / "run"
    proc = subprocess.Popen([*NUDGE, "simulate", "smoke", "--participants", "200", "--workers", workers,
                             "--out", str(out)], env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    try:
        wait_for(lambda: (out / "manifest.json").exists() or proc.poll() is not None)
        proc.send_signal(signal.SIGTERM)
        stderr = proc.communicate(timeout=60)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
    assert proc.returncode == 143, stderr
    assert "Traceback" not in stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "interrupted"
    assert not (out / ".nudge.lock").exists()
    command = stderr.split("resume with: ")[1].strip().splitlines()[0]
    assert command.startswith("nudge simulate smoke --out ") and command.endswith("--resume")
    assert shlex.split(command)[4] == str(out)
