"""``batch.json``'s record of how a batch was computed survives its resumes: a resume with nothing
left keeps the executor, wall time and worker peak of the run that computed the tasks; one that
computes tasks records its own and keeps the earlier run's in ``earlier_runs``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from nudgecli.run_folder_record import part_name
from nudgecli.runs import batch as batch_module
from nudgecli.runs import batch_kinds
from nudgecli.runs import batch_record as batch_record_module
from nudgecli.runs.batch_kinds import replicate
from nudgecli.runs.batch_record import EARLIER_RUNS, RUN_KEYS, BatchRecord
from nudgecli.runs.part_record import PartRecord

#: What a first run on two worker processes recorded (a serial run stands in for it: no pool starts).
FIRST_RUN = {"executor": "processes:2", "worker_peak_rss_mb": 54.2, "wall_s": 3.2, "tasks_computed": 3}


@pytest.fixture(scope="module")
def made_once(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("first") / "batch"
    replicate("smoke", 1, folder)
    record = json.loads((folder / "batch.json").read_text())
    (folder / "batch.json").write_text(json.dumps({**record, **FIRST_RUN}))
    return folder


@pytest.fixture
def finished(made_once: Path, tmp_path: Path) -> Path:
    """A copy of the finished batch, for a test to resume."""
    return Path(shutil.copytree(made_once, tmp_path / "batch"))


def _record(folder: Path) -> dict:
    return json.loads((folder / "batch.json").read_text())


@pytest.mark.usefixtures("unrendered")
def test_a_resume_with_nothing_left_keeps_the_runs_record(finished: Path) -> None:
    before = _record(finished)
    replicate("smoke", 1, finished, resume=True)
    after = _record(finished)
    # was: executor "serial", worker_peak_rss_mb None, wall_s and created of the resume
    assert {k: after.get(k) for k in (*FIRST_RUN, "created", "finished", "versions")} == \
        {k: before[k] for k in (*FIRST_RUN, "created", "finished", "versions")}
    assert after["status"] == "complete" and EARLIER_RUNS not in after


@pytest.mark.usefixtures("unrendered")
def test_a_resume_that_computes_tasks_keeps_the_earlier_runs_record(finished: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(PartRecord, "vouches", lambda self, part, *_: part.name != part_name(1))
    replicate("smoke", 1, finished, resume=True)
    after = _record(finished)
    assert after["status"] == "complete" and after["executor"] == "serial"
    assert after["tasks_computed"] == 1  # participant 1's task (the record vouches for the analysis)
    # was: the first run's executor and worker peak lost
    assert [{k: run.get(k) for k in FIRST_RUN} for run in after.get(EARLIER_RUNS, [])] == [FIRST_RUN]


@pytest.fixture
def unrendered(monkeypatch: pytest.MonkeyPatch) -> None:
    """The batch's figures not rendered (0.7 s of each resume's 0.8 s; not what is tested here)."""
    monkeypatch.setattr(batch_kinds, "_figures", lambda folder, figures: [])


def _killed(monkeypatch: pytest.MonkeyPatch) -> None:
    """What a SIGKILL leaves: the run's ``batch.json`` as it last wrote it (no ``interrupted`` record)."""
    monkeypatch.setattr(BatchRecord, "interrupted", lambda self: None)


@pytest.mark.usefixtures("unrendered")
def test_a_run_killed_after_its_tasks_is_on_record_through_a_resume_with_nothing_left(
        finished: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    vouched = PartRecord.vouches
    monkeypatch.setattr(PartRecord, "vouches", lambda self, part, *a: part.name != part_name(1)
                        and vouched(self, part, *a))
    with monkeypatch.context() as killing:  # killed as it reads its analyses, its one task computed
        _killed(killing)
        killing.setattr(batch_module, "read_analyses", _raise_keyboard_interrupt)
        writes = _count_writes(killing)
        with pytest.raises(KeyboardInterrupt):
            replicate("smoke", 1, finished, resume=True)
        assert len(writes) == 2  # its start and its tasks' end: never rewritten per task
    assert _record(finished)["status"] == "running"
    monkeypatch.setattr(PartRecord, "vouches", vouched)
    replicate("smoke", 1, finished, resume=True)  # nothing left to compute
    after = _record(finished)
    # was: tasks_computed, wall_s and worker_peak_rss_mb absent (written only at the killed run's end)
    assert after["status"] == "complete" and after["executor"] == "serial" and after["tasks_computed"] == 1
    assert after["wall_s"] >= 0 and "worker_peak_rss_mb" in after
    assert [{k: run.get(k) for k in FIRST_RUN} for run in after[EARLIER_RUNS]] == [FIRST_RUN]


@pytest.mark.usefixtures("unrendered")
def test_a_run_killed_mid_way_leaves_its_count_so_far_to_the_resume_that_computes_the_rest(
        finished: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(batch_record_module, "RUNNING_RECORD_S", 0.0)  # recorded with every task
    vouched = PartRecord.vouches
    monkeypatch.setattr(PartRecord, "vouches", lambda self, part, *a: part.name not in (
        part_name(0), part_name(1)) and vouched(self, part, *a))
    write = PartRecord.write

    def killed_at_participant_1(self: PartRecord, part: Path, data: bytes) -> None:
        if part.name == part_name(1):
            raise KeyboardInterrupt
        write(self, part, data)

    with monkeypatch.context() as killing:
        _killed(killing)
        killing.setattr(PartRecord, "write", killed_at_participant_1)
        with pytest.raises(KeyboardInterrupt):
            replicate("smoke", 1, finished, resume=True)
    killed_run = {k: v for k, v in _record(finished).items() if k in RUN_KEYS}
    assert killed_run["tasks_computed"] == 1 and "finished" not in killed_run  # participant 0's task
    monkeypatch.setattr(PartRecord, "vouches", lambda self, part, *a: part.name != part_name(1)
                        and vouched(self, part, *a))
    replicate("smoke", 1, finished, resume=True)  # computes participant 1's task
    after = _record(finished)
    assert after["status"] == "complete" and after["tasks_computed"] == 1
    # was: the killed run in earlier_runs without tasks_computed or wall_s
    assert [{k: run.get(k) for k in RUN_KEYS} for run in after[EARLIER_RUNS]][1:] == \
        [{k: killed_run.get(k) for k in RUN_KEYS}]


def _raise_keyboard_interrupt(*args: object, **kwargs: object) -> None:
    raise KeyboardInterrupt


def _count_writes(monkeypatch: pytest.MonkeyPatch) -> list[dict]:
    """Each ``batch.json`` a run writes, as it wrote it."""
    writes: list[dict] = []
    write = BatchRecord.write

    def counted(self: BatchRecord) -> None:
        writes.append(dict(self.manifest))
        write(self)

    monkeypatch.setattr(BatchRecord, "write", counted)
    return writes


def test_a_finished_runs_wall_time_covers_its_tables_and_figures(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    # recorded as it goes since the running record; a finished run's still ends with its outputs
    import time

    ran = BatchRecord.ran
    at_ran: list[float] = []

    def recorded_at_ran(self: BatchRecord, peak_mb: float | None) -> None:
        ran(self, peak_mb)
        at_ran.append(self.manifest["wall_s"])

    monkeypatch.setattr(BatchRecord, "ran", recorded_at_ran)
    monkeypatch.setattr(batch_kinds, "_figures", lambda folder, figures: time.sleep(0.3) or [])
    replicate("smoke", 1, tmp_path / "batch")
    assert _record(tmp_path / "batch")["wall_s"] >= at_ran[0] + 0.3  # was: the value at ran()
