"""``batch.json``'s record of how a batch was computed survives its resumes: a resume with nothing
left keeps the executor, wall time and worker peak of the run that computed the tasks; one that
computes tasks records its own and keeps the earlier run's in ``earlier_runs``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from nudgecli.run_folder_record import part_name
from nudgecli.runs.batch_kinds import replicate
from nudgecli.runs.batch_record import EARLIER_RUNS
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


def test_a_resume_with_nothing_left_keeps_the_runs_record(finished: Path) -> None:
    before = _record(finished)
    replicate("smoke", 1, finished, resume=True)
    after = _record(finished)
    # was: executor "serial", worker_peak_rss_mb None, wall_s and created of the resume
    assert {k: after.get(k) for k in (*FIRST_RUN, "created", "finished", "versions")} == \
        {k: before[k] for k in (*FIRST_RUN, "created", "finished", "versions")}
    assert after["status"] == "complete" and EARLIER_RUNS not in after


def test_a_resume_that_computes_tasks_keeps_the_earlier_runs_record(finished: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(PartRecord, "vouches", lambda self, part, *_: part.name != part_name(1))
    replicate("smoke", 1, finished, resume=True)
    after = _record(finished)
    assert after["status"] == "complete" and after["executor"] == "serial"
    assert after["tasks_computed"] == 1  # participant 1's task (the record vouches for the analysis)
    # was: the first run's executor and worker peak lost
    assert [{k: run.get(k) for k in FIRST_RUN} for run in after.get(EARLIER_RUNS, [])] == [FIRST_RUN]
