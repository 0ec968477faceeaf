"""Parts built where the work is: on many pool workers a participant task builds its part (the
metrics table and its Parquet bytes) in its worker, below that the batch's process does; the
parts' bytes and the analyses are the same either way."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from nudgecli.config import load_experiment
from nudgecli.report.plans import load_plan
from nudgecli.runs import batch as batch_module
from nudgecli.runs.batch import Batch, run_batch, single_point
from nudgecli.runs.batch_tasks import ParticipantMetrics


def _batch() -> Batch:
    config = load_experiment("smoke")
    return Batch("replicate", single_point(config, (config.study.participants,)), 2, 4, load_plan("paper"))


def _parts(folder: Path) -> dict[str, bytes]:
    parts = sorted((folder / "tasks").rglob("*.parquet"))
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in parts}


@pytest.mark.parametrize("threshold", [2, 3])
def test_parts_are_built_in_the_workers_from_the_threshold_on(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                             threshold: int) -> None:
    serial = run_batch(_batch(), tmp_path / "serial", workers=1)
    log = tmp_path / "frames.txt"
    frame = ParticipantMetrics.frame

    def logged(self: ParticipantMetrics) -> object:  # the workers are forked: they log too
        with open(log, "a") as handle:
            handle.write(f"{os.getpid()}\n")
        return frame(self)

    monkeypatch.setattr(ParticipantMetrics, "frame", logged)
    monkeypatch.setattr(batch_module, "PART_BUILDING_WORKERS", threshold)
    pooled = run_batch(_batch(), tmp_path / "pool", workers=2)
    builders = set(log.read_text().split())
    assert len(log.read_text().split()) == 4  # two participants of two studies, each built once
    if threshold <= 2:
        assert str(os.getpid()) not in builders  # every part built in a worker
    else:
        assert builders == {str(os.getpid())}  # every part built here
    assert _parts(tmp_path / "pool") == _parts(tmp_path / "serial")
    assert pooled.stats == serial.stats
