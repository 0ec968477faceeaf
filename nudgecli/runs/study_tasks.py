"""The tasks of a study that run in a worker, and the worker processes' lifecycle.

A worker (a local process or a dask worker) simulates participants and sends back their
columns (:class:`~nudgecli.sim.study.ParticipantColumns`); the parent (:mod:`nudgecli.runs.study`:
run folder, lock, manifest, parts) makes the tables of them. So this module and everything it
imports load neither pandas nor pyarrow: a fresh (dask or spawned) worker is ready sooner.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Collection
from typing import TYPE_CHECKING

from nudgecli.sim.policy_registry import drew_when_loaded, global_rng_digest, policy_specs
from nudgecli.sim.study import ParticipantColumns, StudyPlan, simulate_participant_columns
from nudgecli.steplog import STEP_COLUMNS

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing.context import BaseContext

    from nudgecli.config import ExperimentConfig

#: Seconds a worker waits between two checks that its parent is alive (where prctl is missing).
PARENT_POLL_S = 0.5
_PR_SET_PDEATHSIG = 1

_WORKER_PLAN: StudyPlan | None = None


def die_with_parent(parent_pid: int) -> None:
    """Make this (worker) process exit when the process ``parent_pid`` dies.

    On Linux the kernel sends SIGKILL at the parent's death (``prctl(PR_SET_PDEATHSIG)``);
    everywhere, a daemon thread also checks ``os.getppid()`` every :data:`PARENT_POLL_S`
    seconds and exits the process once it differs from ``parent_pid`` (the orphan was
    re-parented). So a killed ``nudge`` never leaves workers behind holding its pipes.
    """
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):  # pragma: no cover - no prctl: the thread below covers it
            pass
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(PARENT_POLL_S)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="nudge-parent-watch", daemon=True).start()


_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_ALLOCATOR_TUNED = False


def tune_allocator() -> None:
    """Undo a tiny ``MALLOC_TRIM_THRESHOLD_`` in this process (once; glibc only).

    dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which also fixes glibc's
    mmap threshold at 128 KiB: every large numpy temporary is then mapped and unmapped anew, and
    the layout solving and trials run 2.5-3.5 times slower than in a plain process (measured on
    the paper preset's plan). Where that variable is set, this raises the mmap threshold to 32 MB
    and the trim threshold to 64 MB, so freed memory above 64 MB is still returned to the system.
    """
    global _ALLOCATOR_TUNED
    if _ALLOCATOR_TUNED or "MALLOC_TRIM_THRESHOLD_" not in os.environ or not sys.platform.startswith("linux"):
        return
    _ALLOCATOR_TUNED = True
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        libc.mallopt(_M_MMAP_THRESHOLD, 32 * 1024 * 1024)
        libc.mallopt(_M_TRIM_THRESHOLD, 64 * 1024 * 1024)
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass


def process_context() -> BaseContext:
    """``fork`` where it exists (workers inherit the plan without pickling), else ``spawn``."""
    # imported here: a dask worker never starts processes of its own
    from multiprocessing import get_context

    return get_context("fork") if os.name == "posix" else get_context("spawn")


#: The attribute of a participant's :class:`ParticipantColumns` set when its trials drew from a
#: global random generator (:func:`simulate_watched`); it travels with the columns to the parent.
GLOBAL_RNG_MARK = "drew_from_global_rng"


def simulate_watched(plan: StudyPlan, participant_index: int,
                     step_log_columns: Collection[str] = STEP_COLUMNS) -> ParticipantColumns:
    """:func:`simulate_participant_columns`, and for an experiment with policies of its own, whether
    its trials drew from numpy's or Python's global random generator (``np.random.randint``,
    ``random.random``): such draws are not a function of the run's seed, so the tables of two runs
    of one seed (or of ``--workers 1`` and ``2``) differ. The columns then carry
    :data:`GLOBAL_RNG_MARK` (:func:`drew_from_global_rng`); the tables are unchanged, and the
    paper's conditions (no policy of the experiment's own) are simulated as they were. A run's
    participant and a batch's participant task (its metrics' ``step_log_columns``) are watched alike.
    A draw made once, before any trial (at the policy module's import, or in making the policy the
    run's check makes: :func:`~nudgecli.sim.policy_registry.drew_when_loaded`), marks them too."""
    specs = policy_specs(plan.config)
    if not specs:
        return simulate_participant_columns(plan, participant_index, step_log_columns)
    before = global_rng_digest()
    columns = simulate_participant_columns(plan, participant_index, step_log_columns)
    # a draw at the module's import (or in making its checked policy) was before any trial
    if global_rng_digest() != before or any(drew_when_loaded(spec) for spec in specs):
        setattr(columns, GLOBAL_RNG_MARK, True)
    return columns


def drew_from_global_rng(columns: ParticipantColumns) -> bool:
    """Whether the participant's trials drew from a global random generator (:func:`simulate_watched`)."""
    return bool(getattr(columns, GLOBAL_RNG_MARK, False))


def global_rng_warning(config: ExperimentConfig, where: object) -> str:
    """The one warning line of a run (or a batch) of ``config`` of :func:`drew_from_global_rng`,
    naming its own policies."""
    specs = policy_specs(config)
    named = ", ".join(f"condition {spec.condition!r} (policy {spec.factory})" for spec in specs)
    return (f"Warning: {where}: {named}: a policy drew from numpy's or Python's global random generator "
            "(np.random.*, random.*), which the run's seed does not set: the tables differ between runs of "
            "the same seed and with another --workers; draw from the view's own stream, view.rng, instead "
            "(docs/policies.md)")


def simulate_on_worker(plan: StudyPlan, participant_index: int) -> ParticipantColumns:
    """:func:`simulate_watched` as a dask task (with :func:`tune_allocator` first)."""
    tune_allocator()
    return simulate_watched(plan, participant_index)


def pool_worker_started(parent_pid: int) -> None:
    """Start a worker process of a local pool (the batch's, a study's participants', the layouts'):
    Ctrl-C is left to the parent (SIGINT ignored), which stops the pool (:func:`stop_pool`) and says
    how to resume; a worker that took it would print a ``KeyboardInterrupt`` traceback of its own
    (``Process ForkProcess-4: ... call_queue.get`` of every idle one) before that line. And it exits
    with the parent (:func:`die_with_parent`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(parent_pid)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Stop ``pool`` now, on Ctrl-C or a failure: drop its queued tasks and terminate its processes,
    whose running tasks' results would be thrown away (its workers ignore Ctrl-C:
    :func:`pool_worker_started`; the pool's own exit would wait for every queued task)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AttributeError):
            process.terminate()


def _init_worker(plan: StudyPlan, parent_pid: int) -> None:
    global _WORKER_PLAN
    pool_worker_started(parent_pid)
    _WORKER_PLAN = plan


def _run_in_worker(participant_index: int) -> ParticipantColumns:
    assert _WORKER_PLAN is not None, "worker not initialised"
    return simulate_watched(_WORKER_PLAN, participant_index)
