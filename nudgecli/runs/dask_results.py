"""Waiting for a dask task's result without waiting for ever on a cluster that is gone.

``Future.result()`` waits for as long as the scheduler says nothing: a result whose worker died
after computing it is computed again (the client logs "Couldn't gather 1 keys, rescheduling") and,
with no worker left, never is; a task that killed its workers one after the other is marked failed
(``KilledWorker``) while the batch waits on another. So a result is fetched in a thread while this
one watches the cluster every :data:`POLL_S` seconds (:class:`ClusterWatch`): a lost scheduler
connection, no worker for :data:`NO_WORKERS_GRACE_S` seconds, or another task marked failed ends the
wait with one :class:`~nudgecli.errors.WorkerLostError` (the command line adds the resume command).
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

from nudgecli.errors import ClusterError, NudgeError, WorkerLostError

#: Seconds between two looks at the cluster while a result is awaited.
POLL_S = 0.5
#: Seconds the scheduler may have no worker before the batch gives up: long enough for a nanny
#: to restart a killed worker, or an adaptive cluster to start one.
NO_WORKERS_GRACE_S = 60.0
#: Seconds between two questions to the scheduler about its workers.
WORKERS_EVERY_S = 2.0
#: Statuses of a ``Future`` whose ``result()`` raises at once.
FAILED = ("error", "cancelled")


def scheduler_address(client: Any) -> str:
    """The address of ``client``'s scheduler, as the user gave it (or ``the scheduler``)."""
    with contextlib.suppress(Exception):
        return str(client.scheduler.address)
    return "(unknown address)"


def scheduler_lost(client: Any) -> WorkerLostError:
    """The error of a lost scheduler connection: it names the scheduler and what to do.

    The client is closed here, its loggers quiet: it would otherwise keep trying to reconnect, and
    log the traceback of that attempt when whoever holds it closes it (``runs/study.py``'s too).
    """
    address = scheduler_address(client)  # before the close forgets it
    with quiet_dask_logs(), contextlib.suppress(Exception):
        client.close()
    from nudgecli.runs.dask_cluster import scheduler_option_name

    return WorkerLostError(f"lost the connection to the dask scheduler at {address} (scheduler-connection-"
                           f"lost); restart it, or give another {scheduler_option_name()}")


def as_nudge_error(exc: BaseException, task: str, client: Any) -> BaseException:
    """What the command raises for ``exc``, met fetching ``task``'s result from ``client``'s cluster.

    A lost task (cancelled by the scheduler, or given up after its workers kept dying:
    ``KilledWorker``) is a :class:`WorkerLostError`, naming the scheduler when its connection was
    what was lost; a cluster that cannot load nudge's tasks (workers without nudgecli) a
    :class:`ClusterError`; anything else (an ``OSError``, a :class:`NudgeError`, the task's own
    error) itself.
    """
    from concurrent.futures import CancelledError

    from distributed import KilledWorker

    if isinstance(exc, (OSError, NudgeError)):
        return exc
    if isinstance(exc, (CancelledError, KilledWorker)):
        why = getattr(exc, "reason", None) or type(exc).__name__
        if why == "scheduler-connection-lost" or getattr(client, "status", "running") != "running":
            return scheduler_lost(client)
        if isinstance(exc, KilledWorker):
            died = getattr(exc, "allowed_failures", None)
            workers = "its workers" if not isinstance(died, int) else f"{died + 1} workers"
            return WorkerLostError(f"the dask cluster lost {task} ({why}: {workers} died running it, one "
                                   "after the other; their logs say why, e.g. out of memory)")
        return WorkerLostError(f"the dask cluster lost {task} ({why}: a worker died or left, or the "
                               "scheduler cancelled it)")
    from nudgecli.runs.dask_cluster import install_advice, one_line

    text = one_line(exc)
    # nudgecli itself missing (not a module a task's own code imports, e.g. a policy's typo)
    if "deserialization of the task graph" in text or (isinstance(exc, ModuleNotFoundError)
                                                       and exc.name == "nudgecli"):
        # a worker that joined after the cluster was checked (runs/dask_cluster.py check_cluster)
        return ClusterError(f"the workers of the dask scheduler at {scheduler_address(client)} cannot run "
                            f"{task} ({type(exc).__name__}: {text[:200]}); {install_advice()}")
    return exc


