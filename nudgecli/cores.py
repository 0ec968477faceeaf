"""The cores this process may run on: what parallel work (figures, benchmarks) is sized by."""

from __future__ import annotations

import os


def available_cores() -> int:
    """The cores this process may use (its CPU affinity where the platform has one, else all)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def pool_workers(requested: int, tasks: int) -> int:
    """The worker processes a pool of ``requested`` workers starts for ``tasks`` tasks that can run
    at once: no more than the tasks (a worker with none would only be forked to wait), at least 1.

    Not capped at :func:`available_cores`: more workers than cores is slower, not wrong, and a
    researcher may know better (the size estimate says so: :class:`nudgecli.runs.size.SizeEstimate`).
    """
    return max(1, min(requested, tasks))


__all__ = ["available_cores", "pool_workers"]
