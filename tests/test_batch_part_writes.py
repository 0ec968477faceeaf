"""A batch's parts: written atomically without forcing them to disk (their record's SHA-256 finds
one a power cut left short), with the bytes every other Parquet writer of the toolkit gives."""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd
import pytest

from nudgecli import store
from nudgecli.run_folder_record import file_sha256
from nudgecli.runs.batch_folder import PART_RECORD, PartRecord, parquet_bytes


def _frame() -> pd.DataFrame:
    return pd.DataFrame({"participant": [0, 0], "condition": ["A", "B"],
                         "mode_switches": pd.array([1, None], dtype="Int64"), "completion_time": [1.5, 2.0]})


def test_parquet_bytes_are_what_the_parquet_writer_writes(tmp_path: Path) -> None:
    store.write_parquet_atomic(tmp_path / "written.parquet", _frame())
    assert parquet_bytes(_frame()) == (tmp_path / "written.parquet").read_bytes()


def test_a_batch_part_is_recorded_with_its_sha256_and_not_forced_to_disk(monkeypatch: pytest.MonkeyPatch,
                                                                         tmp_path: Path) -> None:
    synced: list[int] = []
    real_fsync = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: synced.append(fd) or real_fsync(fd))
    record = PartRecord(tmp_path)
    record.write(tmp_path / "tasks/s/part-0000.parquet", parquet_bytes(_frame()))  # its folder is made
    record.write_json(tmp_path / "analyses" / "s-n0002.json", {"p": 0.5})
    assert synced == []
    lines = (tmp_path / PART_RECORD).read_text().splitlines()
    assert lines == [f"{file_sha256(tmp_path / 'tasks/s/part-0000.parquet')}  tasks/s/part-0000.parquet",
                     f"{file_sha256(tmp_path / 'analyses/s-n0002.json')}  analyses/s-n0002.json"]
    assert (tmp_path / "analyses/s-n0002.json").read_text() == store.json_text({"p": 0.5})
    again = PartRecord(tmp_path)
    assert again.vouches(tmp_path / "tasks/s/part-0000.parquet")
    store.write_json_atomic(tmp_path / "batch.json", {})  # any other file is flushed to disk
    assert len(synced) == 1


@pytest.mark.parametrize("tail", ["3b98e3", "\0\0\0\0"])  # a torn line; the zeros a power cut can leave
def test_the_first_line_after_a_torn_one_starts_a_line_of_its_own(tmp_path: Path, tail: str) -> None:
    record = PartRecord(tmp_path)
    first, second = tmp_path / "tasks/s/part-0000.parquet", tmp_path / "tasks/s/part-0001.parquet"
    record.write(first, parquet_bytes(_frame()))
    with open(tmp_path / PART_RECORD, "a") as handle:
        handle.write(tail)
    resumed = PartRecord(tmp_path)
    resumed.write(second, parquet_bytes(_frame().head(1)))
    resumed.write_json(tmp_path / "analyses/s-n0002.json", {"p": 0.5})
    again = PartRecord(tmp_path)  # the next resume vouches for both parts: neither is computed again
    assert again.vouches(first) and again.vouches(second)
    assert again.vouches(tmp_path / "analyses/s-n0002.json", lambda path: True)
    assert (tmp_path / PART_RECORD).read_text().splitlines()[1] == tail
