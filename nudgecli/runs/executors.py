"""Executors of a batch's tasks: in this process, on local worker processes, or on dask.

All three take :class:`Job` objects with :meth:`submit` and give back ``(job, result)`` pairs, in
the order they finish, with :meth:`next_result`; :meth:`broadcast` runs a job once in every worker
(to hand each the data a study's tasks share) before the jobs submitted after it, and its result is
dropped; :meth:`spread` says that every worker is to hold an affinity's data (dask then hints its jobs
to no worker); :meth:`close` ends them, :meth:`abort` at once (after Ctrl-C or a failure). ``workers`` is
how many run at once. The process pool is this package's own (not ``concurrent.futures``), so that
it can send each worker the tasks whose data it already holds: a worker gets, in order, a task
without affinity, a task of an affinity it has served recently, else a task of the affinity the
fewest workers hold. A job marked ``here`` (a batch's analyses) runs in the pool's own process, in
one thread beside the workers, where the process would otherwise only wait for them: its modules
(pandas and the statistics, for the analyses) are then imported once, while the workers run
trials, and not into a worker, whose memory stays that of its trials. On many workers that one thread falls
behind (a 16-core machine's workers finish studies faster than it analyses them), so a ``here``
job marked ``overflow`` goes to a worker that has nothing else to do when waiting for the thread
would take longer than the worker's imports (:meth:`ProcessExecutor.warm`). Its workers exit when
the parent dies (:func:`nudgecli.runs.study_tasks.die_with_parent`) and report their peak memory
when they close. A batch's progress line is :class:`nudgecli.runs.progress.Progress`.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import shutil
import tempfile
import time
from collections import OrderedDict, deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from typing import Any

from nudgecli.errors import NudgeError, WorkerError, WorkerLostError, failure_from_message, failure_message
from nudgecli.runs.dask_cluster import submit_checked
from nudgecli.runs.dask_results import (
    ClusterWatch,
    failed_among,
    next_finished,
    quiet_dask_logs,
    watched_result,
)
from nudgecli.runs.here_jobs import HereThread
from nudgecli.runs.study_tasks import pool_worker_started, process_context

#: Plans (affinities) a worker is assumed to hold: the size of its plan cache.
HELD_AFFINITIES = 4
#: Jobs each pool worker holds at once (one running, one queued), so it never waits for the parent.
POOL_DEPTH = 2
#: A pickled job larger than this goes to a pool worker through a file, not the pipe: a pipe holds
#: 64 KiB on Linux, and a parent blocked writing a large job to a worker that is itself blocked
#: writing a large result back would wait for ever.
PIPE_JOB_BYTES = 32 * 1024


@dataclass(frozen=True)
class Job:
    """A task as sent to an executor: ``func(*args)``, named ``key``.

    ``func`` must be a module-level function (it is pickled to process and dask workers).
    ``affinity`` names what the task shares with others (for a participant task, the study's
    layouts): executors keep tasks of equal affinity together. ``None`` marks a task that may
    run anywhere and goes first (an analysis, which finishes a replication). ``here`` asks the
    process pool to run it in this process, beside its workers (see the module's note), and
    ``overflow`` lets it go to an idle worker when this process is behind; other executors run it
    as any job.
    """

    key: str
    func: Callable[..., Any]
    args: tuple[Any, ...]
    affinity: str | None = None
    here: bool = False
    overflow: bool = False


def execute(job: Job) -> Any:
    """Run a job in this process."""
    return job.func(*job.args)


def run_pickled_job(path: str) -> Any:
    """Run the job pickled in the file ``path`` (a large or broadcast job of the process pool)."""
    with open(path, "rb") as handle:
        job = pickle.load(handle)
    return execute(job)


class SerialExecutor:
    """Runs every job in this process, jobs without affinity first."""

    workers = 1

    def __init__(self) -> None:
        self._queue: deque[Job] = deque()

    def submit(self, job: Job) -> None:
        (self._queue.appendleft if job.affinity is None else self._queue.append)(job)

    def broadcast(self, job: Job) -> None:
        execute(job)

    def spread(self, affinity: str) -> None:
        """Nothing to do: one process runs every job."""

    def next_result(self) -> tuple[Job, Any]:
        job = self._queue.popleft()
        return job, execute(job)

    def close(self) -> None:
        self._queue.clear()

    def abort(self) -> None:
        self.close()


def _peak_rss_kib() -> float | None:
    """This process's peak resident memory in KiB (Linux ``ru_maxrss``), or None where unknown."""
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        return None
    return float(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


def _pool_worker(conn: Connection, parent_pid: int) -> None:
    """A pool worker: receive jobs, send back ``(status, key, result)``; exit with the parent."""
    pool_worker_started(parent_pid)  # Ctrl-C is the parent's to handle
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            conn.send(("bye", "", _peak_rss_kib()))
            return
        try:
            result = execute(job)
        except Exception as exc:  # a full disk, a user's policy that fails: the parent raises it again
            status, payload = failure_message(exc)
            conn.send((status, job.key, payload))
            continue
        conn.send(("ok", job.key, result))


@dataclass
class _Slot:
    process: Any
    conn: Connection
    inflight: dict[str, Job] = field(default_factory=dict)
    holds: OrderedDict[str, None] = field(default_factory=OrderedDict)
    #: whether it has run an overflow job (so holds what they import)
    overflowed: bool = False


class ProcessExecutor:
    """Local worker processes with cache-aware dispatch.

    Each worker holds up to :data:`POOL_DEPTH` jobs. An idle worker gets, in order: a waiting
    job without affinity; a job of an affinity it served recently (whose plan it holds); else a
    job of the affinity held by the fewest workers (so each plan is built by as few workers as
    the load allows). The parent mirrors each worker's plan cache (:data:`HELD_AFFINITIES`, the
    same least-recently-used order).
    """

    def __init__(self, workers: int) -> None:
        context: Any = process_context()  # typeshed's BaseContext lacks Process
        self._slots: list[_Slot] = []
        self._free: deque[Job] = deque()
        self._pending: OrderedDict[str, deque[Job]] = OrderedDict()
        self._broadcast: set[str] = set()  # keys of broadcast jobs in flight (their results are dropped)
        self._spool: str | None = None  # where large and broadcast jobs wait for the workers to read them
        self._spooled_count = 0
        #: jobs in the spool: key -> [its file and the files it reads, workers yet to finish it]
        self._spooled: dict[str, list[Any]] = {}
        #: The largest worker's peak resident memory in MB, known after :meth:`close`.
        self.peak_rss_mb: float | None = None
        self._here = HereThread()  # started on its first job: after the workers are forked
        self._here_waiting: deque[Job] = deque()  # ``here`` jobs not yet handed to the thread
        self._warm_key: str | None = None
        #: seconds of the :meth:`warm` job (a worker's imports before its first overflow job), and
        #: of each overflow job that ran in this process
        self._warm_s: float | None = None
        self._overflow_s: list[float] = []
        for _ in range(workers):
            parent_end, child_end = context.Pipe(duplex=True)
            process = context.Process(target=_pool_worker, args=(child_end, os.getpid()), daemon=True,
                                      name="nudge-worker")
            process.start()
            child_end.close()
            self._slots.append(_Slot(process, parent_end))

    @property
    def pids(self) -> list[int]:
        return [slot.process.pid for slot in self._slots]

    @property
    def workers(self) -> int:
        return len(self._slots)

    def broadcast(self, job: Job, files: Sequence[str] = ()) -> None:
        """Send ``job`` to every worker now, ahead of any job dispatched later; a worker then counts
        as holding its affinity.

        The job is pickled once into a file and the workers get its path (see
        :data:`PIPE_JOB_BYTES`). ``files`` (paths of :meth:`scratch_path`) are what the job reads:
        they are removed with it, once every worker has run it.
        """
        small = self._spooled_job(job, pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL), len(self._slots),
                                  files)
        self._broadcast.add(job.key)
        for slot in self._slots:
            slot.conn.send(small)
            slot.inflight[job.key] = small
            if job.affinity is not None:
                self._hold(slot, job.affinity)

    def spread(self, affinity: str) -> None:
        """Nothing to do: an idle worker already takes jobs of the affinity the fewest workers hold."""

    def warm(self, job: Job) -> None:
        """Run ``job`` (a ``here`` job that imports what the overflow jobs use) in this process's
        thread before the ``here`` jobs submitted after it. The seconds it takes stand for what a
        worker spends before its first overflow job: a worker takes one only when the overflow
        jobs waiting for the thread would keep it busier than that (:meth:`_overflow_pays`)."""
        self._warm_key = job.key
        self.submit(job)

    def submit(self, job: Job) -> None:
        if job.here:
            self._here_waiting.append(job)
            self._feed_here()
        elif job.affinity is None:
            self._free.append(job)
        else:
            self._pending.setdefault(job.affinity, deque()).append(job)

    def _pick(self, slot: _Slot) -> Job | None:
        if self._free:
            return self._free.popleft()
        for key in reversed(slot.holds):
            if self._pending.get(key):
                return self._take(slot, key)
        candidates = [key for key, jobs in self._pending.items() if jobs]
        if not candidates:
            return self._take_overflow(slot) if not slot.inflight and self._overflow_pays(slot) else None
        holders = {key: sum(key in s.holds for s in self._slots) for key in candidates}
        key = min(candidates, key=lambda k: (holders[k], -len(self._pending[k])))
        return self._take(slot, key)

    def _take(self, slot: _Slot, key: str) -> Job:
        job = self._pending[key].popleft()
        if not self._pending[key]:
            del self._pending[key]
        self._hold(slot, key)
        return job

    def _feed_here(self) -> None:
        """Hand the thread its next ``here`` job when it has none (one at a time, so that the
        jobs waiting stay here, where an idle worker can take an overflow job)."""
        if self._here_waiting and not self._here.running:
            self._here.submit(self._here_waiting.popleft())

    def _overflow_pays(self, slot: _Slot) -> bool:
        """Whether the idle worker ``slot`` is to take an overflow job waiting for this process's
        thread: it has run one before (its imports are done), or the overflow jobs waiting would
        take the thread longer (their count times the mean seconds of those it ran) than the
        :meth:`warm` job took. Until both are measured, none goes."""
        waiting = sum(job.overflow for job in self._here_waiting)
        if not waiting or slot.overflowed:
            return waiting > 0
        if self._warm_s is None or not self._overflow_s:
            return False
        return waiting * sum(self._overflow_s) / len(self._overflow_s) > self._warm_s

    def _take_overflow(self, slot: _Slot) -> Job:
        """The last overflow job waiting for the thread (the one that would wait longest), for ``slot``."""
        index = max(i for i, job in enumerate(self._here_waiting) if job.overflow)
        job = self._here_waiting[index]
        del self._here_waiting[index]
        slot.overflowed = True
        return job

    @staticmethod
    def _hold(slot: _Slot, key: str) -> None:
        """Mirror the worker's plan cache: ``key`` is its most recent plan (the oldest beyond
        :data:`HELD_AFFINITIES` dropped)."""
        slot.holds[key] = None
        slot.holds.move_to_end(key)
        while len(slot.holds) > HELD_AFFINITIES:
            slot.holds.popitem(last=False)

    def _fill(self) -> None:
        # breadth first: every worker gets a job before any gets a second (filling one worker to
        # POOL_DEPTH first ran a study's two layout chunks one after the other on one worker)
        for depth in range(1, POOL_DEPTH + 1):
            for slot in self._slots:
                while len(slot.inflight) < depth:
                    job = self._pick(slot)
                    if job is None:
                        return
                    self._send(slot, job)

    def _send(self, slot: _Slot, job: Job) -> None:
        data = pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL)
        if len(data) <= PIPE_JOB_BYTES:
            slot.conn.send_bytes(data)
        else:
            slot.conn.send(self._spooled_job(job, data, 1))
        slot.inflight[job.key] = job

    def scratch_path(self, name: str) -> str:
        """A new path in the spool folder (ending in ``name``), e.g. for a job to write a large
        result into: the workers share this machine's files, so a result meant for every worker (a
        study's solved layouts) can reach them by :meth:`broadcast`'s ``files`` without passing
        through this process."""
        if self._spool is None:
            self._spool = tempfile.mkdtemp(prefix="nudge-jobs-")
        self._spooled_count += 1  # a new name each time: an earlier file may still be being read
        return os.path.join(self._spool, f"{self._spooled_count:06d}-{name}")

    def _spooled_job(self, job: Job, data: bytes, readers: int, files: Sequence[str] = ()) -> Job:
        """Write ``job`` (pickled: ``data``) to a new file of the spool folder, to be read by
        ``readers`` workers (then removed, with ``files``); the small job that runs it from there."""
        path = self.scratch_path("job.pickle")
        with open(path, "wb") as handle:
            handle.write(data)
        self._spooled[job.key] = [[path, *files], readers]
        return Job(job.key, run_pickled_job, (path,), job.affinity)

    def _read_by_one(self, key: str) -> None:
        """One worker is done with the job ``key``: remove its spool file once all its readers are."""
        entry = self._spooled.get(key)
        if entry is None:
            return
        entry[1] -= 1
        if entry[1] == 0:
            del self._spooled[key]
            self._broadcast.discard(key)
            for path in entry[0]:
                with contextlib.suppress(OSError):
                    os.remove(path)

    def next_result(self) -> tuple[Job, Any]:
        while True:
            self._fill()
            finished = self._here.finished()
            if finished is not None:
                job = finished[0]
                if job.key == self._warm_key:
                    self._warm_s = self._here.last_seconds
                elif job.overflow:
                    self._overflow_s.append(self._here.last_seconds)
                self._feed_here()
                return finished
            busy: dict[Any, _Slot | None] = {slot.conn: slot for slot in self._slots if slot.inflight}
            if self._here.running:
                busy[self._here.wakeup] = None
            if not busy:
                raise RuntimeError("no job to wait for")
            conn = wait(list(busy))[0]
            slot = busy[conn]
            if slot is None:  # a job of this process's thread is done: finished() takes it next
                continue
            try:
                status, key, payload = slot.conn.recv()
            except (EOFError, OSError):
                slot.process.join(timeout=1)
                raise WorkerLostError(f"worker {slot.process.pid} died (exit code {slot.process.exitcode}) "
                                      f"while running {', '.join(slot.inflight)}") from None
            job = slot.inflight.pop(key)
            broadcast = key in self._broadcast
            self._read_by_one(key)
            if status != "ok":  # the command's one error line (an OSError's path and cause, a user's error)
                raise failure_from_message(status, payload, f"task {key}")
            if not broadcast:
                # the worker's next job before the caller handles this result (a first part's write
                # imports pandas and pyarrow: longer than a queued job runs)
                self._fill()
                return job, payload

    def close(self) -> None:
        self._here_waiting.clear()
        self._here.close()
        for slot in self._slots:
            with contextlib.suppress(OSError, ValueError):
                slot.conn.send(None)
        deadline = time.monotonic() + 5
        for slot in self._slots:
            self._farewell(slot, deadline)
        for slot in self._slots:
            slot.process.join(timeout=max(0.0, deadline - time.monotonic()))
            if slot.process.is_alive():
                slot.process.terminate()
                slot.process.join(timeout=1)
            slot.conn.close()
        if self._spool is not None:
            shutil.rmtree(self._spool, ignore_errors=True)
            self._spool = None


    def abort(self) -> None:
        """End the workers now (Ctrl-C, a failed task): a running task is not waited for, so the
        command exits at once instead of after :meth:`close`'s farewell (up to 6 s)."""
        self._here_waiting.clear()
        self._here.close()
        for slot in self._slots:
            with contextlib.suppress(OSError, ValueError, AttributeError):
                slot.process.terminate()
        for slot in self._slots:
            slot.process.join(timeout=1)
            with contextlib.suppress(OSError):
                slot.conn.close()
        if self._spool is not None:
            shutil.rmtree(self._spool, ignore_errors=True)
            self._spool = None

    def _farewell(self, slot: _Slot, deadline: float) -> None:
        """Read a closing worker's last messages up to its farewell, which carries its peak memory."""
        try:
            while slot.conn.poll(max(0.0, deadline - time.monotonic())):
                status, _, payload = slot.conn.recv()
                if status == "bye":
                    if payload is not None:
                        self.peak_rss_mb = max(self.peak_rss_mb or 0.0, payload / 1024.0)
                    return
        except (EOFError, OSError):
            return


