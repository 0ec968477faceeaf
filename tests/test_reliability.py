"""Nothing lost, nothing silent: run-folder locks, completeness, resume of damaged parts, write
errors (full disk, read-only folders), Ctrl-C. Fault injection with real processes where the
fault is a process's (SIGKILL, SIGINT, a concurrent writer), with an injected OSError where the
fault is the file system's and this machine cannot make it (no small or read-only mount)."""

from __future__ import annotations

import errno
import json
import os
import shlex
import signal
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import copy_run, one_error_line, wait_for
from click.testing import CliRunner

from nudgecli import results_folders, store
from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import LockError, RunFolderError, WriteError
from nudgecli.locks import run_lock
from nudgecli.report.analysis import analyze
from nudgecli.run_folder_names import LOCK
from nudgecli.runs.study import run_study
from nudgecli.store import RunFolder, default_run_dir

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
NUDGE = [sys.executable, "-m", "nudgecli.cli"]
#: root ignores file permissions, so a chmod-made read-only folder is writable for it
AS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


def tables(path: Path) -> list[pd.DataFrame]:
    run = RunFolder(path)
    return [run.read_trials(), run.read_steps(), pd.read_parquet(path / "participants.parquet"),
            pd.read_parquet(path / "layouts.parquet")]


def assert_same_run(a: Path, b: Path) -> None:
    for left, right in zip(tables(a), tables(b), strict=True):
        pd.testing.assert_frame_equal(left, right, check_exact=True)


