"""A batch killed before its ``batch.json`` (its kept inputs written, or being written; a
``--force`` replacement whose old batch is gone) starts afresh on ``--resume`` or the same command;
a folder holding a file of the person's own beside such a start is still refused."""

from __future__ import annotations

from pathlib import Path

import pytest
from batch_ends_helpers import INPUTS, command, reference, status, tables
from cli_helpers import nudge


def _start_of(kind: str, tmp_path: Path, out: Path, kept: tuple[str, ...]) -> tuple[str, ...]:
    """``out`` as a batch killed before its ``batch.json`` left it: its lock, the kept inputs
    ``kept`` (an uninterrupted batch's bytes) and a temporary of the next input's writer."""
    reference(kind, tmp_path)
    out.mkdir()
    (out / ".nudge.lock").write_bytes(b"")
    for name in kept:
        (out / name).write_bytes(INPUTS[kind][name])
    (out / ".experiment.toml.k2x9q.tmp").write_bytes(b"[experim")
    return command(kind, out)


@pytest.mark.parametrize(("kind", "kept", "resume"), [
    ("replicate", ("experiment.toml", "plan.toml"), True),
    ("replicate", ("experiment.toml", "plan.toml"), False),
    ("replicate", (), True),  # killed in the first input's write
    ("power", ("experiment.toml",), False),
    ("sweep", ("sweep.toml",), True),
])
def test_a_batch_killed_before_its_manifest_starts_afresh(tmp_path: Path, kind: str, kept: tuple[str, ...],
                                                           resume: bool) -> None:
    out = tmp_path / "batch"
    command = _start_of(kind, tmp_path, out, kept)
    done = nudge(*command, "--out", out, *(["--resume"] if resume else []))
    assert done.exit_code == 0, done.output
    assert status(out) == "complete"
    assert tables(out) == reference(kind, tmp_path)
    assert not list(out.glob(".*.tmp"))


@pytest.mark.parametrize("own", [{"notes.txt": b"mine"}, {"experiment.toml": b"# my own experiment\n"}])
def test_a_batch_start_beside_a_file_of_ones_own_is_still_refused(tmp_path: Path,
                                                                  own: dict[str, bytes]) -> None:
    out = tmp_path / "batch"
    command = _start_of("replicate", tmp_path, out, ("plan.toml",))
    for name, data in own.items():
        (out / name).write_bytes(data)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.name != ".nudge.lock"}
    for resume in ([], ["--resume"]):
        refused = nudge(*command, "--out", out, *resume)
        assert refused.exit_code == 1, refused.output
        assert "Error: " in refused.output and ("not empty" in refused.output or "nothing to resume"
                                                in refused.output), refused.output
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.name != ".nudge.lock"} == before


def test_a_replicate_killed_as_its_plan_is_kept_resumes(tmp_path: Path) -> None:
    """SIGKILL once ``plan.toml`` appears (before ``batch.json``): the printed ``--resume`` works."""
    import glob
    import os
    import signal
    import subprocess
    import sys

    out = tmp_path / "batch"
    args = ["replicate", "smoke", "-R", "2", "--participants", "2", "--seed", "9", "--out", str(out)]
    for _ in range(5):
        child = subprocess.Popen([sys.executable, "-m", "nudgecli.cli", *args], start_new_session=True,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        while child.poll() is None and not glob.glob(str(out / "plan.toml")):
            __import__("time").sleep(0.003)
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
        child.wait()
        if not (out / "batch.json").exists():
            break
        import shutil

        shutil.rmtree(out)
    else:
        pytest.skip("the batch wrote its batch.json before it could be killed")
    resumed = nudge(*args, "--resume")
    assert resumed.exit_code == 0, resumed.output
    assert tables(out) == reference("replicate", tmp_path)