class DaskExecutor:
    """A dask.distributed cluster.

    Jobs of one affinity are hinted to one worker (round robin over the workers in the order
    the affinities come), with loose restrictions, so dask's work stealing still moves them to
    idle workers; jobs without affinity go wherever the scheduler puts them.
    """

    def __init__(self, client: Any) -> None:
        from dask.distributed import as_completed

        self._client = client
        self._workers = sorted(client.scheduler_info().get("workers", {}))
        #: Workers at the start (at least 1); the cluster may grow or shrink later.
        self.workers = max(1, len(self._workers))
        self._hints: dict[str, str] = {}
        #: affinities whose data every worker holds (:meth:`broadcast`, :meth:`spread`): their jobs go
        #: anywhere
        self._everywhere: set[str] = set()
        self._jobs: dict[str, Job] = {}
        self._done = as_completed()
        self._watch = ClusterWatch(client)

    def _hint(self, affinity: str) -> list[str] | None:
        if not self._workers or affinity in self._everywhere:
            return None
        if affinity not in self._hints:
            self._hints[affinity] = self._workers[len(self._hints) % len(self._workers)]
        return [self._hints[affinity]]

    def submit(self, job: Job) -> None:
        client = self._client
        hint = None if job.affinity is None else self._hint(job.affinity)
        if hint is not None:
            future = submit_checked(client, job.func, *job.args, key=f"nudge-{job.key}", workers=hint,
                                    allow_other_workers=True)
        else:  # no affinity, one every worker holds, or no worker known yet: anywhere
            future = submit_checked(client, job.func, *job.args, key=f"nudge-{job.key}")
        self._jobs[future.key] = job
        self._done.add(future)

    def spread(self, affinity: str) -> None:
        """Hint the jobs of ``affinity`` to no worker: every worker is to hold its data (e.g. each
        builds a lone study's plan itself), so none should wait for work stealing to get some."""
        self._everywhere.add(affinity)

    def broadcast(self, job: Job) -> None:
        """Run ``job`` in every worker now (``Client.run``); a worker that joins later does not get it.

        Every worker then holds the job's affinity, so the jobs of that affinity are not hinted to
        one worker (the others would wait for work stealing to give them any)."""
        self._client.run(job.func, *job.args)
        if job.affinity is not None:
            self._everywhere.add(job.affinity)

    def next_result(self) -> tuple[Job, Any]:
        """The next job to finish and its result; a task marked failed, a lost worker with no
        other left, or a lost scheduler connection is one error (:mod:`nudgecli.runs.dask_results`),
        never a wait for ever."""
        future = next_finished(self._done, self._watch)
        job = self._jobs.pop(future.key)
        result = self._result(future, f"task {job.key}", self._raise_failed)
        future.release()
        return job, result

    def _result(self, future: Any, task: str, also: Callable[[], None] | None = None) -> Any:
        """``future``'s result (``task`` names it); a task's own error a :class:`WorkerError`."""
        try:
            return watched_result(future, task, self._watch, also)
        except (OSError, NudgeError, WorkerError):  # the command's one error line, as in this process
            raise
        except Exception as exc:
            raise WorkerError(f"{task} failed on the cluster: {exc!r}") from exc

    def _raise_failed(self) -> None:
        """Raise the error of a task already marked failed (``KilledWorker``) while another's
        result is awaited: that one may be computed again on workers that are gone."""
        failed = failed_among(self._done)
        if failed is not None:
            job = self._jobs.get(failed.key)
            self._result(failed, f"task {job.key if job else failed.key}")

    def close(self) -> None:
        with quiet_dask_logs():  # a lost scheduler's tracebacks: the command's error line says it
            self._client.close()

    def abort(self) -> None:
        """Cancel what is queued or running on the cluster, then close the client."""
        with quiet_dask_logs():
            with contextlib.suppress(Exception):  # a lost scheduler must not hide the interrupt
                self._client.cancel(list(self._done.futures))
            self._client.close()


Executor = SerialExecutor | ProcessExecutor | DaskExecutor


def make_executor(workers: int, client: Any) -> Executor:
    """The executor for ``--workers``/``--scheduler`` (a connected dask client wins)."""
    if client is not None:
        return DaskExecutor(client)
    if workers > 1:
        return ProcessExecutor(workers)
    return SerialExecutor()
