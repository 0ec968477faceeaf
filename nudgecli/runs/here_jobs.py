"""The process pool's jobs marked ``here`` (:class:`nudgecli.runs.executors.Job`): run one at a time in
a thread of the pool's own process, beside its workers (:class:`~nudgecli.runs.executors.ProcessExecutor`)."""

from __future__ import annotations

import contextlib
import queue
import signal
import threading
import time
from collections import deque
from multiprocessing.connection import Connection
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from nudgecli.runs.executors import Job


class HereThread:
    """The process pool's jobs marked ``here``: run one at a time in a thread of this process.

    A finished job's result (or exception) waits in :meth:`finished`, and a byte on a pipe
    (:attr:`wakeup`) wakes :meth:`ProcessExecutor.next_result`, which waits on it with the
    workers' pipes. The thread starts with the first job, after the workers are forked (a fork
    while it imports could leave a worker holding an import lock no one releases). It is a daemon:
    a command that ends (Ctrl-C, a failure) does not wait for its job, which writes nothing.
    """

    def __init__(self) -> None:
        self._jobs: queue.SimpleQueue[Job | None] | None = None
        self._done: deque[tuple[Job, bool, Any, float]] = deque()
        self._lock = threading.Lock()
        self.wakeup: Connection | None = None
        self._signal: Connection | None = None
        self.running = 0
        #: The seconds the job :meth:`finished` last gave back ran.
        self.last_seconds = 0.0

    def submit(self, job: Job) -> None:
        if self._jobs is None:
            from multiprocessing import Pipe

            self.wakeup, self._signal = Pipe(duplex=False)
            self._jobs = queue.SimpleQueue()
            threading.Thread(target=self._serve, args=(self._jobs,), name="nudge-here", daemon=True).start()
        self.running += 1
        self._jobs.put(job)

    def _serve(self, jobs: queue.SimpleQueue[Job | None]) -> None:
        """The thread: run the jobs in the order they came, until :meth:`close`'s ``None``."""
        _leave_signals_to_the_main_thread()
        while (job := jobs.get()) is not None:
            self._run(job)

    def _run(self, job: Job) -> None:
        start = time.perf_counter()
        try:
            outcome = (job, True, job.func(*job.args), time.perf_counter() - start)
        except BaseException as exc:  # handed to next_result, which raises it as the job's own
            outcome = (job, False, exc, time.perf_counter() - start)
        with self._lock:
            self._done.append(outcome)
        assert self._signal is not None
        with contextlib.suppress(OSError):
            self._signal.send_bytes(b"1")

    def finished(self) -> tuple[Job, Any] | None:
        """A finished job and its result, or None; a job that failed raises its exception here.
        The seconds it ran are then in :attr:`last_seconds`."""
        with self._lock:
            if not self._done:
                return None
            job, ok, payload, self.last_seconds = self._done.popleft()
        assert self.wakeup is not None
        self.wakeup.recv_bytes()  # its byte: the pipe holds one per job not yet taken
        self.running -= 1
        if not ok:
            raise payload
        return job, payload

    def close(self) -> None:
        """Take no more jobs: the thread ends after the job it runs (which cannot be interrupted,
        and which the process does not wait for when it exits)."""
        if self._jobs is not None:
            self._jobs.put(None)
            self._jobs = None


def _leave_signals_to_the_main_thread() -> None:
    """Block Ctrl-C and SIGTERM in this thread, so that the kernel delivers them to the main thread.

    Python raises a signal's exception in the main thread only; one delivered to this thread
    instead would not wake the main thread from its wait on the workers' pipes, and the
    command would answer a Ctrl-C only when the next result came."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
