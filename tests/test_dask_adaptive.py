"""An adaptive dask cluster that scales from zero workers (``cluster.adapt(minimum=0)``) runs nudge:
it starts workers only for tasks submitted, and the connection check waited for a worker before
submitting anything, so it refused the cluster after ``WORKERS_WAIT_S`` (300 s). The check now asks
the first worker by a task (``runs/dask_cluster.py`` ``first_worker_answer``), which the cluster
starts a worker for; workers of another nudgecli (or none) are still refused before anything is
written, and a worker that joins later is checked before its result is taken."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from dask_helpers import local_cluster

from nudgecli import api
from nudgecli.errors import ClusterError, ConfigError, WorkerLostError
from nudgecli.run_folder_names import MANIFEST
from nudgecli.runs import dask_cluster, dask_results

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


def test_a_result_of_a_worker_that_joined_with_another_nudgecli_is_not_taken(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # the connection check saw the workers there then; an adaptive cluster starts more for the work
    with local_cluster(1) as cluster, distributed.Client(cluster) as client:
        watch = dask_results.ClusterWatch(client)
        monkeypatch.setattr(dask_cluster, "worker_probe", lambda: _another_version)  # as if it joined now
        future = client.submit(sum, [1, 2], pure=False)
        with pytest.raises(ClusterError, match=r"cannot run nudge \(1 of 1 worker\(s\), e\.g\. tcp://.*: it "
                                               r"imports nudgecli 0\.0\.0-other, not .*\); install nudgecli"):
            dask_results.watched_result(future, "task t", watch)


def test_a_cluster_that_never_had_a_worker_is_given_the_wait_of_the_connection_not_the_grace(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # a cluster scaled back to zero before the work came starts a worker for it as it did for the
    # connection check's task: a batch system's queue takes minutes, not the 60 s given to one whose
    # workers all left
    monkeypatch.setattr(dask_results, "NO_WORKERS_GRACE_S", 0.05)
    monkeypatch.setattr(dask_results, "WORKERS_EVERY_S", 0.0)
    monkeypatch.setattr(dask_cluster, "WORKERS_WAIT_S", 0.4)
    with local_cluster(0) as cluster, distributed.Client(cluster) as client:
        watch = dask_results.ClusterWatch(client)
        started = time.monotonic()
        never = r"has had no worker for 0\.4 s \(none joined since the work was submitted\); start some with"
        with pytest.raises(WorkerLostError, match=never):
            while True:
                watch.check()
                time.sleep(0.02)
    assert time.monotonic() - started >= 0.4
