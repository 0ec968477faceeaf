"""An adaptive dask cluster that scales from zero workers (``cluster.adapt(minimum=0)``) runs nudge:
it starts workers only for tasks submitted, and the connection check waited for a worker before
submitting anything, so it refused the cluster after ``WORKERS_WAIT_S`` (300 s). The check now asks
the first worker by a task (``runs/dask_cluster.py`` ``first_worker_answer``), which the cluster
starts a worker for; workers of another nudgecli (or none) are still refused before anything is
written, and a worker that joins later is checked by each task it runs (``submit_checked``), so
no result of another version's code is kept."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from cli_helpers import nudge, one_error_line
from dask_helpers import local_cluster

import nudgecli
from nudgecli import api
from nudgecli.errors import ClusterError, ConfigError
from nudgecli.run_folder_names import MANIFEST
from nudgecli.runs import dask_cluster

distributed = pytest.importorskip("dask.distributed")

#: Seconds the old code waited before refusing the cluster in these tests (300 s in use): long
#: enough for the adaptive cluster to start a worker many times over.
WAIT_S = 20.0


@pytest.fixture
def from_zero(monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """The address of an adaptive cluster without workers that starts up to 2 for submitted tasks
    (looking every 50 ms, not every second, and retiring idle workers after 3 looks)."""
    monkeypatch.setattr(dask_cluster, "WORKERS_WAIT_S", WAIT_S)
    with local_cluster(0) as cluster:
        cluster.adapt(minimum=0, maximum=2, interval="50ms")
        yield cluster.scheduler_address


def test_an_adaptive_cluster_from_zero_runs_smoke_to_the_tables_of_local_workers(
        tmp_path: Path, from_zero: str) -> None:
    notes: list[str] = []
    on_dask = api.simulate("smoke", participants=1, seed=3, scheduler=from_zero, out=tmp_path / "dask",
                           log=notes.append)
    local = api.simulate("smoke", participants=1, seed=3, out=tmp_path / "local")
    pd.testing.assert_frame_equal(on_dask.trials, local.trials)
    assert notes[0].startswith(f"Note: the dask scheduler at {from_zero} has no workers yet; waiting up to")
    assert notes[1].startswith(f"Note: a worker joined the dask scheduler at {from_zero} after ")
    # the manifest records the executor, not the address (a resume command names ADDRESS to fill in)
    manifest = (tmp_path / "dask" / MANIFEST).read_text(encoding="utf-8")
    assert json.loads(manifest)["executor"] == "dask" and from_zero not in manifest


def test_an_adaptive_cluster_from_zero_runs_a_batch(tmp_path: Path, from_zero: str) -> None:
    batch = api.replicate("smoke", 1, participants=2, seed=3, scheduler=from_zero, out=tmp_path / "batch")
    assert batch.computed > 0 and len(batch.rows) > 0


def _another_version() -> str:
    return "0.0.0-other"


def _no_nudgecli() -> str:
    raise ModuleNotFoundError("No module named 'nudgecli'")


@pytest.mark.parametrize(("probe", "said"), [(_another_version, "imports nudgecli 0.0.0-other, not "),
                                             (_no_nudgecli, "No module named 'nudgecli'")])
def test_the_first_worker_of_an_adaptive_cluster_is_refused_before_anything_is_written(
        tmp_path: Path, from_zero: str, monkeypatch: pytest.MonkeyPatch, probe: Any, said: str) -> None:
    monkeypatch.setattr(dask_cluster, "worker_probe", lambda: probe)
    refusal = f"dask scheduler at {from_zero} cannot run nudge .*{said}"
    with pytest.raises(ConfigError, match=refusal) as refused:
        api.simulate("smoke", participants=1, scheduler=from_zero, out=tmp_path / "run")
    assert "install nudgecli" in str(refused.value) and "\n" not in str(refused.value)
    assert not (tmp_path / "run").exists()



def test_a_task_on_a_worker_of_another_nudgecli_is_refused_by_the_task(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # the connection check asked the workers there then; one that joins later (an adaptive
    # cluster's, as the tasks come) is checked by each task it runs: its result never comes back
    from nudgecli.runs.executors import DaskExecutor, Job

    with local_cluster(1) as cluster, distributed.Client(cluster) as client:
        executor, (worker,) = DaskExecutor(client), client.nthreads()
        monkeypatch.setattr(dask_cluster, "worker_probe", lambda: _another_version)  # as if it joined now
        executor.submit(Job("t", sum, ([1, 2],)))
        with pytest.raises(ClusterError) as refused:
            executor.next_result()
        executor.abort()
    assert str(refused.value) == (
        f"the workers of the dask scheduler at {cluster.scheduler_address} cannot run nudge (e.g. "
        f"{worker}: it imports nudgecli 0.0.0-other, not {nudgecli.__version__}); "
        f"install nudgecli {nudgecli.__version__}, this one, in the workers' environment and restart them")


def test_a_run_whose_worker_joined_with_another_nudgecli_keeps_nothing_of_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "run"
    with local_cluster(1) as cluster:
        monkeypatch.setattr(dask_cluster, "check_cluster", lambda *args: None)  # it joined after the check
        monkeypatch.setattr(dask_cluster, "worker_probe", lambda: _another_version)
        result = nudge("simulate", "smoke", "--participants", "2", "--scheduler", cluster.scheduler_address,
                       "--out", out)
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "cannot run nudge (e.g. tcp://" in line, line
    assert "imports nudgecli 0.0.0-other" in line and f"--out {out}" in line and "--resume" in line, line
    assert json.loads((out / MANIFEST).read_text(encoding="utf-8"))["status"] == "interrupted"
    assert not list((out / "trials").glob("part-*"))
