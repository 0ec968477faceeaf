"""The resume commands and ``nudge run`` on a dask scheduler, and the rerun of a failed start.

- The command that resumes an interrupted or failed ``nudge simulate --scheduler ADDR`` (and
  ``nudge run``) names ``--scheduler ADDR`` (it was dropped, and the resume ran locally); an
  address from ``DASK_SCHEDULER_ADDRESS`` is left out: the variable is there again for the rerun,
  as in the batch commands' resume commands.
- ``nudge run`` has ``--scheduler`` (and reads ``DASK_SCHEDULER_ADDRESS``) as ``nudge simulate``
  does: its simulation runs there (it ignored the variable without a word).
- A folder holding only the start of the same run (a start that failed after writing its
  ``config.toml``) refuses a plain rerun offering ``--resume`` (was: only ``--force``).

The scheduler is never connected to: the simulation (``nudgecli.api.simulate``) is replaced by
one that records its scheduler and stops as a run does, so each test takes milliseconds.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from cli_helpers import nudge, one_error_line

import nudgecli.api
from nudgecli.commands import scheduler_choice
from nudgecli.errors import NudgeError, WorkerLostError
from nudgecli.run_folder_names import CONFIG, MANIFEST
from nudgecli.store import RunFolder, simulate_resume_command

ADDRESS = "tcp://127.0.0.1:8786"
OTHER = "tcp://10.0.0.9:8786"


class Simulated:
    """The calls of the replaced simulation (their keywords) and how it stops: ``stop``, raised
    once the run's start (its config.toml) is written."""

    def __init__(self) -> None:
        self.calls: list[dict[str, Any]] = []
        self.stop: BaseException = KeyboardInterrupt()

    def __call__(self, config: Any, **kwargs: Any) -> Any:
        self.calls.append(kwargs)
        out = Path(kwargs["out"])
        out.mkdir(parents=True, exist_ok=True)
        (out / CONFIG).write_text(config.to_toml(), encoding="utf-8")
        raise self.stop


@pytest.fixture
def simulated(monkeypatch: pytest.MonkeyPatch) -> Simulated:
    """``nudgecli.api.simulate`` replaced by a :class:`Simulated`; no ``DASK_SCHEDULER_ADDRESS`` of
    the caller's leaks in, and an address from it is taken without probing it."""
    monkeypatch.delenv(scheduler_choice.SCHEDULER_ENV, raising=False)
    monkeypatch.setattr(scheduler_choice, "check_environment_scheduler", lambda address: None)
    fake = Simulated()
    monkeypatch.setattr(nudgecli.api, "simulate", fake)
    return fake


def test_the_simulate_resume_command_names_the_scheduler() -> None:
    command = simulate_resume_command("smoke", "R", 7, scheduler=ADDRESS)
    assert command == f"nudge simulate smoke --out R --seed 7 --scheduler {ADDRESS} --resume"
    assert "--scheduler" not in simulate_resume_command("smoke", "R", 7)


@pytest.mark.parametrize("command", ["simulate", "run"])
def test_an_interrupted_run_on_a_typed_scheduler_resumes_on_it(
        tmp_path: Path, simulated: Simulated, command: str) -> None:
    out = tmp_path / "run"
    result = nudge(command, "smoke", "--participants", "1", "--scheduler", ADDRESS, "--out", out)
    assert result.exit_code == 130, result.output
    assert simulated.calls[0]["scheduler"] == ADDRESS
    offered = [line for line in result.output.splitlines() if "--resume" in line]
    assert offered and f"--scheduler {ADDRESS} --resume" in offered[0], result.output
    # nudge run's hint offers simulate's and its own: both on the same scheduler
    assert offered[0].count(f"--scheduler {ADDRESS}") == (2 if command == "run" else 1), result.output


def test_a_run_lost_on_a_typed_scheduler_names_it_in_its_resume_command(
        tmp_path: Path, simulated: Simulated) -> None:
    simulated.stop = WorkerLostError("the dask cluster lost participant 0 (worker-lost: a worker died)")
    line = one_error_line(nudge("simulate", "smoke", "--participants", "1", "--scheduler", ADDRESS,
                                "--out", tmp_path / "run").output)
    assert "lost participant 0" in line and f"--scheduler {ADDRESS} --resume" in line, line


def test_a_scheduler_from_the_environment_is_used_and_left_to_it_in_the_resume_command(
        tmp_path: Path, simulated: Simulated, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(scheduler_choice.SCHEDULER_ENV, OTHER)
    result = nudge("run", "smoke", "--participants", "1", "--out", tmp_path / "run")
    assert result.exit_code == 130, result.output
    assert simulated.calls[0]["scheduler"] == OTHER  # was None: nudge run ignored the variable
    assert "--resume" in result.output and "--scheduler" not in result.output, result.output


def test_run_given_workers_runs_locally_with_the_note_as_simulate_does(
        tmp_path: Path, simulated: Simulated, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(scheduler_choice.SCHEDULER_ENV, OTHER)
    result = nudge("run", "smoke", "--participants", "1", "--workers", "2", "--out", tmp_path / "run")
    assert result.exit_code == 130, result.output
    assert simulated.calls[0]["scheduler"] is None and simulated.calls[0]["workers"] == 2
    assert "Note: --workers given: running on local workers" in result.output


def test_a_rerun_into_the_start_of_the_same_run_is_offered_resume(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "run"
    args = ("simulate", "smoke", "--participants", "1", "--seed", "7", "--out", out)
    original = RunFolder.prepare

    def failed_start(self: RunFolder, *a: Any, **k: Any) -> str:  # as a start failing on its cluster
        original(self, *a, **k)
        raise NudgeError("No valid workers found")

    with monkeypatch.context() as patched:
        patched.setattr(RunFolder, "prepare", failed_start)
        assert nudge(*args).exit_code == 1
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [CONFIG]
    line = one_error_line(nudge(*args).output)
    assert "holds only the start of this run" in line and "use --resume" in line, line  # was: --force only
    assert "--force" in line and "choose another --out" in line
    assert nudge(*args, "--resume").exit_code == 0
    assert (out / MANIFEST).is_file()


def test_a_folder_of_another_file_is_still_not_empty_and_offers_no_resume(tmp_path: Path) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    line = one_error_line(nudge("simulate", "smoke", "--participants", "1", "--out", out).output)
    assert "exists and is not empty" in line and "--resume" not in line, line
