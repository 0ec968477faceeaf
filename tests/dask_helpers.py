"""A cheap dask cluster for tests: in-process workers on TCP (a real scheduler's kind of address),
listening on 127.0.0.1 only, its dashboard on a free port (the default 8787 may be another
test's under ``pytest -n``, or anything else's on the machine)."""

from __future__ import annotations

from typing import Any

import pytest


def local_cluster(n_workers: int = 1) -> Any:
    """A ``distributed.LocalCluster`` of ``n_workers`` in-process workers, one thread each."""
    distributed = pytest.importorskip("dask.distributed")
    return distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=False,
                                    protocol="tcp", host="127.0.0.1", dashboard_address="127.0.0.1:0")
