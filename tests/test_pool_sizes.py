"""A worker pool's size has one owner, :func:`nudgecli.cores.pool_workers`: a study's pool
(``nudge simulate --workers``) and a batch's, which on ``--resume`` is sized by the participant tasks
left to run, not all of them (a batch with 2 tasks left and ``--workers 8`` forked a pool for all
its tasks), as its size estimate's ``worker(s)`` words are."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nudgecli.config import load_experiment
from nudgecli.cores import pool_workers
from nudgecli.run_folder_record import part_name
from nudgecli.runs import batch as batch_module
from nudgecli.runs import study as study_module
from nudgecli.runs.batch_kinds import replicate
from nudgecli.runs.part_record import PartRecord


class StopRunError(Exception):
    """Stops the run once its pool is sized (nothing is simulated)."""


def test_a_study_sizes_its_pool_by_the_owner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[tuple[int, int]] = []

    def sized(requested: int, tasks: int) -> int:
        asked.append((requested, tasks))
        raise StopRunError

    monkeypatch.setattr(study_module, "pool_workers", sized)  # was min(workers, len(todo)) of its own
    with pytest.raises(StopRunError):
        study_module.run_study(load_experiment("smoke"), tmp_path / "run", participants=2, workers=8)
    assert asked == [(8, 2)]


def test_a_resumed_batch_starts_no_more_workers_than_tasks_left(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[int] = []

    def no_executor(workers: int, client: Any) -> Any:
        asked.append(workers)
        raise StopRunError

    monkeypatch.setattr(batch_module, "make_executor", no_executor)
    batch = tmp_path / "B"  # 1 study of 3 participants: 3 participant tasks
    with pytest.raises(StopRunError):  # batch.json written, no part
        replicate("smoke", 1, batch, participants=3, workers=8)
    # participant 0 done: 2 tasks left and 1 done, so a count of the done ones is not taken for the
    # count of those left (the record's word on a part is its owner's)
    monkeypatch.setattr(PartRecord, "vouches", lambda self, part, *_: part.name == part_name(0))
    lines: list[str] = []
    with pytest.raises(StopRunError):
        replicate("smoke", 1, batch, participants=3, workers=8, resume=True, log=lines.append)
    assert asked == [3, pool_workers(8, 2)] == [3, 2], asked  # was [3, 3]: all the batch's tasks
    assert " on 2 worker(s)" in lines[0], lines[0]
    assert json.loads((batch / "batch.json").read_text())["executor"] == "processes:2"
