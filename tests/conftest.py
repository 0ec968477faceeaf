"""Settings of the whole test session."""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from unittest import mock

import pytest
from cli_helpers import nudge

# Tests that press Ctrl-C on a child nudge (SIGINT) need the child to take it. A shell that starts
# a job in the background without job control (`pytest &` in a script) ignores SIGINT for it, and
# every process started from it would inherit that and never be interrupted; a handler here is
# reset to the default in each child, so they take Ctrl-C however the suite was started.
signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture()
def private_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The system's temporary directory for this test alone (what the API makes there is seen)."""
    folder = tmp_path / "system-tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


@pytest.fixture
def solves(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[int]]:
    """The number of goals of every layout value iteration solves (each call of
    ``nudgecli.sim.study.solve_layout``), the worker's solved-layout cache emptied before and after."""
    import nudgecli.sim.study as sim_study
    from nudgecli.runs.solved_layouts import clear_solved

    clear_solved()
    calls: list[int] = []
    solve = sim_study.solve_layout

    def counting(goal_cells: Any, *args: Any, **kwargs: Any) -> Any:
        calls.append(len(goal_cells))
        return solve(goal_cells, *args, **kwargs)

    monkeypatch.setattr(sim_study, "solve_layout", counting)
    yield calls
    clear_solved()


@pytest.fixture
def restored_environ() -> Iterator[None]:
    """``os.environ`` as it was before the test, once it ends. A dask ``LocalCluster`` with worker
    processes sets OMP_NUM_THREADS, OPENBLAS_NUM_THREADS, MKL_NUM_THREADS, MALLOC_TRIM_THRESHOLD_ and
    PYTHONHASHSEED in this process's environment to pass them to its workers, and leaves them there:
    every later test of the process (pytest -n runs many in one) and its child processes would get them."""
    with mock.patch.dict(os.environ):
        yield


@pytest.fixture(scope="session")
def analysed_smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two participants of the smoke experiment (seed 5), analysed. Do not modify: tests damage a copy."""
    run = tmp_path_factory.mktemp("analysed-smoke") / "run"
    assert nudge("simulate", "smoke", "--participants", "2", "--seed", "5", "--out", run).exit_code == 0
    assert nudge("analyze", run, "--bootstrap", "100").exit_code == 0
    return run


@pytest.fixture
def my_study(tmp_path: Path) -> Path:
    """experiments/custom-policy.toml renamed "my-study" (no plan of that name), with its policy."""
    experiments = Path(__file__).resolve().parents[1] / "experiments"
    shutil.copytree(experiments / "policies", tmp_path / "policies",
                    ignore=shutil.ignore_patterns("__pycache__"))
    text = (experiments / "custom-policy.toml").read_text()
    path = tmp_path / "my-study.toml"
    path.write_text(text.replace('name = "custom-policy"', 'name = "my-study"'))
    return path
