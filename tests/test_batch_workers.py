"""A batch's worker pool: no more workers than participant tasks (``--workers 16`` forked 16
processes for 2 tasks, ``--workers 100000`` until the machine gave out), and the size estimate
shares the work among the workers that run at once, naming a scheduler's where there is one."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nudgecli.cores import pool_workers
from nudgecli.errors import ConfigError
from nudgecli.runs import batch as batch_module
from nudgecli.runs.batch_kinds import replicate
from nudgecli.runs.size import (
    SECONDS_FIXED,
    SECONDS_PER_ANALYSIS,
    SECONDS_PER_LAYOUT,
    SECONDS_PER_STUDY,
    SECONDS_PER_TASK,
    SECONDS_PER_TRIAL,
    size_estimate,
    tail_seconds,
)

WORK_S = 96 * SECONDS_PER_TRIAL + 6 * SECONDS_PER_ANALYSIS  # 12 participant tasks, 96 trials, 6 analyses
# what the workers do not share: the start, 3 plans of 8 layouts, 12 participants' own work, the tail
FIXED_S = (SECONDS_FIXED + 3 * (SECONDS_PER_STUDY + 8 * SECONDS_PER_LAYOUT) + 12 * SECONDS_PER_TASK
           + tail_seconds(6))


def test_the_pool_is_no_larger_than_the_tasks() -> None:
    assert [pool_workers(w, 2) for w in (1, 2, 16, 100_000)] == [1, 2, 2, 2]
    assert pool_workers(4, 0) == 1


def test_the_estimate_counts_the_workers_that_run_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("nudgecli.runs.size.available_cores", lambda: 4)
    within = size_estimate(3, 12, 6, 96, 3)
    assert within.workers == 3 and within.seconds == pytest.approx(FIXED_S + WORK_S / 3)
    assert "about 3 s on 3 worker(s) and" in within.describe()
    capped = size_estimate(3, 12, 6, 96, 100_000)  # was "on 100000 worker(s)", the work divided by them
    assert capped.workers == 12 and capped.seconds == pytest.approx(FIXED_S + WORK_S / 4)
    assert "on 12 worker(s) sharing 4 cores" in capped.describe()  # told, not refused


def test_on_a_scheduler_the_estimate_is_one_workers_and_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("nudgecli.runs.size.available_cores", lambda: 4)
    local = size_estimate(3, 12, 6, 96, 4)
    assert local.on(None) is local
    remote = local.on("tcp://127.0.0.1:8786")
    assert remote.seconds == pytest.approx(FIXED_S + WORK_S) and remote.on_scheduler
    assert "on one worker (less on the scheduler's workers)" in remote.describe()


def test_a_refused_batch_on_a_scheduler_does_not_say_one_worker(tmp_path: Path) -> None:
    # above the size limit: refused before the scheduler is reached (it was "on 1 worker(s)")
    with pytest.raises(ConfigError) as raised:
        replicate("smoke", 20_000, tmp_path / "out", scheduler="tcp://127.0.0.1:9")
    assert "scheduler's workers" in str(raised.value) and "1 worker(s)" not in str(raised.value)


class StopBatchError(Exception):
    """Stops the batch once its executor is asked for (nothing is simulated)."""


def test_a_batch_starts_no_more_workers_than_its_tasks(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[int] = []

    def no_executor(workers: int, client: Any) -> Any:
        asked.append(workers)
        raise StopBatchError

    monkeypatch.setattr(batch_module, "make_executor", no_executor)
    lines: list[str] = []
    with pytest.raises(StopBatchError):  # smoke: 2 participants, one study
        replicate("smoke", 1, tmp_path / "out", workers=16, log=lines.append)
    assert asked == [2]
    assert json.loads((tmp_path / "out" / "batch.json").read_text())["executor"] == "processes:2"
    assert " on 2 worker(s)" in lines[0]
