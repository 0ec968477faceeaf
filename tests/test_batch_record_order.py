"""A batch's record of its parts, ``checksums.sha256``, is written in its parts' order once the batch
is complete: the same bytes whatever order its tasks finished in (docs/reliability.md: a batch run
twice is byte-identical, ``batch.json``'s timings aside)."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import copy_run, nudge

from nudgecli.runs.batch_folder import PART_RECORD

REPLICATE = ("replicate", "smoke", "-R", "2", "--participants", "2")


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("order") / "batch"
    result = nudge(*REPLICATE, "--workers", "1", "--out", out)
    assert result.exit_code == 0, result.output
    return out


def _names(folder: Path) -> list[str]:
    return [line.split("  ", 1)[1] for line in (folder / PART_RECORD).read_text().splitlines()]


def test_the_record_lists_each_part_once_in_path_order(finished: Path) -> None:
    names = _names(finished)
    assert names == sorted(set(names)) and len(names) == 2 * 2 + 2


def test_a_resumed_batch_writes_the_record_an_uninterrupted_one_writes(tmp_path: Path,
                                                                       finished: Path) -> None:
    folder = copy_run(finished, tmp_path / "batch")
    first = sorted((folder / "tasks").rglob("*.parquet"))[0]
    first.unlink()  # computed again on resume, so its line comes last in the order of completion
    result = nudge(*REPLICATE, "--workers", "1", "--out", folder, "--resume")
    assert result.exit_code == 0, result.output
    assert (folder / PART_RECORD).read_bytes() == (finished / PART_RECORD).read_bytes()


def test_a_batch_on_two_workers_writes_the_record_one_worker_writes(tmp_path: Path, finished: Path) -> None:
    result = nudge(*REPLICATE, "--workers", "2", "--out", tmp_path / "two")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "two" / PART_RECORD).read_bytes() == (finished / PART_RECORD).read_bytes()
