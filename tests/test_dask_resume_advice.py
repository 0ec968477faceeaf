"""The command that resumes work done on a dask scheduler, as a run folder's or a batch folder's
readers advise it later (``nudge analyze`` of an unfinished run, a refused batch resume): the
manifest records the executor (``dask``), never the scheduler's address (a folder shipped with a
paper carries no machine's address), and the advice names ``--scheduler ADDRESS`` for the person
to fill in (it named none, and the resume ran on local workers). A manifest without the record (an
older nudge's) still loads, its advice without ``--scheduler``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.run_folder_names import MANIFEST, part_name
from nudgecli.runs.batch_resume import batch_resume_command
from nudgecli.store import RunFolder


def _unfinished_copy(run: Path, out: Path, executor: str | None) -> Path:
    """A copy of ``run`` whose manifest records ``executor`` (None: no record), a trials part gone."""
    shutil.copytree(run, out)
    manifest = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    manifest.pop("executor", None)
    if executor is not None:
        manifest["executor"] = executor
    (out / MANIFEST).write_text(json.dumps(manifest), encoding="utf-8")
    (out / "trials" / part_name(1)).unlink()
    return out


@pytest.mark.parametrize(("executor", "named"), [("dask", True), ("serial", False), (None, False)])
def test_analyze_of_an_unfinished_dask_run_names_a_scheduler_to_fill_in(
        analysed_smoke_run: Path, tmp_path: Path, executor: str | None, named: bool) -> None:
    run = _unfinished_copy(analysed_smoke_run, tmp_path / "run", executor)
    line = one_error_line(nudge("analyze", run).output)
    assert f"--out {run}" in line and "--resume" in line, line
    assert ("--scheduler ADDRESS --resume" in line) is named, line
    assert ("--scheduler ADDRESS" in RunFolder(run).resume_command()) is named


@pytest.mark.parametrize(("executor", "named"), [("dask", True), ("processes:2", False), (None, False)])
@pytest.mark.parametrize("kind", ["replicate", "sweep"])
def test_the_command_that_resumes_a_dask_batch_names_a_scheduler_to_fill_in(
        tmp_path: Path, kind: str, executor: str | None, named: bool) -> None:
    record = {"batch": {"kind": kind, "replications": 2, "seed": 4}}
    record.update({"executor": executor} if executor else {})
    command = batch_resume_command(tmp_path, record, missing="FILE")
    assert command is not None and command.startswith(f"nudge {kind} FILE --out {tmp_path} "), command
    assert ("--scheduler ADDRESS" in command) is named, command