class ClusterWatch:
    """Says, when asked, whether ``client``'s cluster can still finish the tasks awaited."""

    def __init__(self, client: Any, grace_s: float | None = None) -> None:
        self._client = client
        self._grace_s = NO_WORKERS_GRACE_S if grace_s is None else grace_s
        self._asked = float("-inf")
        self._empty_since: float | None = None

    def check(self) -> None:
        """Raise a :class:`WorkerLostError` when the scheduler connection is gone, or when the
        scheduler has had no worker for the grace period."""
        if getattr(self._client, "status", "running") != "running":
            raise scheduler_lost(self._client)
        now = time.monotonic()
        if now - self._asked < WORKERS_EVERY_S:
            return
        self._asked = now
        try:
            workers = self._client.nthreads()
        except Exception:
            if getattr(self._client, "status", "running") != "running":
                raise scheduler_lost(self._client) from None
            return  # a slow answer is not a lost cluster: asked again next time
        if workers:
            self._empty_since = None
            return
        self._empty_since = now if self._empty_since is None else self._empty_since
        if now - self._empty_since >= self._grace_s:
            raise WorkerLostError(f"the dask scheduler at {scheduler_address(self._client)} has had no "
                                  f"worker for {self._grace_s:g} s (every worker died or left); start "
                                  f"some with `dask worker {scheduler_address(self._client)}`")


def _fetch(future: Any, box: dict[str, Any]) -> None:
    """``future.result()`` into ``box`` (``value`` or ``error``): the thread of :func:`watched_result`."""
    try:
        box["value"] = future.result()
    except BaseException as exc:  # handed to the waiting thread, which raises it as the task's own
        box["error"] = exc


def watched_result(future: Any, task: str, watch: ClusterWatch | None = None,
                   also: Callable[[], None] | None = None) -> Any:
    """``future``'s result, or the error of a cluster that can no longer give it (see the module's note).

    Parameters
    ----------
    future
        A ``dask.distributed.Future``.
    task
        What the task computes, named in the message (e.g. ``task s0-p3``).
    watch
        The cluster's watch (one for the whole batch: it counts how long the cluster has had no
        worker); a new one when None.
    also
        Called at every look at the cluster, to raise for another reason (another task failed).

    Raises
    ------
    WorkerLostError
        The task, its worker or the scheduler was lost (:func:`as_nudge_error`); a task's own
        error is raised as itself.
    """
    client = future.client
    watch = watch or ClusterWatch(client)
    box: dict[str, Any] = {}
    if future.status in FAILED:  # no wait: it raises at once
        _fetch(future, box)
    else:
        fetcher = threading.Thread(target=_fetch, args=(future, box), daemon=True, name="nudge-dask-result")
        fetcher.start()
        while fetcher.is_alive():
            fetcher.join(POLL_S)
            if fetcher.is_alive():
                watch.check()
                if also is not None:
                    also()
    if "error" in box:
        error = as_nudge_error(box["error"], task, client)
        if error is box["error"]:  # the task's own error, with its cause and context as the task raised it
            raise error
        raise error from None
    return box["value"]


def next_finished(done: Any, watch: ClusterWatch) -> Any:
    """The next future of ``done`` (a ``distributed.as_completed``) to finish, erred and cancelled
    ones included, the cluster watched while none is."""
    while not done.has_ready():
        if done.is_empty():
            raise RuntimeError("no job to wait for")
        watch.check()
        # as_completed's own condition (not public API: a distributed without it is polled instead)
        condition = getattr(done, "thread_condition", None)
        if condition is None:
            time.sleep(POLL_S)
            continue
        with condition:
            condition.wait(timeout=POLL_S)
    return next(done)


def failed_among(done: Any) -> Any | None:
    """A future of ``done`` (a ``distributed.as_completed``) finished but erred or cancelled, or None."""
    # as_completed's queue of finished futures (not public API: without it no failure is seen early,
    # and the wait on the result itself still ends, through the cluster's watch)
    lock, queue = getattr(done, "lock", None), getattr(getattr(done, "queue", None), "queue", None)
    if lock is None or queue is None:
        return None
    with lock:
        ready = list(queue)
    return next((future for future in ready if future.status in FAILED), None)


@contextlib.contextmanager
def quiet_dask_logs() -> Iterator[None]:
    """Keep distributed's own loggers quiet (its tracebacks of a lost connection) for a while:
    the command says what happened in its one error line."""
    # distributed sets some of its loggers' levels itself (``distributed.client``): each is raised
    names = ["distributed", *(name for name in list(logging.root.manager.loggerDict)
                              if name.startswith("distributed."))]
    loggers = [logging.getLogger(name) for name in names]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)
