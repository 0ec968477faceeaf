"""The commands that resume work done on, or beside, a dask scheduler.

The command that resumes work done on a dask scheduler, as a run folder's or a batch folder's
readers advise it later (``nudge analyze`` of an unfinished run, a refused batch resume): the
manifest records the executor (``dask``), never the scheduler's address (a folder shipped with a
paper carries no machine's address), and the advice names ``--scheduler ADDRESS`` for the person
to fill in (it named none, and the resume ran on local workers). A manifest without the record (an
older nudge's) still loads, its advice without ``--scheduler``.

``--workers 1`` typed beside ``DASK_SCHEDULER_ADDRESS`` (which it wins over) stays in the resume
command ``simulate`` and ``run`` print: left out as the default, the resume ran on the variable's
scheduler."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.commands import scheduler_choice
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


@pytest.fixture
def simulated(monkeypatch: pytest.MonkeyPatch) -> Any:
    """``nudgecli.api.simulate`` replaced by one that writes the run's start and stops as Ctrl-C
    does (tests/test_dask_resume_commands.py's); an address from the variable is not probed."""
    from test_dask_resume_commands import Simulated

    import nudgecli.api

    monkeypatch.setattr(scheduler_choice, "check_environment_scheduler", lambda address: None)
    fake = Simulated()
    monkeypatch.setattr(nudgecli.api, "simulate", fake)
    return fake


@pytest.mark.parametrize("command", ["simulate", "run"])
def test_workers_1_typed_beside_a_scheduler_variable_stays_in_the_resume_command(
        tmp_path: Path, simulated: Any, monkeypatch: pytest.MonkeyPatch, command: str) -> None:
    # the resume left out --workers 1 (the default) and would have run on the variable's scheduler
    monkeypatch.setenv(scheduler_choice.SCHEDULER_ENV, "tcp://10.0.0.9:8786")
    result = nudge(command, "smoke", "--participants", "1", "--workers", "1", "--out", tmp_path / "run")
    assert result.exit_code == 130, result.output
    assert simulated.calls[0]["scheduler"] is None and simulated.calls[0]["workers"] == 1
    offered = [line for line in result.output.splitlines() if "--resume" in line]
    assert offered and offered[0].count("--workers 1 ") == (2 if command == "run" else 1), result.output


def test_workers_left_out_stay_out_of_the_resume_command(tmp_path: Path, simulated: Any,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(scheduler_choice.SCHEDULER_ENV, raising=False)
    result = nudge("simulate", "smoke", "--participants", "1", "--out", tmp_path / "run")
    assert result.exit_code == 130 and "--resume" in result.output and "--workers" not in result.output
