"""Mends of determinism and resume: a resumed sweep's ``batch.json`` records the digests of the
inputs its folder keeps (not of the resume's own bytes), so the folder's own resume command works
after it; simulating a run's ``config.toml`` takes the people file the run keeps, so it gives the
run's tables again (docs/run-folders.md); the workers of a study's local pools (its participants',
its layouts') ignore Ctrl-C, as the batch pool's do, so it prints no traceback of theirs."""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import signal
from pathlib import Path
from typing import Any

import pytest
from batch_helpers import a_sweep_study
from cli_helpers import nudge, nudge_interrupted, one_error_line
from people_helpers import PEOPLE_BYTES

import nudgecli
from nudgecli.runs import study as study_runs
from nudgecli.runs.batch_folder import BATCH_MANIFEST

#: One point of three participants, one replication: four tasks, so three Ctrl-C'd runs each write one.
SWEEP = ('experiment = "exp.toml"\nreplications = 1\nseed = 11\nset = ["study.participants=3"]\n'
         '[design]\nmethod = "grid"\n[parameters]\n"inference.kappa" = [0.6]\n')


@pytest.fixture()
def study(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``study/``: the sweep file ``my.toml`` and the experiment file it names (the smoke preset's
    copy), the current folder."""
    folder = a_sweep_study(tmp_path / "study", SWEEP)
    monkeypatch.chdir(folder)
    return folder


@pytest.mark.parametrize("edit", ["a comment in the experiment", "replications overridden by an equal -R"])
def test_a_resume_with_other_bytes_records_the_kept_inputs_so_the_folder_resumes_itself(
        study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, edit: str) -> None:
    out = tmp_path / "S"
    assert nudge_interrupted(monkeypatch, "sweep", "my.toml", "--out", str(out)).exit_code == 130
    if edit.startswith("a comment"):
        with (study / "exp.toml").open("a") as handle:
            handle.write("# my note\n")
        again: tuple[str, ...] = ()
    else:
        (study / "my.toml").write_text(SWEEP.replace("replications = 1", "replications = 2"))
        again = ("-R", "1")
    resumed = nudge_interrupted(monkeypatch, "sweep", "my.toml", "--out", str(out), "--resume", *again)
    assert resumed.exit_code == 130, resumed.output
    recorded = json.loads((out / BATCH_MANIFEST).read_text())["inputs"]
    held = {name: hashlib.sha256((out / name).read_bytes()).hexdigest() for name in recorded}
    assert recorded == held
    itself = nudge_interrupted(monkeypatch, "sweep", str(out / "sweep.toml"), "--out", str(out), "--resume")
    assert itself.exit_code == 130, itself.output


def same(where: Path, folder: str, table: str) -> bool:
    """Whether ``folder``'s ``table`` holds the bytes of the run's (``where/run``)."""
    return (where / folder / table).read_bytes() == (where / "run" / table).read_bytes()


def test_simulating_a_runs_config_takes_the_people_file_it_keeps(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    Path("twins.csv").write_bytes(PEOPLE_BYTES)
    made = nudge("simulate", "smoke", "--participants", "1", "--people", "twins.csv", "--out", "run")
    assert made.exit_code == 0, made.output
    again = nudge("simulate", "run/config.toml", "--out", "again")
    assert again.exit_code == 0, again.output
    notes = [line for line in again.stderr.splitlines() if line.startswith("Note: run/config.toml")]
    assert len(notes) == 1 and "--people run/people/twins.csv" in notes[0], again.stderr
    for table in ("participants.parquet", "trials/part-0000.parquet"):
        assert same(tmp_path, "again", table), table
    told: list[str] = []
    nudgecli.simulate("run/config.toml", out="api", log=told.append).close()  # the API's too
    assert "--people run/people/twins.csv" in told[0]
    assert same(tmp_path, "api", "participants.parquet")
    (tmp_path / "run" / "people" / "twins.csv").unlink()  # its copy gone: refused, naming --people
    refused = nudge("simulate", "run/config.toml", "--out", "lost")
    assert refused.exit_code == 1, refused.output
    assert "(--people PATH/twins.csv)" in one_error_line(refused.stderr), refused.output
    assert not (tmp_path / "lost").exists()


class _PoolMadeError(Exception):
    """Raised in place of a pool being started: its initializer is what the test wants."""


def _sigint_ignored_after(initializer: Any, initargs: tuple[Any, ...], answer: Any) -> None:
    """In a child process: run a pool's worker initializer, then say whether SIGINT is ignored."""
    initializer(*initargs)
    answer.put(signal.getsignal(signal.SIGINT) == signal.SIG_IGN)


def test_a_studys_pool_workers_leave_ctrl_c_to_the_parent(monkeypatch: pytest.MonkeyPatch) -> None:
    made: list[tuple[str, Any, tuple[Any, ...]]] = []

    def pool(*_: Any, initializer: Any, initargs: tuple[Any, ...], **__: Any) -> None:
        made.append((getattr(initializer, "__name__", ""), initializer, initargs))
        raise _PoolMadeError

    monkeypatch.setattr(study_runs, "ProcessPoolExecutor", pool)
    with pytest.raises(_PoolMadeError):  # the participants' pool
        next(study_runs._processes(None, [0, 1], 2))  # type: ignore[arg-type]
    with pytest.raises(_PoolMadeError):  # the layouts' pool (the smoke preset's grid world)
        study_runs.build_plan_on(nudgecli.experiment_config("smoke"), 1, 2)
    context = multiprocessing.get_context("fork")
    for name, initializer, initargs in made:
        answer = context.Queue()
        child = context.Process(target=_sigint_ignored_after, args=(initializer, initargs, answer))
        child.start()
        ignored = answer.get(timeout=30)
        child.join(timeout=30)
        assert ignored, f"{name}: a worker of this pool takes Ctrl-C (SIGINT) itself"
    assert len(made) == 2


class _InterruptedPool:
    """A layouts' pool whose map is interrupted by Ctrl-C: records how it was ended."""

    def __init__(self, *_: Any, **__: Any) -> None:
        self.ended: list[str] = []
        worker = self

        class _Worker:
            def terminate(self) -> None:
                worker.ended.append("terminate")

        self._processes = {1: _Worker()}
        _InterruptedPool.made = self

    made: _InterruptedPool | None = None

    def map(self, *_: Any) -> Any:
        raise KeyboardInterrupt

    def shutdown(self, wait: bool = True, **__: Any) -> None:
        self.ended.append(f"shutdown(wait={wait})")


def test_ctrl_c_in_the_layouts_pool_stops_it_without_waiting_for_its_chunks(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(study_runs, "ProcessPoolExecutor", _InterruptedPool)
    with pytest.raises(KeyboardInterrupt):
        study_runs.build_plan_on(nudgecli.experiment_config("smoke"), 1, 2)
    pool = _InterruptedPool.made
    # stop_pool: no join of the running chunks (its workers ignore Ctrl-C), its processes terminated
    assert pool is not None and pool.ended == ["shutdown(wait=False)", "terminate"], pool and pool.ended