@pytest.fixture(scope="module")
def clean_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An uninterrupted smoke run of 3 participants: what every repaired run must equal."""
    out = tmp_path_factory.mktemp("clean") / "run"
    run_study(load_experiment("smoke"), out, participants=3)
    return out


def invoke(args: list[str]):
    return CliRunner().invoke(main, args)


# --- locking -------------------------------------------------------------------------------------


def test_a_second_writer_even_with_force_is_refused_naming_the_holder(tmp_path):
    """Real processes: a long run holds the folder; `--force` from another process is refused."""
    out = tmp_path / "busy"
    first = subprocess.Popen([*NUDGE, "simulate", "smoke", "--participants", "200", "--out", str(out)],
                             env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: (out / "manifest.json").is_file())
        second = subprocess.run([*NUDGE, "simulate", "smoke", "--out", str(out), "--force"], env=ENV,
                                capture_output=True, text=True, timeout=60)
        assert first.poll() is None, "the first run must still be writing for this test to mean anything"
        line = one_error_line(second.stderr)
        assert second.returncode == 1
        assert f"pid {first.pid} on host {socket.gethostname()}" in line and "in use by" in line
        manifest = json.loads((out / "manifest.json").read_text())
        assert manifest["participants"] == 200  # the first run's folder is untouched
        with pytest.raises(LockError, match=f"pid {first.pid}"):
            analyze(out)
    finally:
        first.kill()
        first.wait()


def test_a_lock_file_of_a_dead_pid_is_taken_over_and_one_of_another_host_refused(tmp_path, capsys):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / LOCK).write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname(), "command": "x"}))
    lines: list[str] = []
    with run_lock(folder, log=lines.append):
        assert json.loads((folder / LOCK).read_text())["pid"] == os.getpid()
    assert f"stale lock of `x` (pid {dead.pid}" in lines[0] and capsys.readouterr().err == ""
    assert not (folder / LOCK).exists()
    (folder / LOCK).write_text(json.dumps({"pid": 1, "host": "elsewhere.example", "command": "y"}))
    with pytest.raises(LockError, match=r"another host.*delete"), run_lock(folder):
        pass


def test_the_lock_is_reentrant_in_one_process_and_released_on_error(tmp_path):
    with run_lock(tmp_path / "r") as path, run_lock(path):
        assert (path / LOCK).is_file()
    assert not (tmp_path / "r" / LOCK).exists()
    with pytest.raises(RuntimeError), run_lock(tmp_path / "r"):
        raise RuntimeError
    with run_lock(tmp_path / "r"):
        pass


def test_two_default_run_folders_started_in_the_same_second_differ(tmp_path, monkeypatch):
    class FrozenClock(results_folders.datetime):  # type: ignore[misc,valid-type]
        @classmethod
        def now(cls, tz=None):
            return results_folders.datetime(2026, 1, 2, 3, 4, 5, tzinfo=tz)

    monkeypatch.setattr(results_folders, "datetime", FrozenClock)
    first, second = default_run_dir("smoke", tmp_path), default_run_dir("smoke", tmp_path)
    assert first.name == "smoke-20260102T030405Z" and second.name == "smoke-20260102T030405Z-2"
    assert first.is_dir() and second.is_dir()


def test_default_out_runs_do_not_collide(tmp_path):
    """Two real processes with the default --out, started together: two folders, both complete."""
    procs = [subprocess.Popen([*NUDGE, "simulate", "smoke", "--participants", "1"], cwd=tmp_path, env=ENV,
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True) for _ in range(2)]
    outputs = [proc.communicate(timeout=120)[0] for proc in procs]
    assert [proc.returncode for proc in procs] == [0, 0]
    folders = {out.strip().splitlines()[-1] for out in outputs}
    assert len(folders) == 2
    for folder in folders:
        assert RunFolder(tmp_path / folder).read_manifest()["status"] == "complete"


# --- completeness and resume -------------------------------------------------------------------


def _restore_command(message: str) -> list[str]:
    command = message.split("`")[-2]
    assert command.startswith("nudge simulate ") and command.endswith(" --resume")
    return shlex.split(command)[1:]


@pytest.mark.parametrize(("kind", "damage"), [("trials", "delete"), ("steps", "delete"),
                                              ("trials", "truncate"), ("steps", "truncate")])
def test_analyze_refuses_a_run_with_a_missing_or_corrupt_part_and_resume_restores_it(
        tmp_path, clean_run, kind, damage):
    run = copy_run(clean_run, tmp_path / "run")
    part = run / kind / "part-0001.parquet"
    if damage == "delete":
        part.unlink()
    else:
        part.write_bytes(part.read_bytes()[: part.stat().st_size // 2])
    refused = invoke(["analyze", str(run)])
    assert refused.exit_code == 1
    line = one_error_line(refused.output)
    state = "missing" if damage == "delete" else "unreadable"
    assert f"participant 1: {kind}/part-0001.parquet ({state})" in line
    restored = invoke(_restore_command(line))
    assert restored.exit_code == 0, restored.output
    assert "1 simulated now" in restored.output
    assert_same_run(run, clean_run)
    assert invoke(["analyze", str(run)]).exit_code == 0


def test_analyze_refuses_an_unfinished_run(tmp_path, clean_run):
    run = copy_run(clean_run, tmp_path / "run")
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["status"] = "running"
    (run / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(RunFolderError, match=r"the run was interrupted.*--resume"):  # no process holds it
        analyze(run)


@pytest.mark.parametrize("moment", ["config.toml", "trials/part-0000.parquet", "steps/part-0001.parquet",
                                    "participants/part-0002.parquet"])
def test_sigkill_at_several_moments_then_resume_equals_a_clean_run(tmp_path, clean_run, moment):
    out = tmp_path / "run"
    proc = subprocess.Popen([*NUDGE, "simulate", "smoke", "--participants", "3", "--out", str(out)], env=ENV,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wait_for(lambda: (out / moment).exists() or proc.poll() is not None)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert (out / "config.toml").is_file()  # the run had started (perhaps without a manifest yet)
    holder = json.loads((out / LOCK).read_text())  # the killed run's lock is left behind
    assert holder["pid"] == proc.pid and holder["host"] == socket.gethostname()
    result = invoke(["simulate", "smoke", "--participants", "3", "--out", str(out), "--resume"])
    assert result.exit_code == 0, result.output
    assert f"Warning: {out}: taking over the stale lock" in result.output
    assert f"pid {proc.pid}" in result.output
    assert not (out / LOCK).exists()
    assert_same_run(out, clean_run)
    assert not list(out.rglob(".*.tmp"))


# --- write errors --------------------------------------------------------------------------------


def _full_disk_on(monkeypatch, fragment: str) -> None:
    """Make writing a Parquet file whose path contains ``fragment`` fail as a full disk does."""
    original = pd.DataFrame.to_parquet

    def to_parquet(self, path, *args, **kwargs):
        if fragment in str(path):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return original(self, path, *args, **kwargs)

    monkeypatch.setattr(pd.DataFrame, "to_parquet", to_parquet)


def test_a_full_disk_while_writing_a_participant_leaves_no_half_participant(tmp_path, clean_run, monkeypatch):
    out = tmp_path / "run"
    _full_disk_on(monkeypatch, f"{os.sep}steps{os.sep}.part-0001")
    result = invoke(["simulate", "smoke", "--participants", "3", "--out", str(out)])
    assert result.exit_code == 1
    line = one_error_line(result.output.replace(f"Run folder: {out}", ""))
    assert f"cannot write {out / 'steps' / 'part-0001.parquet'}: No space left on device" in line
    assert (out / "trials" / "part-0000.parquet").is_file()
    assert not (out / "trials" / "part-0001.parquet").exists()  # no trials part without its steps part
    assert not list(out.rglob(".*.tmp")) and not (out / LOCK).exists()
    monkeypatch.undo()
    resumed = invoke(["simulate", "smoke", "--participants", "3", "--out", str(out), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    assert_same_run(out, clean_run)


@pytest.mark.skipif(os.name != "posix", reason="the pool's workers inherit the test's patch by fork")
def test_a_full_disk_under_a_workers_file_is_one_error_line(tmp_path, monkeypatch):
    # a lone study's layout tasks pickle their chunks into the pool's spool folder, in the workers
    import nudgecli.runs.study as study

    def dump(obj, handle, protocol=None):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), handle.name)

    monkeypatch.setattr(study.pickle, "dump", dump)  # the forked workers inherit it
    out = tmp_path / "batch"
    result = CliRunner().invoke(main, ["replicate", "smoke", "-R", "1", "--workers", "2", "--out", str(out)])
    assert result.exit_code == 1, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error: ")]
    assert len(errors) == 1 and "Traceback" not in result.output  # after the size and progress lines
    line = errors[0]
    assert "No space left on device" in line and "layouts" in line
    assert json.loads((out / "batch.json").read_text())["status"] == "interrupted"
    assert not Path(line.split(": ")[1]).parent.exists()  # the spool folder is gone with the pool


def _deny_writes(monkeypatch) -> None:
    """Every new file fails as in a read-only folder (the atomic writer's and any other mkstemp), but
    multiprocessing's shared memory in /dev/shm (the figure writers' counter: not a result)."""
    real = tempfile.mkstemp

    def mkstemp(*args, dir=None, **kwargs):
        if dir is not None and Path(dir) == Path("/dev/shm"):
            return real(*args, dir=dir, **kwargs)
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(dir))

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory, clean_run: Path) -> dict[str, Path]:
    """A metrics table and an analysed run, made once for the write-error tests."""
    base = tmp_path_factory.mktemp("inputs")
    table = base / "study.csv"
    table.write_text(Path(__file__).with_name("data").joinpath("metrics_two_conditions.csv").read_text())
    analysed = copy_run(clean_run, base / "analysed")
    assert invoke(["analyze", str(analysed)]).exit_code == 0
    return {"table": table, "analysed": analysed}


def _commands(tmp_path: Path, inputs: dict[str, Path]) -> dict[str, list[str]]:
    analysed = inputs["analysed"]
    return {
        "simulate": ["simulate", "smoke", "--participants", "1", "--out", str(tmp_path / "sim")],
        "run": ["run", "smoke", "--participants", "1", "--out", str(tmp_path / "run")],
        "analyze": ["analyze", str(inputs["table"]), "--out", str(tmp_path / "analysis")],
        "plot": ["plot", str(analysed), "--formats", "png", "--out", str(tmp_path / "figures")],
        "fit": ["fit", str(analysed / "calibration" / "participant-0000"), "--out",
                str(tmp_path / "fit" / "p.json")],
        "validate": ["validate", "--simulations", "2", "--mc-queries", "0", "--out", str(tmp_path / "val")],
    }


@pytest.mark.parametrize("command", ["simulate", "run", "analyze", "plot", "fit", "validate"])
def test_a_write_error_is_one_error_line_with_path_and_cause(tmp_path, inputs, monkeypatch, command):
    args = _commands(tmp_path, inputs)[command]
    if command == "validate":
        import nudgecli.sim.validation as validation

        def never(*args, **kwargs):
            raise AssertionError("validate computed before checking that it can write")

        monkeypatch.setattr(validation, "run_validation", never)
    _deny_writes(monkeypatch)
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("Error: ")]
    assert len(lines) == 1 and "Permission denied" in lines[0] and "Traceback" not in result.output
    assert str(tmp_path) in lines[0]  # names the path


@pytest.mark.skipif(AS_ROOT, reason="running as root, which ignores a folder's permissions; the injected "
                                    "read-only variant (test_a_write_error_is_one_error_line...) covers it")
@pytest.mark.parametrize("command", ["simulate", "analyze", "fit", "validate"])
def test_a_real_read_only_folder_is_one_error_line(tmp_path, inputs, command):
    args = _commands(tmp_path, inputs)[command]
    locked = tmp_path / "readonly"
    locked.mkdir()
    replaced = {"simulate": ["--out", str(locked / "sim")], "analyze": ["--out", str(locked / "a")],
                "fit": ["--out", str(locked / "p.json")], "validate": ["--out", str(locked / "v")]}
    args = args[:args.index("--out")] if "--out" in args else args
    args += replaced[command] + (["--simulations", "2", "--mc-queries", "0"] if command == "validate" else [])
    locked.chmod(0o555)
    try:
        result = CliRunner().invoke(main, args)
    finally:
        locked.chmod(0o755)
    assert result.exit_code == 1, result.output
    assert "Permission denied" in one_error_line(result.output)


def test_atomic_path_turns_an_oserror_into_a_write_error_and_leaves_no_temporary_file(tmp_path):
    with pytest.raises(WriteError, match=r"cannot write .*x\.txt: No space left on device"), \
            store.atomic_path(tmp_path / "x.txt") as tmp:
        tmp.write_text("half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert list(tmp_path.iterdir()) == []


# --- Ctrl-C --------------------------------------------------------------------------------------


def test_ctrl_c_exits_130_and_prints_the_exact_resume_command(tmp_path, clean_run):
    out = tmp_path / "run"
    proc = subprocess.Popen([*NUDGE, "simulate", "smoke", "--participants", "3", "--out", str(out)], env=ENV,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wait_for(lambda: (out / "participants" / "part-0000.parquet").exists() or proc.poll() is not None)
    proc.send_signal(signal.SIGINT)
    stderr = proc.communicate(timeout=60)[1]
    if proc.returncode == 0:
        pytest.skip("the child finished before the interrupt")
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "Aborted" not in stderr
    command = stderr.split("resume with: ")[1].strip().splitlines()[0]
    assert command == f"nudge simulate smoke --out {out} --participants 3 --resume"
    resumed = invoke(shlex.split(command)[1:])
    assert resumed.exit_code == 0, resumed.output
    assert_same_run(out, clean_run)


def test_ctrl_c_elsewhere_exits_130(tmp_path, monkeypatch):
    import nudgecli.report.analysis as analysis

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(analysis, "analyze", interrupted)
    table = Path(__file__).with_name("data") / "metrics_two_conditions.csv"
    result = CliRunner().invoke(main, ["analyze", str(table)])
    assert result.exit_code == 130 and "Interrupted: " in result.output
    assert "run the command again" in result.output
    monkeypatch.setattr("nudgecli.runs.study.run_study", interrupted)
    result = CliRunner().invoke(main, ["run", "smoke", "--out", str(tmp_path / "never")])
    assert result.exit_code == 130 and "nothing was simulated yet" in result.output
    assert not (tmp_path / "never").exists() or not any((tmp_path / "never").iterdir())


def test_a_refused_run_leaves_no_empty_default_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = invoke(["simulate", "smoke", "--workers", "0"])
    assert result.exit_code == 1 and "--workers must be at least 1" in result.output
    assert not (tmp_path / "results").exists() or not any((tmp_path / "results").iterdir())
